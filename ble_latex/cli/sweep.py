# coding=utf-8
r"""Sweeps gin bindings x training seeds on Ray Tune (`ble-latex-sweep`).

Each trial trains SAC with the jitted trainer (`ble-latex-train
--trainer=jax`, its defaults plus the trial's bindings) in
SWEEP_DIR/runs/p<point>_seed<s> and reports its latex_validation TW50 over
the window at every policy snapshot (`ble_latex.run.sweep_lib`):

  ble-latex-sweep --sweep_dir=/tmp/latex/sweep --space=space.yaml \
      --seeds=0,1,2 --num_iterations=60 --asha --ray_address=local

  ble-latex-sweep --sweep_dir=/tmp/latex/sweep --seeds=0,1 \
      --grid='sac_trainer_config.updates_per_step=4,8' \
      --grid='sac_trainer_config.num_envs=8,16'

Killed and re-run with the same flags, the sweep resumes (Tune's restore).
Writes SWEEP_DIR/results.csv, results.md and best_config.gin (for
`ble-latex-train --trainer=jax --gin_file=SWEEP_DIR/best_config.gin`).
Needs the 'ray' extra (pip install 'ble_latex[ray]').
"""

import os
import sys
from typing import Optional, Sequence

from absl import flags

import ble_latex  # pylint: disable=unused-import  # Fixes first.
from ble_latex import configs
from ble_latex.cli import common as cli
from ble_latex.run import distributed
from ble_latex.run import run_dir
from ble_latex.run import sweep_lib

# The command's own flags (`cli.run_absl`).
FLAGS = flags.FlagValues()
flags.DEFINE_string('sweep_dir', None, 'Directory of the sweep (runs/, tune/, '
                    'results.csv, results.md, best_config.gin).',
                    flag_values=FLAGS)
flags.DEFINE_string('space', None, 'Space file (.json, .yaml, .yml): '
                    'bindings and how to vary them (grid, choice, uniform, '
                    'loguniform, randint) and num_samples.', flag_values=FLAGS)
flags.DEFINE_multi_string('grid', [], 'NAME=V1,V2,...: a gin binding to grid '
                          'over (with or instead of --space).',
                          flag_values=FLAGS)
flags.DEFINE_list('seeds', ['0'], 'Training seeds of every point.',
                  flag_values=FLAGS)
flags.DEFINE_integer('num_samples', None, 'Draws of the sampled bindings '
                     '(default: the space file\'s num_samples, else 1).',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('search_seed', 0, 'Seed of the random draws.',
                     flag_values=FLAGS)
flags.DEFINE_integer('num_iterations', 100, 'Rounds per trial (each: one '
                     'episode per balloon).', lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('policy_snapshot_period', 5, 'Rounds between policy '
                     'snapshots, validations, reports and checkpoints.',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('validation_episodes', 100, 'latex_validation seeds '
                     'each snapshot flies.', lower_bound=1, upper_bound=100,
                     flag_values=FLAGS)
flags.DEFINE_boolean('asha', False, 'Stop weak trials early (Tune\'s ASHA on '
                     'the validation TW50 over the window).', flag_values=FLAGS)
flags.DEFINE_integer('grace_period', 10, 'With --asha: rounds every trial '
                     'runs before it may be stopped.', lower_bound=1,
                     flag_values=FLAGS)
flags.DEFINE_float('cpus_per_trial', 1.0, 'Ray CPUs each trial reserves.',
                   lower_bound=0.0, flag_values=FLAGS)
flags.DEFINE_integer('max_concurrent_trials', None, 'Most trials at once '
                     '(default: as Ray\'s CPUs allow).', lower_bound=1,
                     flag_values=FLAGS)
flags.DEFINE_string('ray_address', 'local', 'local (an embedded Ray on this '
                    'machine), auto (the cluster this machine joined) or '
                    'HOST:PORT / ray://HOST:PORT.', flag_values=FLAGS)
flags.DEFINE_integer('ray_num_cpus', None, 'CPUs of a --ray_address=local '
                     'Ray (default: all).', lower_bound=1, flag_values=FLAGS)
cli.define_gin_flags(FLAGS, files_help='Gin files for every trial.',
                     bindings_help='Gin bindings for every trial.')
flags.mark_flag_as_required('sweep_dir', flag_values=FLAGS)


def settings_from_flags() -> sweep_lib.SweepSettings:
  """The sweep the flags describe; raises SpaceError / ValueError."""
  space = sweep_lib.load_space(FLAGS.space) if FLAGS.space else None
  space = sweep_lib.merge(space, [sweep_lib.parse_grid_flag(g)
                                  for g in FLAGS.grid], FLAGS.num_samples)
  seeds = tuple(run_dir.training_seeds(FLAGS.seeds))
  return sweep_lib.SweepSettings(
      sweep_dir=os.path.abspath(FLAGS.sweep_dir),
      points=tuple(sweep_lib.points(space, FLAGS.search_seed, len(seeds))),
      seeds=seeds,
      num_iterations=FLAGS.num_iterations,
      policy_snapshot_period=FLAGS.policy_snapshot_period,
      validation_episodes=FLAGS.validation_episodes,
      gin_files=tuple(os.path.abspath(p) for p in FLAGS.gin_file),
      gin_bindings=tuple(FLAGS.gin_bindings),
      asha_grace_period=FLAGS.grace_period if FLAGS.asha else None,
      cpus_per_trial=FLAGS.cpus_per_trial)


def _main(argv: Sequence[str]) -> None:
  try:
    settings = settings_from_flags()
  except ValueError as e:  # SpaceError, --seeds.
    raise cli.CommandUsageError(str(e)) from e
  sweep_lib.check_points(settings)  # Gin errors name the binding, here.
  try:
    with sweep_lib.lock(settings):  # Refuses a busy sweep dir before Ray.
      sweep_lib.check_resume(settings)
  except ValueError as e:
    raise cli.CommandUsageError(str(e)) from e
  try:
    distributed.connect(FLAGS.ray_address, FLAGS.ray_num_cpus)
  except distributed.RayUnavailableError as e:
    raise cli.CommandUsageError(str(e)) from e
  try:
    rows = sweep_lib.run(settings,
                         max_concurrent_trials=FLAGS.max_concurrent_trials)
  finally:
    if FLAGS.ray_address == 'local':
      distributed.shutdown()
  with open(os.path.join(settings.sweep_dir, sweep_lib.RESULTS_MD),
            encoding='utf-8') as f:
    print(f.read())
  failed = [r['trial'] for r in rows if r['status'].startswith('error')]
  if failed:
    print(f'ble-latex-sweep: trials failed: {", ".join(failed)} (see '
          f'{sweep_lib.RESULTS_CSV}; re-run the command to retry them)',
          file=sys.stderr)
    sys.exit(1)


def check() -> None:
  """Ray missing, bad address or gin file: one line, exit status 2."""
  distributed.check_ray_flags(FLAGS.ray_address, FLAGS.ray_num_cpus)
  if FLAGS.num_iterations < FLAGS.policy_snapshot_period:
    raise cli.CommandUsageError(
        '--num_iterations must be >= --policy_snapshot_period (trials '
        'report at snapshots)')
  configs.check_gin_files(FLAGS.gin_file)


def main(argv: Optional[Sequence[str]] = None) -> int:
  """The command (`cli.run_absl`); returns the exit status."""
  return cli.run_absl(_main, 'ble-latex-sweep', FLAGS, argv, doc=__doc__,
                      check=check)


if __name__ == '__main__':
  sys.exit(main())
