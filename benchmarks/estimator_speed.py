# coding=utf-8
"""The onboard estimator's cost: a stride with it against a tree without it.

  git archive 48168f9 | tar -x -C /tmp/ble_before   # (mkdir it first)
  python benchmarks/estimator_speed.py --compare_tree=/tmp/ble_before \
      --json=benchmarks/estimator_speed.json

Times `dynamics.step` (one 20-minute stride in calm air, jitted, vmapped
over --batch balloons at 16-18 km under a ballast command; the best of
--repeats calls after a warm-up) under the paper's model, the realistic
preset (`flight.params.REALISTIC`: the heating disturbance, so the dT_h
filter) and the preset with ValBal's stress walk
(`flight.params.LIFT_WALK_STRESS`: both filters), for this tree and the
other, in subprocesses that alternate --rounds times (the best of each
kept), so a changing load on a shared machine weighs on both alike.
"""

import argparse
import datetime as dt
import json
import os
import platform
import subprocess
import sys
import time

from ble_latex import safe_io

PROGRAM = r'''
import json, sys, time
import jax, jax.numpy as jnp
from ble_latex.flight import atmosphere, dynamics, launch, params, state
batch, repeats = int(sys.argv[1]), int(sys.argv[2])

def calm(x, y, p, t):
  return jnp.zeros_like(x), jnp.zeros_like(x)

def best(p):
  atm = atmosphere.reset(jax.random.PRNGKey(0))
  new = lambda h: launch.neutral_launch(p, atm, state.initial_state(
      p, h, atm_params=atm, key=jax.random.PRNGKey(1)))
  states = jax.vmap(new)(jnp.linspace(16000.0, 18000.0, batch))
  actions = jnp.tile(jnp.asarray([17500.0, 1.0, -1.0]), (batch, 1))
  keys = jax.random.split(jax.random.PRNGKey(2), batch)
  fly = jax.jit(jax.vmap(lambda s, a, k: dynamics.step(
      p, atm, s, a, calm, 1200.0, key=k if p.stochastic else None)))
  jax.block_until_ready(fly(states, actions, keys))
  times = []
  for _ in range(repeats):
    start = time.perf_counter()
    jax.block_until_ready(fly(states, actions, keys))
    times.append(time.perf_counter() - start)
  return min(times)

print(json.dumps({
    'paper': best(params.make_flight_params()),
    'realistic': best(params.realistic_flight_params()),
    'stress': best(params.realistic_flight_params(
        **params.LIFT_WALK_STRESS))}))
'''
CASES = ('paper', 'realistic', 'stress')


def measure(tree: str, batch: int, repeats: int) -> dict:
  """Best seconds per stride of `tree`'s ble_latex, in a subprocess."""
  env = dict(os.environ, PYTHONPATH=tree)
  out = subprocess.run(
      [sys.executable, '-c', PROGRAM, str(batch), str(repeats)], env=env,
      cwd=tree, check=True, capture_output=True, text=True)
  return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
  parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
  parser.add_argument('--compare_tree', required=True,
                      help='a checkout of a commit without the estimator')
  parser.add_argument('--batch', type=int, default=64)
  parser.add_argument('--repeats', type=int, default=5)
  parser.add_argument('--rounds', type=int, default=3)
  parser.add_argument('--json', default='')
  args = parser.parse_args(argv)
  if not os.path.isdir(os.path.join(args.compare_tree, 'ble_latex')):
    parser.error(f'--compare_tree: no ble_latex/ in {args.compare_tree!r}')
  if min(args.batch, args.repeats, args.rounds) < 1:
    parser.error('--batch, --repeats and --rounds must be >= 1')
  if args.json and safe_io.output_problem(args.json):
    parser.error(f'--json: {safe_io.output_problem(args.json)}')
  here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
  record = {
      'command': 'python benchmarks/estimator_speed.py ' + ' '.join(
          sys.argv[1:] if argv is None else argv),
      'date': dt.datetime.now(dt.timezone.utc).isoformat(timespec='seconds'),
      'machine': f'{platform.machine()}, {os.cpu_count()} CPUs',
      'batch': args.batch, 'load_before': round(os.getloadavg()[0], 1)}
  start = time.time()
  runs = {'this_tree': [], 'other_tree': []}
  for _ in range(args.rounds):
    runs['this_tree'].append(measure(here, args.batch, args.repeats))
    runs['other_tree'].append(measure(args.compare_tree, args.batch,
                                      args.repeats))
  for tree, rows in runs.items():
    record[tree] = {k: min(row[k] for row in rows) for k in CASES}
  record['load_after'] = round(os.getloadavg()[0], 1)
  record['seconds'] = round(time.time() - start, 1)
  record['ratio'] = {k: record['this_tree'][k] / record['other_tree'][k]
                     for k in CASES}
  for k in CASES:
    print(f'{k}: {1e3 * record["this_tree"][k]:.2f} ms per stride of '
          f'{args.batch} against {1e3 * record["other_tree"][k]:.2f} ms: '
          f'{record["ratio"][k]:.2f}x')
  if args.json:
    safe_io.atomic_write(args.json, json.dumps(record, indent=1) + '\n')
  return 0


if __name__ == '__main__':
  sys.exit(main())
