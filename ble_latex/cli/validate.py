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
  python -m ble_latex.cli.validate --output_dir /tmp/val \
      --gin_bindings 'LatexBalloon.valve_flow_mols_per_s = 0.1'

Exit status 0 when the max ascent-rate error is below --max_error_percent.
"""

import functools
import os
import sys
from typing import Any, Dict, List, Optional, Sequence, Tuple

from absl import flags

from ble_latex import configs
from ble_latex import quiet
from ble_latex.cli import common as cli

with quiet.third_party_noise():
  # pylint: disable=g-import-not-at-top
  import jax
  import jax.numpy as jnp
  import numpy as np

  from ble_latex.flight import atmosphere as atmosphere_lib
  from ble_latex.flight import dynamics
  from ble_latex.flight import params as params_lib
  from ble_latex.flight import physics
  from ble_latex.flight import state as state_lib
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
  # BLE's Atmosphere(PRNGKey(seed)): the same lapse-rate blend.
  atm = atmosphere_lib.reset(jax.random.PRNGKey(seed))
  params = params_lib.flight_params_from_gin()
  state = state_lib.initial_state(params, start_altitude_m, atm_params=atm)
  stride_s = params.stride_s

  def calm(x_m, y_m, pressure_pa, t_s):
    del y_m, pressure_pa, t_s
    return jnp.zeros_like(x_m), jnp.zeros_like(x_m)

  fly = jax.jit(functools.partial(dynamics.step_with_trajectory,
                                  wind_fn=calm, time_delta_s=stride_s))
  host = lambda tree: jax.tree.map(np.asarray, jax.device_get(tree))  # pylint: disable=unnecessary-lambda-assignment
  finite_rates = params.finite_valve or params.finite_ballast

  times: List[float] = [0.0]
  altitude = [float(state.altitude_m)]
  rate = [float(state.ascent_rate_mps)]
  helium = [float(state.helium_mols)]
  sand = [float(state.sand_kg)]
  strides: List[Dict[str, Any]] = []
  rk4_h_errors: List[float] = []
  rk4_v_errors: List[float] = []
  for i, command in enumerate(commands):
    if int(state.status) != state_lib.FlightStatus.OK:
      break
    t0 = i * stride_s
    h0 = float(state.altitude_m)
    state, actuated, samples = fly(params, atm, state,
                                   jnp.asarray(command, jnp.float32))
    samples = host(samples)
    n_sub = len(samples.time_s)
    # Right after the actuation (an instantaneous release), then the end of
    # each sub-step k at (k + 1) / n of the stride.
    times.append(t0)
    altitude.append(float(actuated.altitude_m))
    rate.append(float(actuated.ascent_rate_mps))
    helium.append(float(actuated.helium_mols))
    sand.append(float(actuated.sand_kg))
    for k in range(n_sub):
      times.append(t0 + stride_s * (k + 1) / n_sub)
      altitude.append(float(samples.altitude_m[k]))
      rate.append(float(samples.ascent_rate_mps[k]))
      helium.append(float(samples.helium_mols[k]))
      sand.append(float(samples.sand_kg[k]))
    decision = state_lib.DecisionCode(int(state.last_decision))
    desired = float(state.desired_ascent_rate_mps)
    end_rate = float(state.ascent_rate_mps)
    guard = bool(state.guard_engaged)
    record = {
        'command': tuple(command),
        'decision': decision.name.lower(),
        'start_altitude_m': h0,
        'end_altitude_m': float(state.altitude_m),
        'desired_rate': desired,
        'end_rate': end_rate,
        'guard': guard,
    }
    if decision in (state_lib.DecisionCode.VENT,
                    state_lib.DecisionCode.BALLAST):
      record['rate_error'] = abs(end_rate - desired) / abs(desired)
    if reference and not guard and not finite_rates:
      h_err, v_err = _rk4_errors(params, atm, actuated, state, stride_s)
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
      'stride_s': stride_s,
      'max_rate_error': max(errors) if errors else float('nan'),
      'max_rk4_altitude_error_m': (max(rk4_h_errors) if rk4_h_errors else
                                   float('nan')),
      'max_rk4_rate_error': (max(rk4_v_errors) if rk4_v_errors else
                             float('nan')),
  }


RK4_DT_S = 0.05  # [s] the reference's fixed step


def rk4_reference(params, atm, start, duration_s: float,
                  dt_s: float = RK4_DT_S):
  """Eq. fullN2L integrated by classical RK4 with a fine fixed step.

  The reference the core's closed-form integrator is checked against
  (not the model): m h'' = L g - k(h) |h'| h' with k(h) = 1/2 rho c_d A at
  the altitude, helium and sand fixed (as after an instantaneous release).
  Runs in float64 inside a local `jax.enable_x64` scope (nothing global).

  Args:
    params: The flight system.
    atm: The atmosphere.
    start: The state right after the actuation.
    duration_s: Time to integrate. # [s]
    dt_s: RK4 step. # [s]

  Returns:
    (altitude [m], ascent rate [m/s]) at the end.
  """
  with jax.enable_x64(True):
    f64 = lambda v: jnp.asarray(np.float64(v))  # pylint: disable=unnecessary-lambda-assignment
    n, m_s = f64(start.helium_mols), f64(start.sand_kg)
    payload, c_d = f64(params.payload_kg), f64(params.drag_coefficient)
    atm64 = atmosphere_lib.params_from_alpha(f64(atm.alpha))
    lift = physics.free_lift(n, payload, m_s) * physics.GRAVITY  # [N]
    mass = physics.total_mass(payload, m_s, n)  # [kg]

    def acc(h, v):
      ambient = atmosphere_lib.at_height(atm64, h)
      k = physics.drag_factor(n, c_d, ambient.temperature, ambient.pressure)
      return (lift - k * jnp.abs(v) * v) / mass

    def body(_, hv):
      h, v = hv
      k1h, k1v = v, acc(h, v)
      k2h, k2v = v + 0.5 * dt_s * k1v, acc(h + 0.5 * dt_s * k1h,
                                           v + 0.5 * dt_s * k1v)
      k3h, k3v = v + 0.5 * dt_s * k2v, acc(h + 0.5 * dt_s * k2h,
                                           v + 0.5 * dt_s * k2v)
      k4h, k4v = v + dt_s * k3v, acc(h + dt_s * k3h, v + dt_s * k3v)
      return (h + dt_s / 6.0 * (k1h + 2 * k2h + 2 * k3h + k4h),
              v + dt_s / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v))

    steps = int(round(duration_s / dt_s))
    h, v = jax.jit(lambda hv: jax.lax.fori_loop(0, steps, body, hv))(
        (f64(start.altitude_m), f64(start.ascent_rate_mps)))
    return float(h), float(v)


def _rk4_errors(params, atm, actuated, end, duration: float
                ) -> Tuple[float, float]:
  """(|h - h_ref| [m], |v - v_ref| / max(|v_ref|, 0.05 m/s)) at stride end."""
  h_ref, v_ref = rk4_reference(params, atm, actuated, duration)
  return (abs(float(end.altitude_m) - h_ref),
          abs(float(end.ascent_rate_mps) - v_ref) / max(abs(v_ref), 0.05))


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


# The command's own flags (`cli.run_absl`).
FLAGS = flags.FlagValues()
flags.DEFINE_string('output_dir', 'validation_output',
                    f'Folder for {OUTPUT_FILENAME}.', flag_values=FLAGS)
flags.DEFINE_integer('seed', 0, "Seed of BLE's atmosphere.", flag_values=FLAGS)
flags.DEFINE_float('max_error_percent', 5.0,
                   'Exit status 1 above this ascent-rate error.',
                   flag_values=FLAGS)
flags.DEFINE_multi_string('gin_file', [],
                          'Gin files (e.g. gin_configs/latex_physics.gin).',
                          flag_values=FLAGS)
flags.DEFINE_alias('gin_files', 'gin_file', flag_values=FLAGS)  # ble_latex 0.1.
flags.DEFINE_multi_string('gin_bindings', [],
                          "Gin bindings, e.g. 'create_state.sand_kg = 3.0'.",
                          flag_values=FLAGS)
flags.DEFINE_boolean('no_reference', False,
                     'Skip the RK4 reference comparison.', flag_values=FLAGS)


def _check() -> None:
  cli.check_gin_files(FLAGS.gin_file)


def _main(argv: Sequence[str]) -> int:
  """Flies the command sequence, writes the figure; 1 above the error bound."""
  args = FLAGS
  if args.gin_file or args.gin_bindings:
    configs.bind_gin(None, None, args.gin_file, args.gin_bindings,
                     env_defaults=False)
  cli.prepare_output_dir(args.output_dir, '--output_dir')
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


def main(argv: Optional[Sequence[str]] = None) -> int:
  """The command (`cli.run_absl`); returns the exit status."""
  return cli.run_absl(_main, 'ble-latex-validate', FLAGS, argv, doc=__doc__,
                      check=_check)


if __name__ == '__main__':
  sys.exit(main())
