# coding=utf-8
"""A plan's objective and the winds it is flown in (pure JAX).

A plan is piecewise constant: `num_segments` altitude targets a0 [m] and
float flags a2 in {-1, +1} over `horizon` strides, flown with a fixed time
factor a1 (`plan_actions`) on `flight.dynamics.step`, the core the env flies
(`fly`). The objective (`objective`), per stride t of the plan (discounted):
sigmoid((R - d_t) / w) + shaping * 2^(-d_t / halflife), plus progress *
(d_0 - d_end) / R (the approach over the plan), minus a resource cost (sand
dropped and helium vented, as lift [kg], divided by the fraction of the
launch sand margin left and scaled by the fraction of the episode left:
spending is cheap at the end and dear when little is left; under the sun,
the sand the episode's later sunsets need is not in that margin,
`sunset_sand_kg`, and their lift is not in the helium margin,
`night_margin_kg`), minus a terminal cost where the plan ends the flight.

The winds (`planning_wind`): the oracle's is the ground truth; the forecast
planners' is the forecast of the `blind` state (the flight's noise removed),
corrected by the winds the balloon measures.
"""

import functools
from typing import Any, Callable, Optional, Tuple

import jax
import jax.numpy as jnp
import numpy as np

from ble_latex.agents.planning import config as plan_config
from ble_latex.envs import env_types
from ble_latex.envs import observed_winds
from ble_latex.envs import winds
from ble_latex.flight import dynamics
from ble_latex.flight import envelope
from ble_latex.flight import estimator
from ble_latex.flight import physics
from ble_latex.flight import state as state_lib
from ble_latex.flight import thermal
from ble_latex.wind import noise_gp
from ble_latex.wind import simplex

Array = jax.Array
# Points of the day's grid of the sun's forcing (`sunset_sand_kg`): one per
# 20-minute stride, finer than the ~2.7 h the forcing takes to fall.
SUN_GRID = 72
_DAY_S = 86_400.0  # [s]


def blind(state: env_types.EnvState) -> env_types.EnvState:
  """The state without its noise (what a forecast planner may read).

  The simplex noise of the flight (and with it the future true wind) is
  replaced by zeros; the forecast, the balloon and its measured wind (an
  observation) stay.
  """
  zeros = lambda tree: jax.tree.map(jnp.zeros_like, tree)
  return state.replace(noise_u=zeros(state.noise_u),
                       noise_v=zeros(state.noise_v))


def measurement(wind: winds.Wind, state: env_types.EnvState
                ) -> Tuple[Array, Array, Array]:
  """Where the balloon is and its measured-minus-forecast wind there.

  Args:
    wind: The env's wind.
    state: The balloon's env state (its measured wind at the balloon; the
      forecast is read from the `blind` state).

  Returns:
    (point (x [km], y [km], pressure [Pa], time [h]), du, dv [m/s]).
  """
  return observed_winds.measurement(blind(state), wind)


def planning_wind(config: plan_config.PlannerConfig, wind: winds.Wind,
                  state: env_types.EnvState,
                  noise: Optional[Tuple[Any, Any]] = None,
                  memory: Optional[noise_gp.Measurements] = None
                  ) -> Callable[[Array, Array, Array, Array], Tuple[Array,
                  Array]]:
  """The wind a planner flies its plans in: (x, y, P, t) -> (u, v). # [m/s]

  ORACLE: the ground truth (`wind.ground_truth`). Otherwise the forecast
  (`wind.forecast_column` at one pressure) of the `blind` state (with
  `noise`: the ground truth of the state given that noise instead, one
  scenario), plus a correction from the measured wind: with `memory`
  (`wind_memory` > 0) the Gaussian-process posterior mean of the noise given
  the measurements (`noise_gp.posterior_mean`); else the measured-minus-
  planned wind at the balloon, decaying as
  exp(-|t - t0| / wind_correction_hours - |P - P0| / wind_correction_pa).

  Args:
    config: The planner (mode, wind_correction_hours, wind_correction_pa).
    wind: The env's wind.
    state: The balloon's env state (its measured wind at the balloon).
    noise: (noise_u, noise_v) simplex parameters of a scenario (drawn by
      the planner, `scenario_noise`), or None: the forecast alone.
    memory: The measurements (the current one included) for the Gaussian-
      process correction, or None.

  Returns:
    A pure JAX function (x [m], y [m], pressure [Pa], time [s]) -> (u, v)
    eastward and northward wind. # [m/s]
  """
  if config.mode == plan_config.ORACLE:
    return functools.partial(wind.ground_truth, state)
  state = blind(state)
  f = state.flight

  if noise is None:
    def forecast(x_m, y_m, pressure_pa, t_s):
      return wind.forecast_column(state, x_m, y_m, pressure_pa, t_s)
  else:
    forecast = functools.partial(
        wind.ground_truth, state.replace(noise_u=noise[0], noise_v=noise[1]))

  if memory is not None:
    weights = noise_gp.fit(memory)

    def expected(x_m, y_m, pressure_pa, t_s):
      u, v = forecast(x_m, y_m, pressure_pa, t_s)
      du, dv = noise_gp.posterior_mean(
          memory, weights, observed_winds.point(
              x_m, y_m, pressure_pa, t_s).astype(memory.du.dtype))
      return u + du.astype(u.dtype), v + dv.astype(v.dtype)

    return expected
  if config.wind_correction_hours <= 0.0:
    return forecast
  u0, v0 = forecast(f.x_m, f.y_m, f.pressure_pa, f.time_s)
  du, dv = state.wind_u - u0, state.wind_v - v0

  def corrected(x_m, y_m, pressure_pa, t_s):
    u, v = forecast(x_m, y_m, pressure_pa, t_s)
    weight = jnp.exp(
        -jnp.abs(t_s - f.time_s) / (3600.0 * config.wind_correction_hours)
        - jnp.abs(pressure_pa - f.pressure_pa) / config.wind_correction_pa)
    return u + weight * du, v + weight * dv

  return corrected


def scenario_noise(config: plan_config.PlannerConfig,
                   key: Array) -> Tuple[Any, Any]:
  """`config.scenarios` simplex noise fields of BLE's model (stacked).

  Args:
    config: The planner (scenarios > 0).
    key: The planner's key for them (never the flight's noise key).

  Returns:
    (noise_u, noise_v) with a leading axis of `config.scenarios`.
  """
  return jax.vmap(simplex.reset_uv_noise_params)(
      jax.random.split(key, config.scenarios))


def plan_actions(config: plan_config.PlannerConfig, targets_m: Array,
                 floats: Array) -> Array:
  """[horizon, 3] actions (a0, a1, a2) of a piecewise-constant plan.

  Args:
    config: The planner (horizon, num_segments, time_factor).
    targets_m: [num_segments] altitude targets a0. # [m]
    floats: [num_segments] float flags a2.

  Returns:
    [horizon, 3] actions: each segment's a0 and a2 repeated over its
    strides, a1 = `config.time_factor`.
  """
  segment = (np.arange(config.horizon) * config.num_segments) // config.horizon
  a0 = targets_m[segment]
  a2 = floats[segment]
  a1 = jnp.full_like(a0, config.time_factor)
  return jnp.stack([a0, a1, a2], axis=-1)


def objective(config: plan_config.PlannerConfig, params: env_types.EnvParams,
              state: env_types.EnvState, wind_fn: Callable[..., Any],
              targets_m: Array, floats: Array,
              terminal: Optional[Callable[[Any], Array]] = None) -> Array:
  """The planning objective of one plan from `state` (see module docstring).

  Differentiable in `targets_m` (the core's `lax.scan`, smooth within a
  controller branch). `state.steps` and `params.episode_steps` mask strides
  past the end of the episode and scale the resource cost.

  Args:
    config: The planner (horizon, reward shaping and costs).
    params: The env parameters (flight system, stride, episode_steps).
    state: The balloon's env state the plan starts from.
    wind_fn: (x [m], y [m], pressure [Pa], time [s]) -> (u, v) [m/s], the
      wind the plan is flown in (`planning_wind`).
    targets_m: [num_segments] altitude targets a0. # [m]
    floats: [num_segments] float flags a2.
    terminal: None, or V of a plan's final flight (`plan_value`): its
      `beyond` term is added.

  Returns:
    The objective (a scalar, higher is better): discounted in-radius value
    plus shaping and progress, minus resource and terminal costs (plus
    the learned value beyond the horizon).
  """
  actions = plan_actions(config, targets_m, floats)
  f_end, (distance_km, status) = fly(params, state, wind_fn, state.flight,
                                     actions, exact=exact(config))
  t = jnp.arange(config.horizon)
  value = jnp.sum(stride_values(config, params, state, distance_km, status,
                                t))
  left = params.episode_steps - state.steps  # Strides left in the episode.
  # The plan's last stride inside the episode.
  last = jnp.clip(jnp.minimum(left, config.horizon) - 1, 0, config.horizon - 1)
  # The flight ended inside the plan (before the episode's end).
  ended = status[last] != state_lib.FlightStatus.OK
  return total(value, end_terms(config, params, state, f_end,
                                distance_km[last], ended)) + beyond(
                                    config, params, state, terminal, f_end,
                                    config.horizon, ended)


def beyond(config: plan_config.PlannerConfig, params: env_types.EnvParams,
           state: env_types.EnvState,
           terminal: Optional[Callable[[Any], Array]], f_end: Any, n: Any,
           ended: Array) -> Array:
  """value_weight x discount^n x V(f_end): the value after a plan's end.

  Args:
    config: The planner (value_weight, discount).
    params: The env parameters (episode_steps).
    state: The state the plan starts from (its `steps`).
    terminal: V of a final flight (`plan_value.terminal_fn`), or None (0).
    f_end: The flight where the plan (so far) ends.
    n: The strides it flew.
    ended: Whether the flight ended in it.

  Returns:
    The term; 0 where the plan reaches the episode's end or the flight
    ended.
  """
  if terminal is None:
    return jnp.zeros((), f_end.altitude_m.dtype)
  after = (n < params.episode_steps - state.steps) & ~ended
  return jnp.where(after, config.value_weight * config.discount ** n *
                   terminal(f_end), 0.0).astype(f_end.altitude_m.dtype)


def total(value: Array, terms: Tuple[Array, Array, Array]) -> Array:
  """The objective: value + progress - resource cost - terminal cost."""
  progress, cost, terminal = terms
  return value + progress - cost - terminal


def model_flight(params: env_types.EnvParams, state: env_types.EnvState,
                 exact: bool = False) -> Any:
  """The flight system a planner flies its plans with (`fly`).

  The flight's own, as the env flies it (`env_types.flight_params_of`: the
  sun's clock set to the flight's start, its station's place); with the
  disturbances held (`FlightParams.noiseless`: the disturbance so far, in
  the state, kept as it is, no new draws) unless `exact` (the oracle, which
  draws the env's own: `fly`). Under the paper's physics `params.flight`
  itself. The one place the planners' model of the flight system is
  chosen (the state they start from is `estimator.planning_view`'s).

  Args:
    params: The env parameters (their `flight` system).
    state: The env state the plan starts from (its start time, station).
    exact: Keep the stochastic disturbances (the oracle).

  Returns:
    The `FlightParams` of the plan's flights.
  """
  flight = env_types.flight_params_of(params, state)
  return flight if exact else flight.noiseless()


def exact(config: plan_config.PlannerConfig) -> bool:
  """Whether `config`'s plans fly the env's own disturbances (`fly`): the
  oracle's (it knows the whole truth: the wind, the burst volume and the
  disturbance path)."""
  return config.mode == plan_config.ORACLE


def fly(params: env_types.EnvParams, state: env_types.EnvState,
        wind_fn: Callable[..., Any], f: Any, actions: Array,
        exact: bool = False) -> Tuple[Any, Tuple[Array, Array]]:
  """Flies `actions` ([T, 3], one per stride) from flight `f` on the core.

  The flight system is `model_flight`'s (the flight's own sun clock and
  station). Forecast plans fly the expected dynamics: realistic physics'
  disturbances (lift walk, heating) are held at the balloon's estimates,
  with no new steps, and the burst volume is a low quantile of its law
  (`estimator.planning_view`: no hidden truth). `exact`
  (the oracle) flies them as the env does: each stride with the env's key
  of that stride (`env_types.walk_key` of `state` at stride `state.steps`
  + n, n the strides from `state.flight` to `f` and on, counted on the
  flight's clock), so that, on the true wind, the plan's flight is the
  env's.

  Args:
    params: The env parameters (flight system, stride).
    state: The env state the plan starts from.
    wind_fn: The wind the plan is flown in (`planning_wind`).
    f: The flight the actions start from (`state.flight`, or where a
      partial plan ends).
    actions: [T, 3] actions (a0, a1, a2), one per stride.
    exact: Draw the env's disturbances (the oracle).

  Returns:
    The flight after the last stride, and per stride its distance to the
    station [km] and its `FlightStatus`.
  """
  flight = model_flight(params, state, exact)
  if not exact:  # No hidden truth: the estimates (`estimator.planning_view`).
    _, f = estimator.planning_view(env_types.flight_params_of(params, state),
                                   f)
  keyed = exact and flight.stochastic

  def stride(f, action):
    key = None
    if keyed:  # The env's key of this stride (`jax_env.step_env`).
      n = jnp.round((f.time_s - state.flight.time_s) / params.stride_s)
      key = env_types.walk_key(state.replace(
          steps=state.steps + n.astype(state.steps.dtype)))
    f = dynamics.step(flight, state.atmosphere, f, action, wind_fn,
                      params.stride_s, key=key)
    return f, (jnp.hypot(f.x_m, f.y_m) / 1000.0, f.status)

  return jax.lax.scan(stride, f, actions)


def stride_values(config: plan_config.PlannerConfig,
                  params: env_types.EnvParams,
                  state: env_types.EnvState, distance_km: Array,
                  status: Array, t: Array) -> Array:
  """The objective's per-stride terms: discount^t (in-radius + shaping).

  Args:
    config: The planner (radius, shaping, discount).
    params: The env parameters (episode_steps).
    state: The state the plan starts from (its `steps`).
    distance_km: Distances to the station after strides t. # [km]
    status: `FlightStatus` after strides t.
    t: Stride indices in the plan (0 is the first).

  Returns:
    The terms (0 where the flight has ended or the episode is over).
  """
  alive = ((status == state_lib.FlightStatus.OK) &
           (t < params.episode_steps - state.steps))
  within = jax.nn.sigmoid((config.radius_km - distance_km) /
                          config.radius_width_km)
  shaping = config.shaping * jnp.exp2(-distance_km / config.halflife_km)
  return jnp.where(alive, config.discount ** t * (within + shaping),
                   0.0).astype(distance_km.dtype)


def end_terms(config: plan_config.PlannerConfig, params: env_types.EnvParams,
              state: env_types.EnvState, f_end: Any, d_end_km: Array,
              ended: Array) -> Tuple[Array, Array, Array]:
  """Progress, resource cost and terminal cost of a (partial) plan.

  Args:
    config: The planner (progress, costs).
    params: The env parameters (launch sand, episode length).
    state: The state the plan starts from.
    f_end: The flight where the plan (so far) ends.
    d_end_km: Its distance at the last stride inside the episode. # [km]
    ended: Whether the flight ended (before the episode's end).

  Returns:
    (progress * (d_0 - d_end) / R, cost, terminal_cost * ended).
  """
  f0 = state.flight
  dtype = d_end_km.dtype
  d0 = jnp.hypot(f0.x_m, f0.y_m) / 1000.0
  progress = config.progress * (d0 - d_end_km) / config.radius_km
  # Resource margins as a fraction of the launch sand (both start near it).
  initial = jnp.maximum(params.flight.initial_sand_kg, 1e-3)
  sand_margin, helium_margin = resource_margins(params, f0)
  left = params.episode_steps - state.steps
  time_left = jnp.clip(left / params.episode_steps, 0.0, 1.0)
  dropped = f_end.sand_dropped_kg - f0.sand_dropped_kg
  vented = (f_end.helium_vented_mols - f0.helium_vented_mols) * (
      physics.LIFT_PER_MOL)
  shortfall_cost = None
  flight = model_flight(params, state)
  if flight.gas_superheat:  # Static: the sun is flown, its sunsets cost sand.
    # The sand the sunsets after the plan's end (to the episode's end) will
    # need is not the plan's to spend; a plan that leaves less than that
    # pays the terminal cost pro rata of a day's sunset (it cannot float
    # through them). The same lift is kept out of the helium margin
    # (`helium_reserve` x it): a balloon that holds its altitude vents at
    # each sunrise what it dropped at the sunset before, and each night its
    # cooled gas lifts that much less (`night_margin_kg`). Both keep
    # `resource_buffer_kg` more for what the model does not foresee.
    end_s = f0.time_s + left * params.stride_s
    need, per_day = sunset_sand_kg(flight, f_end, end_s)
    need = need + config.resource_buffer_kg
    sand_margin = sand_margin - need
    short = jnp.maximum(need - resource_margins(params, f_end)[0], 0.0)
    if config.helium_reserve > 0.0:  # Static.
      keep = config.helium_reserve * need
      helium_margin = night_margin_kg(flight, f0) - keep
      short = short + jnp.maximum(keep - night_margin_kg(flight, f_end), 0.0)
    shortfall_cost = config.terminal_cost * jnp.minimum(
        short / jnp.maximum(per_day, 1e-3), 1.0)
  cost = time_left * (
      config.sand_cost * dropped / jnp.maximum(sand_margin / initial, 0.05) +
      config.helium_cost * vented / jnp.maximum(helium_margin / initial, 0.05))
  if shortfall_cost is not None:
    cost = cost + shortfall_cost
  return progress, cost, config.terminal_cost * ended.astype(dtype)


def sunset_sand_kg(flight: Any, f: Any, end_s: Array) -> Tuple[Array, Array]:
  """The sand the sunsets from flight `f`'s time to `end_s` take. # [kg]

  The helium's temperature follows the sun's forcing on it
  (`thermal.forcing_at`, at the balloon's place `thermal.position_lat_lon`):
  +superheat_day_k by day, -cooling_night_k by night. A gas at rest at air
  temperature T and pressure P lifts M_air beta - M_He per mol, beta =
  T_gas / T (`physics.buoyant_lift_per_mol`; Archimedes with the ideal
  gas), so a fall dT of the forcing loses n M_air dT / T of lift, which a
  balloon holding its altitude pays in sand. The falls are summed over the
  span (whole days: a day's total fall, the forcing being daily periodic;
  the rest of a day on a `SUN_GRID`-point grid, linear within a cell);
  rises (sunrises: lift gained, vented or climbed) are not counted. Zero
  without the sun (`gas_superheat` off: the paper's physics).

  Args:
    flight: The flight system (`model_flight`: the sun's clock, station,
      superheat_day_k, cooling_night_k and their elevation window).
    f: A `FlightState` (its time, place, helium, air T and P).
    end_s: The end of the span on the flight's clock (the episode's
      end). # [s]

  Returns:
    (sand the span's sunsets take, that of one whole day). # [kg]
  """
  dtype = f.altitude_m.dtype
  if not flight.gas_superheat:
    zero = jnp.zeros((), dtype)
    return zero, zero
  lat, lon = thermal.position_lat_lon(flight.latitude_deg,
                                      flight.longitude_deg, f.x_m, f.y_m)
  cell = _DAY_S / SUN_GRID  # [s]
  k = jnp.arange(SUN_GRID, dtype=dtype)
  forcing = thermal.forcing_at(flight, f.time_s + cell * jnp.concatenate(
      [k, k[-1:] + 1.0]), lat, lon)  # [K]
  falls = jnp.maximum(forcing[:-1] - forcing[1:], 0.0)  # [K] per cell
  span = jnp.maximum(end_s - f.time_s, 0.0)
  days = jnp.floor(span / _DAY_S)
  rest = jnp.clip((span - days * _DAY_S) / cell - k, 0.0, 1.0)
  day_fall = jnp.sum(falls)  # [K]
  fall = days * day_fall + jnp.sum(rest * falls)  # [K]
  t, p = f.temperature_k, f.pressure_pa

  def lift(d_k):  # n (M_air beta - M_He) gained by a gas warmer by d_k.
    return f.helium_mols * (physics.buoyant_lift_per_mol(t, p, t + d_k, p) -
                            physics.buoyant_lift_per_mol(t, p, t, p))

  return lift(fall).astype(dtype), lift(day_fall).astype(dtype)


def night_margin_kg(flight: Any, f: Any) -> Array:
  """The lift flight `f` can still vent at its gas's temperature. # [kg]

  L + m_s with L the free lift of the gas as it is (`envelope.free_lift_kg`:
  n (M_air beta - M_He) - m_p - m_s plus the disturbance the state holds,
  the estimator's under `planning_view`), the condition `dynamics.
  resource_status` ends a flight on (out of helium below 0). Unlike
  `resource_margins`' (the paper's ledger, at beta = 1) it counts the sun's
  heating by day and the night's cooling.

  Args:
    flight: The flight system (`model_flight`).
    f: A `FlightState`.

  Returns:
    The margin, at least 0. # [kg]
  """
  g = envelope.of_state(flight, f, f.temperature_k, f.pressure_pa, f.time_s)
  return jnp.maximum(envelope.free_lift_kg(flight, f, g) + f.sand_kg, 0.0)


def resource_margins(params: env_types.EnvParams,
                     f: Any) -> Tuple[Array, Array]:
  """The sand that can still be dropped and the lift that can be vented.

  Args:
    params: The env parameters (`flight.min_drop_kg`).
    f: A `FlightState`.

  Returns:
    (sand_kg - min_drop_kg, free_lift_kg + sand_kg), each at least 0. # [kg]
  """
  return (jnp.maximum(f.sand_kg - params.flight.min_drop_kg, 0.0),
          jnp.maximum(f.free_lift_kg + f.sand_kg, 0.0))
