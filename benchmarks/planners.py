"""The planners (`ble_latex.agents.planning`) on a suite, balloons batched.

  python benchmarks/planners.py --agent=latex_mpc --suite=latex_small \
      --output_dir=benchmarks/records/planners/results [--num_seeds=100] [--batch=25] \
      [--gin_bindings='LatexMpcAgent.num_samples=64']

Flies the suite's first --num_seeds seeds --batch at a time with the JAX env
(`run/planner_batch.py`: the same worlds as `ble-latex-eval`'s gym env for
the same seeds, no TensorFlow): one vmapped `planning.plan_batch` call per
decision plans for the whole batch, then the batch flies `replan_every`
strides.
Writes OUTPUT_DIR/SUITE/NAME.json in `ble-latex-eval`'s record format
(`benchmarks/results_table.py` reads it) and OUTPUT_DIR/SUITE/timing/NAME.json
(seconds per decision and per episode, compile time, load). Resumable: the
records of finished batches are kept in NAME.partial.json with the settings
they were flown with (`run_config`) and skipped when the command runs again
with the same settings; other settings are refused, naming what differs.
Re-flying chosen seeds (--seeds) of a finished NAME.json merges them into it
(the other seeds are kept) when it was flown with the same settings, and is
refused otherwise (--name_override writes elsewhere): a record never loses
seeds. --short flies 2 seeds for 12 strides (a smoke test).
"""

import json
import os
import sys
from typing import Any, Dict, List, Optional, Sequence

from absl import flags
import numpy as np

import ble_latex  # pylint: disable=unused-import  # Fixes first.
from ble_latex import errors
from ble_latex import quiet
from ble_latex import safe_io
from ble_latex.cli import common as cli
from ble_latex.run import episode_log
from ble_latex.run import planner_batch
from ble_latex.run import wind_file

FLAGS = flags.FlagValues()
flags.DEFINE_string('agent', 'latex_mpc', 'latex_mpc, latex_mpc_oracle or '
                    'latex_mpc_grad.', flag_values=FLAGS)
flags.DEFINE_string('suite', 'latex_small', 'Evaluation suite.',
                    flag_values=FLAGS)
flags.DEFINE_string('output_dir', str(episode_log.RECORDS_DIR / 'planners' / 'results'),
                    'Output folder (SUITE/NAME.json inside).',
                    flag_values=FLAGS)
flags.DEFINE_string('name_override', None, 'Name of the output files.',
                    flag_values=FLAGS)
flags.DEFINE_integer('num_seeds', None, 'First seeds of the suite (default: '
                     'all).', lower_bound=1, flag_values=FLAGS)
flags.DEFINE_list('seeds', None, 'These seeds of the suite only (after '
                  '--num_seeds), e.g. a diagnostic re-flight of chosen '
                  'flights.', flag_values=FLAGS)
flags.DEFINE_integer('batch', planner_batch.BATCH_SIZE,
                     'Balloons planned in one call.', lower_bound=1,
                     flag_values=FLAGS)
flags.DEFINE_integer('max_episode_length', None, 'Cap on the strides.',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('seed', 0, 'Agent seed.', flag_values=FLAGS)
cli.define_gin_flags(FLAGS, files_help='Extra gin files.',
                     bindings_help='Gin bindings.')
flags.DEFINE_string('wind_file', None, cli.WIND_FILE_HELP, flag_values=FLAGS)
flags.DEFINE_alias('era5_path', 'wind_file', flag_values=FLAGS)
flags.DEFINE_boolean('short', False, '2 seeds, 12 strides (smoke test).',
                     flag_values=FLAGS)


def run_config(agent: str, suite: str, config: Any, max_steps: int,
               agent_seed: int, gin_files: Sequence[str],
               gin_bindings: Sequence[str]) -> Dict[str, Any]:
  """What a flight's records depend on, as JSON reads it back.

  A resume (NAME.partial.json) and a merge into a finished NAME.json must
  agree on all of it: the planner's settings (`vars(config)`), the stride
  cap, the agent seed and the gin that set the env.
  """
  return json.loads(json.dumps({
      'agent': agent, 'suite': suite, 'config': vars(config),
      'max_steps': int(max_steps), 'seed': int(agent_seed),
      'gin_files': list(gin_files), 'gin_bindings': list(gin_bindings)}))


def differences(recorded: Dict[str, Any], current: Dict[str, Any]) -> str:
  """'max_steps: 5 there, 2 here; ...' for the keys whose values differ.

  Keys missing from `recorded` (records of older runs) are not compared;
  planner settings are compared one by one.
  """
  parts = []
  for key, value in current.items():
    if key not in recorded or recorded[key] == value:
      continue
    if key == 'config' and isinstance(recorded[key], dict):
      for field, v in value.items():
        if recorded[key].get(field) != v:
          parts.append(f'config.{field}: {recorded[key].get(field)!r} there, '
                       f'{v!r} here')
    else:
      parts.append(f'{key}: {recorded[key]!r} there, {value!r} here')
  return '; '.join(parts)


def _read_json(path: str, what: str) -> Any:
  """A JSON file's content; a truncated or unreadable file is one line."""
  try:
    with open(path, encoding='utf-8') as f:
      return json.loads(f.read())
  except (ValueError, UnicodeDecodeError) as e:  # JSONDecodeError too.
    raise cli.CommandFailure(f'{what} {path} is not valid JSON ({e}); '
                             'delete it to start over') from e


def _checked_records(records: Any, path: str, seeds: Sequence[int]
                     ) -> List[Dict[str, Any]]:
  """Eval records of the suite's seeds (`records.validate_eval`), or one line."""
  from ble_latex.run import records as records_lib  # pylint: disable=g-import-not-at-top
  try:
    records_lib.validate_eval(records, path)
  except ValueError as e:
    raise cli.CommandFailure(f'{e}; delete it to start over') from e
  stray = sorted({r['seed'] for r in records} - set(seeds))
  if stray:
    raise cli.CommandFailure(f'{path}: seeds {stray[:5]} are not seeds of '
                             'this suite; delete it to start over')
  return records


def load_partial(path: str, current: Dict[str, Any], seeds: Sequence[int]
                 ) -> List[Dict[str, Any]]:
  """The finished batches of NAME.partial.json, flown with `current`.

  Raises:
    cli.CommandFailure: The file is truncated or not a partial file (one
      line, exit status 1).
    errors.ResumeError: It was flown with other settings (naming them; exit
      status 2).
  """
  data = _read_json(path, 'partial file')
  if (not isinstance(data, dict) or set(data) != {'run_config', 'records'}
      or not isinstance(data['run_config'], dict)):
    raise cli.CommandFailure(
        f'partial file {path}: expected {{"run_config": {{...}}, "records": '
        '[...]}} (a partial file without its settings cannot be resumed); '
        'delete it to start over')
  differ = differences(data['run_config'], current)
  if differ:
    raise errors.ResumeError(
        f'partial file {path} was flown with other settings ({differ}); '
        'fly those again, delete the file or use --name_override')
  return _checked_records(data['records'], path, seeds)


def _main(argv: Sequence[str]) -> int:
  del argv
  from ble_latex.envs import env_params  # pylint: disable=g-import-not-at-top
  from ble_latex.run import gin_binding  # pylint: disable=g-import-not-at-top
  with quiet.third_party_noise():
    from ble_latex.agents.planning import config as plan_config  # pylint: disable=g-import-not-at-top
    from ble_latex.run import metrics  # pylint: disable=g-import-not-at-top
    from ble_latex.run import suites  # pylint: disable=g-import-not-at-top
  if FLAGS.agent not in plan_config.PLANNERS:
    raise cli.CommandUsageError(
        f'--agent={FLAGS.agent!r}: one of {sorted(plan_config.PLANNERS)}')
  if FLAGS.name_override is not None:  # Kept inside --output_dir.
    cli.output_name(FLAGS.name_override, '--name_override')
  gin_binding.bind_gin(None, None, FLAGS.gin_file, FLAGS.gin_bindings)
  # --wind_file: its bindings (and the suite's dates) join the user's.
  bindings = [*FLAGS.gin_bindings, *wind_file.era5_bindings(
      FLAGS.wind_file, None, suites.era5_dates(FLAGS.suite))]
  if len(bindings) > len(FLAGS.gin_bindings):
    gin_binding.bind_gin(None, None, FLAGS.gin_file, bindings)
  config = plan_config.from_gin(FLAGS.agent)
  suite = suites.get_eval_suite(FLAGS.suite)
  seeds = list(suite.seeds)[:FLAGS.num_seeds]
  if FLAGS.seeds is not None:
    try:
      chosen = [int(s) for s in FLAGS.seeds]
    except ValueError as e:
      raise cli.CommandUsageError(f'--seeds: integers, got {FLAGS.seeds}') from e
    missing = sorted(set(chosen) - set(seeds))
    if missing or not chosen:
      raise cli.CommandUsageError(
          f'--seeds: {missing or "none given"} not among the '
          f'{len(seeds)} seeds of {FLAGS.suite}')
    seeds = [s for s in seeds if s in set(chosen)]
  max_steps = FLAGS.max_episode_length or suite.max_episode_length
  if FLAGS.short:
    seeds, max_steps = seeds[:2], min(max_steps, 12)
  # Before anything is compiled: the batched call's size (one line).
  plan_config.check_batch(config, min(FLAGS.batch, len(seeds)),
                          plan_config.PLANNERS[FLAGS.agent].__name__,
                          '--batch')
  name = FLAGS.name_override or FLAGS.agent
  folder = os.path.join(FLAGS.output_dir, FLAGS.suite)
  cli.prepare_output_dir(folder, '--output_dir')
  path = os.path.join(folder, f'{name}.json')
  partial = os.path.join(folder, f'{name}.partial.json')
  # Not beside the records: results_table.py reads SUITE/*.json.
  timing_path = os.path.join(folder, 'timing', f'{name}.json')
  os.makedirs(os.path.dirname(timing_path), exist_ok=True)
  current = run_config(FLAGS.agent, FLAGS.suite, config, max_steps,
                       FLAGS.seed, FLAGS.gin_file, bindings)
  all_seeds = list(suite.seeds)
  with safe_io.locked_file(path, what='planner output'):
    # A finished record with seeds this run does not fly (a re-flight of
    # chosen seeds): those seeds are kept and the re-flown ones merged in,
    # if the record was flown with these settings; never fewer seeds.
    kept: List[Dict[str, Any]] = []
    timing: Dict[str, Any] = {}
    if os.path.exists(path):
      finished = _checked_records(_read_json(path, 'record'), path, all_seeds)
      if {r['seed'] for r in finished} - set(seeds):
        old = (_read_json(timing_path, 'timing file')
               if os.path.exists(timing_path) else {})
        recorded = old.get('run_config') if isinstance(old, dict) else None
        if not isinstance(recorded, dict):  # Records of older runs.
          recorded = {k: old[k] for k in ('agent', 'config', 'max_steps',
                                          'gin_bindings')
                      if isinstance(old, dict) and k in old}
        differ = differences(recorded, current) if recorded else (
            'its settings are not recorded')
        if differ:
          raise errors.ResumeError(
              f'{path} holds {len(finished)} seeds flown with other settings '
              f'({differ}); re-flying {len(seeds)} of them would mix or drop '
              'records: use --name_override')
        kept = [r for r in finished if r['seed'] not in set(seeds)]
        timing = old
    records: List[Dict[str, Any]] = []
    if os.path.exists(partial):
      records = load_partial(partial, current, all_seeds)
      if os.path.exists(timing_path):
        timing = _read_json(timing_path, 'timing file')
        if not isinstance(timing, dict):
          raise cli.CommandFailure(f'timing file {timing_path}: expected a '
                                   'JSON object; delete it to start over')
      print(f'resuming: {len(records)} seeds done', file=sys.stderr)
    done = {r['seed'] for r in records}
    todo = [s for s in seeds if s not in done]
    timing.update({'agent': FLAGS.agent, 'config': vars(config),
                   'batch': FLAGS.batch, 'max_steps': max_steps,
                   'cpus': os.cpu_count(),
                   'gin_bindings': list(bindings),
                   'wind_source': env_params.wind_source(),
                   'run_config': current})
    timing.setdefault('loadavg', []).append(os.getloadavg())
    compiled = set()
    for b in range(0, len(todo), FLAGS.batch):
      chunk = todo[b:b + FLAGS.batch]
      records += planner_batch.fly_batch(config, chunk, max_steps,
                                         FLAGS.seed, timing, compiled)
      timing['loadavg'].append(os.getloadavg())
      safe_io.atomic_write(partial, json.dumps(
          {'run_config': current, 'records': records}))
      safe_io.atomic_write(timing_path, json.dumps(timing, indent=1))
      stats = metrics.summarize(records)
      print(f'{len(records)}/{len(seeds)} seeds: tw50_window '
            f'{stats["tw50_window_mean"]:.3f}, out of resources '
            f'{stats["out_of_resources_pct"]:.0f} %', file=sys.stderr)
    complete = set(seeds) <= {r['seed'] for r in records}
    records = sorted({r['seed']: r for r in kept + records}.values(),
                     key=lambda r: r['seed'])
    batches = timing.get('batches', [])
    balloons = sum(len(b['seeds']) for b in batches)
    # Warm calls (records of older runs: the calls after each first).
    warm = [b.get('plan_s_warm', [b['plan_s_mean_after_first']] *
                  (b['plan_calls'] - 1)) for b in batches]
    calls = sum(len(w) for w in warm)
    plan_sum = sum(sum(w) for w in warm)
    # Seconds per decision of one balloon: a batched call's wall / balloons.
    per_call = [float(np.mean(w)) / len(b['seeds'])
                for b, w in zip(batches, warm) if w]
    timing['summary'] = {
        'seeds': len(records),
        's_per_decision_per_balloon': (float(np.mean(per_call)) if per_call
                                       else None),
        's_per_batched_call': plan_sum / calls if calls else None,
        's_per_episode_per_balloon': (
            sum(b['wall_s'] for b in batches) / balloons if balloons
            else None),
    }
    safe_io.atomic_write(timing_path, json.dumps(timing, indent=1))
    # Each record names its winds, as `ble-latex-eval`'s do.
    safe_io.atomic_write(path, json.dumps([
        {**r, 'wind_source': timing['wind_source']} for r in records]))
    if os.path.exists(partial) and complete:
      os.remove(partial)
  print(json.dumps({'output': path, **metrics.summarize(records),
                    **timing['summary']}))
  return 0


def check() -> None:
  """An unknown suite or a bad agent seed: one line, exit status 2."""
  from ble_latex.run import suites  # pylint: disable=g-import-not-at-top
  suites.check_suite(FLAGS.suite)
  if not 0 <= FLAGS.seed < 2**31:  # The planners take an int32 seed.
    raise cli.CommandUsageError(f'--seed must be in [0, 2**31), got '
                                f'{FLAGS.seed}')


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/planners.py', FLAGS, argv,
                      doc=__doc__, check=check)


if __name__ == '__main__':
  sys.exit(main())
