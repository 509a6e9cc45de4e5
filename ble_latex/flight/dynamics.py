# coding=utf-8
"""One 20-minute stride of the latex balloon, as a pure JAX function.

The JAX twin of `ble_latex.ble.balloon.LatexBalloon.simulate_step` (paper
sections "Equations of Motion" and "Altitude Controller"):

  1. The controller acts once (Eq. fullcontroller, `controller.decide`, at
     the ambient T and P of the start altitude, on what the balloon knows:
     `estimator.controller_view`) and its amounts replace any pending
     release; instantaneous releases (the paper's default) happen at once.
  2. The stride is cut into n = ceil(time_delta / max_substep) equal
     sub-steps (<= 3 min, boundaries rounded to microseconds as
     `datetime.timedelta` does). At the start of each, `wind_fn(x, y, P, t)`
     gives the horizontal wind at the balloon's position, pressure and time;
     the horizontal velocity equals the wind for the whole sub-step.
  3. Inside a sub-step the vertical motion (Eq. fullN2L) advances in chunks
     of at most `vertical_step_s` (60 s), each one `physics.vertical_step`
     (exact `relax`, k at the predicted midpoint). While a finite-rate
     release is pending the chunks are at most `actuation_chunk_s` (10 s) and
     end when the release does; the piece rate * chunk is released at the
     chunk's midpoint. After every chunk: grounded (h <= 0) or burst
     (V > burst volume) end the flight; otherwise the in-stride band guard
     floats a balloon heading out of the band (`guard_within_stride`).
  4. At the end: out of helium (n (M_air - M_He) < m_p) or out of sand
     (m_s < m_s_min). A terminal status stops the sub-steps (the time
     advances to the end of the sub-step in which it happened) and freezes
     the state: stepping a terminal state returns it unchanged (NumPy raises
     instead).

Everything is traced once: the sub-step and chunk grid of the instantaneous
case (`schedule`, from `time_delta_s`, `max_substep_s` and
`vertical_step_s`) is run with `lax.scan`, either built into the program
(a static `time_delta_s`) or passed as data (`padded_schedule`: a traced
argument padded to powers of two, so strides of other lengths reuse the
compiled step; the same values, except that XLA may round the position
update x + u dt once differently: <= 1 ulp of x, y); with finite rates
each sub-step runs a `lax.while_loop` that reproduces NumPy's chunking
exactly. `step` is vmappable over states, actions and atmosphere/flight parameters.
"""

import datetime as dt
import functools
import math
from typing import Callable, NamedTuple, Optional, Tuple, Union

import jax
import jax.numpy as jnp
import numpy as np

from ble_latex.flight import atmosphere as atmosphere_lib
from ble_latex.flight import controller as controller_lib
from ble_latex.flight import disturbance
from ble_latex.flight import envelope
from ble_latex.flight import estimator
from ble_latex.flight import gas as gas_lib
from ble_latex.flight import params as params_lib
from ble_latex.flight import physics
from ble_latex.flight import state as state_lib

Array = jax.Array
FlightState = state_lib.FlightState
FlightStatus = state_lib.FlightStatus
# (x [m], y [m], pressure [Pa], time [s]) -> (u [m/s], v [m/s]); pure JAX.
WindFn = Callable[[Array, Array, Array, Array], Tuple[Array, Array]]
# (params, state, action, T [K], P [Pa]) -> Actuation: `controller.decide`.
DecideFn = Callable[..., controller_lib.Actuation]

# BLE's standard atmosphere is defined on [-610 m, 85 km).
ATMOSPHERE_MIN_M = -600.0  # [m]
ATMOSPHERE_MAX_M = 84_000.0  # [m]
DEFAULT_TIME_DELTA_S = 1200.0  # [s] the paper's 20-minute stride
# Safety bound on the chunks of one sub-step with finite rates.
_MAX_CHUNKS_PER_SUBSTEP = 10_000
# Shortest chunk that completes a finite-rate release (as NumPy). # [s]
_MIN_RELEASE_CHUNK_S = 1e-6


def _clamp(h: Array) -> Array:
  return jnp.clip(h, ATMOSPHERE_MIN_M, ATMOSPHERE_MAX_M)


def _keep(new, old):
  """`new` with the dtypes of `old` (scan/while carries must not change)."""
  return jax.tree.map(lambda a, b: jnp.asarray(a, b.dtype), new, old)


def _select(condition: Array, on_true, on_false):
  return _keep(controller_lib.select(condition, on_true, on_false), on_false)


def schedule(time_delta_s: float, max_substep_s: float,
             vertical_step_s: float) -> Tuple[np.ndarray, ...]:
  """The static sub-step and chunk grid of `LatexBalloon.simulate_step`.

  Args:
    time_delta_s: Stride length. # [s]
    max_substep_s: Longest sub-step. # [s]
    vertical_step_s: Longest vertical chunk. # [s]

  Returns:
    (starts, durations, ends) of the sub-steps, shape (n,), and the chunk
    lengths of each sub-step (instantaneous releases), shape (n, m), padded
    with zeros; all float64 seconds.
  """
  total = dt.timedelta(seconds=time_delta_s)
  sub = dt.timedelta(seconds=max_substep_s)
  n_sub = max(1, math.ceil(total / sub - 1e-9))
  starts, durations, ends, rows = [], [], [], []
  elapsed = dt.timedelta()
  for i in range(1, n_sub + 1):
    boundary = total * i / n_sub
    duration = (boundary - elapsed).total_seconds()
    starts.append(elapsed.total_seconds())
    durations.append(duration)
    ends.append(boundary.total_seconds())
    row, done = [], 0.0
    while duration - done > 1e-9:
      chunk = min(vertical_step_s, duration - done)
      row.append(chunk)
      done += chunk
    rows.append(row)
    elapsed = boundary
  chunks = np.zeros((n_sub, max(len(r) for r in rows)))
  for i, row in enumerate(rows):
    chunks[i, :len(row)] = row
  return (np.asarray(starts), np.asarray(durations), np.asarray(ends),
          chunks)


class Schedule(NamedTuple):
  """A stride's sub-step and chunk grid as data (`padded_schedule`).

  Passed to `step` instead of a static `time_delta_s`, it is a traced
  argument: strides of other lengths reuse the compiled step as long as the
  padded shapes agree. Rows with `valid` False are padding: they change
  nothing (no wind query, no flight, no time).

  Attributes:
    starts: Sub-step starts, shape (n,). # [s]
    durations: Sub-step lengths, shape (n,). # [s]
    ends: Sub-step ends, shape (n,). # [s]
    chunks: Chunk lengths of each sub-step (instantaneous releases), zero
      padded, shape (n, m). # [s]
    valid: Which rows are sub-steps of the stride, shape (n,).
  """
  starts: Array
  durations: Array
  ends: Array
  chunks: Array
  valid: Array


def _power_of_two(n: int) -> int:
  return 1 << max(0, n - 1).bit_length()


def padded_schedule(time_delta_s: float, max_substep_s: float,
                    vertical_step_s: float) -> Schedule:
  """`schedule` as a `Schedule`, its shapes padded to powers of two.

  The sub-steps are padded to the next power of two (invalid rows), the
  chunks of a row to the next power of two of the most a sub-step of at most
  `max_substep_s` can need (zero chunks, which change nothing), so the
  compiled step is shared by every stride up to that many sub-steps. The
  values are `schedule`'s, so `step` flies the same stride (the position
  within 1 ulp: XLA may fuse x + u dt otherwise than with constants).

  Args:
    time_delta_s: Stride length. # [s]
    max_substep_s: Longest sub-step. # [s]
    vertical_step_s: Longest vertical chunk. # [s]

  Returns:
    The grid (NumPy float64 arrays and a bool mask).
  """
  starts, durations, ends, chunks = schedule(time_delta_s, max_substep_s,
                                             vertical_step_s)
  n, m = chunks.shape
  rows = _power_of_two(n)
  columns = _power_of_two(max(m, math.ceil(max_substep_s / vertical_step_s)
                              + 1))
  pad = rows - n
  return Schedule(
      starts=np.pad(starts, (0, pad), constant_values=ends[-1]),
      durations=np.pad(durations, (0, pad)),
      ends=np.pad(ends, (0, pad), constant_values=ends[-1]),
      chunks=np.pad(chunks, ((0, pad), (0, columns - m))),
      valid=np.arange(rows) < n)


def release(state: FlightState, *, vent: Array, drop: Array) -> FlightState:
  """Vents / drops, capped at the pending amounts and at what is aboard.

  The settled lift does not change: the current free lift (its property)
  follows the pending amounts and reaches the settled lift exactly when they
  are released.

  Args:
    state: The balloon.
    vent: Helium to vent now. # [mol]
    drop: Sand to drop now. # [kg]

  Returns:
    The balloon after the release.
  """
  f = state
  vent = jnp.maximum(0.0, jnp.minimum(vent, jnp.minimum(f.pending_vent_mols,
                                                          f.helium_mols)))
  drop = jnp.maximum(0.0, jnp.minimum(drop, jnp.minimum(f.pending_drop_kg,
                                                          f.sand_kg)))
  return _keep(f.replace(
      helium_mols=f.helium_mols - vent,
      helium_vented_mols=f.helium_vented_mols + vent,
      pending_vent_mols=jnp.maximum(0.0, f.pending_vent_mols - vent),
      sand_kg=f.sand_kg - drop,
      sand_dropped_kg=f.sand_dropped_kg + drop,
      pending_drop_kg=jnp.maximum(0.0, f.pending_drop_kg - drop)), f)


def actuate(params: params_lib.FlightParams, state: FlightState,
            actuation: controller_lib.Actuation) -> FlightState:
  """Replaces the pending release by `actuation` (instant without a rate).

  What was still pending is abandoned (as NumPy); the settled lift becomes
  the actuation's target lift.

  Args:
    params: The flight system (finite_valve, finite_ballast).
    state: The balloon before the actuation.
    actuation: The controller's decision (`controller.decide`).

  Returns:
    The state with the new pending vent and drop (each capped at what is
    aboard) and settled lift; amounts without a finite rate
    (`params.finite_valve`, `params.finite_ballast`) are already released.
  """
  f = _keep(state.replace(
      pending_vent_mols=jnp.minimum(actuation.vent_mols, state.helium_mols),
      pending_drop_kg=jnp.minimum(actuation.drop_kg, state.sand_kg),
      settled_lift_kg=actuation.lift_after_kg), state)
  if not params.finite_valve:
    f = release(f, vent=f.pending_vent_mols, drop=0.0)
  if not params.finite_ballast:
    f = release(f, vent=0.0, drop=f.pending_drop_kg)
  return f


def _gas_pressure(params: params_lib.FlightParams, pressure: Array) -> Array:
  """P_g = P (+ the latex overpressure). # [Pa]"""
  if params.latex_overpressure:
    return pressure + params.overpressure_pa
  return pressure


def _vertical_in_gas(params: params_lib.FlightParams, f: FlightState,
                     duration: Array, gas_at) -> Tuple[Array, Array]:
  """Eq. fullN2L with the lift and drag of the gas `gas_at(h)` on the path.

  (`physics.vertical_step_varying`; realistic physics.) Returns (h, hdot).
  """
  def forces_at(h, v):
    g = gas_at(h)
    return (envelope.free_lift_kg(params, f, g) * physics.GRAVITY,
            envelope.drag_factor(params, f.helium_mols, g, v))

  mass = physics.total_mass(params.payload_kg, f.sand_kg, f.helium_mols)
  return physics.vertical_step_varying(
      f.altitude_m, f.ascent_rate_mps, duration, mass=mass,
      forces_at=forces_at)


def _integrate_gas(params: params_lib.FlightParams,
                   atm: atmosphere_lib.AtmosphereParams, f: FlightState,
                   duration: Array, forcing: Array) -> FlightState:
  """Eq. fullN2L with the helium's temperature as a state (`gas`).

  Strang splitting of Eq. (1) of `gas`: relax T_g toward T + f + dT_h for
  half the chunk at the start altitude, the vertical step with T_g adiabatic
  along the path (T_g(h) = T_g0 (P_g(h) / P_g0)^kappa in the lift and drag
  at every altitude the step evaluates), relax for the other half at the
  end altitude.
  """
  tau = params.gas_thermal_lag_s
  half = 0.5 * duration
  start = atmosphere_lib.at_height(atm, _clamp(f.altitude_m))
  p0 = _gas_pressure(params, start.pressure)
  t0 = gas_lib.relax(f.gas_temperature_k,
                     start.temperature + forcing + f.heating_k, half, tau)

  def gas_at(h):
    ambient = atmosphere_lib.at_height(atm, _clamp(h))
    p = _gas_pressure(params, ambient.pressure)
    return envelope.Gas(ambient.temperature, ambient.pressure,
                        gas_lib.adiabatic(t0, p0, p), p)

  h, v = _vertical_in_gas(params, f, duration, gas_at)
  g = gas_at(h)
  t1 = gas_lib.relax(g.temperature, g.air_temperature + forcing + f.heating_k,
                     half, tau)
  new = f.replace(altitude_m=h, ascent_rate_mps=v, gas_temperature_k=t1)
  # The onboard estimate, from the chunk's measurements (`estimator`;
  # skipped at trace time without a disturbance).
  new = estimator.observe_chunk(params, f, new, duration,
                                air_start_k=start.temperature,
                                gas_pressure_start=p0, gas_end=g,
                                forcing_k=forcing)
  return _keep(new, f)


def _integrate(params: params_lib.FlightParams,
               atm: atmosphere_lib.AtmosphereParams, f: FlightState,
               duration: Array, time_s: Array = None,
               forcing: Array = None) -> FlightState:
  """Eq. fullN2L over `duration` (one `physics.vertical_step`).

  With realistic physics (`params.realistic`) the lift and the drag factor
  are those of `envelope` at the altitude (gas at `time_s`) and, for c_d(Re),
  the speed (`physics.vertical_step_varying`); under `gas_state` the gas's
  temperature is integrated too (`_integrate_gas`, `forcing` = f(sun) of
  the sub-step).
  """
  if params.gas_state:
    return _integrate_gas(params, atm, f, duration, forcing)
  if params.realistic:
    def gas_at(h):
      ambient = atmosphere_lib.at_height(atm, _clamp(h))
      return envelope.gas(params, ambient.temperature, ambient.pressure,
                          time_s, f.x_m, f.y_m)

    h, v = _vertical_in_gas(params, f, duration, gas_at)
    new = f.replace(altitude_m=h, ascent_rate_mps=v)
    if params.stochastic:  # The onboard estimate of W (`estimator`).
      start = atmosphere_lib.at_height(atm, _clamp(f.altitude_m))
      new = estimator.observe_chunk(
          params, f, new, duration, air_start_k=start.temperature,
          gas_pressure_start=_gas_pressure(params, start.pressure),
          gas_end=gas_at(h))
    return _keep(new, f)

  def drag_k_at(h):
    ambient = atmosphere_lib.at_height(atm, _clamp(h))
    return physics.drag_factor(f.helium_mols, params.drag_coefficient,
                               ambient.temperature, ambient.pressure)

  mass = physics.total_mass(params.payload_kg, f.sand_kg, f.helium_mols)
  h, v = physics.vertical_step(
      f.altitude_m, f.ascent_rate_mps, duration,
      lift_force=f.free_lift_kg * physics.GRAVITY, mass=mass,
      drag_k_at=drag_k_at)
  return _keep(f.replace(altitude_m=h, ascent_rate_mps=v), f)


def envelope_status(params: params_lib.FlightParams,
                    atm: atmosphere_lib.AtmosphereParams,
                    state: FlightState, time_s: Array = None) -> Array:
  """GROUNDED (h <= 0), BURST (nRT/P > burst volume) or the current status.

  Realistic physics: V = n R T_gas / P_gas (gas at `time_s`) against this
  flight's burst volume (`envelope.burst_volume_m3`).

  Args:
    params: The flight system (realistic switches, burst_volume_m3).
    atm: The atmosphere.
    state: The balloon.
    time_s: Flight time for the gas temperature (realistic physics only;
      None otherwise). # [s]

  Returns:
    The `FlightStatus` code. # int32
  """
  ambient = atmosphere_lib.at_height(atm, _clamp(state.altitude_m))
  if params.realistic:
    volume = envelope.volume(state.helium_mols, envelope.of_state(
        params, state, ambient.temperature, ambient.pressure, time_s))
    burst = envelope.burst_volume_m3(params, state)
  else:
    volume = physics.volume(state.helium_mols, ambient.temperature,
                            ambient.pressure)
    burst = params.burst_volume_m3
  return jnp.where(
      state.altitude_m <= 0.0, FlightStatus.GROUNDED,
      jnp.where(volume > burst, FlightStatus.BURST,
                state.status)).astype(jnp.int32)


def resource_status(params: params_lib.FlightParams,
                    state: FlightState, lift_kg: Array = None) -> Array:
  """OUT_OF_HELIUM (n (M_air - M_He) < m_p), OUT_OF_SAND (m_s < m_s_min), OK.

  n (M_air - M_He) - m_p is evaluated as L + m_s from the carried free lift,
  so a balloon floated exactly with no sand left is not out of helium.
  `lift_kg`: the realistic free lift (None = the paper's).

  Args:
    params: The flight system (min_drop_kg).
    state: The balloon (free_lift_kg, sand_kg).
    lift_kg: The realistic free lift; None uses `state.free_lift_kg`.
      # [kg]

  Returns:
    The `FlightStatus` code (OUT_OF_HELIUM, OUT_OF_SAND or OK). # int32
  """
  lift = state.free_lift_kg if lift_kg is None else lift_kg
  out_of_helium = lift + state.sand_kg < 0.0
  out_of_sand = state.sand_kg + 1e-12 < params.min_drop_kg
  return jnp.where(out_of_helium, FlightStatus.OUT_OF_HELIUM,
                   jnp.where(out_of_sand, FlightStatus.OUT_OF_SAND,
                             FlightStatus.OK)).astype(jnp.int32)


def _after_chunk(params: params_lib.FlightParams,
                 atm: atmosphere_lib.AtmosphereParams,
                 f: FlightState, time_s: Array = None,
                 forcing: Array = None) -> FlightState:
  """Envelope check, then the in-stride band guard (if enabled).

  Under gas_state the guard's float nulls the lift of the gas settled at
  rest (`envelope.settled`, as the controller's Eq. float).
  """
  f = f.replace(status=envelope_status(params, atm, f, time_s))
  if not params.guard_within_stride:
    return f
  if params.realistic:
    ambient = atmosphere_lib.at_height(atm, _clamp(f.altitude_m))
    g = envelope.of_state(params, f, ambient.temperature, ambient.pressure,
                          time_s)
    seen = estimator.controller_view(params, f)  # W: its estimate.
    lift = envelope.free_lift_kg(params, seen, g)
    heading = (f.status == FlightStatus.OK) & (
        controller_lib.heading_out_of_band(params, f, lift))
    rest = envelope.settled(params, g, forcing, 0.0)
    guard = controller_lib.float_actuation(
        f, guarded=True, lift_kg=envelope.free_lift_kg(params, seen, rest),
        lift_per_mol=envelope.lift_per_mol(params, rest))
  else:
    heading = (f.status == FlightStatus.OK) & (
        controller_lib.heading_out_of_band(params, f))
    guard = controller_lib.float_actuation(f, guarded=True)
  engage = heading & ((guard.vent_mols > 0.0) | (guard.drop_kg > 0.0))
  guarded = actuate(params, f, guard).replace(
      guard_engaged=jnp.ones_like(f.guard_engaged))
  return _select(engage, guarded, f)


def _releasing(params: params_lib.FlightParams, f: FlightState) -> Array:
  """A finite-rate release is under way."""
  out = jnp.zeros_like(f.status, bool)
  if params.finite_valve:
    out = out | (f.pending_vent_mols > 0.0)
  if params.finite_ballast:
    out = out | (f.pending_drop_kg > 0.0)
  return out


def _time_to_release(params: params_lib.FlightParams,
                     f: FlightState) -> Array:
  """Seconds until the pending release that finishes last is done."""
  t = jnp.zeros_like(f.altitude_m)
  if params.finite_valve:
    t = jnp.maximum(t, jnp.where(f.pending_vent_mols > 0.0,
                                 f.pending_vent_mols /
                                 params.valve_flow_mols_per_s, 0.0))
  if params.finite_ballast:
    t = jnp.maximum(t, jnp.where(f.pending_drop_kg > 0.0,
                                 f.pending_drop_kg /
                                 params.ballast_rate_kg_per_s, 0.0))
  return jnp.maximum(t, _MIN_RELEASE_CHUNK_S)


def _chunks_static(params: params_lib.FlightParams,
                   atm: atmosphere_lib.AtmosphereParams, f: FlightState,
                   chunks: Array, time_s: Array = None,
                   forcing: Array = None) -> FlightState:
  """A sub-step on the static chunk grid (instantaneous releases)."""

  def body(f, chunk):
    active = (f.status == FlightStatus.OK) & (chunk > 0.0)
    g = _after_chunk(params, atm,
                     _integrate(params, atm, f, chunk, time_s, forcing),
                     time_s, forcing)
    return _select(active, g, f), None

  f, _ = jax.lax.scan(body, f, chunks)
  return f


def _chunks_dynamic(params: params_lib.FlightParams,
                    atm: atmosphere_lib.AtmosphereParams, f: FlightState,
                    duration: Array, time_s: Array = None,
                    forcing: Array = None) -> FlightState:
  """A sub-step with finite-rate releases (NumPy's chunking, while_loop)."""
  eps = jnp.finfo(jnp.result_type(duration)).eps
  tolerance = jnp.maximum(1e-9, 16.0 * eps * duration)  # [s]
  zero = jnp.zeros_like(duration)

  def cond(carry):
    f, done, count = carry
    return ((duration - done > tolerance) & (f.status == FlightStatus.OK) &
            (count < _MAX_CHUNKS_PER_SUBSTEP))

  def body(carry):
    f, done, count = carry
    chunk = jnp.minimum(params.vertical_step_s, duration - done)
    releasing = _releasing(params, f)
    piece = jnp.minimum(jnp.minimum(chunk, params.actuation_chunk_s),
                        _time_to_release(params, f))
    whole = _integrate(params, atm, f, chunk, time_s, forcing)
    half = _integrate(params, atm, f, 0.5 * piece, time_s, forcing)
    half = release(
        half,
        vent=(params.valve_flow_mols_per_s * piece
              if params.finite_valve else zero),
        drop=(params.ballast_rate_kg_per_s * piece
              if params.finite_ballast else zero))
    half = _integrate(params, atm, half, 0.5 * piece, time_s, forcing)
    g = _after_chunk(params, atm, _select(releasing, half, whole), time_s,
                     forcing)
    done = done + jnp.where(releasing, piece, chunk)
    return _keep(g, f), done, count + 1

  f, _, _ = jax.lax.while_loop(cond, body, (f, zero, jnp.zeros((), jnp.int32)))
  return f


def step(params: params_lib.FlightParams,
         atm_params: atmosphere_lib.AtmosphereParams,
         state: FlightState,
         action: Array,
         wind_fn: WindFn,
         time_delta_s: Union[float, Schedule] = DEFAULT_TIME_DELTA_S,
         key: Optional[Array] = None,
         decide_fn: Optional[DecideFn] = None) -> FlightState:
  """One controller action and `time_delta_s` of flight (one stride).

  Args:
    params: The flight system (its static fields shape the computation).
    atm_params: The atmosphere (`atmosphere.reset(key)`).
    state: The balloon; a terminal status is returned unchanged.
    action: (a0 desired altitude [m], a1 time factor [.], a2 float flag [.]),
      shape (3,); clipped into the action Box.
    wind_fn: Pure JAX (x [m], y [m], pressure [Pa], time [s]) -> (u, v)
      [m/s], queried at the start of every sub-step at the balloon.
    time_delta_s: Simulated time to advance: a static Python number (its
      grid is built into the program), or its `padded_schedule` (traced:
      one compiled step serves every stride with the same padded shapes;
      the same values but x, y within 1 ulp). # [s]
    key: PRNG key of the stride's disturbances; needed (and used) only
      when `params.stochastic` (lift_walk, heating_noise; one key per
      stride: split yours).
    decide_fn: Another controller in place of Eq. fullcontroller
      (`controller.decide`), with its signature (params, state, action,
      T [K], P [Pa]) -> `controller.Actuation`; the action is clipped into
      the Box first (e.g. a ValBal-style deadband,
      benchmarks/valbal_check.py).

  Returns:
    The state after the stride.

  Raises:
    ValueError: `params.lift_walk` without a key (at trace time).
  """
  return _step(params, atm_params, state, action, wind_fn, time_delta_s,
               record=False, key=key, decide_fn=decide_fn)[0]


def step_with_trajectory(
    params: params_lib.FlightParams,
    atm_params: atmosphere_lib.AtmosphereParams,
    state: FlightState,
    action: Array,
    wind_fn: WindFn,
    time_delta_s: Union[float, Schedule] = DEFAULT_TIME_DELTA_S,
    key: Optional[Array] = None,
    decide_fn: Optional[DecideFn] = None
) -> Tuple[FlightState, FlightState, FlightState]:
  """`step`, also returning the states inside the stride (plots, checks).

  Args:
    params: The flight system (its static fields shape the computation).
    atm_params: The atmosphere (`atmosphere.reset(key)`).
    state: The balloon; a terminal status is returned unchanged.
    action: (a0 desired altitude [m], a1 time factor [.], a2 float flag [.]),
      shape (3,); clipped into the action Box.
    wind_fn: Pure JAX (x [m], y [m], pressure [Pa], time [s]) -> (u, v)
      [m/s], queried at the start of every sub-step at the balloon.
    time_delta_s: Simulated time to advance, a static number or its
      `padded_schedule` (as in `step`). # [s]
    key: PRNG key of the stride's disturbances; needed (and used) only
      when `params.stochastic`.
    decide_fn: Another controller in place of Eq. fullcontroller (as in
      `step`).

  Returns:
    (state after the stride, state right after the controller's actuation,
    states after each physics sub-step stacked on a leading axis; with a
    `Schedule`, its padding rows repeat the state after the stride).

  Raises:
    ValueError: `params.lift_walk` without a key (at trace time).
  """
  return _step(params, atm_params, state, action, wind_fn, time_delta_s,
               record=True, key=key, decide_fn=decide_fn)


def _step(params, atm_params, state, action, wind_fn, time_delta_s, *,
          record: bool, key: Optional[Array] = None,
          decide_fn: Optional['DecideFn'] = None):
  """`step`'s body; `record` also returns the actuated and sub-step states."""
  if params.stochastic and key is None:
    raise ValueError('FlightParams.lift_walk / heating_noise (LatexBalloon.'
                     'lift_walk_kg_per_sqrt_s / heating_noise_k) draw a '
                     'disturbance: dynamics.step needs a PRNG key per stride')
  action = _keep(controller_lib.clip_action(action), state.last_action)
  ambient = atmosphere_lib.at_height(atm_params, _clamp(state.altitude_m))
  actuation = (decide_fn or controller_lib.decide)(
      params, estimator.controller_view(params, state), action,
      ambient.temperature, ambient.pressure)
  f = actuate(params, state.replace(guard_engaged=actuation.guarded),
              actuation)
  actuated = f

  dtype = state.altitude_m.dtype
  masked = isinstance(time_delta_s, Schedule)
  if masked:
    grid = time_delta_s
    xs = tuple(jnp.asarray(a, dtype) for a in grid[:4]) + (
        jnp.asarray(grid.valid, bool),)
  else:
    xs = tuple(jnp.asarray(a, dtype) for a in schedule(
        time_delta_s, params.max_substep_s, params.vertical_step_s))
  finite = params.finite_valve or params.finite_ballast
  if params.stochastic:  # One key per sub-step row.
    xs = xs + (jax.random.split(key, len(xs[0])),)

  def substep(carry, x):
    f, elapsed = carry
    start, duration, end, chunk_row = x[:4]
    active = f.status == FlightStatus.OK
    time_s = state.time_s + start  # The sun's time of this sub-step.
    f_before = f
    if params.lift_walk and params.heating_noise:
      walk_key, heat_key = jax.random.split(x[-1])
    elif params.stochastic:
      walk_key = heat_key = x[-1]
    if params.lift_walk_intermittent:  # Calm / gusty spells.
      walk, gusty = disturbance.intermittent_transition(
          f.lift_walk_kg, f.lift_walk_gusty, duration,
          sigma=params.lift_walk_kg_per_sqrt_s,
          calm_sigma=params.lift_walk_calm_kg_per_sqrt_s,
          time_constant_s=params.lift_walk_time_constant_s,
          calm_mean_s=params.lift_walk_calm_mean_s,
          gusty_mean_s=params.lift_walk_gusty_mean_s, key=walk_key)
      f = f.replace(lift_walk_kg=walk, lift_walk_gusty=gusty)
    elif params.lift_walk:  # The disturbance's exact transition.
      f = f.replace(lift_walk_kg=disturbance.transition(
          f.lift_walk_kg, duration, sigma=params.lift_walk_kg_per_sqrt_s,
          time_constant_s=params.lift_walk_time_constant_s, key=walk_key))
    if params.heating_noise:  # The bounded heating disturbance.
      f = f.replace(heating_k=gas_lib.heating_transition(
          f.heating_k, duration, rms_k=params.heating_noise_k,
          time_constant_s=params.heating_noise_time_s, key=heat_key))
    # f(sun) of this sub-step at the balloon (gas_state's relaxation).
    forcing = (envelope.forcing_k(params, time_s, f.x_m, f.y_m)
               if params.gas_state else None)
    pressure = atmosphere_lib.at_height(atm_params,
                                        _clamp(f.altitude_m)).pressure
    query = (f.x_m, f.y_m, pressure, state.time_s + start)
    if masked:  # No wind query on a padding row (a host wind is not called).
      active = active & x[4]
      calm = jax.tree.map(lambda a: jnp.zeros(a.shape, a.dtype),
                          jax.eval_shape(wind_fn, *query))
      u, v = jax.lax.cond(x[4], lambda: tuple(wind_fn(*query)),
                          lambda: tuple(calm))
    else:
      u, v = wind_fn(*query)
    if finite:
      g = _chunks_dynamic(params, atm_params, f, duration, time_s, forcing)
    else:
      g = _chunks_static(params, atm_params, f, chunk_row, time_s, forcing)
    g = g.replace(x_m=g.x_m + u * duration, y_m=g.y_m + v * duration)
    g = _select(active, g, f_before)
    return (g, jnp.where(active, end, elapsed).astype(elapsed.dtype)), (
        g if record else None)

  (f, elapsed), samples = jax.lax.scan(substep, (f, jnp.zeros((), dtype)),
                                       xs)

  ambient = atmosphere_lib.at_height(atm_params, _clamp(f.altitude_m))
  if params.realistic:
    lift = envelope.free_lift_kg(params, f, envelope.of_state(
        params, f, ambient.temperature, ambient.pressure,
        state.time_s + elapsed))
  else:
    lift = None
  status = jnp.where(f.status == FlightStatus.OK,
                     resource_status(params, f, lift), f.status)
  new = f.replace(
      sand_kg=jnp.maximum(f.sand_kg, 0.0),
      time_s=state.time_s + elapsed,
      status=status,
      last_action=action,
      last_decision=actuation.decision,
      desired_ascent_rate_mps=actuation.desired_ascent_rate,
      pressure_pa=ambient.pressure,
      temperature_k=ambient.temperature)
  return (_select(state.status == FlightStatus.OK, _keep(new, state), state),
          actuated, samples)


def make_step(wind_fn: WindFn,
              time_delta_s: float = DEFAULT_TIME_DELTA_S) -> Callable[
                  [params_lib.FlightParams, atmosphere_lib.AtmosphereParams,
                   FlightState, Array], FlightState]:
  """`step` with the wind and stride bound, jitted.

  Args:
    wind_fn: The wind callback (part of the jit cache key).
    time_delta_s: Stride length (static). # [s]

  Returns:
    jitted (params, atm_params, state, action) -> state; vmap it for
    batches, e.g. jax.vmap(fn, in_axes=(None, None, 0, 0)).
  """
  return jax.jit(functools.partial(step, wind_fn=wind_fn,
                                   time_delta_s=float(time_delta_s)))


def make_scheduled_step(wind_fn: WindFn) -> Callable[
    [params_lib.FlightParams, atmosphere_lib.AtmosphereParams, FlightState,
     Array, Schedule], FlightState]:
  """`step` with the wind bound, jitted; the stride is a traced argument.

  Args:
    wind_fn: The wind callback (part of the jit cache key).

  Returns:
    jitted (params, atm_params, state, action, schedule) -> state, with
    `schedule = padded_schedule(time_delta_s, params.max_substep_s,
    params.vertical_step_s)`: it compiles once per padded shape (powers of
    two of sub-steps), not once per stride length.
  """
  def scheduled(params, atm_params, state, action, grid):
    return step(params, atm_params, state, action, wind_fn, Schedule(*grid))
  return jax.jit(scheduled)
