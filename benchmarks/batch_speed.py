"""Batched JAX env speed: balloon-steps/s for 1..4096 balloons, side by side.

In one run, each measurement in its own fresh subprocess (own peak RSS):
- a profile of one batched stride (--profile_batch balloons): the whole
  `step_env` and its parts jitted alone (flight core, wind queries,
  observation), to show where the time goes;
- `ble_latex.envs.jax_env.LatexBalloonJaxEnv`, N balloons (N = --batch_sizes): one
  jitted call resets N balloons and flies them through --steps 20-minute
  strides (`jax_env.rollout`, timed by `run.speed.rollout_speed`:
  ground-truth wind with noise re-queried every <= 3 min, the 71 features
  and the reward at every stride). Reported: the first call (compile +
  run), then the best of --repeats timed calls; for each wind of --winds:
  BLE's VAE field ('vae') and ERA5 in JAX ('era5',
  `EnvParams.wind_grid`: a synthetic grid of the paper's size, 368 times
  (1 Nov 2022 - 31 Jan 2023, 6-hourly) x 8 levels (20-175 hPa) x 26 x 26
  (+-5 deg at 0.4 deg) of random winds, or --era5_path's file), side by
  side;
- `LatexBalloon-v0` (gym, one balloon; it flies the same core) and BLE's
  `BalloonLearningEnvironment-v0` (3-minute steps) over the same simulated
  time, measured by `benchmarks/env_speed.py`'s worker;
- `LatexBalloon-v0` before the flight core (--before_ref, the commit with
  the NumPy model): checked out into a temporary `git worktree` and timed by
  that commit's own `env_speed.py` worker with the same interpreter, so the
  single-env speed-up is measured side by side too.
Throughput is compared in simulated balloon-hours per wall second.

  python benchmarks/batch_speed.py --json=benchmarks/records/batch_speed.json
"""

import json
import os
import subprocess
import sys
import tempfile
import time
from typing import Optional, Sequence

from absl import flags

from ble_latex.cli import common as cli
from ble_latex.run import speed

_HERE = os.path.dirname(os.path.abspath(__file__))


def profile_worker(batch: int, repeats: int) -> dict:
  """Where a batched stride's time goes: its parts, each jitted alone.

  For `batch` balloons after reset: the whole `step_env`; the flight core's
  stride with a constant wind (no wind queries); the ground-truth wind at
  the 7 sub-step queries of a stride (VAE forecast + 2 x 5 simplex
  harmonics each); the observation (25-level forecast column + features).
  """
  import jax  # pylint: disable=g-import-not-at-top
  import jax.numpy as jnp  # pylint: disable=g-import-not-at-top
  import ble_latex  # noqa: F401  pylint: disable=g-import-not-at-top,unused-import
  from ble_latex.run import gin_binding  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import jax_env  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import winds  # pylint: disable=g-import-not-at-top
  from ble_latex.flight import dynamics  # pylint: disable=g-import-not-at-top

  gin_binding.bind_gin(None, None, [], [])
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  params = env.default_params
  keys = jax.random.split(jax.random.PRNGKey(0), batch)
  _, state = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(keys, params)
  action = jnp.tile(jnp.array([18_000.0, 2.0, -1.0]), (batch, 1))
  subs = 7  # ceil(20 min / 3 min) wind queries per stride

  def whole(s):
    return jax.vmap(env.step_env, in_axes=(0, 0, 0, None))(keys, s, action,
                                                            params)[1]

  def flight_only(s):
    calm = lambda x, y, p, t: (jnp.zeros_like(x), jnp.zeros_like(x))
    return jax.vmap(lambda f, a, atm: dynamics.step(
        params.flight, atm, f, a, calm, params.stride_s))(
            s.flight, action, s.atmosphere)

  def wind_only(s):
    def one(st):
      f = st.flight
      t = f.time_s + jnp.arange(subs) * 171.4
      return winds.ground_truth_wind(st, f.x_m, f.y_m, f.pressure_pa, t)
    return jax.vmap(one)(s)

  def obs_only(s):
    return jax.vmap(jax_env.observation, in_axes=(0, None))(s, params)

  result = {'batch': batch}
  for name, fn in (('step_env', whole), ('flight_core_calm_wind', flight_only),
                   ('ground_truth_wind_7_queries', wind_only),
                   ('observation', obs_only)):
    fn = jax.jit(fn)
    jax.block_until_ready(fn(state))
    times = []
    for _ in range(repeats):
      t = time.perf_counter()
      jax.block_until_ready(fn(state))
      times.append(time.perf_counter() - t)
    result[name + '_ms'] = 1e3 * min(times)
  return result


def _child(args, env=None) -> dict:
  out = subprocess.run([sys.executable, *args], capture_output=True,
                       text=True, check=False, env=env)
  if out.returncode:
    raise RuntimeError(f'{args} failed:\n{out.stderr[-3000:]}')
  return json.loads(out.stdout.strip().splitlines()[-1])


def _before_env_speed(ref: str, steps: int) -> dict:
  """`env_speed.py --worker latex` of commit `ref`, from a temp worktree."""
  repo = os.path.dirname(_HERE)
  with tempfile.TemporaryDirectory() as tmp:
    tree = os.path.join(tmp, 'before')
    subprocess.run(['git', '-C', repo, 'worktree', 'add', '--detach', tree,
                    ref], check=True, capture_output=True)
    try:
      # The editable install's import finder would find today's ble_latex
      # first: drop it, then run the old worker with the old tree first on
      # the path.
      bootstrap = (
          'import runpy, sys; '
          'sys.meta_path[:] = [f for f in sys.meta_path '
          'if "__editable__" not in repr(f)]; '
          f'sys.path.insert(0, {tree!r}); '
          'import ble_latex; '
          f'assert ble_latex.__file__.startswith({tree!r}), ble_latex.__file__; '
          f'sys.argv = [{os.path.join(tree, "benchmarks", "env_speed.py")!r}, '
          f'"--worker", "latex", "--steps", "{steps}"]; '
          'runpy.run_path(sys.argv[0], run_name="__main__")')
      r = _child(['-c', bootstrap])
      r['ref'] = ref
      return r
    finally:
      subprocess.run(['git', '-C', repo, 'worktree', 'remove', '--force',
                      tree], check=False, capture_output=True)


FLAGS = flags.FlagValues()
flags.DEFINE_string('batch_sizes', '1,16,256,1024,4096',
                    'Numbers of balloons, comma-separated.', flag_values=FLAGS)
flags.DEFINE_integer('steps', 216, 'Strides per rollout (216 = one 3-day '
                     'episode).', lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('repeats', 2, 'Timed rollouts per size.', lower_bound=1,
                     flag_values=FLAGS)
flags.DEFINE_float('gym_episodes', 1.0, 'LatexBalloon-v0 episodes; BLE flies '
                   'the same simulated time in 3-minute steps.',
                   flag_values=FLAGS)
flags.DEFINE_string('before_ref', 'dcfa0e1', 'Git commit of LatexBalloon-v0 '
                    'before the flight core (NumPy model), timed side by '
                    'side; empty: skip.', flag_values=FLAGS)
flags.DEFINE_string('json', None, 'Also write the results here.',
                    flag_values=FLAGS)
flags.DEFINE_integer('profile_batch', 1024, 'Batch size of the per-part '
                     'profile (0: none).', lower_bound=0, flag_values=FLAGS)
flags.DEFINE_list('winds', ['vae', 'era5'], "Winds of the batched env: "
                  "'vae' (BLE's generative field), 'era5' (ERA5 in JAX, "
                  'EnvParams.wind_grid).', flag_values=FLAGS)
flags.DEFINE_string('era5_path', None, "ERA5 file of the 'era5' runs; "
                    "default: a synthetic grid of the paper's size.",
                    flag_values=FLAGS)
flags.DEFINE_bool('skip_gym', False, 'Skip the gym/BLE single-env runs and '
                  'the ratios to them.', flag_values=FLAGS)
flags.DEFINE_integer('worker', None, 'Internal: time this batch size here.',
                     flag_values=FLAGS)
flags.DEFINE_string('worker_wind', 'vae', 'Internal: the worker\'s wind.',
                    flag_values=FLAGS)
flags.DEFINE_integer('profile_worker', None, 'Internal: profile this batch '
                     'size here.', flag_values=FLAGS)


def _main(argv: Sequence[str]) -> None:
  args = FLAGS
  if args.worker is not None:
    print(json.dumps(speed.rollout_speed(args.worker, args.steps, args.repeats,
                                         args.worker_wind, args.era5_path)))
    return
  if args.profile_worker is not None:
    print(json.dumps(profile_worker(args.profile_worker, max(args.repeats,
                                                             3))))
    return

  load_before = os.getloadavg()
  results = {'jax': [], 'gym': {}}
  for wind in args.winds:
    if wind not in ('vae', 'era5'):
      raise cli.CommandUsageError(f"--winds takes vae, era5; got {wind!r}")
  for batch in (int(b) for b in args.batch_sizes.split(',')):
    for wind in args.winds:
      r = _child([__file__, '--worker', str(batch), '--steps',
                  str(args.steps), '--repeats', str(args.repeats),
                  '--worker_wind', wind] +
                 ([f'--era5_path={args.era5_path}'] if args.era5_path
                  else []))
      results['jax'].append(r)
      print(f'jax {wind:4s} N={batch:5d}: {r["balloon_steps_per_s"]:12.0f} '
            f'balloon-steps/s  first call {r["first_call_s"]:6.1f} s  best '
            f'{r["wall_s"]:7.2f} s  peak RSS {r["peak_rss_mb"]:6.0f} MB',
            flush=True)
  by_wind = {}
  for r in results['jax']:
    by_wind.setdefault(r['batch'], {})[r['wind']] = r
  for batch, runs in by_wind.items():
    if 'vae' in runs and 'era5' in runs:
      ratio = (runs['era5']['balloon_steps_per_s'] /
               runs['vae']['balloon_steps_per_s'])
      results.setdefault('era5_vs_vae', {})[str(batch)] = ratio
      print(f'N={batch}: ERA5 / VAE throughput {ratio:.2f}x', flush=True)
  if args.skip_gym:
    args.before_ref = ''
  latex_steps = int(args.gym_episodes * 216)
  env_speed = os.path.join(_HERE, 'env_speed.py')
  for name, steps in (() if args.skip_gym else
                      (('latex', latex_steps),
                       ('ble', int(latex_steps * 20 / 3)))):
    r = _child([env_speed, '--worker', name, '--steps', str(steps)])
    results['gym'][name] = r
    print(f'{r["env"]}: {r["steps_per_s"]:.1f} steps/s, '
          f'{r["sim_hours_per_wall_s"]:.2f} simulated h/s, '
          f'{r["wall_s_per_3_days"]:.2f} s per 3 days, '
          f'peak RSS {r["peak_rss_mb"]:.0f} MB', flush=True)
  if args.before_ref:
    r = _before_env_speed(args.before_ref, latex_steps)
    results['gym']['latex_before'] = r
    ratio = (results['gym']['latex']['sim_hours_per_wall_s'] /
             r['sim_hours_per_wall_s'])
    results['ratio_single_env_vs_before'] = ratio
    print(f'{r["env"]} at {args.before_ref} (NumPy model): '
          f'{r["steps_per_s"]:.1f} steps/s, {r["wall_s_per_3_days"]:.2f} s '
          f'per 3 days; the core-backed env is {ratio:.1f}x faster',
          flush=True)
  vae_runs = [r for r in results['jax'] if r['wind'] == 'vae']
  best = max(vae_runs or results['jax'],
             key=lambda r: r['sim_hours_per_wall_s'])
  for name in results['gym']:
    if name == 'latex_before':
      continue
    ratio = best['sim_hours_per_wall_s'] / results['gym'][name][
        'sim_hours_per_wall_s']
    results[f'ratio_sim_time_vs_{name}'] = ratio
    print(f'simulated-time throughput, JAX N={best["batch"]} / '
          f'{results["gym"][name]["env"]}: {ratio:.0f}x')
  if args.profile_batch:
    r = _child([__file__, '--profile_worker', str(args.profile_batch),
                '--repeats', str(args.repeats)])
    results['profile'] = r
    print(f'one stride of {args.profile_batch} balloons, parts jitted alone: '
          + ', '.join(f'{k[:-3]} {v:.1f} ms' for k, v in r.items()
                      if k.endswith('_ms')), flush=True)
  speed.write_results(results, load_before, args.json)


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/batch_speed.py', FLAGS, argv,
                      doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
