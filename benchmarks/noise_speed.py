"""Simplex noise speed: the noise kernel, the ground-truth wind, the env.

In one run, in this process (JAX's default float32, on the default device):
- `ble_latex.wind.simplex.noise4d` vmapped over 10 harmonics (BLE's u and v
  harmonics) of --batch points each: points/s of the jitted kernel;
- `ble_latex.envs.winds.ground_truth_wind` of --batch reset balloons (the
  VAE forecast plus the u and v noise, 10 harmonics): queries/s;
- `LatexBalloonJaxEnv.step_env` vmapped over --batch balloons: one stride;
each best of --repeats timed calls after a warm-up call, with its compile
time (wall time of `jax.jit(f).lower(...).compile()`) and the size of its
program (lines of the lowered StableHLO text, and of the optimised HLO);
then, unless --rollout_steps is 0, the batched env's balloon-steps/s at
--batch balloons through `ble_latex.run.speed.rollout_speed` (reset
plus a `jax_env.rollout` of --rollout_steps strides; its first call is
compile plus run).

Run it on two commits side by side (e.g. a `git worktree` of the earlier one
with `PYTHONPATH` pointing at it) to compare kernels; the JSON records which
`ble_latex` was imported and the load average.

  python benchmarks/noise_speed.py --json=benchmarks/records/noise_speed.json
"""

import os
import sys
from typing import Optional, Sequence

from absl import flags

from ble_latex.cli import common as cli
from ble_latex.run import speed

def measure(batch: int, repeats: int) -> dict:
  """Times the kernel, the ground-truth wind and one stride at `batch`."""
  import jax  # pylint: disable=g-import-not-at-top
  import jax.numpy as jnp  # pylint: disable=g-import-not-at-top
  import ble_latex  # pylint: disable=g-import-not-at-top
  from ble_latex.run import gin_binding  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import jax_env  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import winds  # pylint: disable=g-import-not-at-top
  from ble_latex.wind import simplex  # pylint: disable=g-import-not-at-top

  gin_binding.bind_gin(None, None, [], [])
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  params = env.default_params
  keys = jax.random.split(jax.random.PRNGKey(0), batch)
  _, state = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(keys, params)
  result = {'batch': batch, 'ble_latex': os.path.dirname(ble_latex.__file__),
            'device': str(jax.devices()[0])}

  # The kernel: 10 harmonics (the u and v components' perm tables) at BLE's
  # noise coordinates of order 1 to 300.
  perm = jnp.concatenate([state.noise_u.perm[0], state.noise_v.perm[0]])
  coordinates = jax.random.uniform(jax.random.PRNGKey(1), (4, perm.shape[0],
                                                           batch),
                                   minval=-300.0, maxval=300.0)
  r = speed.time_compiled(jax.vmap(simplex.noise4d), (perm, *coordinates), repeats)
  r['points_per_s'] = perm.shape[0] * batch / r['best_s']
  result['noise4d'] = r

  def wind(s):
    f = s.flight
    return jax.vmap(winds.ground_truth_wind)(s, f.x_m, f.y_m, f.pressure_pa,
                                             f.time_s)
  r = speed.time_compiled(wind, (state,), repeats)
  r['queries_per_s'] = batch / r['best_s']
  result['ground_truth_wind'] = r

  action = jnp.tile(jnp.array([18_000.0, 2.0, -1.0]), (batch, 1))

  def stride(s):
    return jax.vmap(env.step_env, in_axes=(0, 0, 0, None))(keys, s, action,
                                                           params)[1]
  r = speed.time_compiled(stride, (state,), repeats)
  r['balloon_steps_per_s'] = batch / r['best_s']
  result['step_env'] = r
  return result


FLAGS = flags.FlagValues()
flags.DEFINE_integer('batch', 1024, 'Balloons (and points per harmonic).',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('repeats', 3, 'Timed calls per measurement (best '
                     'reported).', lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('rollout_steps', 72, 'Strides of the batched env '
                     'rollout (run.speed.rollout_speed); 0: skip.',
                     lower_bound=0, flag_values=FLAGS)
flags.DEFINE_string('json', None, 'Also write the results here.',
                    flag_values=FLAGS)


def _main(argv: Sequence[str]) -> None:
  del argv
  args = FLAGS
  load_before = os.getloadavg()
  results = measure(args.batch, args.repeats)
  for name, rate in (('noise4d', 'points_per_s'),
                     ('ground_truth_wind', 'queries_per_s'),
                     ('step_env', 'balloon_steps_per_s')):
    r = results[name]
    print(f'{name:18s} N={args.batch}: {r[rate]:12.0f} {rate[:-6]}/s  '
          f'best {1e3 * r["best_s"]:8.2f} ms  compile {r["compile_s"]:6.2f} s'
          f'  StableHLO {r["stablehlo_lines"]:6d} lines  HLO '
          f'{r["hlo_lines"]:6d} lines', flush=True)
  if args.rollout_steps:
    r = speed.rollout_speed(args.batch, args.rollout_steps, args.repeats)
    results['rollout'] = r
    print(f'rollout N={args.batch}, {args.rollout_steps} strides: '
          f'{r["balloon_steps_per_s"]:.0f} balloon-steps/s  first call '
          f'{r["first_call_s"]:.1f} s  best {r["wall_s"]:.2f} s', flush=True)
  speed.write_results(results, load_before, args.json,
                            note=f'ble_latex from {results["ble_latex"]}; ')


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/noise_speed.py', FLAGS, argv,
                      doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
