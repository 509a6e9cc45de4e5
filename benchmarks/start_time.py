"""Time to the first step: ble_latex's Gymnasium env against BLE's own env.

Each measurement is a fresh Python process (`python -c`, nothing imported
before) timing `import ble_latex, gymnasium`, `gymnasium.make(ID)`, the
first `env.reset(seed=0)` and the first `env.step(...)` (reset and step
compile, or load from JAX's persistent compilation cache, the env's jitted
functions), and recording whether TensorFlow was imported. The cases:

- cold: no compilation cache at all (what every process pays by default),
  `--cold_repeats` times, interleaved with
- ble: BLE's own `gym.make('BalloonLearningEnvironment-v0')` -> reset ->
  step in a fresh process (`import balloon_learning_environment.env`,
  TensorFlow included, as BLE's users start it), so the ratio cold / ble is
  measured side by side under the same load;
- warm: an opt-in cache directory (`BLE_LATEX_JAX_CACHE=1`) filled by one
  start, then `--repeats` later starts;
- vector: `gymnasium.make_vec(ID, num_envs=--num_envs)` + reset + step, warm.

The machine's load average (`os.getloadavg`) is recorded before and after
each run: on a shared machine it explains most of the spread. So is each
child's CPU time (user + system, `cpu_s`): on 2 cores a start cannot take
less wall time than about half of it, which bounds the cold ratio.

  python benchmarks/start_time.py --repeats 5 --json benchmarks/records/start_time.json
"""

import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from typing import Optional, Sequence

from absl import flags

from ble_latex import safe_io
from ble_latex.cli import common as cli

ID = 'ble_latex/LatexBalloon-v0'
REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

_CHILD = '''
import time
t0 = time.perf_counter()
import ble_latex, gymnasium
t1 = time.perf_counter()
if {num_envs}:
  env = gymnasium.make_vec({id!r}, num_envs={num_envs})
else:
  env = gymnasium.make({id!r})
t2 = time.perf_counter()
env.reset(seed=0)
t3 = time.perf_counter()
env.step(env.action_space.sample())
t4 = time.perf_counter()
import json, sys
print(json.dumps({{'import_s': t1 - t0, 'make_s': t2 - t1, 'reset_s': t3 - t2,
                  'step_s': t4 - t3, 'total_s': t4 - t0,
                  'tensorflow_imported': 'tensorflow' in sys.modules}}))
'''

# BLE's own env, as its README starts it (gym 0.25 API).
_BLE_CHILD = '''
import time
t0 = time.perf_counter()
import gym
import balloon_learning_environment.env.balloon_env  # registers the id
t1 = time.perf_counter()
env = gym.make('BalloonLearningEnvironment-v0')
t2 = time.perf_counter()
env.reset()
t3 = time.perf_counter()
env.step(env.action_space.sample())
t4 = time.perf_counter()
import json, sys
print(json.dumps({'import_s': t1 - t0, 'make_s': t2 - t1, 'reset_s': t3 - t2,
                  'step_s': t4 - t3, 'total_s': t4 - t0,
                  'tensorflow_imported': 'tensorflow' in sys.modules}))
'''


def run_once(cache_dir: Optional[str], num_envs: int = 0,
             ble: bool = False) -> dict:
  """One fresh process; `cache_dir` None: no persistent cache at all."""
  env = dict(os.environ)
  for name in ('JAX_COMPILATION_CACHE_DIR', 'BLE_LATEX_JAX_CACHE',
               'BLE_LATEX_JAX_CACHE_DIR'):
    env.pop(name, None)
  if cache_dir is not None:
    env.update(BLE_LATEX_JAX_CACHE='1', BLE_LATEX_JAX_CACHE_DIR=cache_dir)
  code = _BLE_CHILD if ble else _CHILD.format(id=ID, num_envs=num_envs)
  load_before = os.getloadavg()
  cpu_before = resource.getrusage(resource.RUSAGE_CHILDREN)
  start = time.perf_counter()
  result = subprocess.run(
      [sys.executable, '-c', code],
      env=env, cwd=REPO, capture_output=True, text=True, timeout=1200)
  wall = time.perf_counter() - start
  cpu_after = resource.getrusage(resource.RUSAGE_CHILDREN)
  cpu = (cpu_after.ru_utime + cpu_after.ru_stime -
         cpu_before.ru_utime - cpu_before.ru_stime)
  if result.returncode != 0:
    raise RuntimeError(result.stderr[-3000:])
  out = json.loads(result.stdout.strip().splitlines()[-1])
  out.update(process_wall_s=wall, cpu_s=cpu, stderr_empty=result.stderr == '',
             load_before=load_before[0], load_after=os.getloadavg()[0])
  return out


FLAGS = flags.FlagValues()
flags.DEFINE_integer('repeats', 5, 'Warm starts to time.', lower_bound=1,
                     flag_values=FLAGS)
flags.DEFINE_integer('cold_repeats', 3, 'Cold starts of ours and of BLE, '
                     'interleaved.', lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('num_envs', 16, 'Balloons of the vector env timed.',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_string('json', '', 'Also write the report here.',
                    flag_values=FLAGS)


def _main(argv: Sequence[str]) -> int:
  args = FLAGS
  with tempfile.TemporaryDirectory(prefix='ble_latex_jax_cache_') as cache:
    runs = {'cold': [], 'ble': [], 'warm': [], 'vector_warm': []}
    for i in range(args.cold_repeats):
      runs['cold'].append(run_once(None))
      print('cold', i, runs['cold'][-1], flush=True)
      runs['ble'].append(run_once(None, ble=True))
      print('ble', i, runs['ble'][-1], flush=True)
    run_once(cache)  # Fills the opt-in cache.
    for i in range(args.repeats):
      runs['warm'].append(run_once(cache))
      print('warm', i, runs['warm'][-1], flush=True)
    run_once(cache, args.num_envs)  # Fills the cache for the vector env.
    for i in range(max(1, args.repeats // 2)):
      runs['vector_warm'].append(run_once(cache, args.num_envs))
      print('vector warm', i, runs['vector_warm'][-1], flush=True)

  def summary(rows):
    totals = sorted(r['total_s'] for r in rows)
    cpu = sorted(r['cpu_s'] for r in rows)
    return {'min_s': totals[0], 'median_s': totals[len(totals) // 2],
            'max_s': totals[-1], 'n': len(totals),
            'cpu_median_s': cpu[len(cpu) // 2],
            'tensorflow_imported': any(r['tensorflow_imported'] for r in rows),
            'stderr_empty': all(r['stderr_empty'] for r in rows)}

  ratios = sorted(ours['total_s'] / ble['total_s']
                  for ours, ble in zip(runs['cold'], runs['ble']))
  report = {
      'what': ('fresh process: import ble_latex, gymnasium; gymnasium.make('
               f'{ID!r}); env.reset(seed=0); env.step; against BLE\'s '
               'gym.make(BalloonLearningEnvironment-v0), reset, step'),
      'cold_over_ble': {'per_pair': ratios,
                        'median': ratios[len(ratios) // 2]},
      'num_envs_vector': args.num_envs,
      'machine': {'cpus': os.cpu_count(), 'platform': platform.platform(),
                  'python': platform.python_version()},
      'summary': {k: summary(v) for k, v in runs.items()},
      'runs': runs,
  }
  print(json.dumps(report['summary'], indent=1))
  print('cold / BLE:', json.dumps(report['cold_over_ble']))
  if args.json:
    safe_io.atomic_write(args.json, json.dumps(report, indent=1) + '\n')
  return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/start_time.py', FLAGS, argv,
                      doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
