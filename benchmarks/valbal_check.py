# coding=utf-8
"""The realistic physics flown as ValBal, beside ValBal's numbers (issue 44).

Binds latex_physics.gin, latex_realistic.gin and valbal.gin (a ValBal-sized
system: 2.8 kg envelope + avionics + 1 kg payload, 4 kg of ballast, ValBal's
valve and ballast rates, the 12.25-17 km band, launched where and when
ValBal's record flight was) and measures, with the flight core's own
functions:

  * the lift lost over a sunset by a balloon held at 13.5 km: the realistic
    free lift 3 h before the sun sets minus 2 h after (the window of ValBal's
    ballast measurements); ValBal: its table 0.43 kg, measured 0.2-0.7 kg;
  * ballast per day and days aloft of `--flights` flights (calm air, each
    its own atmosphere and disturbance draws) flown by issue 44's ValBal-style
    position deadband at 13.5 km +- 750 m (`calibration.deadband_decide`
    with velocity=False), for up to `--days`; ValBal: its trajectory
    planner's budget (1/(2.845e-5 tol + 0.0175) + 13) g/h plus its sunset
    table, 0.93 + 0.43 = 1.36 kg/day at +-750 m (valbal-trajectory
    `cpp/sim.cpp`: ValBal's own model, a fit of its simulations at
    1.4 g/sqrt(s)), 3 days aloft with a 1 kg payload (datasheet);
each at the preset's disturbance, with ValBal's simulator's walk before 2018
(0.67 g/sqrt(s), `SIGMA_2018`) and the stress setting (ValBal's
1.4 g/sqrt(s), `flight.params.LIFT_WALK_STRESS`) on top.

The rows of the calibration table (issue 68) are
`benchmarks/float_calibration.py`'s; this script keeps issue 44's cases.

Days aloft are also flown for two other loads of the same system (`CASES`):

  * `no_payload`: no payload and 4.5 kg of ballast, the case ValBal
    demonstrated (datasheet: "An endurance of five days was demonstrated with
    zero payload"; record flight 121 h 34 min) with the ballast its
    trajectory planner starts from (stanford-ssi/valbal-trajectory
    `cpp/sim.cpp:493`, `state.bal = 4500` g); ValBal's own simulator reports
    "5 day flight, 4 949 g ballast used" at 1.4 g/sqrt(s);
  * `payload_takes_ballast`: the 1 kg payload carried instead of 1 kg of that
    ballast (3.5 kg), a what-if: no ValBal source says the payload displaces
    ballast (a latex balloon at 13.5 km is far below its burst volume, so
    physics does not force it; a fixed launch budget would).

  python benchmarks/valbal_check.py --output=benchmarks/records/valbal_check.json
"""

import argparse
import datetime as dt
import json
import os
import platform
import sys
import time

from ble_latex import safe_io
from ble_latex.flight import calibration
from ble_latex.flight import params as params_lib

VALBAL = {
    'sunset_loss_kg': (0.2, 0.7),  # measured around ValBal's sunsets
    'sunset_table_kg': 0.43,  # ValBal's sunset table, integrated
    # ValBal's trajectory planner's budget at +-750 m, sunsets included
    # (valbal-trajectory cpp/sim.cpp; 1.26 at +-1 km).
    'ballast_kg_per_day_at_750m': 1.36,
    'days_aloft_1kg_payload': 3.0,  # datasheet
}
# ValBal's simulator's disturbance before its November 2018 "constants name
# refactor" (hootl/lasagna/PastaSim.cpp: 0.67 g/sqrt(s); 1.4 after, the
# stress setting), flown beside the default and the stress setting. # [kg/sqrt(s)]
SIGMA_2018 = {'lift_walk_kg_per_sqrt_s': 0.67e-3}
# Other loads of the preset (see the module): make_flight_params overrides,
# relative to valbal.gin's 1.0 kg payload (payload_kg 2.8 = 1.2 kg envelope
# + 0.6 kg avionics, both assumed, + 1.0 kg) and 4.0 kg of ballast.
CASES = {
    'preset': {},
    'no_payload': {'payload_kg': 1.8, 'sand_kg': 4.5},
    'payload_takes_ballast': {'sand_kg': 3.5},
}


def valbal_params(**overrides) -> params_lib.FlightParams:
  """The ValBal preset under the realistic physics (gin, then overrides)."""
  return calibration.preset_params(valbal=True, **overrides)


def main(argv=None) -> int:
  parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
  parser.add_argument('--flights', type=int, default=8)
  parser.add_argument('--days', type=float, default=7.0)
  parser.add_argument('--output', default='')
  args = parser.parse_args(argv)
  if args.flights < 1 or not 0.5 <= args.days <= 30.0:
    parser.error('--flights must be >= 1 and --days in 0.5..30')
  if args.output and safe_io.output_problem(args.output):
    parser.error(f'--output: {safe_io.output_problem(args.output)}')
  start = time.time()
  record = {
      'command': 'python benchmarks/valbal_check.py ' + ' '.join(
          f'--{k}={v}' for k, v in vars(args).items() if v != ''),
      'date': dt.datetime.now(dt.timezone.utc).isoformat(timespec='seconds'),
      'machine': f'{platform.machine()}, {os.cpu_count()} CPUs, load '
                 f'{os.getloadavg()[0]:.1f} at start',
      'valbal': VALBAL,
  }
  base = valbal_params()
  record['params'] = {k: getattr(base, k) for k in (
      'payload_kg', 'initial_sand_kg', 'superheat_day_k', 'cooling_night_k',
      'gas_thermal_lag_s', 'gas_state', 'heating_noise_k',
      'heating_noise_time_s', 'lift_walk_kg_per_sqrt_s', 'band_low_m',
      'band_high_m', 'valve_flow_mols_per_s', 'ballast_rate_kg_per_s')}
  record['sunset'] = calibration.sunset_loss_kg(base)
  print('sunset', record['sunset'], flush=True)
  for case, load in CASES.items():
    for name, over in (('default', {}), ('sigma_0.67', SIGMA_2018),
                       ('stress', params_lib.LIFT_WALK_STRESS)):
      p = valbal_params(**load, **over)
      out = calibration.band_flights(p, flights=args.flights, days=args.days,
                                     velocity=False)
      out['lift_walk_kg_per_sqrt_s'] = p.lift_walk_kg_per_sqrt_s
      out['payload_kg'] = p.payload_kg
      out['initial_sand_kg'] = p.initial_sand_kg
      # The preset's rows keep their names (`default`, `stress`).
      record[name if case == 'preset' else f'{case}_{name}'] = out
      print(case, name, out, flush=True)
  record['seconds'] = round(time.time() - start, 1)
  record['load_at_end'] = round(os.getloadavg()[0], 1)
  if args.output:
    safe_io.atomic_write(args.output, json.dumps(record, indent=1) + '\n')
  return 0


if __name__ == '__main__':
  sys.exit(main())
