# coding=utf-8
"""The realistic float measured as a balloon engineer checks it (issue 68).

Each function flies the flight core (`dynamics.step`, calm air, BLE's
atmosphere) and returns one row of the calibration table that
`benchmarks/float_calibration.py` prints, against the ranges its sources
give (`TARGETS`, docs/physics.md):

  * `plant_constant`: the terminal speed per gram of free lift after a small
    lift step at float (ValBal's own plant constant: 0.006 m/s per g,
    stanford-ssi/balloons-VALBAL `hootl/lasagna/PastaSim.h`,
    `src/LasagnaController.h`);
  * `calm_probability`: P(2 h with no action and |dh| <= 100 m) at the
    default disturbance, the SSI-71 calm segment (2018-06-15 ~03:20-05:20
    UTC, valbal-trajectory `figs/flightperf`);
  * `sunset_loss_kg`: the lift a neutral balloon loses over a sunset (ValBal's
    sunset table, 0.43 kg; ballast measured around sunsets 0.2-0.7 kg);
  * `band_flights`: ValBal-style deadband flights (`deadband_decide`: nothing
    inside 13.5 km +- 750 m): ballast per day including sunsets (ValBal's
    trajectory planner budgets (1/(2.845e-5 tol + 0.0175) + 13) g/h plus its
    sunset table, 1.36 kg/day at +-750 m; valbal-trajectory `cpp/sim.cpp`)
    and days aloft (datasheet: 0 / 1 / 5 kg of payload -> 5 / 3 / 1 days;
    record flight 121 h 34 min with no payload);
  * the default balloon's float at 17 km (`band_flights` of its own band).

Pure JAX flights, vmapped over seeds; the numbers depend only on the
parameters and the seed.
"""

import functools
from typing import Any, Dict

import gin
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import configs
from ble_latex.flight import atmosphere as atmosphere_lib
from ble_latex.flight import controller as controller_lib
from ble_latex.flight import dynamics
from ble_latex.flight import envelope
from ble_latex.flight import gas as gas_lib
from ble_latex.flight import launch
from ble_latex.flight import params as params_lib
from ble_latex.flight import solar
from ble_latex.flight import state as state_lib

Array = jax.Array

# ValBal's controller (src/LasagnaController.h): setpoint, half band, speed
# limit. # [m], [m], [m/s]
VALBAL_SETPOINT_M = 13_500.0
VALBAL_HALF_BAND_M = 750.0
VALBAL_SPEED_LIMIT_MPS = 0.5
# The deadband's return rate = error / RETURN_TIME_S, capped at the speed
# limit, and the speed error it tolerates before it acts (assumptions:
# ValBal's controller is a lead compensator on the velocity error with a
# deadband, src/LasagnaController.h). # [s], [m/s]
RETURN_TIME_S = 3000.0
SPEED_TOLERANCE_MPS = 0.1
# The calm segment: 2 h, |dh| <= 100 m (SSI-71, valbal-trajectory
# figs/flightperf). # [s], [m]
CALM_DURATION_S = 7200.0
CALM_HALF_BAND_M = 100.0
# The lift step of the plant constant (a ValBal ballast pulse is ~5-20 g)
# and when its speed is read (after 6 thermal time constants of 600 s: the
# damping lift has built up). # [kg], [s]
PLANT_STEP_KG = 0.010
PLANT_READ_S = 3600.0
# The ranges each row is held against (docs/physics.md gives the sources).
TARGETS = {
    'plant_default_mps_per_g': (0.004, 0.010),
    'plant_valbal_mps_per_g': (0.003, 0.0065),
    'calm_probability': (0.1, 0.5),
    'band_cost_kg_per_day': (1.2, 1.5),
    'sunset_loss_kg': (0.2, 0.7),
    'days_aloft_payload_takes_ballast': (2.0, 4.0),
    'days_aloft_no_payload': (4.0, 6.0),
}


# The gin files of the realistic preset (and, for ValBal, its system).
REALISTIC_GIN = ('latex_physics.gin', 'latex_realistic.gin')
VALBAL_GIN = REALISTIC_GIN + ('valbal.gin',)
# The realistic task (issue 63): the realistic physics with the resources
# sized from ValBal's ballast fraction (latex_realistic_task.gin).
TASK_GIN = REALISTIC_GIN + ('latex_realistic_task.gin',)


def preset_params(valbal: bool = False, task: bool = False,
                  **overrides: Any) -> params_lib.FlightParams:
  """The realistic preset's flight system, the task's or ValBal's.

  Parses `REALISTIC_GIN` (or `TASK_GIN` with `task`, `VALBAL_GIN` with
  `valbal`) into a clean gin configuration and clears it after, so nothing
  the caller bound leaks in or out; `overrides` are `make_flight_params`
  arguments on top.
  """
  if valbal and task:
    raise ValueError('preset_params: valbal and task are two presets; '
                     'pick one')
  names = VALBAL_GIN if valbal else TASK_GIN if task else REALISTIC_GIN
  gin.clear_config()
  try:
    gin.parse_config_files_and_bindings(
        [configs.gin_file(name) for name in names], [])
    return params_lib.flight_params_from_gin(**overrides)
  finally:
    gin.clear_config()


def _calm(x_m, y_m, pressure_pa, t_s):
  del y_m, pressure_pa, t_s
  return jnp.zeros_like(x_m), jnp.zeros_like(x_m)


def _nothing(state: state_lib.FlightState) -> controller_lib.Actuation:
  zero = jnp.zeros_like(state.altitude_m)
  return controller_lib.Actuation(
      decision=jnp.full(zero.shape, int(state_lib.DecisionCode.NOTHING),
                        jnp.int32),
      desired_ascent_rate=zero, vent_mols=zero, drop_kg=zero,
      guarded=jnp.zeros(zero.shape, bool), lift_after_kg=state.free_lift_kg)


def hold_decide(params, state, action, temperature, pressure):
  """A controller that does nothing (`dynamics.step`'s decide_fn)."""
  del params, action, temperature, pressure
  return _nothing(state)


def deadband_decide(params, state, action, temperature, pressure, *,
                    setpoint_m: float = VALBAL_SETPOINT_M,
                    half_band_m: float = VALBAL_HALF_BAND_M,
                    velocity: bool = True):
  """A ValBal-style deadband around setpoint +- half band.

  velocity (the calibration's): the wanted rate is 0 inside the band and,
  outside, towards the setpoint at error / RETURN_TIME_S, at most
  VALBAL_SPEED_LIMIT_MPS; when the ascent rate is off it by more than
  SPEED_TOLERANCE_MPS, Eq. vent / Eq. ballast (`controller.decide`) to it,
  else nothing. Not velocity (issue 44's `benchmarks/valbal_check.py`):
  nothing inside the band; outside, unless already heading back at half
  the wanted rate, Eq. vent / Eq. ballast to it. `action` is ignored.
  """
  del action
  h, v = state.altitude_m, state.ascent_rate_mps
  error = setpoint_m - h  # [m]
  outside = jnp.abs(error) > half_band_m
  towards = jnp.clip(error / RETURN_TIME_S, -VALBAL_SPEED_LIMIT_MPS,
                     VALBAL_SPEED_LIMIT_MPS)
  if velocity:
    rate = jnp.where(outside, towards, 0.0)
    act = jnp.abs(v - rate) > SPEED_TOLERANCE_MPS
  else:
    rate = towards
    act = outside & ~(v * jnp.sign(error) >= 0.5 * jnp.abs(rate))
  one = jnp.ones_like(h)
  command = jnp.stack([h + rate * params.stride_s, one, -one])
  decided = controller_lib.decide(params, state, command, temperature,
                                  pressure)
  return controller_lib.select(act, decided, _nothing(state))


def start_time_of_elevation(params: params_lib.FlightParams,
                            night: bool) -> float:
  """The first flight time the sun is steady at the station. # [s]

  Steady: below `sun_elevation_night_deg` (night) or above
  `sun_elevation_day_deg` (day) for the 2 h before (many thermal time
  constants: the lagged forcing has caught up, the gas is at rest at its
  target) and the 3 h after, so the solar forcing is flat.
  """
  times = np.arange(0.0, 2 * 86_400.0, 300.0)
  elevation = np.asarray(solar.sun_elevation_deg(
      params.start_day_j2000, params.start_second_of_day, jnp.asarray(times),
      params.latitude_deg, params.longitude_deg))
  flat = (elevation < params.sun_elevation_night_deg if night else
          elevation > params.sun_elevation_day_deg)
  before, after = int(2 * 3600 / 300), int(3 * 3600 / 300)
  for i in range(before, len(times) - after):
    if flat[i - before:i + after].all():
      return float(times[i])
  raise ValueError('no steady 3 h of sun at the station in two days')


def _launch(params, altitude_m, key, time_s, heating_k=0.0):
  """A neutral balloon at rest, its heating disturbance set to heating_k."""
  atm_key, burst_key = jax.random.split(key)
  atm = atmosphere_lib.reset(atm_key)
  state = launch.neutral_launch(params, atm, state_lib.initial_state(
      params, altitude_m, atm_params=atm, time_s=time_s, key=burst_key))
  return atm, state.replace(
      heating_k=jnp.asarray(heating_k, state.heating_k.dtype),
      gas_temperature_k=state.gas_temperature_k + heating_k)


def plant_constant(params: params_lib.FlightParams, altitude_m: float, *,
                   seed: int = 0) -> Dict[str, float]:
  """Terminal speed per gram after a `PLANT_STEP_KG` lift step at float.

  A neutral balloon at rest at `altitude_m` under a steady night sun, no
  disturbance, drops PLANT_STEP_KG of sand and then does nothing; its
  ascent rate PLANT_READ_S later (the damping lift has built up) divided by
  the step. Also the damping c of `gas.damping_kg_per_mps` there.
  """
  p = params.noiseless()
  atm, state = _launch(p, altitude_m, jax.random.PRNGKey(seed),
                       start_time_of_elevation(p, night=True))
  state = state_lib.with_resources(p, state,
                                   sand_kg=state.sand_kg - PLANT_STEP_KG)
  step = jax.jit(functools.partial(dynamics.step, wind_fn=_calm,
                                   time_delta_s=300.0,
                                   decide_fn=hold_decide))
  action = jnp.zeros(3, state.altitude_m.dtype)
  for _ in range(int(PLANT_READ_S / 300.0)):
    state = step(p, atm, state, action)
  ambient = atmosphere_lib.at_height(atm, jnp.float32(altitude_m))
  damping = float(gas_lib.damping_kg_per_mps(
      state.helium_mols, ambient.temperature, ambient.pressure,
      p.gas_thermal_lag_s)) if p.gas_state else 0.0
  return {'altitude_m': altitude_m,
          'speed_mps': float(state.ascent_rate_mps),
          'mps_per_g': float(state.ascent_rate_mps) / (PLANT_STEP_KG * 1e3),
          'damping_g_per_mps': 1e3 * damping,
          'rise_m': float(state.altitude_m) - altitude_m}


@functools.lru_cache(maxsize=8)
def _free_flier(params, strides: int, stride_s: float, altitude_m: float,
                time_s: float):
  """Jitted keys [N] -> altitudes [N, strides * substeps] of hold flights."""
  step = functools.partial(dynamics.step_with_trajectory, wind_fn=_calm,
                           time_delta_s=stride_s)
  rms = params.heating_noise_k

  def one(key):
    start_key, heat_key, walk_key = jax.random.split(key, 3)
    heating = rms * jax.random.normal(heat_key) if params.heating_noise else (
        0.0)
    atm, state = _launch(params, altitude_m, start_key, time_s, heating)
    float_cmd = jnp.asarray([altitude_m, 1.0, 1.0], state.altitude_m.dtype)
    keys = jax.random.split(walk_key, strides)
    state, _, _ = step(params, atm, state, float_cmd, key=keys[0])

    def body(state, k):
      new, _, samples = dynamics.step_with_trajectory(
          params, atm, state, float_cmd, _calm, stride_s, key=k,
          decide_fn=hold_decide)
      return new, samples.altitude_m

    _, altitude = jax.lax.scan(body, state, keys[1:])
    return altitude.reshape(-1) - altitude_m

  return jax.jit(jax.vmap(one))


def calm_probability(params: params_lib.FlightParams, *, flights: int = 512,
                     altitude_m: float = VALBAL_SETPOINT_M,
                     seed: int = 0) -> Dict[str, float]:
  """P(no action for CALM_DURATION_S and |dh| <= CALM_HALF_BAND_M).

  Each flight: a neutral balloon at `altitude_m` under a steady night sun,
  its heating disturbance drawn from its stationary law (a lift walk starts
  at 0), floated once (Eq. float: the controller nulls the lift of a gas at
  rest; it cannot see the disturbance), then left alone for one stride of
  settling and CALM_DURATION_S; |dh| read every sub-step.
  """
  stride_s = params.stride_s
  strides = 1 + int(round(CALM_DURATION_S / stride_s))
  fly = _free_flier(params, strides + 1, stride_s, altitude_m,
                    start_time_of_elevation(params, night=True))
  dh = np.asarray(fly(jax.random.split(jax.random.PRNGKey(seed), flights)))
  per_stride = dh.shape[1] // strides
  window = dh[:, per_stride:]  # After one stride of settling.
  window = window - dh[:, per_stride - 1:per_stride]
  calm = np.abs(window).max(axis=1) <= CALM_HALF_BAND_M
  return {'flights': flights, 'probability': float(calm.mean()),
          'median_max_abs_dh_m': float(np.median(np.abs(window).max(axis=1)))}


def sunset_loss_kg(params: params_lib.FlightParams,
                   altitude_m: float = VALBAL_SETPOINT_M) -> Dict[str, float]:
  """Lift lost by a neutral balloon at rest at `altitude_m` over a sunset.

  The free lift of a gas at rest (the air's plus the lagged forcing) 3 h
  before the sun's elevation crosses 0 going down minus 2 h after, at the
  station (alpha = 0.5 atmosphere): the window of ValBal's ballast
  measurements.
  """
  atm = atmosphere_lib.params_from_alpha(jnp.float32(0.5))
  state = launch.neutral_launch(params, atm, state_lib.initial_state(
      params, altitude_m, atm_params=atm, key=jax.random.PRNGKey(0)))
  times = np.arange(0.0, 2 * 86_400.0, 60.0)
  elevation = np.asarray(solar.sun_elevation_deg(
      params.start_day_j2000, params.start_second_of_day,
      jnp.asarray(times), params.latitude_deg, params.longitude_deg))
  sets = np.nonzero((elevation[:-1] > 0.0) & (elevation[1:] <= 0.0))[0]
  t_set = float(times[sets[0]])
  ambient = atmosphere_lib.at_height(atm, jnp.float32(altitude_m))

  def lift(t):
    g = envelope.gas(params, ambient.temperature, ambient.pressure,
                     jnp.float32(t))
    return float(envelope.free_lift_kg(params, state, g))

  before, after = lift(t_set - 3 * 3600.0), lift(t_set + 2 * 3600.0)
  return {'sunset_h_after_start': t_set / 3600.0,
          'lift_3h_before_kg': before, 'lift_2h_after_kg': after,
          'loss_kg': before - after}


@functools.lru_cache(maxsize=8)
def _band_flier(strides: int, stride_s: float, setpoint_m: float,
                half_band_m: float, velocity: bool):
  """Jitted (params, keys [N]) -> final states, altitudes, statuses."""
  decide = functools.partial(deadband_decide, setpoint_m=setpoint_m,
                             half_band_m=half_band_m, velocity=velocity)
  step = functools.partial(dynamics.step, wind_fn=_calm,
                           time_delta_s=stride_s, decide_fn=decide)

  def one(params, key):
    start_key, walk_key = jax.random.split(key)
    atm, state = _launch(params, setpoint_m, start_key, 0.0)
    action = jnp.zeros(3, state.altitude_m.dtype)

    def body(state, k):
      new = step(params, atm, state, action,
                 key=k if params.stochastic else None)
      return new, (new.altitude_m, new.status)

    final, (altitude, status) = jax.lax.scan(
        body, state, jax.random.split(walk_key, strides))
    return final, altitude, status

  return jax.jit(jax.vmap(one, in_axes=(None, 0)))


def band_flights(params: params_lib.FlightParams, *, flights: int = 16,
                 days: float = 7.0, setpoint_m: float = VALBAL_SETPOINT_M,
                 half_band_m: float = VALBAL_HALF_BAND_M,
                 velocity: bool = True, seed: int = 0) -> Dict[str, Any]:
  """`flights` deadband flights of up to `days`: cost and days aloft.

  Each its own atmosphere and disturbance, launched neutral at the setpoint
  at the params' start time (the sun's clock), held by `deadband_decide`
  (`velocity`: its mode) until out of sand (or helium) or `days`.
  """
  strides = int(round(days * 86_400.0 / params.stride_s))
  keys = jax.random.split(jax.random.PRNGKey(seed), flights)
  final, altitude, status = _band_flier(
      strides, params.stride_s, setpoint_m, half_band_m, velocity)(
          params, keys)
  status = np.asarray(status)
  ok = status == int(state_lib.FlightStatus.OK)
  aloft_strides = np.where(ok.all(axis=1), strides, np.argmin(ok, axis=1) + 1)
  aloft_days = aloft_strides * params.stride_s / 86_400.0
  sand = np.asarray(final.sand_dropped_kg)
  altitude = np.asarray(altitude)
  in_band = np.abs(altitude - setpoint_m) <= half_band_m
  return {
      'flights': flights, 'max_days': days,
      'days_aloft_mean': float(aloft_days.mean()),
      'days_aloft_min': float(aloft_days.min()),
      'days_aloft_max': float(aloft_days.max()),
      'ballast_kg_per_day_mean': float((sand / aloft_days).mean()),
      'helium_vented_mols_per_day_mean': float(
          (np.asarray(final.helium_vented_mols) / aloft_days).mean()),
      'time_in_band_pct': float(100.0 * in_band[ok].mean()),
      'altitude_range_m': [float(altitude[ok].min()),
                           float(altitude[ok].max())],
      'days_aloft': [round(float(d), 3) for d in aloft_days],
      'ended': [state_lib.FlightStatus(int(s[-1])).name for s in status],
  }
