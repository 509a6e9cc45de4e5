# coding=utf-8
r"""`ble-latex-validate`: the paper's Fig. "impact of venting and ballasting".

Flies the latex balloon through a fixed sequence of float / vent / ballast
commands at 20-minute intervals (no wind), plots altitude, desired vs
simulated ascent rate, helium and sand over time to
`<output_dir>/latex_validation.png`, and prints

  * the max ascent-rate error: over the strides where the controller vented
    or ballasted, max |hdot_sim - hdot_des| / |hdot_des| with hdot_sim the
    simulated ascent rate at the END of the stride (the paper's steady-state
    assumption; the rate drifts during a stride because the drag factor
    changes with altitude, so this is the largest deviation in the stride);
  * the integrator's error against a fine-step RK4 reference (dt = 0.05 s) of
    Eq. fullN2L over the same strides.

Usage:
  ble-latex-validate --output_dir /tmp/val
  python -m ble_latex.validate --output_dir /tmp/val \
      --gin_bindings 'LatexBalloon.valve_flow_mols_per_s = 0.1'

Exit status 0 when the max ascent-rate error is below --max_error_percent.
"""

import argparse
import datetime as dt
import os
import sys
from typing import Any, Dict, List, Optional, Sequence, Tuple

from ble_latex import cli
from ble_latex import quiet

with quiet.third_party_noise():
  # pylint: disable=g-import-not-at-top
  from balloon_learning_environment.env import wind_field
  from balloon_learning_environment.env.balloon import standard_atmosphere
  from balloon_learning_environment.utils import units
  import gin
  import jax
  import numpy as np
  import s2sphere as s2

  from ble_latex import balloon as balloon_lib
  from ble_latex import controller as controller_lib
  from ble_latex import physics
  # pylint: enable=g-import-not-at-top

# (a0 desired altitude [m], a1 time factor, a2 float flag), one per 20 min,
# starting neutrally buoyant at 17 km: float, ballast up, float, vent down,
# ballast (slower descent), float, ballast up, vent (slower ascent), float,
# vent down, float, ballast up, float. Moves of at most ~1.1 km per stride
# (0.4-1.1 m/s, typical of small vent/ballast balloons).
COMMANDS: Tuple[Tuple[float, float, float], ...] = (
    (17_000.0, 1.0, 1.0),
    (18_000.0, 1.0, -1.0),
    (18_000.0, 1.0, 1.0),
    (17_000.0, 1.0, -1.0),
    (16_500.0, 1.0, -1.0),
    (16_500.0, 1.0, 1.0),
    (17_500.0, 1.0, -1.0),
    (19_000.0, 2.0, -1.0),
    (19_000.0, 1.0, 1.0),
    (17_400.0, 1.0, -1.0),
    (17_400.0, 1.0, 1.0),
    (18_400.0, 1.0, -1.0),
    (18_400.0, 1.0, 1.0),
)
START_ALTITUDE_M = 17_000.0  # [m]
OUTPUT_FILENAME = 'latex_validation.png'


def run_validation(
    commands: Sequence[Tuple[float, float, float]] = COMMANDS,
    *,
    seed: int = 0,
    start_altitude_m: float = START_ALTITUDE_M,
    reference: bool = True) -> Dict[str, Any]:
  """Flies the command sequence and measures the errors.

  Args:
    commands: (a0, a1, a2) per 20-minute stride.
    seed: PRNG seed of BLE's atmosphere (lapse-rate blend).
    start_altitude_m: Start altitude (neutrally buoyant). # [m]
    reference: Also integrate each stride with the fine RK4 reference.

  Returns:
    A dict with per-stride records ('strides'), the within-stride samples
    ('times_h', 'altitude', 'ascent_rate', 'helium', 'sand'), the
    'max_rate_error' (fraction), 'max_rk4_altitude_error_m' and
    'max_rk4_rate_error' (fraction; NaN without reference).
  """
  atmosphere = standard_atmosphere.Atmosphere(jax.random.PRNGKey(seed))
  state = balloon_lib.create_state(
      center_latlng=s2.LatLng.from_degrees(1.0, -113.0),
      date_time=dt.datetime(2022, 11, 1, tzinfo=dt.timezone.utc),
      atmosphere=atmosphere,
      altitude_m=start_altitude_m)
  balloon = balloon_lib.LatexBalloon(state)
  stride = balloon.controller.stride
  calm = wind_field.WindVector(units.Velocity(mps=0.0),
                               units.Velocity(mps=0.0))

  times: List[float] = [0.0]
  altitude = [state.altitude_m]
  rate = [state.ascent_rate_mps]
  helium = [state.helium_mols]
  sand = [state.sand_kg]
  strides: List[Dict[str, Any]] = []
  rk4_h_errors: List[float] = []
  rk4_v_errors: List[float] = []
  for i, command in enumerate(commands):
    if state.latex_status != balloon_lib.LatexBalloonStatus.OK:
      break
    t0 = i * stride.total_seconds()
    h0 = state.altitude_m
    balloon.simulate_step(calm, atmosphere, np.array(command), stride)
    traj = balloon.last_trajectory
    for p in traj:
      times.append(t0 + p.time_s)
      altitude.append(p.altitude_m)
      rate.append(p.ascent_rate_mps)
      helium.append(p.helium_mols)
      sand.append(p.sand_kg)
    record = {
        'command': tuple(command),
        'decision': state.last_decision.value,
        'start_altitude_m': h0,
        'end_altitude_m': state.altitude_m,
        'desired_rate': state.desired_ascent_rate_mps,
        'end_rate': state.ascent_rate_mps,
        'guard': state.guard_engaged,
    }
    if state.last_decision in (controller_lib.Decision.VENT,
                               controller_lib.Decision.BALLAST):
      record['rate_error'] = abs(state.ascent_rate_mps -
                                 state.desired_ascent_rate_mps) / abs(
                                     state.desired_ascent_rate_mps)
    if (reference and not state.guard_engaged and
        balloon.valve_flow_mols_per_s is None and
        balloon.ballast_rate_kg_per_s is None):
      h_err, v_err = _rk4_errors(traj, state, atmosphere,
                                 stride.total_seconds())
      record['rk4_altitude_error_m'] = h_err
      record['rk4_rate_error'] = v_err
      rk4_h_errors.append(h_err)
      rk4_v_errors.append(v_err)
    strides.append(record)

  errors = [r['rate_error'] for r in strides if 'rate_error' in r]
  return {
      'strides': strides,
      'times_h': np.array(times) / 3600.0,
      'altitude': np.array(altitude),
      'ascent_rate': np.array(rate),
      'helium': np.array(helium),
      'sand': np.array(sand),
      'stride_s': stride.total_seconds(),
      'max_rate_error': max(errors) if errors else float('nan'),
      'max_rk4_altitude_error_m': (max(rk4_h_errors) if rk4_h_errors else
                                   float('nan')),
      'max_rk4_rate_error': (max(rk4_v_errors) if rk4_v_errors else
                             float('nan')),
  }


def _rk4_errors(traj: Sequence[balloon_lib.TrajectoryPoint],
                state: balloon_lib.LatexBalloonState,
                atmosphere: standard_atmosphere.Atmosphere,
                duration: float) -> Tuple[float, float]:
  """(|h - h_ref| [m], |v - v_ref| / max(|v_ref|, 0.05 m/s)) at stride end."""
  start = traj[0]  # After the (instantaneous) actuation.
  n, m_s = start.helium_mols, start.sand_kg

  def drag_k_at(h: float) -> float:
    a = atmosphere.at_height(units.Distance(m=h))
    return float(physics.drag_factor(n, state.drag_coefficient,
                                     a.temperature, a.pressure))

  _, hs, vs = physics.rk4_vertical(
      start.altitude_m, start.ascent_rate_mps, duration,
      lift_force=float(physics.free_lift(n, state.payload_kg, m_s)) *
      physics.GRAVITY,
      mass=float(physics.total_mass(state.payload_kg, m_s, n)),
      drag_k_at=drag_k_at, dt=0.05)
  end = traj[-1]
  return (abs(end.altitude_m - hs[-1]),
          abs(end.ascent_rate_mps - vs[-1]) / max(abs(vs[-1]), 0.05))


def plot(result: Dict[str, Any], path: str) -> None:
  """Writes the four-panel figure (altitude, ascent rate, helium, sand)."""
  import matplotlib  # pylint: disable=g-import-not-at-top
  matplotlib.use('Agg')
  import matplotlib.pyplot as plt  # pylint: disable=g-import-not-at-top

  stride_h = result['stride_s'] / 3600.0
  t = result['times_h']
  fig, axes = plt.subplots(4, 1, figsize=(10, 11), sharex=True)
  ax_h, ax_v, ax_n, ax_s = axes
  ax_h.plot(t, result['altitude'] / 1000.0, color='C0', label='altitude')
  ax_v.plot(t, result['ascent_rate'], color='C0', label='simulated')
  desired_t, desired_v = [], []
  colors = {'vent': 'C3', 'ballast': 'C2', 'float': 'C7', 'nothing': 'w'}
  for i, r in enumerate(result['strides']):
    start, end = i * stride_h, (i + 1) * stride_h
    for ax in axes:
      ax.axvspan(start, end, color=colors[r['decision']], alpha=0.12, lw=0)
    ax_h.text(start + 0.5 * stride_h, 1.0, r['decision'], rotation=90,
              ha='center', va='top', fontsize=7,
              transform=ax_h.get_xaxis_transform())
    if r['decision'] in ('vent', 'ballast'):
      # a0 is due a1 strides after the command.
      ax_h.plot([start + r['command'][1] * stride_h],
                [r['command'][0] / 1000.0], 'x', color='C1')
    desired_t += [start, end]
    desired_v += [r['desired_rate'], r['desired_rate']]
  ax_h.plot([], [], 'x', color='C1', label='a0 at a1 strides after the command')
  ax_v.plot(desired_t, desired_v, '--', color='C1', label='desired')
  ax_n.plot(t, result['helium'], color='C4')
  ax_s.plot(t, result['sand'], color='C5')
  ax_h.set_ylabel('altitude [km]')
  ax_v.set_ylabel('ascent rate [m/s]')
  ax_n.set_ylabel('helium [mol]')
  ax_s.set_ylabel('sand [kg]')
  ax_s.set_xlabel('time [h]')
  ax_h.legend(loc='lower right', fontsize=8)
  ax_v.legend(loc='lower right', fontsize=8)
  ax_h.set_title('Latex balloon: venting and ballasting at 20-min intervals '
                 f'(max ascent-rate error {100 * result["max_rate_error"]:.2f}'
                 '%)')
  for ax in axes:
    ax.grid(alpha=0.3)
  fig.tight_layout()
  fig.savefig(path, dpi=120)
  plt.close(fig)


def _parse(argv: Optional[Sequence[str]]) -> argparse.Namespace:
  parser = argparse.ArgumentParser(
      prog='ble-latex-validate',
      description=('Reproduces the paper\'s Fig. "impact of venting and '
                   'ballasting" and prints the max ascent-rate error.'))
  parser.add_argument('--output_dir', default='validation_output',
                      help='Folder for latex_validation.png.')
  parser.add_argument('--seed', type=int, default=0,
                      help='Seed of BLE\'s atmosphere.')
  parser.add_argument('--max_error_percent', type=float, default=5.0,
                      help='Exit status 1 above this ascent-rate error.')
  parser.add_argument('--gin_files', nargs='*', default=[],
                      help='Gin files (e.g. gin_configs/latex_physics.gin).')
  parser.add_argument('--gin_bindings', action='append', default=[],
                      help="Gin bindings, e.g. 'LatexBalloon.vertical_step = "
                      "...' (repeatable).")
  parser.add_argument('--no_reference', action='store_true',
                      help='Skip the RK4 reference comparison.')
  return parser.parse_args(argv)


def main(argv: Optional[Sequence[str]] = None) -> int:
  """Console entry point; returns the exit status."""
  args = _parse(sys.argv[1:] if argv is None else argv)
  if args.gin_files or args.gin_bindings:
    try:
      cli.check_gin_files(args.gin_files)
      gin.parse_config_files_and_bindings(args.gin_files, args.gin_bindings)
    except cli.CommandUsageError as e:
      cli.usage_error('ble-latex-validate', str(e))
    except ValueError as e:
      message = cli.gin_usage_message(e)
      if message is None:
        raise
      cli.usage_error('ble-latex-validate', message)
  os.makedirs(args.output_dir, exist_ok=True)
  result = run_validation(seed=args.seed, reference=not args.no_reference)
  path = os.path.join(args.output_dir, OUTPUT_FILENAME)
  plot(result, path)

  print(f'{"stride":>6} {"command (a0, a1, a2)":>24} {"decision":>9} '
        f'{"h0 [m]":>9} {"h1 [m]":>9} {"desired":>8} {"simulated":>9} '
        f'{"error":>7}')
  for i, r in enumerate(result['strides']):
    a0, a1, a2 = r['command']
    error = (f'{100 * r["rate_error"]:6.2f}%' if 'rate_error' in r else
             f'{"-":>7}')
    print(f'{i:>6} {f"({a0:.0f}, {a1:g}, {a2:g})":>24} {r["decision"]:>9} '
          f'{r["start_altitude_m"]:9.1f} {r["end_altitude_m"]:9.1f} '
          f'{r["desired_rate"]:8.3f} {r["end_rate"]:9.3f} {error}')
  if not args.no_reference:
    if np.isnan(result['max_rk4_altitude_error_m']):
      print('integrator vs RK4 reference: skipped (finite actuation rates or '
            'in-stride guard)')
    else:
      print('integrator vs RK4 reference (dt=0.05 s), per 20-min stride: max '
            f'altitude error {result["max_rk4_altitude_error_m"]:.3f} m, max '
            f'ascent-rate error {100 * result["max_rk4_rate_error"]:.3f}%')
  print(f'wrote {path}')
  print(f'max ascent-rate error: {100 * result["max_rate_error"]:.2f}%')
  return 0 if 100 * result['max_rate_error'] < args.max_error_percent else 1


if __name__ == '__main__':
  sys.exit(main())
