"""`ble-latex-eval` one balloon at a time vs batched (`run/batch_eval.py`).

  python benchmarks/eval_speed.py --json=benchmarks/records/eval_speed.json

Each measurement runs in a fresh interpreter with no persistent compilation
cache (compiles included, as a user's first eval pays them); the agent and
env are built first (not timed: both ways build the same), then only the
flying is timed:

- `sac_pretrained` on `latex_small`: `eval_lib.evaluate(batched=False)` on
  the suite's first --sac_serial_seeds seeds (today's path), and the batched
  `eval_lib.evaluate` on all of the suite's seeds (`batch_eval.BATCH_SIZE`
  at once) and on the same first seeds; seconds per episode each way;
- a planner (--planner) on the suite's first --planner_seeds seeds, one batch
  each way: the batched `eval_lib.evaluate` and `planner_batch.fly_batch`
  (`benchmarks/planners.py`'s batched call, the one the issue measures
  against), same config.

The machine's load average is recorded before and after each measurement.
"""

import datetime as dt
import json
import os
import platform
import subprocess
import sys
import time
from typing import Any, Dict, Optional, Sequence

from absl import flags

from ble_latex import safe_io
from ble_latex.cli import common as cli

FLAGS = flags.FlagValues()
flags.DEFINE_string('suite', 'latex_small', 'Suite evaluated.',
                    flag_values=FLAGS)
flags.DEFINE_integer('sac_serial_seeds', 10, 'First seeds flown one at a '
                     'time by sac_pretrained (0: skip sac_pretrained).',
                     lower_bound=0, flag_values=FLAGS)
flags.DEFINE_string('planner', 'latex_mpc', 'The planner compared.',
                    flag_values=FLAGS)
flags.DEFINE_integer('planner_seeds', 4, 'First seeds the planner flies, '
                     'one batch each way (0: skip).', lower_bound=0,
                     flag_values=FLAGS)
flags.DEFINE_integer('max_episode_length', None, 'Cap on the strides '
                     '(default: the suite\'s).', lower_bound=1,
                     flag_values=FLAGS)
flags.DEFINE_string('json', None, 'Write the results here.',
                    flag_values=FLAGS)
flags.DEFINE_string('measure', None, 'Internal: one measurement (a child '
                    'process): serial, batched, planner_eval or '
                    'planner_bench, then NUM_SEEDS.', flag_values=FLAGS)


def _measure(what: str, num_seeds: int, suite_name: str,
             max_steps: Optional[int], planner: str) -> Dict[str, Any]:
  """One measurement in this process: its wall time and records' means."""
  # pylint: disable=g-import-not-at-top
  from ble_latex.run import eval_lib
  from ble_latex.run import metrics
  from ble_latex.run import suites
  # pylint: enable=g-import-not-at-top
  suite = suites.get_eval_suite(suite_name)
  seeds = list(suite.seeds)[:num_seeds]
  max_steps = max_steps or suite.max_episode_length
  agent = 'sac_pretrained' if what in ('serial', 'batched') else planner
  began = time.perf_counter()
  built = eval_lib.build(eval_lib.EvalSpec(agent=agent))
  build_s = time.perf_counter() - began
  began = time.perf_counter()
  if what == 'planner_bench':
    from ble_latex.run import planner_batch  # pylint: disable=g-import-not-at-top
    records = planner_batch.fly_batch(built[0].config, seeds, max_steps, 0,
                                      {}, set())
  else:
    records = eval_lib.evaluate(*built, seeds, max_steps,
                                batched=what != 'serial')
  wall = time.perf_counter() - began
  stats = metrics.summarize(records)
  return {'what': what, 'agent': agent, 'seeds': len(seeds),
          'max_steps': max_steps, 'build_s': round(build_s, 2),
          'fly_s': round(wall, 2),
          's_per_episode': round(wall / len(seeds), 3),
          'tw50_window_mean': stats['tw50_window_mean'],
          'reward_mean': stats['reward_mean']}


def _child(what: str, num_seeds: int) -> Dict[str, Any]:
  """Runs one measurement in a fresh interpreter without a compile cache."""
  env = {k: v for k, v in os.environ.items()
         if k not in ('JAX_COMPILATION_CACHE_DIR', 'BLE_LATEX_JAX_CACHE')}
  argv = [sys.executable, os.path.abspath(__file__),
          f'--measure={what},{num_seeds}', f'--suite={FLAGS.suite}',
          f'--planner={FLAGS.planner}']
  if FLAGS.max_episode_length:
    argv.append(f'--max_episode_length={FLAGS.max_episode_length}')
  load_before = os.getloadavg()
  result = subprocess.run(argv, env=env, capture_output=True, text=True)
  if result.returncode:
    out = {'what': what, 'seeds': num_seeds, 'failed': result.returncode,
           'stderr_tail': result.stderr.strip().splitlines()[-8:]}
  else:
    out = json.loads(result.stdout.strip().splitlines()[-1])
  out['loadavg_before'] = [round(x, 2) for x in load_before]
  out['loadavg_after'] = [round(x, 2) for x in os.getloadavg()]
  print(json.dumps(out), file=sys.stderr, flush=True)
  return out


def _main(argv: Sequence[str]) -> None:
  del argv
  if FLAGS.measure is not None:
    what, num_seeds = FLAGS.measure.split(',')
    print(json.dumps(_measure(what, int(num_seeds), FLAGS.suite,
                              FLAGS.max_episode_length, FLAGS.planner)))
    return
  from ble_latex.run import suites  # pylint: disable=g-import-not-at-top
  size = len(suites.get_eval_suite(FLAGS.suite).seeds)
  report: Dict[str, Any] = {
      'command': ' '.join(['python', 'benchmarks/eval_speed.py',
                           *sys.argv[1:]]),
      'date': dt.datetime.now().isoformat(timespec='minutes'),
      'host': platform.node(), 'cpus': os.cpu_count(), 'suite': FLAGS.suite}
  if FLAGS.sac_serial_seeds:
    serial = _child('serial', FLAGS.sac_serial_seeds)
    batched_same = _child('batched', FLAGS.sac_serial_seeds)
    batched_suite = _child('batched', size)
    report['sac_pretrained'] = {
        'serial': serial, 'batched_same_seeds': batched_same,
        'batched_suite': batched_suite}
    if not any('failed' in r for r in (serial, batched_same, batched_suite)):
      report['sac_pretrained'].update({
          'speedup_per_episode_suite': round(
              serial['s_per_episode'] / batched_suite['s_per_episode'], 2),
          'speedup_per_episode_same_seeds': round(
              serial['s_per_episode'] / batched_same['s_per_episode'], 2)})
    _write(report)
  if FLAGS.planner_seeds:
    via_eval = _child('planner_eval', FLAGS.planner_seeds)
    bench = _child('planner_bench', FLAGS.planner_seeds)
    report['planner'] = {
        'eval_batched': via_eval, 'benchmarks_planners_fly_batch': bench}
    if 'failed' not in via_eval and 'failed' not in bench:
      report['planner']['eval_over_benchmark'] = round(
          via_eval['fly_s'] / bench['fly_s'], 3)
    _write(report)
  print(json.dumps(report, indent=1))


def _write(report: Dict[str, Any]) -> None:
  """Writes the report so far to --json (after each part)."""
  if FLAGS.json:
    safe_io.atomic_write(FLAGS.json, json.dumps(report, indent=1) + '\n')


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/eval_speed.py', FLAGS, argv,
                      doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
