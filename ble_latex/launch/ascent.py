# coding=utf-8
"""A launch from the ground: the realistic ascent, its drift, burst, landing.

What ASTRA's and CUSF's predictors compute, on this project's flight core:
the balloon leaves the ground with the free lift of a chosen ascent rate and
climbs through the winds (its horizontal velocity is the wind's, as in every
stride of `flight.dynamics`), either to its float altitude, where the float
phase begins (`launch.scoring` flies it from there), or, where it bursts
first, to its burst and then down under its parachute to the landing point.

- The ascent is `flight.dynamics.step` itself, stride after stride of
  `Ascent.step_s`, with no controller action (`_idle`: nothing vented or
  dropped) in the flight system of the realistic mode that matches ASTRA
  (`ascent_flight_params`: ASTRA's c_d(Re) and TA-1200 burst draw, the gas at
  the air's temperature and pressure as in ASTRA, `flight.reference.
  reference_params`; no lift disturbance, no band guard).
- The launch fill: the helium whose steady ascent rate on the ground is
  `Ascent.ascent_rate_mps` (`launch_helium_mols`, by bisection on
  `flight.reference.steady_ascent_rate`; the operator's "ascent rate" of
  CUSF's burst calculator).
- The descent (`descent_rate`): CUSF's predictor's parachute, a rate given at
  sea level that grows as the air thins, v(h) = v_0 sqrt(rho_0 / rho(h))
  (drag = weight at every height, c_d A fixed: 1/2 rho v^2 c_d A = m g), with
  the drift of the wind at each step.

`fly` is pure JAX (jittable, vmappable over launches); positions are offsets
from the station [m] and times the flight clock [s], as the env's.
"""

import dataclasses
import math
from typing import Callable, NamedTuple, Tuple

import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import gin_values
from ble_latex.flight import atmosphere as atmosphere_lib
from ble_latex.flight import controller as controller_lib
from ble_latex.flight import dynamics
from ble_latex.flight import params as params_lib
from ble_latex.flight import physics
from ble_latex.flight import reference
from ble_latex.flight import state as state_lib

Array = jax.Array
# (x [m], y [m], pressure [Pa], t [s]) -> (u, v) [m/s], as `dynamics.WindFn`.
WindFn = Callable[[Array, Array, Array, Array], Tuple[Array, Array]]
# ASTRA's drag and burst law: the `params.REALISTIC` fields that the
# issue-28 reference table compares with ASTRA.
_ASTRA_FIELDS = ('drag_coefficient_subcritical',
                 'drag_coefficient_supercritical', 'reynolds_transition',
                 'reynolds_band', 'burst_weibull_scale_m',
                 'burst_weibull_shape')
# The vertical step of the ascent's integrator: the burst is found within
# ~50 m (5 m/s x 10 s). # [s]
_VERTICAL_STEP_S = 10.0
_BISECTIONS = 60


@dataclasses.dataclass(frozen=True)
class Ascent:
  """How the balloons go up and come down (static: hashable).

  Attributes:
    ascent_rate_mps: Steady ascent rate on the ground the balloon is filled
      for (CUSF's and ASTRA's usual 5 m/s). # [m/s]
    descent_rate_mps: The parachute's descent rate at sea level (CUSF's
      predictor's input). # [m/s]
    step_s: Stride of the ascent and of the descent. # [s]
    max_hours: The longest ascent, and the longest descent, flown. # [h]
    launch_altitude_m: The release height: 1 m above sea level (the wind
      files hold no terrain; the flight core ends a flight at h <= 0). # [m]
  """
  ascent_rate_mps: float = 5.0
  descent_rate_mps: float = 5.0
  step_s: float = 30.0
  max_hours: float = 4.0
  launch_altitude_m: float = 1.0

  def __post_init__(self):
    for name in ('ascent_rate_mps', 'descent_rate_mps', 'step_s',
                 'max_hours'):
      value = getattr(self, name)
      if not gin_values.is_positive(value):  # > 0 in the float32 core too.
        raise ValueError(f'ascent {name} must be a finite number > 0 in '
                         f'float32 (>= 1.2e-38), got {value}')
    if not 0.0 < self.launch_altitude_m < 5000.0:
      raise ValueError('ascent launch_altitude_m must be in (0, 5000) m, '
                       f'got {self.launch_altitude_m}')

  @property
  def steps(self) -> int:
    """Strides of the ascent scan (and of the descent scan)."""
    return int(math.ceil(self.max_hours * 3600.0 / self.step_s))


class Leg(NamedTuple):
  """One launch's way up (and down). Positions [m] east/north of the
  station, times on the flight clock [s]; fields that do not apply are NaN.

  Attributes:
    floats: It reached the float altitude (bool).
    float_x_m, float_y_m, float_time_s: Where and when.
    bursts: It burst on the way up (bool).
    burst_x_m, burst_y_m, burst_time_s, burst_altitude_m: Where and when.
    land_x_m, land_y_m, land_time_s: The landing (sea level) after a burst.
  """
  floats: Array
  float_x_m: Array
  float_y_m: Array
  float_time_s: Array
  bursts: Array
  burst_x_m: Array
  burst_y_m: Array
  burst_time_s: Array
  burst_altitude_m: Array
  land_x_m: Array
  land_y_m: Array
  land_time_s: Array


def ascent_flight_params(flight: params_lib.FlightParams
                         ) -> params_lib.FlightParams:
  """The flight system as the realistic ascent flies it (matches ASTRA).

  `flight`'s balloon (payload, sand, burst volume) with ASTRA's c_d(Re)
  (`drag_model='smooth'`) and TA-1200 burst draw from `params.REALISTIC`,
  the gas at the air's temperature and pressure (`reference.
  reference_params`, as ASTRA), no gas state, no heating noise, no band
  guard (nothing is commanded on the way up), and vertical steps of 10 s.
  """
  realistic = {name: params_lib.REALISTIC[name] for name in _ASTRA_FIELDS}
  return reference.reference_params(flight.replace(
      drag_model=params_lib.REALISTIC['drag_model'], burst_spread=True,
      gas_state=False, heating_noise=False, guard_within_stride=False,
      vertical_step_s=_VERTICAL_STEP_S, **realistic))


def launch_helium_mols(flight: params_lib.FlightParams,
                       atm: atmosphere_lib.AtmosphereParams,
                       ascent_rate_mps: float,
                       altitude_m: float = 0.0) -> float:
  """The helium whose steady ascent rate at `altitude_m` is the one asked.

  Bisection (the rate grows with the helium) on `reference.
  steady_ascent_rate` of `flight`'s payload and sand (Eq. fullN2L at steady
  state: L g = k(h, v) v^2), in float64. # [mol]

  Raises:
    ValueError: the rate needs more than 50 times the balloon's weight in
      free lift.
  """
  with jax.enable_x64(True):
    payload = jnp.float64(flight.payload_kg)
    sand = jnp.float64(flight.initial_sand_kg)
    low = (payload + sand) / physics.LIFT_PER_MOL  # Neutral. # [mol]

    def rate(helium):
      return reference.steady_ascent_rate(flight, atm, helium, payload, sand,
                                          jnp.float64(altitude_m))

    high = low * 51.0
    if float(rate(high)) < ascent_rate_mps:
      raise ValueError(f'an ascent rate of {ascent_rate_mps:g} m/s needs '
                       'over 50x the balloon\'s weight in free lift')

    def body(_, bounds):
      lo, hi = bounds
      mid = 0.5 * (lo + hi)
      fast = rate(mid) >= ascent_rate_mps
      return jnp.where(fast, lo, mid), jnp.where(fast, mid, hi)

    lo, hi = jax.jit(lambda b: jax.lax.fori_loop(0, _BISECTIONS, body, b))(
        (low, high))
    return float(0.5 * (lo + hi))


def _idle(params, state, action, temperature, pressure
          ) -> controller_lib.Actuation:
  """No command on the way up: nothing vented or dropped (`decide_fn`)."""
  del params, action, temperature, pressure
  zero = jnp.zeros_like(state.helium_mols)
  return controller_lib.Actuation(
      decision=jnp.zeros((), jnp.int32), desired_ascent_rate=zero,
      vent_mols=zero, drop_kg=zero, guarded=jnp.zeros((), bool),
      lift_after_kg=state.settled_lift_kg)  # The lift kept (`actuate`).


def descent_rate(descent_rate_mps: Array, density: Array,
                 sea_level_density: Array) -> Array:
  """The parachute's descent rate at an air density. # [m/s]

  v = v_0 sqrt(rho_0 / rho): drag 1/2 rho v^2 c_d A equal to the weight at
  every height (CUSF predictor, `pred_src/run_model.c`: the sea-level rate
  scaled by the density).

  Args:
    descent_rate_mps: v_0, at sea level. # [m/s]
    density: rho. # [kg/m^3]
    sea_level_density: rho_0. # [kg/m^3]
  """
  return descent_rate_mps * jnp.sqrt(sea_level_density / density)


def fly(params: params_lib.FlightParams, atm: atmosphere_lib.AtmosphereParams,
        wind_fn: WindFn, *, x_m: Array, y_m: Array, time_s: Array,
        float_altitude_m: Array, helium_mols: Array, burst_key: Array,
        ascent: Ascent) -> Leg:
  """One launch from the ground: its float point, or its burst and landing.

  Args:
    params: The ascent's flight system (`ascent_flight_params`).
    atm: The atmosphere.
    wind_fn: The winds (the world's truth, with its noise).
    x_m: The launch site, east of the station. # [m]
    y_m: North of the station. # [m]
    time_s: The launch on the flight clock. # [s]
    float_altitude_m: Where the balloon is stopped (vented to float); inf:
      never (a flight to burst). # [m]
    helium_mols: The launch fill (`launch_helium_mols`). # [mol]
    burst_key: This flight's burst draw.
    ascent: The settings.

  Returns:
    The `Leg`; where neither float nor burst is reached within
    `ascent.max_hours`, both flags are False.
  """
  dtype = jnp.result_type(float)
  flight = state_lib.initial_state(
      params, jnp.asarray(ascent.launch_altitude_m, dtype), x_m, y_m,
      atm_params=atm, helium_mols=jnp.asarray(helium_mols, dtype),
      time_s=time_s, key=burst_key)
  action = jnp.asarray(controller_lib.ACTION_LOW)
  target = jnp.asarray(float_altitude_m, dtype)
  nan = jnp.full((), jnp.nan, dtype)

  def up(carry, _):
    before, found = carry
    after = dynamics.step(params, atm, before, action, wind_fn,
                          ascent.step_s, decide_fn=_idle)
    crossed = ((~found) & (before.status == state_lib.FlightStatus.OK) &
               (after.altitude_m >= target))
    frac = jnp.clip((target - before.altitude_m) /
                    jnp.maximum(after.altitude_m - before.altitude_m, 1e-9),
                    0.0, 1.0)
    point = tuple(b + frac * (a - b) for b, a in (
        (before.x_m, after.x_m), (before.y_m, after.y_m),
        (before.time_s, after.time_s)))
    found = found | crossed
    after = jax.tree.map(lambda b, a: jnp.where(found, b, a), before, after)
    return (after, found), (crossed, point)

  (top, floats), (crossed, points) = jax.lax.scan(
      up, (flight, jnp.zeros((), bool)), None, length=ascent.steps)
  pick = jnp.argmax(crossed)
  float_point = [jnp.where(floats, p[pick], nan) for p in points]
  bursts = (~floats) & (top.status == state_lib.FlightStatus.BURST)

  sea = atmosphere_lib.at_height(atm, jnp.zeros((), dtype))

  def down(carry, _):
    x, y, h, t, landed, land = carry
    ambient = atmosphere_lib.at_height(atm, h)
    u, v = wind_fn(x, y, ambient.pressure, t)
    rate = descent_rate(ascent.descent_rate_mps, ambient.density,
                        sea.density)
    dt = ascent.step_s
    h_next = h - rate * dt
    frac = jnp.clip(h / jnp.maximum(h - h_next, 1e-9), 0.0, 1.0)
    touch = (~landed) & (h_next <= 0.0)
    land = tuple(jnp.where(touch, value, old) for value, old in zip(
        (x + u * dt * frac, y + v * dt * frac, t + dt * frac), land))
    landed = landed | touch
    keep = landed
    return ((jnp.where(keep, x, x + u * dt), jnp.where(keep, y, y + v * dt),
             jnp.where(keep, h, h_next), jnp.where(keep, t, t + dt), landed,
             land), None)

  start = (top.x_m, top.y_m, top.altitude_m, top.time_s,
           jnp.zeros((), bool), (nan, nan, nan))
  (_, _, _, _, landed, land), _ = jax.lax.scan(down, start, None,
                                               length=ascent.steps)
  landed = landed & bursts
  burst = [jnp.where(bursts, value, nan) for value in (
      top.x_m, top.y_m, top.time_s, top.altitude_m)]
  return Leg(floats, *float_point, bursts, *burst,
             *[jnp.where(landed, value, nan) for value in land])


def leg_to_host(leg: Leg) -> dict:
  """A `Leg` of N launches as NumPy arrays by field name."""
  return {name: np.asarray(value) for name, value in leg._asdict().items()}
