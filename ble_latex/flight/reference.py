# coding=utf-8
"""The paper's venting and ballasting flight, and a fine RK4 reference.

`run_validation` flies the latex balloon through a fixed sequence of float /
vent / ballast commands at 20-minute intervals (no wind) and measures

  * the max ascent-rate error: over the strides where the controller vented
    or ballasted, max |hdot_sim - hdot_des| / |hdot_des| with hdot_sim the
    simulated ascent rate at the END of the stride (the paper's steady-state
    assumption; the rate drifts during a stride because the drag factor
    changes with altitude, so this is the largest deviation in the stride);
  * the integrator's error against a fine-step RK4 reference (`rk4_reference`,
    dt = 0.05 s) of Eq. fullN2L over the same strides.

`ble-latex-validate` (`ble_latex.cli.validate`) plots and prints it.
"""

import functools
from typing import Any, Dict, List, Sequence, Tuple

import jax
import jax.numpy as jnp
import numpy as np

from ble_latex.flight import atmosphere as atmosphere_lib
from ble_latex.flight import dynamics
from ble_latex.flight import params as params_lib
from ble_latex.flight import physics
from ble_latex.flight import state as state_lib

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
