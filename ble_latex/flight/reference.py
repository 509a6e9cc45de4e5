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
from typing import Any, Dict, List, Optional, Sequence, Tuple

import jax
import jax.numpy as jnp
import numpy as np

from ble_latex.flight import atmosphere as atmosphere_lib
from ble_latex.flight import dynamics
from ble_latex.flight import envelope
from ble_latex.flight import gas as gas_lib
from ble_latex.flight import launch
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
Array = jax.Array


def run_validation(
    commands: Sequence[Tuple[float, float, float]] = COMMANDS,
    *,
    seed: int = 0,
    start_altitude_m: float = START_ALTITUDE_M,
    reference: bool = True,
    params: Optional[params_lib.FlightParams] = None,
    start_time_s: float = 0.0) -> Dict[str, Any]:
  """Flies the command sequence and measures the errors.

  Args:
    commands: (a0, a1, a2) per 20-minute stride.
    seed: PRNG seed of BLE's atmosphere (lapse-rate blend).
    start_altitude_m: Start altitude (neutrally buoyant under `params`'
      gas, `launch.neutral_launch`). # [m]
    reference: Also integrate each stride with the fine RK4 reference: the
      paper's Eq. fullN2L (`rk4_reference`), or, under realistic physics
      with `gas_state` and no disturbance, the motion and the gas's
      temperature as one ODE (`rk4_gas_reference`); other realistic
      settings have no reference.
    params: The flight system; None = `flight_params_from_gin()`.
    start_time_s: Flight time at the first command (the sun's clock of
      realistic physics). # [s]

  Returns:
    A dict with per-stride records ('strides'), the within-stride samples
    ('times_h', 'altitude', 'ascent_rate', 'helium', 'sand'), the
    'max_rate_error' (fraction), 'max_rk4_altitude_error_m' and
    'max_rk4_rate_error' (fraction; NaN without reference), and the
    resources spent: 'helium_vented_mols', 'sand_dropped_kg' and
    'lift_spent_kg' = vented (M_air - M_He) + dropped.
  """
  # BLE's Atmosphere(PRNGKey(seed)): the same lapse-rate blend; the seed's
  # other keys (burst draw, random walk) are split from a second key, so the
  # paper's model flies the same atmosphere as before.
  atm = atmosphere_lib.reset(jax.random.PRNGKey(seed))
  if params is None:
    params = params_lib.flight_params_from_gin()
  burst_key, walk_key = jax.random.split(
      jax.random.fold_in(jax.random.PRNGKey(seed), 28))
  state = launch.neutral_launch(params, atm, state_lib.initial_state(
      params, start_altitude_m, atm_params=atm, time_s=start_time_s,
      key=burst_key))
  stride_s = params.stride_s
  reference = reference and (not params.realistic or (
      params.gas_state and not params.stochastic))

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
    t0 = i * stride_s  # Since the first command.
    h0 = float(state.altitude_m)
    walk_key, stride_key = jax.random.split(walk_key)
    state, actuated, samples = fly(
        params, atm, state, jnp.asarray(command, jnp.float32),
        key=stride_key if params.stochastic else None)
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
      'helium_vented_mols': float(state.helium_vented_mols),
      'sand_dropped_kg': float(state.sand_dropped_kg),
      'lift_spent_kg': float(state.helium_vented_mols * physics.LIFT_PER_MOL
                             + state.sand_dropped_kg),
      'status': state_lib.FlightStatus(int(state.status)).name,
  }


# A day at float: 72 float commands (20-minute strides) at 17 km.
FLOAT_DAY_COMMANDS: Tuple[Tuple[float, float, float], ...] = (
    (17_000.0, 1.0, 1.0),) * 72


def run_day_at_float(params: Optional[params_lib.FlightParams] = None, *,
                     seed: int = 0,
                     start_altitude_m: float = START_ALTITUDE_M,
                     start_time_s: float = 0.0) -> Dict[str, Any]:
  """`run_validation` of `FLOAT_DAY_COMMANDS`: drift and cost of a day.

  Free in the paper's model (a neutral balloon in still air stays put);
  with realistic physics the night cooling, the morning superheat and the
  random walk cost helium and sand, and the balloon drifts between floats.
  """
  return run_validation(FLOAT_DAY_COMMANDS, seed=seed,
                        start_altitude_m=start_altitude_m, reference=False,
                        params=params, start_time_s=start_time_s)


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


def rk4_gas_reference(params, atm, start, duration_s: float,
                      dt_s: float = RK4_DT_S):
  """The realistic motion and the gas's temperature by fine RK4, float64.

  One ODE in (h, hdot, T_g) (`gas`, Eq. (1)):

    m hdot' = L(h, T_g) g - k(h, hdot, T_g) |hdot| hdot
    T_g'    = kappa T_g (dP_g/dh) hdot / P_g + (T + f + dT_h - T_g) / tau

  with L and k of `envelope` (the helium at T_g and P_g), dP/dh by
  automatic differentiation of the atmosphere, f the sun's forcing held per
  physics sub-step at the sub-step's start (as the core defines it), helium,
  sand and the disturbances fixed (as after an instantaneous release).
  Checks the core's split integrator (`dynamics._integrate_gas`), not the
  model. In a local `jax.enable_x64` scope.

  Args:
    params: The flight system (gas_state).
    atm: The atmosphere.
    start: The state right after the actuation.
    duration_s: Time to integrate. # [s]
    dt_s: RK4 step. # [s]

  Returns:
    (altitude [m], ascent rate [m/s], gas temperature [K]) at the end.
  """
  with jax.enable_x64(True):
    to64 = lambda tree: jax.tree.map(  # pylint: disable=unnecessary-lambda-assignment
        lambda a: jnp.asarray(np.asarray(a).astype(np.float64))
        if np.asarray(a).dtype.kind == 'f' else jnp.asarray(a), tree)
    f = to64(start)
    p64 = to64(params)
    atm64 = atmosphere_lib.params_from_alpha(jnp.float64(atm.alpha))
    mass = physics.total_mass(p64.payload_kg, f.sand_kg, f.helium_mols)
    tau = p64.gas_thermal_lag_s
    over = p64.overpressure_pa if params.latex_overpressure else 0.0

    def pressure(h):
      return atmosphere_lib.at_height(atm64, h).pressure

    def rates(y, forcing):
      h, v, temp = y
      ambient = atmosphere_lib.at_height(atm64, h)
      p_gas = ambient.pressure + over
      g = envelope.Gas(ambient.temperature, ambient.pressure, temp, p_gas)
      lift = envelope.free_lift_kg(params, f, g) * physics.GRAVITY
      k = envelope.drag_factor(params, f.helium_mols, g, v)
      dp_dh = jax.grad(pressure)(h)
      target = ambient.temperature + forcing + f.heating_k
      return (v, (lift - k * jnp.abs(v) * v) / mass,
              gas_lib.KAPPA_HELIUM * temp * dp_dh * v / p_gas +
              (target - temp) / tau)

    def rk4(y, forcing):
      k1 = rates(y, forcing)
      k2 = rates(tuple(a + 0.5 * dt_s * b for a, b in zip(y, k1)), forcing)
      k3 = rates(tuple(a + 0.5 * dt_s * b for a, b in zip(y, k2)), forcing)
      k4 = rates(tuple(a + dt_s * b for a, b in zip(y, k3)), forcing)
      return tuple(a + dt_s / 6.0 * (b1 + 2 * b2 + 2 * b3 + b4)
                   for a, b1, b2, b3, b4 in zip(y, k1, k2, k3, k4))

    @jax.jit
    def substep(y, time_s, steps):
      forcing = envelope.forcing_k(p64, time_s, f.x_m, f.y_m)
      return jax.lax.fori_loop(0, steps, lambda _, y: rk4(y, forcing), y)

    y = (f.altitude_m, f.ascent_rate_mps, f.gas_temperature_k)
    done = 0.0
    while done < duration_s - 1e-9:
      length = min(params.max_substep_s, duration_s - done)
      y = substep(y, f.time_s + done, int(round(length / dt_s)))
      done += length
    return tuple(float(a) for a in y)


def _rk4_errors(params, atm, actuated, end, duration: float
                ) -> Tuple[float, float]:
  """(|h - h_ref| [m], |v - v_ref| / max(|v_ref|, 0.05 m/s)) at stride end."""
  if params.realistic:
    h_ref, v_ref, _ = rk4_gas_reference(params, atm, actuated, duration)
  else:
    h_ref, v_ref = rk4_reference(params, atm, actuated, duration)
  return (abs(float(end.altitude_m) - h_ref),
          abs(float(end.ascent_rate_mps) - v_ref) / max(abs(v_ref), 0.05))


# -- Reference checks of the two physics modes (issue 28) --------------------
#
# The reference system of the table: a 1200 g latex envelope (TA-1200)
# and a 1 kg payload, no sand, 1.0 kg of free lift, in BLE's atmosphere with
# the lapse-rate blend alpha = 0.5 (the middle of its range).
REFERENCE_PAYLOAD_KG = 2.2  # [kg] 1.2 kg envelope + 1.0 kg payload
REFERENCE_FREE_LIFT_KG = 1.0  # [kg]
REFERENCE_ALPHA = 0.5  # [.]
ASCENT_ALTITUDES_M = (0.0, 15_000.0, 18_000.0, 20_000.0)  # [m]
STATION_RATE_MPS = 0.85  # [m/s] the station-keeping rate of the lift row
STATION_ALTITUDE_M = 17_000.0  # [m]
# The references' own numbers (the issue's table; not computed here): ASTRA
# (sobester/astra_simulator), CUSF (projecthorus/cusf-burst-calc).
PUBLISHED = {
    'ascent_0m': 5.16,  # [m/s] ASTRA (CUSF 5.00)
    'ascent_15000m': 5.12,  # [m/s] ASTRA
    'ascent_18000m': 5.54,  # [m/s] ASTRA
    'ascent_20000m': 5.84,  # [m/s] ASTRA
    'burst_mean_m': 34_300.0,  # [m] ASTRA (CUSF 33 900)
    'burst_p05_m': 31_000.0,  # [m] ASTRA
    'burst_p95_m': 36_500.0,  # [m] ASTRA
    'station_lift_kg': 0.0311,  # [kg] ASTRA's drag on the default system
}
_BISECTIONS = 80


def _bisect(fn, low, high, iterations: int = _BISECTIONS):
  """The root of a function with fn(low) > 0 > fn(high) (or the reverse)."""
  sign_low = jnp.sign(fn(low))

  def body(_, bounds):
    lo, hi = bounds
    mid = 0.5 * (lo + hi)
    same = jnp.sign(fn(mid)) == sign_low
    return jnp.where(same, mid, lo), jnp.where(same, hi, mid)

  lo, hi = jax.lax.fori_loop(0, iterations, body, (low, high))
  return 0.5 * (lo + hi)


def _gas(params, atm, altitude_m, time_s):
  ambient = atmosphere_lib.at_height(atm, altitude_m)
  return envelope.gas(params, ambient.temperature, ambient.pressure, time_s)


def steady_ascent_rate(params: params_lib.FlightParams,
                       atm: atmosphere_lib.AtmosphereParams,
                       helium_mols: Array, payload_kg: Array, sand_kg: Array,
                       altitude_m: Array, time_s: Array = 0.0) -> Array:
  """The steady rate of Eq. fullN2L at an altitude, both modes. # [m/s]

  The rate hdot >= 0 with L(h) g = k(h, hdot) hdot^2 (`envelope`: the
  mode's gas, lift and c_d(Re)), by bisection on [0, 50] m/s; in the paper's
  model that is `physics.terminal_velocity`. The balloon keeps its helium on
  the way up (the ascent of the references), no random walk.
  """
  g = _gas(params, atm, altitude_m, time_s)
  lift = (helium_mols * envelope.lift_per_mol(params, g) - payload_kg -
          sand_kg)

  def residual(v):
    return lift - envelope.steady_lift_kg(params, helium_mols, g, v)

  return _bisect(residual, jnp.zeros_like(lift), jnp.full_like(lift, 50.0))


def burst_altitude_m(params: params_lib.FlightParams,
                     atm: atmosphere_lib.AtmosphereParams, helium_mols: Array,
                     burst_volume_m3: Array, time_s: Array = 0.0) -> Array:
  """Where the envelope reaches its burst volume (V = n R T_gas / P_gas). # [m]

  Bisection on [5, 60] km (V grows with altitude).
  """
  def residual(h):
    return burst_volume_m3 - envelope.volume(helium_mols,
                                             _gas(params, atm, h, time_s))

  shape = jnp.shape(burst_volume_m3)
  return _bisect(residual, jnp.full(shape, 5_000.0),
                 jnp.full(shape, 60_000.0))


def reference_table(params: params_lib.FlightParams, *,
                    seed: int = 0, draws: int = 4000,
                    time_s: float = 0.0) -> Dict[str, float]:
  """The issue-28 reference rows computed by this mode's equations.

  In float64 (a local `jax.enable_x64` scope). Rows: the reference system's
  steady ascent rate at `ASCENT_ALTITUDES_M` ('ascent_<h>m'), its burst
  altitude (at the nominal `burst_volume_m3`, or, with `burst_spread`, the
  mean and 5 / 95 % of `draws` drawn burst volumes: 'burst_mean_m',
  'burst_p05_m', 'burst_p95_m'), and the free lift that holds
  `STATION_RATE_MPS` at `STATION_ALTITUDE_M` for the default system of
  `params` (payload + initial sand, neutral helium): 'station_lift_kg'.
  ASTRA's gas is at ambient temperature and pressure
  (astra/simulator.py:1105-1112), so compare like with like by passing
  params with gas_superheat and latex_overpressure off
  (`reference_params`).

  Args:
    params: The flight system (its switches; payload and sand of the
      station row).
    seed: PRNG seed of the burst draws.
    draws: Number of burst draws.
    time_s: Flight time of the sun (gas_superheat only). # [s]

  Returns:
    Row name -> value (m/s, m or kg).
  """
  with jax.enable_x64(True):
    atm = atmosphere_lib.params_from_alpha(jnp.float64(REFERENCE_ALPHA))
    payload = jnp.float64(REFERENCE_PAYLOAD_KG)
    helium = (payload + REFERENCE_FREE_LIFT_KG) / physics.LIFT_PER_MOL
    rows = {}
    for h in ASCENT_ALTITUDES_M:
      rows[f'ascent_{h:.0f}m'] = float(steady_ascent_rate(
          params, atm, helium, payload, 0.0, jnp.float64(h), time_s))
    if params.burst_spread:
      keys = jax.random.split(jax.random.PRNGKey(seed), draws)
      diameters = jax.vmap(lambda k: physics.draw_burst_diameter(
          k, jnp.float64(params.burst_weibull_scale_m),
          params.burst_weibull_shape))(keys)
      bursts = np.asarray(jax.jit(burst_altitude_m, static_argnums=0)(
          params, atm, helium, physics.burst_volume_of_diameter(diameters),
          time_s))
      rows['burst_mean_m'] = float(bursts.mean())
      rows['burst_p05_m'] = float(np.percentile(bursts, 5))
      rows['burst_p95_m'] = float(np.percentile(bursts, 95))
    else:
      rows['burst_mean_m'] = float(burst_altitude_m(
          params, atm, helium, jnp.float64(params.burst_volume_m3), time_s))
    station_helium = (params.payload_kg + params.initial_sand_kg) / (
        physics.LIFT_PER_MOL)
    rows['station_lift_kg'] = float(envelope.steady_lift_kg(
        params, jnp.float64(station_helium),
        _gas(params, atm, jnp.float64(STATION_ALTITUDE_M), time_s),
        jnp.float64(STATION_RATE_MPS)))
  return rows


def reference_params(params: params_lib.FlightParams
                     ) -> params_lib.FlightParams:
  """`params` as the references fly it: helium at ambient T and P, no walk.

  ASTRA's balloon gas has the air's temperature and (excessPressureCoeff
  = 1) pressure (astra/simulator.py:1105-1112) and no lift disturbance; the
  drag model and the burst draw stay.
  """
  return params.replace(gas_superheat=False, latex_overpressure=False,
                        lift_walk=False)


def ascent_profile(params: params_lib.FlightParams,
                   altitudes_m: Sequence[float]) -> np.ndarray:
  """The reference system's steady ascent rate at each altitude. # [m/s]

  `steady_ascent_rate` of `REFERENCE_PAYLOAD_KG` with
  `REFERENCE_FREE_LIFT_KG` at launch (helium kept), float64.
  """
  with jax.enable_x64(True):
    atm = atmosphere_lib.params_from_alpha(jnp.float64(REFERENCE_ALPHA))
    payload = jnp.float64(REFERENCE_PAYLOAD_KG)
    helium = (payload + REFERENCE_FREE_LIFT_KG) / physics.LIFT_PER_MOL
    rates = jax.jit(jax.vmap(
        lambda h: steady_ascent_rate(params, atm, helium, payload, 0.0, h)))(
            jnp.asarray(altitudes_m, jnp.float64))
    return np.asarray(rates)


def compare_modes(modes: Dict[str, params_lib.FlightParams], *,
                  seed: int = 0) -> Dict[str, Dict[str, Any]]:
  """Flies each mode: the manoeuvre, a day at float, the reference rows.

  Args:
    modes: Name -> flight system (e.g. {'paper': paper_flight_params(),
      'realistic': realistic_flight_params()}).
    seed: Atmosphere (and draw) seed of the flights.

  Returns:
    Name -> {'manoeuvre': `run_validation`, 'day': `run_day_at_float`,
    'table': `reference_table(reference_params(p))`, 'altitudes_m',
    'ascent_mps': `ascent_profile`}.
  """
  altitudes = np.arange(0.0, 32_001.0, 1_000.0)
  out = {}
  for name, p in modes.items():
    out[name] = {
        'manoeuvre': run_validation(seed=seed, reference=not p.realistic,
                                    params=p),
        'day': run_day_at_float(p, seed=seed),
        'table': reference_table(reference_params(p), draws=2000),
        'altitudes_m': altitudes,
        'ascent_mps': ascent_profile(reference_params(p), altitudes),
    }
  return out
