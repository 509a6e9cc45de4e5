"""Vector env throughput: make_vec's batched core vs gymnasium's SyncVectorEnv.

`gymnasium.make_vec('ble_latex/LatexBalloon-v0', num_envs=N)` (the default
vector entry point: all N balloons in one jitted, vmapped core call,
`gymnasium_vector.LatexBalloonVectorEnv`) against
`make_vec(..., vectorization_mode='sync')` (a `SyncVectorEnv` of N single
envs, each stepping its balloon through the same compiled step), side by
side in one run. Each (mode, N) runs in its own fresh subprocess: build,
`reset(seed=0)`, one warm-up step (compilation, or loading it from the
persistent cache), then seeded uniform random actions for at least
--min_seconds of stepping (auto-resets included when episodes end).
Reported: balloon-steps/s (N x steps / wall s), wall s per vector step,
first reset and first step times, peak RSS, load average.

  python benchmarks/vector_env_speed.py --json benchmarks/records/vector_env_speed.json
"""

import json
import os
import resource
import subprocess
import sys
import time
from typing import Optional, Sequence

from absl import flags

from ble_latex import safe_io
from ble_latex.cli import common as cli

ID = 'ble_latex/LatexBalloon-v0'
REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def worker(mode: str, num_envs: int, min_seconds: float,
           max_steps: int) -> dict:
  """Steps one vector env; returns its measurements."""
  t0 = time.perf_counter()
  import ble_latex  # noqa: F401  pylint: disable=g-import-not-at-top,unused-import
  import gymnasium  # pylint: disable=g-import-not-at-top
  import jax  # pylint: disable=g-import-not-at-top
  import numpy as np  # pylint: disable=g-import-not-at-top
  kwargs = {} if mode == 'batched' else {'vectorization_mode': 'sync'}
  envs = gymnasium.make_vec(ID, num_envs=num_envs, **kwargs)
  built = time.perf_counter()
  envs.reset(seed=0)
  reset_s = time.perf_counter() - built
  space = envs.single_action_space
  rng = np.random.default_rng(0)

  def actions():
    return rng.uniform(space.low, space.high,
                       (num_envs,) + space.shape).astype(np.float32)

  warmup_s = []
  for _ in range(2):  # Compilation (or cache loads) of the step.
    t = time.perf_counter()
    envs.step(actions())
    warmup_s.append(time.perf_counter() - t)
  step_s, resets = [], 0
  start = time.perf_counter()
  while len(step_s) < max_steps and (
      len(step_s) < 3 or time.perf_counter() - start < min_seconds):
    t = time.perf_counter()
    _, _, terminated, truncated, _ = envs.step(actions())
    step_s.append(time.perf_counter() - t)
    resets += int(np.any(terminated | truncated))
  wall = time.perf_counter() - start
  envs.close()
  steps = len(step_s)
  median = float(np.median(step_s))
  return {
      'mode': mode, 'num_envs': num_envs, 'vector_type': type(envs).__name__,
      'steps': steps, 'wall_s': wall,
      'steps_with_episode_ends': resets,
      # All measured steps, auto-resets (and their first compilation) included.
      'balloon_steps_per_s': num_envs * steps / wall,
      # From the median step: the steady rate between episode ends.
      'median_balloon_steps_per_s': num_envs / median,
      'median_step_s': median, 'max_step_s': float(np.max(step_s)),
      'build_s': built - t0, 'first_reset_s': reset_s,
      'warmup_steps_s': warmup_s,
      'peak_rss_mb': resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
      'device': str(jax.devices()[0]),
  }


def run(mode: str, num_envs: int, min_seconds: float, max_steps: int) -> dict:
  load_before = os.getloadavg()[0]
  result = subprocess.run(
      [sys.executable, __file__, '--worker', mode, '--num_envs',
       str(num_envs), '--min_seconds', str(min_seconds), '--max_steps',
       str(max_steps)], cwd=REPO, capture_output=True, text=True,
      timeout=3600)
  if result.returncode != 0:
    raise RuntimeError(f'{mode} N={num_envs}: {result.stderr[-3000:]}')
  out = json.loads(result.stdout.strip().splitlines()[-1])
  out.update(load_before=load_before, load_after=os.getloadavg()[0])
  return out


FLAGS = flags.FlagValues()
flags.DEFINE_string('sizes', '1,64,1024',
                    'Numbers of balloons, comma-separated.', flag_values=FLAGS)
flags.DEFINE_string('modes', 'batched,sync',
                    'Vector env modes, comma-separated.', flag_values=FLAGS)
flags.DEFINE_float('min_seconds', 10.0, 'Least measuring time per row.',
                   flag_values=FLAGS)
flags.DEFINE_integer('max_steps', 200, 'Most steps per row.',
                     flag_values=FLAGS)
flags.DEFINE_string('json', '', 'Also write the report here.',
                    flag_values=FLAGS)
flags.DEFINE_string('worker', '', 'Internal: measure this mode in this '
                    'process.', flag_values=FLAGS)
flags.DEFINE_integer('num_envs', 1, 'Internal: balloons of a --worker.',
                     flag_values=FLAGS)


def _main(argv: Sequence[str]) -> int:
  args = FLAGS
  if args.worker:
    print(json.dumps(worker(args.worker, args.num_envs, args.min_seconds,
                            args.max_steps)))
    return 0
  rows = []
  for n in (int(s) for s in args.sizes.split(',')):
    for mode in args.modes.split(','):
      rows.append(run(mode, n, args.min_seconds, args.max_steps))
      print(json.dumps(rows[-1]), flush=True)
  table = {}
  for r in rows:
    table.setdefault(r['num_envs'], {})[r['mode']] = r[
        'median_balloon_steps_per_s']
  speedup = {n: v['batched'] / v['sync'] for n, v in table.items()
             if 'batched' in v and 'sync' in v}
  report = {'env': ID, 'cpus': os.cpu_count(), 'rows': rows,
            'median_balloon_steps_per_s': table,
            'batched_over_sync': speedup}
  print(json.dumps({'median_balloon_steps_per_s': table,
                    'batched_over_sync': speedup}, indent=1))
  if args.json:
    safe_io.atomic_write(args.json, json.dumps(report, indent=1) + '\n')
  return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/vector_env_speed.py', FLAGS, argv,
                      doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
