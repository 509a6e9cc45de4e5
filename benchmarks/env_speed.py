"""Env speed: LatexBalloon-v0 vs BLE's BalloonLearningEnvironment-v0.

Both envs use BLE's generative (VAE) wind field with simplex noise, are driven
by seeded random actions, and are measured in the same run, one fresh
subprocess each (so each one's peak RSS is its own), alternating for
--repeats rounds. Reported per env: steps/s, simulated flight-hours per wall
second, wall seconds per simulated 3 days, peak RSS; and the ratios. With
--profile, a cProfile of the latex env's steps (top functions by cumulative
time) shows where latex step time goes.

  python benchmarks/env_speed.py --episodes 3 --repeats 2 --profile
"""

import cProfile
import io
import json
import pstats
import resource
import subprocess
import sys
import time
from typing import Optional, Sequence

from absl import flags

from ble_latex import safe_io
from ble_latex.cli import common as cli

ENVS = {
    'latex': ('LatexBalloon-v0', 20.0),  # (env id, minutes per step)
    'ble': ('BalloonLearningEnvironment-v0', 3.0),
}


def worker(name: str, steps: int, profile: bool) -> dict:
  """Runs `steps` env steps (resetting at episode ends) and reports."""
  import ble_latex  # noqa: F401  pylint: disable=g-import-not-at-top,unused-import
  import gym  # pylint: disable=g-import-not-at-top
  import numpy as np  # pylint: disable=g-import-not-at-top
  env_id, minutes = ENVS[name]
  env = gym.make(env_id).unwrapped
  rng = np.random.default_rng(0)
  space = env.action_space

  def action():
    if isinstance(space, gym.spaces.Discrete):  # The latex Box has `n` too.
      return int(rng.integers(space.n))
    return rng.uniform(space.low, space.high)

  env.reset(seed=0)
  env.step(action())  # Warm up (first-call compilation, caches).
  profiler = cProfile.Profile() if profile else None
  seed, done = 1, True
  start = time.perf_counter()
  if profiler:
    profiler.enable()
  reset_s = 0.0
  for _ in range(steps):
    if done:
      t = time.perf_counter()
      env.reset(seed=seed)
      reset_s += time.perf_counter() - t
      seed += 1
    _, _, done, _ = env.step(action())
  if profiler:
    profiler.disable()
  wall = time.perf_counter() - start
  result = {
      'env': env_id,
      'steps': steps,
      'wall_s': wall,
      'reset_s': reset_s,
      'steps_per_s': steps / wall,
      'sim_hours_per_wall_s': steps * minutes / 60.0 / wall,
      'wall_s_per_3_days': 3 * 24 * 60 / minutes * wall / steps,
      'peak_rss_mb': resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
  }
  if profiler:
    out = io.StringIO()
    pstats.Stats(profiler, stream=out).sort_stats('cumulative').print_stats(25)
    result['profile'] = out.getvalue()
  return result


FLAGS = flags.FlagValues()
flags.DEFINE_float('episodes', 3, 'Latex episodes (x216 steps) per '
                   'measurement; BLE runs the same simulated time (x1440 '
                   'steps).', flag_values=FLAGS)
flags.DEFINE_integer('repeats', 2, 'Measurements of each env.', lower_bound=1,
                     flag_values=FLAGS)
flags.DEFINE_boolean('profile', False, 'Profile the first latex repeat.',
                     flag_values=FLAGS)
flags.DEFINE_string('json', None, 'Also write the results here.',
                    flag_values=FLAGS)
flags.DEFINE_enum('worker', None, list(ENVS),
                  'Internal: measure this env in this process.',
                  flag_values=FLAGS)
flags.DEFINE_integer('steps', None, 'Internal: steps of a --worker.',
                     flag_values=FLAGS)


def _main(argv: Sequence[str]) -> None:
  args = FLAGS
  if args.worker:
    print(json.dumps(worker(args.worker, args.steps, args.profile)))
    return

  latex_steps = int(args.episodes * 216)
  # Same simulated time for BLE (3-min steps): 20/3 as many steps.
  steps = {'latex': latex_steps, 'ble': int(latex_steps * 20 / 3)}
  runs = {name: [] for name in ENVS}
  for r in range(args.repeats):
    for name in ENVS:
      cmd = [sys.executable, __file__, '--worker', name,
             '--steps', str(steps[name])]
      if args.profile and name == 'latex' and r == 0:
        cmd.append('--profile')
      out = subprocess.run(cmd, capture_output=True, text=True, check=True)
      runs[name].append(json.loads(out.stdout.strip().splitlines()[-1]))

  def best(name, key):  # Best of the repeats (least disturbed).
    return max(run[key] for run in runs[name]) if key != 'wall_s_per_3_days' \
        else min(run[key] for run in runs[name])

  print(f'{"env":34s} {"steps/s":>9s} {"sim h/s":>9s} {"s/3 days":>9s} '
        f'{"peak RSS MB":>12s}')
  for name in ENVS:
    print(f'{ENVS[name][0]:34s} {best(name, "steps_per_s"):9.1f} '
          f'{best(name, "sim_hours_per_wall_s"):9.2f} '
          f'{best(name, "wall_s_per_3_days"):9.2f} '
          f'{max(r["peak_rss_mb"] for r in runs[name]):12.0f}')
  ratio = (best('latex', 'sim_hours_per_wall_s') /
           best('ble', 'sim_hours_per_wall_s'))
  print(f'simulated-time throughput, latex / BLE: {ratio:.1f}x')
  if args.profile:
    print('\nlatex step profile (cumulative, first repeat):')
    print(runs['latex'][0]['profile'])
  if args.json:
    for name in ENVS:
      for run in runs[name]:
        run.pop('profile', None)
    safe_io.atomic_write(args.json, json.dumps(
        {'runs': runs, 'ratio_sim_time': ratio}, indent=1))


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/env_speed.py', FLAGS, argv,
                      doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
