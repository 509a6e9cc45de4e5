# coding=utf-8
r"""Evaluates an agent on held-out latex seeds (`ble-latex-eval`), BLE-style.

Same flags and meaning as BLE's `balloon_learning_environment.eval.eval`, with
the latex env and suites:

  ble-latex-eval --agent=sac --suite=latex_tiny --output_dir=/tmp/latex/eval \
      --checkpoint_dir=/tmp/latex/sac/checkpoints --checkpoint_idx=49

Writes OUTPUT_DIR/SUITE/NAME.json: one object per seed with seed, reward,
tw50, tw50_window, window_steps, steps, helium_vented_mols, sand_dropped_kg, terminal_reason,
final_distance_km and flight_path (docs/training.md, "Eval output"), with
the flight's station (station_lat, station_lon, station_source), its start
(start_utc) and each point's lat, lon and utc (`ble_latex.run.tracks`).

With --ray_address the seeds (after --num_shards/--shard_idx) are Ray tasks
on a local Ray (`local`) or a cluster (`auto`, `HOST:PORT`); the file written
is the same (`ble_latex.run.distributed`, docs/ray.md):

  ble-latex-eval --agent=station_seeker --env_name=LatexBalloonDiscrete-v0 \
      --suite=latex_small --ray_address=local --ray_num_cpus=2

On ERA5 (`--era5_path=era5_paper.nc`, or `--gin_file=gin_configs/
paper_era5.gin`) the flights start inside the suite's dates
(`suites.era5_dates`: latex_validation flies 'validation', every other
suite 'eval'; `--era5_dates` to choose), never the training dates. On any
wind file each record also has `wind_source` and its flight's station,
`station_lat`/`station_lon` [deg] from the file: on a gridded snapshot (GFS,
GRIB2) --wind_file draws station s for seed s (`GriddedWindField.stations =
'per_seed'`) unless a station is bound (docs/winds.md); on BLE's winds the
station is the nominal position `latex_flight.latitude_deg/longitude_deg`.

If seeds fail on Ray, the others are written to NAME.partial.json and the
command exits with status 1, listing each failed seed with its error.

One writer per output file: while an eval writes OUTPUT_DIR/SUITE/NAME.json,
another eval of the same file exits with status 1, naming the first's pid
and host (shards, other agents and names write alongside).
"""

import json
import os
import sys
from typing import Any, Optional, Sequence

from absl import app
from absl import flags

import ble_latex  # pylint: disable=unused-import  # Fixes first.
from ble_latex import agents
from ble_latex import configs
from ble_latex.ble import gym_registration
from ble_latex.cli import common as cli
from ble_latex.run import gin_binding
from ble_latex.run import wind_file

# Imported on first use, after the flags are parsed (`--help` stays fast).
batch_eval = cli.lazy_module('ble_latex.run.batch_eval')
distributed = cli.lazy_module('ble_latex.run.distributed')
env_params = cli.lazy_module('ble_latex.envs.env_params')
eval_lib = cli.lazy_module('ble_latex.run.eval_lib')
metrics = cli.lazy_module('ble_latex.run.metrics')
suites = cli.lazy_module('ble_latex.run.suites')
tracks = cli.lazy_module('ble_latex.run.tracks')

# The command's own flags (`cli.run_absl`).
FLAGS = flags.FlagValues()
flags.DEFINE_string('agent', 'sac', 'The name of the agent to create.',
                    flag_values=FLAGS)
flags.DEFINE_string('env_name', 'LatexBalloon-v0', 'Environment to evaluate.',
                    flag_values=FLAGS)
flags.DEFINE_string('suite', 'latex_tiny',
                    f'Evaluation suite: {sorted(suites.SUITE_SIZES)} (held '
                    'out), latex_validation (for choosing checkpoints) or '
                    'any BLE suite.', flag_values=FLAGS)
flags.DEFINE_string('agent_gin_file', None, 'Gin file for agent configuration.',
                    flag_values=FLAGS)
cli.define_gin_flags(FLAGS)
flags.DEFINE_string('output_dir', '/tmp/ble_latex/eval',
                    'The directory to output the json summary.',
                    flag_values=FLAGS)
flags.DEFINE_integer('num_shards', 1, 'Number of shards to split the suite.',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('shard_idx', 0, 'The index of this shard.', lower_bound=0,
                     flag_values=FLAGS)
flags.DEFINE_boolean('pretty_json', False, 'Indent the json output.',
                     flag_values=FLAGS)
flags.DEFINE_string('checkpoint_dir', None, 'Directory to load checkpoints.',
                    flag_values=FLAGS)
flags.DEFINE_integer('checkpoint_idx', None, 'Checkpoint iteration to load.',
                     flag_values=FLAGS)
flags.DEFINE_string('name_override', None, 'Name of the json output file.',
                    flag_values=FLAGS)
flags.DEFINE_integer('max_episode_length', None,
                     'Override the suite\'s episode length.', lower_bound=1,
                     flag_values=FLAGS)
flags.DEFINE_integer('seed', 0, 'Agent seed.', flag_values=FLAGS)
flags.DEFINE_string('ray_address', None,
                    'Fly the seeds as Ray tasks: local (an embedded Ray on '
                    'this machine), auto (the cluster this machine joined) '
                    "or HOST:PORT / ray://HOST:PORT. Needs the 'ray' extra.",
                    flag_values=FLAGS)
flags.DEFINE_string('wind_file', None, cli.WIND_FILE_HELP, flag_values=FLAGS)
flags.DEFINE_alias('era5_path', 'wind_file', flag_values=FLAGS)
cli.define_station_flags(FLAGS)
flags.DEFINE_string('era5_dates', None,
                    cli.ERA5_DATES_HELP.format(
                        default="the suite's (latex_validation: validation; "
                        'every other suite: eval)'), flag_values=FLAGS)
flags.DEFINE_integer('ray_num_cpus', None,
                     'CPUs of a --ray_address=local Ray (default: all).',
                     lower_bound=1, flag_values=FLAGS)


def _main(argv: Sequence[str]) -> None:
  if (FLAGS.checkpoint_dir is None) != (FLAGS.checkpoint_idx is None):
    raise app.UsageError('--checkpoint_dir and --checkpoint_idx go together.')
  if FLAGS.name_override is not None:  # Kept inside --output_dir.
    cli.output_name(FLAGS.name_override, '--name_override')
  # ERA5 (--era5_path, or a gin file binding it): the suite's dates; the
  # bindings travel in the spec (Ray workers bind the same).
  gin_binding.bind_gin(FLAGS.agent, FLAGS.agent_gin_file, FLAGS.gin_file,
                       FLAGS.gin_bindings)
  era5_bindings = wind_file.era5_bindings(
      FLAGS.wind_file, FLAGS.era5_dates, suites.era5_dates(FLAGS.suite),
      station=wind_file.station_bindings(FLAGS.station_lat, FLAGS.station_lon))
  spec = eval_lib.EvalSpec(
      agent=FLAGS.agent, env_name=FLAGS.env_name,
      agent_gin_file=FLAGS.agent_gin_file, gin_files=tuple(FLAGS.gin_file),
      gin_bindings=(*FLAGS.gin_bindings, *era5_bindings),
      checkpoint_dir=FLAGS.checkpoint_dir, checkpoint_idx=FLAGS.checkpoint_idx,
      seed=FLAGS.seed)
  name = FLAGS.name_override or (
      f'{FLAGS.agent}_{FLAGS.checkpoint_idx}'
      if FLAGS.checkpoint_idx is not None else FLAGS.agent)
  path = eval_lib.output_path(FLAGS.output_dir, FLAGS.suite, name,
                              FLAGS.num_shards, FLAGS.shard_idx)
  _evaluate(spec, path)


def _evaluate(spec: 'eval_lib.EvalSpec', path: str) -> None:
  """Flies the suite's seeds (here or on Ray) and writes `path`."""
  if FLAGS.ray_address is not None:
    # Before JAX starts threads in this process: Ray forks its daemons.
    try:
      distributed.connect(FLAGS.ray_address, FLAGS.ray_num_cpus)
    except distributed.RayUnavailableError as e:
      raise cli.CommandUsageError(str(e)) from e
  agent, env = eval_lib.build(spec)  # Checks the spec before Ray work starts.
  # A refused spec leaves no folder; the output's one writer is this process
  # from here on (a second eval of the same file is refused before it runs).
  cli.prepare_output_dir(os.path.dirname(path), '--output_dir')
  with eval_lib.lock_output(path):
    _fly(spec, path, agent, env)


def _fly(spec: 'eval_lib.EvalSpec', path: str, agent: Any, env: Any) -> None:
  """Flies the suite's seeds with `agent` (or on Ray) and writes `path`."""
  suite = suites.get_eval_suite(FLAGS.suite)
  seeds = eval_lib.shard(suite.seeds, FLAGS.num_shards, FLAGS.shard_idx)
  max_steps = FLAGS.max_episode_length or suite.max_episode_length
  description = f'eval {FLAGS.agent} {FLAGS.suite}'
  if FLAGS.ray_address is None:
    results = eval_lib.evaluate(agent, env, seeds, max_steps,
                                description=description)
  else:
    # JAX-core agents fly batched on the workers too (`batch_eval`).
    batch_size = (batch_eval.BATCH_SIZE if batch_eval.flies_batched(agent, env)
                  else 1)
    del agent, env  # Workers build their own.
    try:
      results = distributed.evaluate(spec, seeds, max_steps,
                                     description=description,
                                     batch_size=batch_size)
    except distributed.SeedsFailedError as e:
      partial = path[:-len('.json')] + '.partial.json'
      eval_lib.write_results(partial, e.completed, FLAGS.pretty_json)
      print(f'ble-latex-eval: {e}\nThe {len(e.completed)} other records are '
            f'in {partial}.', file=sys.stderr)
      sys.exit(1)
    finally:
      if FLAGS.ray_address == 'local':
        distributed.shutdown()
  source = env_params.wind_source()  # Each record names its winds.
  results = [{**r, 'wind_source': source} for r in results]
  # Each record names its flight's station and start, each point its
  # lat/lon and UTC time (`tracks.locate`).
  results = tracks.locate(results, env_params.params_from_gin())
  eval_lib.write_results(path, results, FLAGS.pretty_json)
  print(json.dumps({'output': path, 'wind_source': source,
                    **metrics.summarize(results)}))


def check() -> None:
  """Unknown agent, suite, env or gin file: one line, exit status 2."""
  agents.check_agent(FLAGS.agent)
  suites.check_suite(FLAGS.suite)
  gym_registration.check_env_name(FLAGS.env_name)
  configs.check_gin_files([FLAGS.agent_gin_file, *FLAGS.gin_file])
  distributed.check_ray_flags(FLAGS.ray_address, FLAGS.ray_num_cpus)
  eval_lib.shard([], FLAGS.num_shards, FLAGS.shard_idx)  # Before any lock.


def main(argv: Optional[Sequence[str]] = None) -> int:
  """The command (`cli.run_absl`); returns the exit status."""
  return cli.run_absl(_main, 'ble-latex-eval', FLAGS, argv, doc=__doc__,
                      check=check)


if __name__ == '__main__':
  sys.exit(main())
