"""The Gymnasium env's three programs compiled with XLA's defaults and fast.

Lowers the single env's `draw`, `start` and `step`
(`gymnasium_compile.Compiled`)
jitted with XLA's defaults and with `jax_cache.CPU_FAST_COMPILE`, then
compiles each lowering, `--repeats` rounds alternating the two (no
persistent cache, in-process caches cleared: every compile is a real one),
and records wall and process CPU seconds per compile, the best call of
each compiled `step`, the machine's load average,
how far a 216-step episode's observations and rewards flown with the
fast programs are from the default ones, and (`--batch_sizes`) the vector
env's batched step flown both ways, alternated, in balloon-steps/s (why the
vector env keeps XLA's defaults):

  python benchmarks/compile_options.py --repeats 3 --json benchmarks/records/compile_options.json
"""

import argparse
import json
import os
import resource
import time
from typing import Any, Dict

import gymnasium
import jax
import numpy as np

import ble_latex  # noqa: F401  pylint: disable=unused-import
from ble_latex import jax_cache
from ble_latex import safe_io
from ble_latex.envs import gymnasium_compile
from ble_latex.envs import jax_env

SETS = ('XLA defaults', 'fast (jax_cache.CPU_FAST_COMPILE)')


def _cpu_s() -> float:
  usage = resource.getrusage(resource.RUSAGE_SELF)
  return usage.ru_utime + usage.ru_stime


def _episode(programs, params, seed: int = 3, steps: int = 216):
  """Observations and rewards of one episode of fixed random actions."""
  draw, start, step = programs
  key = jax_env.arena_key(jax.random.PRNGKey(seed))
  state, _ = draw(key, params)
  state, packed = start(state, params)
  rng = np.random.default_rng(0)
  out = [np.asarray(packed)]
  for _ in range(steps):
    action = np.array([rng.uniform(14_000, 21_000), rng.uniform(0, 2),
                       rng.uniform(-1, 1)], np.float32)
    parts, packed = step(state, action, params)
    state = state.replace(**parts)
    out.append(np.asarray(packed))
  return np.concatenate([o.ravel() for o in out]).astype(np.float64)


def _vector_speeds(core, params, batch_sizes, seconds):
  """Batched step rates [balloon-steps/s], both ways, two alternated rounds."""
  speeds = {}
  for n in batch_sizes:
    keys = gymnasium_compile.arena_keys(np.arange(n, dtype=np.uint32))
    actions = np.tile(np.array([16_000.0, 1.0, 0.0], np.float32), (n, 1))
    ways = dict(zip(SETS, (gymnasium_compile.Compiled(core, True, fast)
                           for fast in (False, True))))
    rates = {name: [] for name in SETS}
    for _ in range(2):
      for name, fns in ways.items():
        state, _ = fns.draw(keys, params)
        state, _ = fns.start(state, params)
        jax.block_until_ready(fns.step(state, actions, params, np.bool_(False)))
        begun, strides = time.perf_counter(), 0
        while time.perf_counter() - begun < seconds:
          parts, packed = fns.step(state, actions, params, np.bool_(False))
          state = state.replace(**parts)
          jax.block_until_ready(packed)
          strides += 1
        rates[name].append(round(n * strides / (time.perf_counter() - begun)))
    speeds[str(n)] = rates
    print(f'N = {n}:', json.dumps(rates), flush=True)
  return speeds


def main() -> None:
  parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
  parser.add_argument('--repeats', type=int, default=3)
  parser.add_argument('--batch_sizes', default='64,1024',
                      help='Vector env batch sizes to time ("" for none).')
  parser.add_argument('--seconds', type=float, default=3.0,
                      help='Stepping time per batch size, set and round.')
  parser.add_argument('--json', default='', help='Also write the report here.')
  args = parser.parse_args()
  if args.json and safe_io.output_problem(args.json):
    parser.error(f'--json: {safe_io.output_problem(args.json)}')
  env = gymnasium.make('ble_latex/LatexBalloon-v0').unwrapped
  params = env.params
  core = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  fast_options = dict(jax_cache.CPU_FAST_COMPILE)
  default_fns, fast_fns = (gymnasium_compile.Compiled(core, False, fast)
                           for fast in (False, True))
  key = jax_env.arena_key(jax.random.PRNGKey(0))

  def lower(fns):
    """Fresh lowerings (a lowering keeps the program it compiled)."""
    drawn = jax.eval_shape(fns.draw, key, params)[0]
    started = jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, x.dtype),
                           drawn)
    return {'draw': fns.draw.lower(key, params),
            'start': fns.start.lower(drawn, params),
            'step': fns.step.lower(
                started, jax.ShapeDtypeStruct((3,), np.float32), params,
                np.bool_(False))}

  report: Dict[str, Any] = {'loadavg_before': os.getloadavg(),
                            'jax': jax.__version__, 'repeats': args.repeats,
                            'fast_options': fast_options,
                            'runs': {name: [] for name in SETS}}
  compiled = {}
  for _ in range(args.repeats):
    for name in SETS:
      run = {}
      programs = []
      jax.clear_caches()  # A real compile every time.
      lowered = lower(default_fns if name == SETS[0] else fast_fns)
      for part, lowering in lowered.items():
        wall, cpu = time.perf_counter(), _cpu_s()
        program = lowering.compile()
        run[part] = {'wall_s': round(time.perf_counter() - wall, 3),
                     'cpu_s': round(_cpu_s() - cpu, 3)}
        programs.append(program)
      state, _ = programs[0](key, params)
      state, _ = programs[1](state, params)
      action = np.array([16_000.0, 1.0, 0.0], np.float32)
      jax.block_until_ready(programs[2](state, action, params))
      calls = []
      for _ in range(200):
        begun = time.perf_counter()
        jax.block_until_ready(programs[2](state, action, params))
        calls.append(time.perf_counter() - begun)
      run['step_best_call_ms'] = round(1000 * min(calls), 4)
      run['step_median_call_ms'] = round(1000 * float(np.median(calls)), 4)
      report['runs'][name].append(run)
      compiled[name] = programs
      print(name, json.dumps(run), flush=True)
  default, fast = (_episode(compiled[name], params) for name in SETS)
  differing, worst = 0, 0.0
  for seed in range(20):
    seed_key = jax_env.arena_key(jax.random.PRNGKey(seed))
    for a, b in zip(*(jax.tree.leaves(compiled[name][0](seed_key, params))
                      for name in SETS)):
      a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
      if not np.array_equal(a, b):
        differing += 1
        worst = max(worst, float(np.max(np.abs(a - b) /
                                        np.maximum(np.abs(a), 1e-30))))
  report['draw_leaves_differing_20_seeds'] = differing
  report['draw_max_relative_diff'] = worst
  report['episode_max_abs_diff'] = float(np.max(np.abs(default - fast)))
  report['episode_bitwise_equal'] = bool(np.array_equal(default, fast))
  report['vector_steps_per_s'] = _vector_speeds(
      core, params, [int(n) for n in args.batch_sizes.split(',') if n],
      args.seconds)
  report['loadavg_after'] = os.getloadavg()
  for name, runs in report['runs'].items():
    print(name, 'median wall s:', {
        part: float(np.median([r[part]['wall_s'] for r in runs]))
        for part in ('draw', 'start', 'step')})
  print('episode: max |default - fast|', report['episode_max_abs_diff'],
        '; draw, 20 seeds:', differing, 'leaves differ, max relative', worst)
  if args.json:
    safe_io.atomic_write(args.json, json.dumps(report, indent=1))


if __name__ == '__main__':
  main()
