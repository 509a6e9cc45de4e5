# coding=utf-8
"""The onboard estimator's share of a stride, measured in one process.

  python benchmarks/estimator_cost.py --json=benchmarks/records/estimator_cost.json

Times `dynamics.step` (one 20-minute stride in calm air, jitted, vmapped
over --batch balloons at 16-18 km under a ballast command:
`run.speed.STRIDE_SETUP`) under the realistic preset
(`flight.params.REALISTIC`: the dT_h filter) and with ValBal's stress walk
on top (`flight.params.LIFT_WALK_STRESS`: both filters), once as it is and
once compiled with the filters taken out (`estimator.observe_chunk` and
`estimator.controller_view` replaced by the identity while it is traced).
The two programs are called in turn, --repeats times each, so a changing
load on a shared machine weighs on both alike; the record keeps the best
and the median of each. (Across commits, `gas_step_speed.py --rounds`
compares two trees.)
"""

import argparse
import json
import os
import statistics
import sys
import time

import jax

from ble_latex import safe_io
from ble_latex.flight import dynamics
from ble_latex.flight import estimator
from ble_latex.flight import params as params_lib
from ble_latex.run import speed

CASES = {'realistic': {},
         'stress': params_lib.LIFT_WALK_STRESS}


def _programs(params, batch):
  """(call with the filters, call without), each warmed up."""
  calm, flights = speed.stride_setup()
  atm, states, actions, keys = flights(params, batch)

  def program():
    fly = jax.jit(jax.vmap(lambda s, a, k: dynamics.step(
        params, atm, s, a, calm, 1200.0, key=k)))
    return lambda: jax.block_until_ready(fly(states, actions, keys))

  with_filters = program()
  with_filters()
  observe, view = estimator.observe_chunk, estimator.controller_view
  estimator.observe_chunk = lambda params, before, after, *a, **k: after
  estimator.controller_view = lambda params, state: state
  try:
    without = program()
    without()  # Traced now, without the filters.
  finally:
    estimator.observe_chunk, estimator.controller_view = observe, view
  return with_filters, without


def main(argv=None) -> int:
  parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
  parser.add_argument('--batch', type=int, default=256)
  parser.add_argument('--repeats', type=int, default=20)
  parser.add_argument('--json', default='')
  args = parser.parse_args(argv)
  if min(args.batch, args.repeats) < 1:
    parser.error('--batch and --repeats must be >= 1')
  if args.json and safe_io.output_problem(args.json):
    parser.error(f'--json: {safe_io.output_problem(args.json)}')
  record = speed.record_header('estimator_cost.py', argv, args.batch)
  for name, overrides in CASES.items():
    calls = _programs(params_lib.realistic_flight_params(**overrides),
                      args.batch)
    times = ([], [])
    for _ in range(args.repeats):
      for call, out in zip(calls, times):
        start = time.perf_counter()
        call()
        out.append(time.perf_counter() - start)
    row = {f'{k}_{s}': f(t) for k, t in zip(('with', 'without'), times)
           for s, f in (('best_s', min), ('median_s', statistics.median))}
    row['ratio_best'] = row['with_best_s'] / row['without_best_s']
    row['ratio_median'] = row['with_median_s'] / row['without_median_s']
    record[name] = row
    print(f'{name}: {1e3 * row["with_best_s"]:.2f} ms per stride of '
          f'{args.batch} with the filters, {1e3 * row["without_best_s"]:.2f}'
          f' ms without: {row["ratio_best"]:.2f}x (medians '
          f'{row["ratio_median"]:.2f}x)')
  record['load_after'] = round(os.getloadavg()[0], 1)
  if args.json:
    safe_io.atomic_write(args.json, json.dumps(record, indent=1) + '\n')
  return 0


if __name__ == '__main__':
  sys.exit(main())
