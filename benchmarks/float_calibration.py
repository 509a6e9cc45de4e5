# coding=utf-8
"""The realistic float's calibration table (issue 68), each row against its range.

  python benchmarks/float_calibration.py --json=benchmarks/records/float_calibration.json

Rows (`ble_latex.flight.calibration` measures each; docs/physics.md gives the
sources of the ranges in `calibration.TARGETS`):

- plant constant, m/s per g of free lift after a 10 g lift step at float:
  the default balloon at 17 km (gin_configs/latex_realistic.gin) and the
  ValBal preset at 13.5 km (+ gin_configs/valbal.gin);
- calm probability: the ValBal preset at the default disturbance, P(2 h with
  no action and |dh| <= 100 m);
- sunset loss: the ValBal preset's lift lost over a sunset;
- band cost: the ValBal preset held at 13.5 km +- 750 m by a ValBal-style
  deadband, ballast per day including sunsets;
- days aloft: the ValBal preset with the 1 kg payload displacing 1 kg of the
  4.5 kg launch budget of ballast (3.5 kg) and with no payload (4.5 kg);
- the default balloon's float at 17 km held by the same deadband at +- 1 km
  (reported, no range).

`--plant=before` measures the same rows on the plant before issue 68 (gas
temperature not a state, the 0.35 g/sqrt(s) random walk) for comparison.

`--sweep=RMS:TAU,...` instead flies, for each heating disturbance (stationary
rms [K] : correlation time [s]) on the ValBal preset, the calm probability
(256 flights) and the band cost and days aloft of the 1 kg payload displacing
ballast (8 flights, 7 days): the trade-off between the calm row and the cost
rows (docs/physics.md):

  python benchmarks/float_calibration.py \
      --sweep=0.25:1800,0.25:600,1:1800,2:1800,3:1800,2:600 \
      --json=benchmarks/records/float_calibration_sweep.json
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

# The plant before issue 68 (kept to compare): no gas state, the random walk.
BEFORE = {'gas_state': False, 'heating_noise_k': None,
          'vertical_step': params_lib.DEFAULTS.vertical_step_s,
          **params_lib.LIFT_WALK_RANDOM}
# The loads of days aloft: ValBal's launch budget of ballast with no payload
# (valbal-trajectory cpp/sim.cpp starts from 4500 g) and the 1 kg payload
# displacing 1 kg of it (payload_kg 2.8 = 1.2 kg envelope + 0.6 kg avionics,
# both assumptions, + 1.0 kg; gin_configs/valbal.gin).
LOADS = {'no_payload': {'payload_kg': 1.8, 'sand_kg': 4.5},
         'payload_takes_ballast': {'payload_kg': 2.8, 'sand_kg': 3.5}}


flight_params = calibration.preset_params


def _row(name, value, target=None):
  low, high = target if target else (None, None)
  inside = None if target is None else bool(low <= value <= high)
  return {'row': name, 'value': value, 'range': target, 'inside': inside}


def measure(before: bool, flights: int, days: float) -> dict:
  """The table's rows and the flights behind them."""
  extra = BEFORE if before else {}
  targets = calibration.TARGETS
  default = flight_params(False, **extra)
  valbal = flight_params(True, **extra)
  out = {'rows': [], 'details': {}}
  rows, details = out['rows'], out['details']
  plant = calibration.plant_constant(default, 17_000.0)
  details['plant_default'] = plant
  rows.append(_row('plant constant, default balloon at 17 km [m/s per g]',
                   plant['mps_per_g'], targets['plant_default_mps_per_g']))
  plant = calibration.plant_constant(valbal, 13_500.0)
  details['plant_valbal'] = plant
  rows.append(_row('plant constant, ValBal preset at 13.5 km [m/s per g]',
                   plant['mps_per_g'], targets['plant_valbal_mps_per_g']))
  calm = calibration.calm_probability(valbal, flights=32 * flights)
  details['calm'] = calm
  rows.append(_row('calm probability, ValBal preset (2 h, |dh| <= 100 m)',
                   calm['probability'], targets['calm_probability']))
  sunset = calibration.sunset_loss_kg(valbal)
  details['sunset'] = sunset
  rows.append(_row('sunset loss, ValBal preset [kg]', sunset['loss_kg'],
                   targets['sunset_loss_kg']))
  band = calibration.band_flights(valbal, flights=flights, days=days)
  details['band'] = band
  rows.append(_row('band cost, ValBal preset +-750 m [kg ballast/day]',
                   band['ballast_kg_per_day_mean'],
                   targets['band_cost_kg_per_day']))
  for load, over in LOADS.items():
    aloft = calibration.band_flights(flight_params(True, **extra, **over),
                                     flights=flights, days=days)
    details[f'days_{load}'] = aloft
    rows.append(_row(f'days aloft, ValBal preset, {load.replace("_", " ")} '
                     f'({over["sand_kg"]} kg ballast)',
                     aloft['days_aloft_mean'],
                     targets[f'days_aloft_{load}']))
  own = calibration.band_flights(default, flights=flights, days=3.0,
                                 setpoint_m=17_000.0, half_band_m=1000.0)
  details['default_float'] = own
  rows.append(_row('default balloon held at 17 km +-1 km [kg ballast/day]',
                   own['ballast_kg_per_day_mean']))
  rows.append(_row('default balloon held at 17 km +-1 km, altitude range '
                   '[km]', [round(a / 1e3, 2)
                            for a in own['altitude_range_m']]))
  return out


def sweep(cells) -> list:
  """Calm probability against band cost per heating disturbance."""
  rows = []
  for rms, tau in cells:
    over = {'heating_noise_k': rms, 'heating_noise_time_s': tau}
    calm = calibration.calm_probability(flight_params(True, **over),
                                        flights=256)
    band = calibration.band_flights(
        flight_params(True, **over, **LOADS['payload_takes_ballast']),
        flights=8, days=7.0)
    rows.append({'rms_k': rms, 'time_s': tau,
                 'calm': calm['probability'],
                 'cost': band['ballast_kg_per_day_mean'],
                 'days': band['days_aloft_mean'],
                 'inband': band['time_in_band_pct']})
    print(rows[-1], flush=True)
  return rows


def _cells(text: str):
  try:
    cells = [tuple(float(x) for x in c.split(':')) for c in text.split(',')]
  except ValueError:
    cells = []
  if not cells or any(len(c) != 2 or not 0 <= c[0] <= 30 or
                      not 1 <= c[1] <= 864_000 for c in cells):
    raise argparse.ArgumentTypeError(
        f'--sweep must be RMS:TAU,... (0-30 K : 1 s-10 days), got {text!r}')
  return cells


def table(rows) -> str:
  """The rows as Markdown."""
  lines = ['| row | value | range | inside |', '|---|---|---|---|']
  for r in rows:
    value = r['value']
    text = (f'{value:.4g}' if isinstance(value, float) else str(value))
    rng = '' if r['range'] is None else f'{r["range"][0]:g}-{r["range"][1]:g}'
    inside = {None: '', True: 'yes', False: '**no**'}[r['inside']]
    lines.append(f'| {r["row"]} | {text} | {rng} | {inside} |')
  return '\n'.join(lines)


def main(argv=None) -> int:
  parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
  parser.add_argument('--flights', type=int, default=16,
                      help='deadband flights per row (calm: 32x)')
  parser.add_argument('--days', type=float, default=7.0)
  parser.add_argument('--plant', choices=('now', 'before'), default='now')
  parser.add_argument('--sweep', type=_cells, default=None,
                      help='RMS:TAU,...: the heating-disturbance sweep')
  parser.add_argument('--json', default='',
                      help='write the record here (atomically)')
  args = parser.parse_args(argv)
  if args.flights < 1 or not 0.5 <= args.days <= 30.0:
    parser.error('--flights must be >= 1 and --days in 0.5..30')
  if args.json and safe_io.output_problem(args.json):
    parser.error(f'--json: {safe_io.output_problem(args.json)}')
  start = time.time()
  record = {
      'command': 'python benchmarks/float_calibration.py ' + ' '.join(
          sys.argv[1:] if argv is None else argv),
      'date': dt.datetime.now(dt.timezone.utc).isoformat(timespec='seconds'),
      'machine': f'{platform.machine()}, {os.cpu_count()} CPUs, load '
                 f'{os.getloadavg()[0]:.1f} at start',
      'plant': args.plant,
  }
  if args.sweep:
    record['sweep'] = sweep(args.sweep)
  else:
    record.update(measure(args.plant == 'before', args.flights, args.days))
    print(table(record['rows']))
  record['seconds'] = round(time.time() - start, 1)
  record['load_at_end'] = round(os.getloadavg()[0], 1)
  if args.json:
    safe_io.atomic_write(args.json, json.dumps(record, indent=1) + '\n')
  return 0


if __name__ == '__main__':
  sys.exit(main())
