"""The functional env's auto-reset cost: `step` against `step_env`, side by side.

For each N (--batch_sizes), in its own fresh subprocess: N balloons flown for
--strides strides in one jitted `lax.scan` of the vmapped function (params
shared, `in_axes=None`; only observations and rewards leave the scan, as
`jax_env.rollout` flies them), for

- `step_env`: no reset (the baseline);
- `step, no pool`: gymnax's auto-reset with `EnvParams.reset_pool` None (a
  full reset, VAE decode included, computed for every balloon every step);
- `step, pool K`: auto-reset from a pool of --pool_size worlds
  (`LatexBalloonJaxEnv.with_reset_pool`);
- `step, pool K, E-stride episodes`: the same with `episode_steps` =
  --short_episode (N/E balloons end at every stride: a stress case).

The scan's final state is returned and its input donated
(`donate_argnums`), as a training loop carries the env state from call to
call: the N forecast grids (~317 kB per balloon) are updated in place.
Two more variants time the form of earlier runs, where the final state is
dropped and the input kept (`..., state dropped`): there XLA copies the
input state into the scan once per call wherever the scan writes a leaf,
i.e. the pool's forecast grids and noise permutations (336 MB at N = 1024),
a cost of that harness, not of the step; `step_env` never writes them.

Episodes are staggered: balloon i starts at a step drawn uniformly in
[0, episode_steps), so about N/216 balloons end at every stride, as in a
long gymnax-style training run. Actions are uniform in [-1, 1]^3 (the env's
default normalized actions). Every call starts from the same state (a fresh
copy, made outside the timing, is donated). After a first (compiling) call
of each, the variants are timed in --repeats rounds, one call of each per
round (so a load change hits them alike); reported: the best call of each,
as balloon-steps/s and its time over `step_env`'s (a `state dropped`
variant's over `step_env, state dropped`'s).

  python benchmarks/autoreset_speed.py --json=benchmarks/records/autoreset_speed.json
"""

import json
import os
import subprocess
import sys
import time
from typing import Any, Dict, Optional, Sequence

from absl import flags

from ble_latex.cli import common as cli
from ble_latex.run import speed

def worker(batch: int, strides: int, repeats: int, pool_size: int,
           short_episode: int) -> Dict[str, Any]:
  """Times the variants above for `batch` balloons, in this process."""
  import jax  # pylint: disable=g-import-not-at-top
  import jax.numpy as jnp  # pylint: disable=g-import-not-at-top
  import ble_latex  # noqa: F401  pylint: disable=g-import-not-at-top,unused-import
  from ble_latex.envs import env_params  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import jax_env  # pylint: disable=g-import-not-at-top

  env = jax_env.LatexBalloonJaxEnv()
  params = env_params.params_from_gin()
  t = time.perf_counter()
  pooled = env.with_reset_pool(jax.random.PRNGKey(1234), params, pool_size)
  jax.block_until_ready(pooled.reset_pool)
  pool_s = time.perf_counter() - t
  keys = jax.random.split(jax.random.PRNGKey(0), batch)
  _, state0 = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(keys, params)

  def staggered(p):
    steps = jax.random.randint(jax.random.PRNGKey(2), (batch,), 0,
                               p.episode_steps)
    return state0.replace(steps=steps.astype(jnp.int32))

  def make(fn_name, carried=True):
    fn = getattr(env, fn_name)

    def fly(state, key, p):
      def one(state, k):
        act_key, step_key = jax.random.split(k)
        action = jax.random.uniform(act_key, (batch, 3), minval=-1.0,
                                    maxval=1.0)
        out = jax.vmap(fn, in_axes=(0, 0, 0, None))(
            jax.random.split(step_key, batch), state, action, p)
        return out[1], (out[0], out[2])
      state, (obs, rewards) = jax.lax.scan(one, state,
                                           jax.random.split(key, strides))
      return (obs, rewards, state) if carried else (obs, rewards)
    return jax.jit(fly, donate_argnums=(0,) if carried else ()), carried

  pool_name = f'step, pool {pool_size}'
  variants = {
      'step_env': ('step_env', params, True),
      'step, no pool': ('step', params, True),
      pool_name: ('step', pooled, True),
      f'{pool_name}, {short_episode}-stride episodes': (
          'step', pooled.replace(episode_steps=short_episode), True),
      'step_env, state dropped': ('step_env', params, False),
      f'{pool_name}, state dropped': ('step', pooled, False),
  }
  fresh = jax.jit(lambda s: jax.tree.map(jnp.copy, s))

  def start(state, carried):
    return jax.block_until_ready(fresh(state)) if carried else state

  result = {'batch': batch, 'strides': strides, 'pool_size': pool_size,
            'pool_build_s': pool_s, 'device': str(jax.devices()[0]),
            'jax': jax.__version__, 'loadavg_before': os.getloadavg(),
            'variants': {}}
  compiled = {}
  for name, (fn_name, p, carried) in variants.items():
    fly, carried = make(fn_name, carried)
    state = staggered(p)
    s = start(state, carried)
    t = time.perf_counter()
    jax.block_until_ready(fly(s, jax.random.PRNGKey(0), p))
    compiled[name] = (fly, state, p, carried)
    result['variants'][name] = {'first_call_s': time.perf_counter() - t,
                                'all_s': []}
  # Rounds over the variants (the load drifts): the best call of each.
  for r in range(repeats):
    for name, (fly, state, p, carried) in compiled.items():
      s = start(state, carried)
      t = time.perf_counter()
      obs = jax.block_until_ready(fly(s, jax.random.PRNGKey(r + 1), p))[0]
      v = result['variants'][name]
      v['all_s'].append(time.perf_counter() - t)
      v['finite_obs'] = bool(jnp.all(jnp.isfinite(obs)))
  for name, v in result['variants'].items():
    v['best_s'] = best = min(v['all_s'])
    v['balloon_steps_per_s'] = batch * strides / best
    print(f'  N={batch:5d} {name:44s} first {v["first_call_s"]:6.1f} s  '
          f'best {best:7.3f} s  {batch * strides / best:10.0f} '
          'balloon-steps/s', file=sys.stderr, flush=True)
  for name, v in result['variants'].items():
    base = ('step_env, state dropped' if name.endswith('state dropped')
            else 'step_env')
    v['time_over_step_env'] = (v['best_s'] /
                               result['variants'][base]['best_s'])
  result['loadavg_after'] = os.getloadavg()
  return result


FLAGS = flags.FlagValues()
flags.DEFINE_string('batch_sizes', '64,1024', 'Numbers of balloons, '
                    'comma-separated.', flag_values=FLAGS)
flags.DEFINE_integer('strides', 16, 'Strides per timed call.', lower_bound=1,
                     flag_values=FLAGS)
flags.DEFINE_integer('repeats', 5, 'Rounds of timed calls over the variants '
                     '(the best call of each reported).',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('pool_size', 256, 'Worlds in the reset pool.',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('short_episode', 8, 'Episode length of the stress '
                     'variant [strides].', lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('worker', None, 'Internal: time this batch size here.',
                     flag_values=FLAGS)
flags.DEFINE_string('json', None, 'Also write the results here.',
                    flag_values=FLAGS)


def _main(argv: Sequence[str]) -> None:
  del argv
  args = FLAGS
  common = ['--strides', str(args.strides), '--repeats', str(args.repeats),
            '--pool_size', str(args.pool_size), '--short_episode',
            str(args.short_episode)]
  if args.worker is not None:
    print(json.dumps(worker(args.worker, args.strides, args.repeats,
                            args.pool_size, args.short_episode)))
    return
  load_before = os.getloadavg()
  results = {'runs': []}
  for batch in (int(b) for b in args.batch_sizes.split(',')):
    out = subprocess.run([sys.executable, __file__, '--worker', str(batch),
                          *common], stdout=subprocess.PIPE, text=True,
                         check=False)
    if out.returncode:
      raise RuntimeError(f'worker N={batch} failed (exit {out.returncode})')
    results['runs'].append(json.loads(out.stdout.strip().splitlines()[-1]))
  print(f'{"N":>5s} | {"variant":44s} | {"balloon-steps/s":>15s} | '
        f'{"time / step_env":>15s}')
  for r in results['runs']:
    for name, v in r['variants'].items():
      print(f'{r["batch"]:5d} | {name:44s} | {v["balloon_steps_per_s"]:15.0f}'
            f' | {v["time_over_step_env"]:15.2f}')
  speed.write_results(results, load_before, args.json)


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/autoreset_speed.py', FLAGS, argv,
                      doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
