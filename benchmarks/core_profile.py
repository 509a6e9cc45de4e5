"""Where the JAX env's compile and run time go: its parts, jitted alone.

For N = 1 (one balloon, unbatched) and N = --batch (vmapped over balloons
after `reset`), each part below is jitted alone and measured by
`ble_latex.run.speed.time_compiled`: compile time (wall time of
`jax.jit(f).lower(...).compile()`), program size (lines of the optimised HLO,
`compiled.as_text()`), and the best of --repeats calls after a warm-up call:

- `dynamics.step`: one 20-minute stride of the flight core, constant (calm)
  wind (no wind queries);
- `ground_truth_wind`: one query of the ground-truth wind (VAE forecast +
  u and v simplex noise, 10 harmonics) at the balloon;
- `observation`: the 25-level forecast column plus the 71 features;
- `reset_forecast`: the VAE decode of one forecast (`generative`);
- `env.reset`, `env.step_env` (one stride with 7 wind queries and the
  observation), `env.step` (`step_env` plus gymnax's auto-reset branch);
  these three return the whole state, whose copy (e.g. 1024 forecast grids,
  ~325 MB) is part of their call time;
- `step_env scan/stride`: `SCAN_STRIDES` strides of `step_env` in one
  `lax.scan` returning only observations and rewards (as `jax_env.rollout`
  flies them: no state copy), its best call time divided by the strides.

With --compare_tree (e.g. a `git worktree add /tmp/core_base <commit>` of an
earlier commit) the same measurements of that tree's `ble_latex` run in a
subprocess right after this tree's, so two commits are compared side by side
under the same load; the load average is recorded before and after each.

  python benchmarks/core_profile.py --json=benchmarks/records/core_profile.json
"""

import json
import os
import subprocess
import sys
from typing import Any, Dict, Optional, Sequence

from absl import flags

from ble_latex.cli import common as cli
from ble_latex.run import speed

_HERE = os.path.dirname(os.path.abspath(__file__))
_REPO = os.path.dirname(_HERE)
# Strides of the `scan` part (its best time is reported per stride).
SCAN_STRIDES = 8


def _parts(batch: int) -> Dict[str, Any]:
  """{part: (function, args)} for `batch` balloons (1: unbatched)."""
  import jax  # pylint: disable=g-import-not-at-top
  import jax.numpy as jnp  # pylint: disable=g-import-not-at-top
  from ble_latex.run import gin_binding  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import jax_env  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import winds  # pylint: disable=g-import-not-at-top
  from ble_latex.flight import dynamics  # pylint: disable=g-import-not-at-top
  from ble_latex.wind import generative  # pylint: disable=g-import-not-at-top

  gin_binding.bind_gin(None, None, [], [])
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  params = env.default_params
  single = batch == 1
  key = jax.random.PRNGKey(0)
  keys = key if single else jax.random.split(key, batch)
  action = jnp.array([18_000.0, 2.0, -1.0])
  actions = action if single else jnp.tile(action, (batch, 1))
  # Batched over the first argument(s) only; `params` is shared.
  vm = (lambda f, n: f) if single else (
      lambda f, n: jax.vmap(f, in_axes=(0,) * n + (None,)))
  _, state = jax.jit(vm(env.reset, 1))(keys, params)

  def calm(x, y, p, t):
    del y, p, t
    return jnp.zeros_like(x), jnp.zeros_like(x)

  def flight(f, atm, a, p):
    return dynamics.step(p.flight, atm, f, a, calm, p.stride_s)

  def wind(s, p):
    del p
    f = s.flight
    return winds.ground_truth_wind(s, f.x_m, f.y_m, f.pressure_pa, f.time_s)

  def step_env(k, s, a, p):
    return env.step_env(k, s, a, p)

  def step(k, s, a, p):
    return env.step(k, s, a, p)

  def scan(k, s, a, p):
    def one(carry, _):
      obs, carry, reward, _, _ = env.step_env(k, carry, a, p)
      return carry, (obs, reward)
    return jax.lax.scan(one, s, None, length=SCAN_STRIDES)[1]

  forecast_keys = jax.vmap(lambda k: generative.split_wind_key(k)[1])(
      jnp.atleast_2d(keys))
  if single:
    forecast_keys = forecast_keys[0]
  return {
      'dynamics.step': (vm(flight, 3), (state.flight, state.atmosphere,
                                        actions, params)),
      'ground_truth_wind': (vm(wind, 1), (state, params)),
      'observation': (vm(jax_env.observation, 1), (state, params)),
      'reset_forecast': (vm(generative.reset_forecast, 1),
                         (forecast_keys, params.decoder)),
      'env.reset': (vm(env.reset, 1), (keys, params)),
      'env.step_env': (vm(step_env, 3), (keys, state, actions, params)),
      'env.step': (vm(step, 3), (keys, state, actions, params)),
      'step_env scan/stride': (vm(scan, 3), (keys, state, actions, params)),
  }


def worker(batches: Sequence[int], repeats: int) -> dict:
  """Measures every part at every batch size, in this process."""
  import jax  # pylint: disable=g-import-not-at-top
  import ble_latex  # pylint: disable=g-import-not-at-top

  result = {'ble_latex': os.path.dirname(ble_latex.__file__),
            'device': str(jax.devices()[0]), 'jax': jax.__version__,
            'loadavg_before': os.getloadavg(), 'parts': {}}
  for batch in batches:
    for name, (fn, args) in _parts(batch).items():
      r = speed.time_compiled(fn, args, repeats)
      del r['all_s']
      if name == 'step_env scan/stride':
        r['best_s'] /= SCAN_STRIDES
      result['parts'][f'{name} N={batch}'] = r
      print(f'  {name:18s} N={batch:5d}: compile {r["compile_s"]:6.2f} s  '
            f'HLO {r["hlo_lines"]:6d} lines  best {1e3 * r["best_s"]:9.3f} ms',
            file=sys.stderr, flush=True)
  result['loadavg_after'] = os.getloadavg()
  return result


def _run_worker(tree: str, batches: Sequence[int], repeats: int) -> dict:
  """`worker` in a subprocess importing `tree`'s `ble_latex` first."""
  env = dict(os.environ, PYTHONPATH=tree)
  out = subprocess.run(
      [sys.executable, __file__, '--worker', '--batches',
       ','.join(map(str, batches)), '--repeats', str(repeats)],
      stdout=subprocess.PIPE, text=True, check=False, env=env)
  if out.returncode:
    raise RuntimeError(f'worker for {tree} failed (exit {out.returncode})')
  r = json.loads(out.stdout.strip().splitlines()[-1])
  if os.path.realpath(r['ble_latex']) != os.path.realpath(
      os.path.join(tree, 'ble_latex')):
    raise RuntimeError(f'worker imported {r["ble_latex"]}, not {tree}')
  head = subprocess.run(['git', '-C', tree, 'rev-parse', 'HEAD'],
                        capture_output=True, text=True, check=False)
  dirty = subprocess.run(['git', '-C', tree, 'status', '--porcelain',
                          'ble_latex'], capture_output=True, text=True,
                         check=False)
  r['commit'] = head.stdout.strip() + (' (modified)' if dirty.stdout.strip()
                                       else '')
  return r


def _table(runs: Dict[str, dict]) -> str:
  """One row per part: compile [s], HLO lines, best call [ms] of each run."""
  names = list(runs)
  head = f'{"part":28s}' + ''.join(
      f' | {n[:24]:>24s}: compile s  HLO lines   best ms' for n in names)
  lines = [head, '-' * len(head)]
  keys = list(runs[names[0]]['parts'])
  for k in keys:
    row = f"{k:28s}"
    for n in names:
      r = runs[n]['parts'].get(k)
      row += (f' | {"":24s}  {r["compile_s"]:9.2f} {r["hlo_lines"]:10d} '
              f'{1e3 * r["best_s"]:9.3f}' if r else f' | {"-":>58s}')
    lines.append(row)
  return '\n'.join(lines)


FLAGS = flags.FlagValues()
flags.DEFINE_string('batches', '1,1024', 'Batch sizes (1: one balloon, '
                    'unbatched), comma-separated.', flag_values=FLAGS)
flags.DEFINE_integer('repeats', 5, 'Timed calls per part (best reported).',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_string('compare_tree', None, 'Another checkout (e.g. a git '
                    'worktree of an earlier commit) measured right after '
                    'this one.', flag_values=FLAGS)
flags.DEFINE_integer('rounds', 1, 'Alternate this tree and --compare_tree '
                     'this many times; per part the best round is kept.',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_bool('worker', False, 'Internal: measure in this process, JSON '
                  'on stdout.', flag_values=FLAGS)
flags.DEFINE_string('json', None, 'Also write the results here.',
                    flag_values=FLAGS)


def _best(rounds: Sequence[dict]) -> dict:
  """Per part the round with the smallest call time (compile: its own min)."""
  out = dict(rounds[0], rounds=[{k: v for k, v in r.items() if k != 'parts'}
                                for r in rounds])
  out['parts'] = {}
  for k in rounds[0]['parts']:
    rs = [r['parts'][k] for r in rounds]
    best = dict(min(rs, key=lambda r: r['best_s']))
    best['compile_s'] = min(r['compile_s'] for r in rs)
    best['lower_s'] = min(r['lower_s'] for r in rs)
    out['parts'][k] = best
  return out


def _main(argv: Sequence[str]) -> None:
  del argv
  args = FLAGS
  batches = [int(b) for b in args.batches.split(',')]
  if args.worker:
    print(json.dumps(worker(batches, args.repeats)))
    return
  trees = {'this': _REPO}
  if args.compare_tree:
    trees['compare'] = os.path.abspath(args.compare_tree)
  load_before = os.getloadavg()
  rounds: Dict[str, list] = {n: [] for n in trees}
  for i in range(args.rounds):
    for name, tree in trees.items():
      print(f'round {i + 1}: {tree}', file=sys.stderr, flush=True)
      rounds[name].append(_run_worker(tree, batches, args.repeats))
  runs = {f'{n} ({os.path.basename(trees[n])})': _best(r)
          for n, r in rounds.items()}
  results: Dict[str, Any] = {'runs': runs}
  print(_table(runs))
  if args.compare_tree:
    this, other = (runs[n]['parts'] for n in runs)
    results['ratio_compare_over_this'] = {
        k: {'compile': other[k]['compile_s'] / this[k]['compile_s'],
            'call': other[k]['best_s'] / this[k]['best_s']} for k in this}
    print('compare / this:  ' + ', '.join(
        f'{k}: compile {v["compile"]:.2f}x call {v["call"]:.2f}x'
        for k, v in results['ratio_compare_over_this'].items()))
  speed.write_results(results, load_before, args.json)


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/core_profile.py', FLAGS, argv,
                      doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
