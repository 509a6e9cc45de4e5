# coding=utf-8
"""The flight core's stride cost: paper and realistic, this tree against another.

  git worktree add /tmp/ble_before 1e397a1
  python benchmarks/gas_step_speed.py --compare_tree=/tmp/ble_before \
      --json=benchmarks/records/gas_step_speed.json

Times `dynamics.step` (one 20-minute stride in calm air, jitted, vmapped
over --batch balloons at 16-18 km under a ballast command; the best of
--repeats calls after a warm-up) for the paper's model and for
`flight.params.REALISTIC` (issue 68: the gas state, 20 s vertical steps, the
heating disturbance) and, where the tree has it, the preset with ValBal's
stress walk (`flight.params.LIFT_WALK_STRESS`), then runs the same
measurement of the other tree's `ble_latex` (its own REALISTIC: before
issue 68, the lagged forcing and the random walk) in a subprocess right
after, under the same load, and prints the ratios side by side; --rounds
alternates the two trees (the best of each kept), so a changing load on a
shared machine weighs on both alike. Issue 68's bound: realistic <= 1.3x
the other tree's realistic; the paper's model unchanged. The onboard
estimator's cost (issue 63 item 3) against a tree without it:

  python benchmarks/gas_step_speed.py --compare_tree=/tmp/ble_before \
      --batch=256 --rounds=3 --json=benchmarks/records/estimator_step_speed.json
"""

import argparse
import json
import os
import subprocess
import sys
import time

from ble_latex import safe_io
from ble_latex.run import speed

# The stride timed in the tree under test (`run.speed.STRIDE_SETUP`'s).
PROGRAM = speed.STRIDE_SETUP + r'''
import json, sys, time
batch, repeats = int(sys.argv[1]), int(sys.argv[2])

def best(p):
  atm, states, actions, keys = flights(p, batch)
  stochastic = p.lift_walk or getattr(p, 'heating_noise', False)
  fly = jax.jit(jax.vmap(lambda s, a, k: dynamics.step(
      p, atm, s, a, calm, 1200.0, key=k if stochastic else None)))
  jax.block_until_ready(fly(states, actions, keys))
  times = []
  for _ in range(repeats):
    start = time.perf_counter()
    jax.block_until_ready(fly(states, actions, keys))
    times.append(time.perf_counter() - start)
  return min(times)

times = {'paper': best(params.make_flight_params()),
         'realistic': best(params.make_flight_params(**params.REALISTIC))}
if hasattr(params, 'LIFT_WALK_STRESS'):
  times['stress'] = best(params.make_flight_params(
      **{**params.REALISTIC, **params.LIFT_WALK_STRESS}))
print(json.dumps(times))
'''


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
                      help='a checkout of the commit to compare against')
  parser.add_argument('--batch', type=int, default=256)
  parser.add_argument('--repeats', type=int, default=7)
  parser.add_argument('--rounds', type=int, default=1,
                      help='alternations of the two trees')
  parser.add_argument('--json', default='')
  args = parser.parse_args(argv)
  if not os.path.isdir(os.path.join(args.compare_tree, 'ble_latex')):
    parser.error(f'--compare_tree: no ble_latex/ in {args.compare_tree!r}')
  if min(args.batch, args.repeats, args.rounds) < 1:
    parser.error('--batch, --repeats and --rounds must be >= 1')
  if args.json and safe_io.output_problem(args.json):
    parser.error(f'--json: {safe_io.output_problem(args.json)}')
  here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
  record = speed.record_header('gas_step_speed.py', argv, args.batch)
  start = time.time()
  runs = {'this_tree': [], 'other_tree': []}
  for _ in range(args.rounds):
    runs['this_tree'].append(measure(here, args.batch, args.repeats))
    runs['other_tree'].append(measure(args.compare_tree, args.batch,
                                      args.repeats))
  for tree, rows in runs.items():
    record[tree] = {k: min(row[k] for row in rows) for k in rows[0]}
  record['load_after'] = round(os.getloadavg()[0], 1)
  record['seconds'] = round(time.time() - start, 1)
  cases = [k for k in record['this_tree'] if k in record['other_tree']]
  record['ratio'] = {k: record['this_tree'][k] / record['other_tree'][k]
                     for k in cases}
  for k in cases:
    print(f'{k}: {1e3 * record["this_tree"][k]:.2f} ms per stride of '
          f'{args.batch} against {1e3 * record["other_tree"][k]:.2f} ms: '
          f'{record["ratio"][k]:.2f}x')
  if args.json:
    safe_io.atomic_write(args.json, json.dumps(record, indent=1) + '\n')
  return 0


if __name__ == '__main__':
  sys.exit(main())
