# coding=utf-8
r"""Trains an agent on the latex balloon (`ble-latex-train`), BLE-style.

Same flags and meaning as BLE's `balloon_learning_environment.train`, with the
latex env and SAC as defaults:

  ble-latex-train --base_dir=/tmp/latex/sac --num_iterations=50 \
      --episodes_per_iteration=10

With `--trainer=jax` SAC trains in jitted rounds on the batched env
(`ble_latex.run.jax_train`, gin `sac_trainer_config.*`): an iteration
is one episode on each of `sac_trainer_config.num_envs` balloons in parallel.
`--seeds` runs several training seeds, each in BASE_DIR/seed_<s>: one after
another, or with `--vmap_seeds` (jax trainer) all in one vmapped XLA call
per round, which gains where the hardware has room for more than one
seed's work (docs/benchmarks.md, for measurements):

  ble-latex-train --trainer=jax --base_dir=/tmp/latex/jax \
      --num_iterations=170 --policy_snapshot_period=5 --seeds=0,1,2,3,4 \
      [--vmap_seeds]

The run directory holds `checkpoints/` (one per iteration), `episodes.jsonl`
(one line per episode) and `metrics/` (tensorboard, pickle); the jax trainer
also writes `validation.jsonl` (each policy snapshot flown on
`latex_validation`). Killed and
restarted with the same flags, training resumes after the last checkpoint:
episodes logged after it are dropped and re-run from their seeds, so no
episode is lost or repeated. Episode i always flies env seed i (held-out eval
seeds start at 1,000,000).

On ERA5 (`--era5_path`, or `--gin_file=gin_configs/paper_era5.gin`) flights
start inside the 'train' dates (`--era5_dates`, `gridded.DATE_SPLITS`), and the
jax trainer's validation flies the 'validation' dates (docs/era5.md):

  ble-latex-train --trainer=jax --base_dir=/tmp/latex/era5 \
      --era5_path=era5_paper.nc --policy_snapshot_period=5
"""

import os
import sys
from typing import List, Optional, Sequence, Tuple

from absl import flags

import ble_latex  # pylint: disable=unused-import  # Fixes first.
from ble_latex import agents
from ble_latex import configs
from ble_latex import errors
from ble_latex.ble import gym_registration
from ble_latex.cli import common as cli
from ble_latex.run import gin_binding
from ble_latex.run import wind_file

# Imported on first use, after the flags are parsed (`--help` stays fast).
collectors = cli.lazy_module('ble_latex.run.collectors')
env_params = cli.lazy_module('ble_latex.envs.env_params')
run_dir = cli.lazy_module('ble_latex.run.run_dir')
suites = cli.lazy_module('ble_latex.run.suites')
train_lib = cli.lazy_module('ble_latex.run.train_lib')

# The command's own flags (`cli.run_absl`).
FLAGS = flags.FlagValues()
flags.DEFINE_enum('trainer', 'agent', ['agent', 'jax'],
                  "'agent': the agent's own loop, one balloon at a time "
                  "(BLE's); 'jax': jitted SAC on the batched env "
                  '(sac_trainer; --agent=sac, gin sac_trainer_config).',
                  flag_values=FLAGS)
flags.DEFINE_string('agent', 'sac', 'Type of agent to create.',
                    flag_values=FLAGS)
flags.DEFINE_string('env_name', 'LatexBalloon-v0',
                    'Name of environment to create.', flag_values=FLAGS)
flags.DEFINE_integer('num_iterations', 50, 'Number of iterations to train.',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('episodes_per_iteration', 10,
                     'Episodes per iteration; a checkpoint is written after '
                     'each iteration.', lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('max_episode_length', suites.EPISODE_STEPS,
                     'Maximum steps per episode (216 x 20 min = 3 days).',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_string('base_dir', None,
                    'Directory for checkpoints, episodes.jsonl and metrics.',
                    flag_values=FLAGS)
flags.DEFINE_string('agent_gin_file', None,
                    'Gin file for agent configuration (default: the agent\'s).',
                    flag_values=FLAGS)
cli.define_gin_flags(
    FLAGS, files_help='Extra gin files (e.g. gin_configs/paper_era5.gin).')
flags.DEFINE_multi_string('collectors', ['progress', 'episodes', 'tensorboard'],
                          'Collectors: console, episodes, pickle, progress, tensorboard '
                          '(ble_latex.run.collectors.AVAILABLE_COLLECTORS).',
                          flag_values=FLAGS)
flags.DEFINE_integer('seed', 0, 'Seed of the agent (env seeds are episode '
                     'indices).', flag_values=FLAGS)
flags.DEFINE_list('seeds', None,
                  'Training seeds, run one after another, each in '
                  'BASE_DIR/seed_<s> (instead of --seed in BASE_DIR).',
                  flag_values=FLAGS)
flags.DEFINE_bool('vmap_seeds', False,
                  '--trainer=jax with --seeds: train the seeds together, '
                  'one jax.vmap-ed round for all (instead of one after '
                  'another).', flag_values=FLAGS)
flags.DEFINE_integer('validation_episodes', 100,
                     '--trainer=jax: latex_validation seeds each policy '
                     'snapshot flies (batched) into validation.jsonl; 0: '
                     'none.', flag_values=FLAGS)
flags.DEFINE_integer('checkpoint_period', 1,
                     '--trainer=jax: iterations between checkpoints (each '
                     'holds the replay buffer).', flag_values=FLAGS)
flags.DEFINE_integer('policy_snapshot_period', 0,
                     'SAC only: every this many iterations also export the '
                     'policy (~1 MB) to BASE_DIR/policies/, for choosing one '
                     'on a validation suite afterwards. 0: never.',
                     flag_values=FLAGS)
flags.DEFINE_string('wind_file', None, cli.WIND_FILE_HELP, flag_values=FLAGS)
flags.DEFINE_alias('era5_path', 'wind_file', flag_values=FLAGS)
cli.define_station_flags(FLAGS)
flags.DEFINE_string('era5_dates', None,
                    cli.ERA5_DATES_HELP.format(default='train (the jax '
                                               "trainer's validation flies "
                                               'validation)'),
                    flag_values=FLAGS)
flags.mark_flag_as_required('base_dir', flag_values=FLAGS)


def seed_dirs() -> List[Tuple[int, str]]:
  """(seed, run directory) of each training run this command makes."""
  if FLAGS.seeds is None:
    return [(FLAGS.seed, FLAGS.base_dir)]
  return [(int(s), os.path.join(FLAGS.base_dir, f'seed_{int(s)}'))
          for s in FLAGS.seeds]


def _main(argv: Sequence[str]) -> None:
  """Trains; refused input is one line (`cli.run_absl`).

  A bad checkpoint (`errors.BadFileError`, naming the file and entry) or a run
  that diverged (`sac_core.TrainingDiverged`) exits 1; a refused resume
  (`errors.ResumeError`) or binding exits 2.
  """
  del argv
  jax_trainer = FLAGS.trainer == 'jax'
  agent_gin_file = FLAGS.agent_gin_file
  if jax_trainer:  # Its gin name (`sac_trainer_config.*`), before parsing.
    from ble_latex.agents.sac import trainer as sac_trainer  # pylint: disable=g-import-not-at-top,unused-import
  gin_binding.bind_gin(FLAGS.agent, agent_gin_file, FLAGS.gin_file,
                       FLAGS.gin_bindings)
  era5_bindings = wind_file.era5_bindings(
      FLAGS.wind_file, FLAGS.era5_dates, suites.TRAIN_DATES,
      station=wind_file.station_bindings(FLAGS.station_lat, FLAGS.station_lon))
  if era5_bindings:  # ERA5: the file, and the training dates.
    gin_binding.bind_gin(FLAGS.agent, agent_gin_file, FLAGS.gin_file,
                         [*FLAGS.gin_bindings, *era5_bindings])
  env_params.params_from_gin()  # Refused env values: errors.ConfigError.
  if jax_trainer:  # Its settings (sizes that drive memory too), first.
    from ble_latex.agents.sac import trainer as sac_trainer  # pylint: disable=g-import-not-at-top
    sac_trainer.TrainerConfig()
  cli.prepare_output_dir(FLAGS.base_dir, '--base_dir')
  if jax_trainer:
    # pylint: disable=g-import-not-at-top
    from ble_latex.run import jax_train
    # pylint: enable=g-import-not-at-top
    first = suites.VALIDATION_SEED_OFFSET
    jax_train.train_seeds(
        validation_params=_era5_validation_params(),
        runs=seed_dirs(), num_iterations=FLAGS.num_iterations,
        collectors=FLAGS.collectors,
        policy_snapshot_period=FLAGS.policy_snapshot_period,
        checkpoint_period=FLAGS.checkpoint_period,
        validation_seeds=range(first, first + FLAGS.validation_episodes),
        vmap=FLAGS.vmap_seeds)
    return
  for seed, base_dir in seed_dirs():
    train_lib.train(agent_name=FLAGS.agent, env_name=FLAGS.env_name,
          base_dir=base_dir, num_iterations=FLAGS.num_iterations,
          episodes_per_iteration=FLAGS.episodes_per_iteration,
          max_episode_length=FLAGS.max_episode_length,
          collectors=FLAGS.collectors, seed=seed,
          policy_snapshot_period=FLAGS.policy_snapshot_period)


def _era5_validation_params():
  """The jax trainer's validation env on ERA5: the validation dates.

  When training flies the 'train' split (the default), the training params
  with flights starting in the 'validation' split (the same winds on the
  device, `gridded_jax.grid_from_settings`); None otherwise (no ERA5, or other
  training dates: validation flies the training env; choose with
  `ble-latex-eval --suite=latex_validation --era5_dates=...`).
  """
  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import env_params
  from ble_latex.wind import gridded
  from ble_latex.wind import gridded_jax
  # pylint: enable=g-import-not-at-top
  params = env_params.params_from_gin()
  if (params.wind_grid is None or
      gridded.settings().start_dates != suites.TRAIN_DATES):
    return None
  return params.replace(wind_grid=gridded_jax.grid_from_settings(
      gridded.settings(start_dates=suites.era5_dates('latex_validation'))))


def check() -> None:
  """Unknown agent, env, collector or gin file: one line, exit status 2."""
  agents.check_agent(FLAGS.agent)
  gym_registration.check_env_name(FLAGS.env_name)
  if FLAGS.seeds is not None:
    run_dir.training_seeds(FLAGS.seeds)
  else:
    run_dir.training_seed(FLAGS.seed)
  if FLAGS.vmap_seeds and (FLAGS.trainer != 'jax' or FLAGS.seeds is None):
    raise cli.CommandUsageError('--vmap_seeds needs --trainer=jax and --seeds')
  if FLAGS.trainer == 'jax':
    for name in ('episodes_per_iteration', 'max_episode_length'):
      if FLAGS[name].present:
        raise cli.CommandUsageError(
            f'--{name} is not used by --trainer=jax: an iteration is one '
            'episode per balloon (gin sac_trainer_config.num_envs), episodes '
            'last latex_episode.episode_steps')
    if FLAGS.agent != 'sac' or FLAGS.env_name != 'LatexBalloon-v0':
      raise cli.CommandUsageError(
          '--trainer=jax trains SAC on LatexBalloon-v0 only (--agent=sac, '
          '--env_name=LatexBalloon-v0)')
    if not 0 <= FLAGS.validation_episodes <= 100:
      raise cli.CommandUsageError('--validation_episodes must be in [0, 100]'
                                  ' (latex_validation has 100 seeds)')
    if FLAGS.checkpoint_period < 1:
      raise cli.CommandUsageError('--checkpoint_period must be >= 1')
  for name in FLAGS.collectors:
    if name not in collectors.AVAILABLE_COLLECTORS:
      raise cli.CommandUsageError(errors.unknown(
          'collector', name, collectors.AVAILABLE_COLLECTORS))
  configs.check_gin_files([FLAGS.agent_gin_file, *FLAGS.gin_file])


def main(argv: Optional[Sequence[str]] = None) -> int:
  """The command (`cli.run_absl`); returns the exit status."""
  return cli.run_absl(_main, 'ble-latex-train', FLAGS, argv, doc=__doc__,
                      check=check)


if __name__ == '__main__':
  sys.exit(main())
