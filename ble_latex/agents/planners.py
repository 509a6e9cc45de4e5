# coding=utf-8
"""Planning baselines over the batched JAX flight core (issue 29).

Three model-predictive controllers plan over `flight.dynamics.step`, the
same core the env flies, and act through the same altitude controller:

- `latex_mpc`: a beam search over plans (`search='cem'`: the cross-entropy
  method; one iteration is random shooting) on the **forecast** only. Its
  winds are the flight's forecast field
  (`Wind.forecast_column` at the balloon's pressure), corrected by the winds
  it measures: with `wind_memory` > 0 (16 for `latex_mpc`) the Gaussian-
  process posterior mean of BLE's noise given its last `wind_memory`
  measurements (`wind.noise_gp`); with 0 the current measurement, decaying
  with time and pressure away from the balloon. The noise of the flight is
  removed from the state before the planner sees it (`blind`), so the plan
  cannot depend on the noise or the future truth.
- `latex_mpc_oracle`: the same planner on the **true** wind (forecast +
  noise): a clairvoyant upper bound for any controller, not a controller.
  Its beam search plans the whole episode at once (`horizon` 216 strides,
  one plan per 216 strides): on the true wind and the paper's physics the
  env flies a plan exactly (the planner flies the same core in the same
  wind), so nothing is gained by replanning, and a plan that reaches the
  episode's end sees every later consequence of spending sand or helium.
  Under realistic physics the free-lift random walk is not foreseen (set
  `replan_every` lower there).
- `latex_mpc_grad`: first-order MPC on the forecast: the best sampled plans
  (one CEM iteration) are refined by normalised gradient ascent
  (`jax.grad` through the core's `lax.scan`) on their altitude targets. The
  one decision that needs relaxing for gradients, "inside the radius", is a
  sigmoid; the controller's branches (ballast / vent / nothing) keep their
  `jnp.where` selects, so gradients flow through the active branch, and the
  plan's float flags stay those of the sampled start (discrete).

A plan is piecewise constant: `num_segments` altitude targets a0 [m] and
float flags a2 in {-1, +1} over `horizon` strides, flown with a fixed time
factor a1. The objective, per stride t of the plan (discounted):
sigmoid((R - d_t) / w) + shaping * 2^(-d_t / halflife), plus progress *
(d_0 - d_end) / R (the approach over the plan), minus a resource
cost (sand dropped and helium vented, as lift [kg], divided by the fraction
of the launch sand margin left and scaled by the fraction of the episode
left: spending is cheap at the end and dear when little is left), minus a
terminal cost where the plan ends the flight.

Plans are searched by CEM (`search='cem'`: whole plans sampled around a
distribution refit to the best) or by a beam search (`search='beam'`,
`beam_search`: the plan built segment by segment from a fixed set of
choices, keeping the `beam_width` best partial plans). Either way the fixed
altitude grid, the warm start and "float here" are scored too, and the best
plan by `objective` is flown.

The pure functions (`plan`, `plan_batch`, `objective`) take the env's
`EnvState` of one balloon (vmap them over balloons: `plan_batch`); the agent
classes are thin BLE `Agent`s that read the core state of the env they fly
(`attach_env`, called by `run.runner.create_agent`).
"""

import dataclasses
import functools
import inspect
import time
from typing import (Any, Callable, Dict, List, NamedTuple, Optional,
                    Sequence, Tuple)

from balloon_learning_environment.agents import agent
import gin
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import errors
from ble_latex import gin_values
from ble_latex.envs import jax_env
from ble_latex.flight import dynamics
from ble_latex.flight import physics
from ble_latex.flight import state as state_lib
from ble_latex.wind import noise_gp
from ble_latex.wind import simplex

Array = jax.Array
FORECAST, ORACLE, GRADIENT = 'forecast', 'oracle', 'gradient'
MODES = (FORECAST, ORACLE, GRADIENT)
CEM, BEAM = 'cem', 'beam'
SEARCHES = (CEM, BEAM)


@dataclasses.dataclass(frozen=True)
class PlannerConfig:
  """Everything that shapes a planner (hashable: a static jit argument).

  Attributes:
    mode: FORECAST, ORACLE or GRADIENT (see the module docstring).
    num_samples: Plans sampled per CEM iteration.
    iterations: CEM iterations (1: random shooting around the warm start).
    elite_fraction: Fraction of the samples that refit the CEM distribution.
    horizon: Strides planned ahead (24 = 8 h).
    num_segments: Piecewise-constant pieces of a plan (horizon split evenly).
    replan_every: Strides flown from a plan before planning again.
    time_factor: a1 of every planned action. # [.]
    plan_float: Whether plans choose float flags (else never float).
    float_probability: Initial probability of a float segment.
    altitude_low_m: Lowest altitude target. # [m]
    altitude_high_m: Highest altitude target. # [m]
    init_std_m: Initial CEM standard deviation of a target. # [m]
    min_std_m: Floor of the CEM standard deviation. # [m]
    radius_km: Radius of the in-radius term. # [km]
    radius_width_km: Width of its sigmoid. # [km]
    shaping: Weight of the 2^(-d / halflife) term. # [.]
    halflife_km: Its half-life distance. # [km]
    progress: Weight of the approach over the plan, (d_0 - d_end) / radius
      (a constant pull towards the station, also from far away). # [.]
    discount: Per-stride discount of the objective. # [.]
    sand_cost: Cost per kg of sand dropped (at a full margin). # [1/kg]
    helium_cost: Cost per kg of lift vented (at a full margin). # [1/kg]
    terminal_cost: Cost of a plan that ends the flight. # [.]
    wind_correction_hours: e-folding time of the measured-wind correction
      of the forecast (0: none; FORECAST and GRADIENT only). # [h]
    wind_correction_pa: e-folding pressure distance of that correction. # [Pa]
    grad_starts: GRADIENT: best samples refined by gradient ascent.
    grad_steps: GRADIENT: gradient steps per start.
    grad_step_m: GRADIENT: length of a normalised step of the targets. # [m]
    grid_levels: Altitudes of a fixed grid over [altitude_low_m,
      altitude_high_m] whose plans are scored at every iteration besides
      the `num_samples` samples: for each, "go there and stay" (every
      segment targets it, no float) and "go there and float" (first segment
      targets it, then floats); 0: no grid. The grid keeps every layer of
      the band in the search when the CEM distribution has narrowed around
      one.
    scenarios: FORECAST and GRADIENT: 0 plans on the forecast alone; K > 0
      scores each plan by its mean objective over K wind scenarios, the
      forecast plus K simplex noise fields drawn afresh from BLE's noise
      model (`simplex.reset_uv_noise_params` of the planner's own keys, the
      same K for every plan of a decision: never the flight's noise), each
      corrected near the balloon to the wind it measures (as the forecast
      is). ORACLE ignores it (it flies the one true wind).
    search: CEM (the cross-entropy method over whole plans) or BEAM (a
      beam search over the plan's segments, `beam_search`).
    beam_width: BEAM: partial plans kept after each segment.
    beam_cell_km: BEAM: 0 keeps the `beam_width` best partial plans; > 0
      keeps at most one per cell first (the best of those whose flights end
      in the same beam_cell_km x beam_cell_km square and `beam_cell_m`
      altitude bin, `best_per_cell`), so that the beam is not spent on
      near-copies of one flight: dynamic programming's rule that of two
      paths to one state only the better one matters, on a coarse state. # [km]
    beam_cell_m: BEAM: the altitude bin of those cells. # [m]
    beam_resource_value: BEAM: 0 ranks partial plans by their objective;
      v > 0 adds v x (sand margin + helium margin, `resource_margins`) x
      the fraction of the episode left where they end: what the resources
      kept are worth to the strides after them, which a plan reaching to
      the episode's end (the oracle's) cannot otherwise see, so that the
      beam keeps frugal plans beside greedy ones. The plan flown is still
      the best final plan by `objective`. # [1/kg]
    wind_memory: FORECAST and GRADIENT: 0 corrects the forecast by the
      current measurement with the exp-decay above; K > 0 by the Gaussian-
      process posterior mean of BLE's noise given the last K measurements,
      one per decision (`wind.noise_gp`: the covariance of BLE's simplex
      noise harmonics; the wind_correction_* fields are then unused).
  """
  mode: str = FORECAST
  num_samples: int = 256
  iterations: int = 2
  elite_fraction: float = 0.125
  horizon: int = 24
  num_segments: int = 4
  replan_every: int = 2
  time_factor: float = 2.0
  plan_float: bool = True
  float_probability: float = 0.5
  altitude_low_m: float = 14_000.0
  altitude_high_m: float = 21_000.0
  init_std_m: float = 2_000.0
  min_std_m: float = 150.0
  radius_km: float = 50.0
  radius_width_km: float = 3.0
  shaping: float = 0.3
  halflife_km: float = 100.0
  progress: float = 2.0
  discount: float = 0.98
  sand_cost: float = 0.1
  helium_cost: float = 0.1
  terminal_cost: float = 20.0
  wind_correction_hours: float = 3.0
  wind_correction_pa: float = 1_000.0
  grad_starts: int = 4
  grad_steps: int = 5
  grad_step_m: float = 150.0
  grid_levels: int = 15
  scenarios: int = 0
  search: str = CEM
  beam_width: int = 32
  beam_cell_km: float = 0.0
  beam_cell_m: float = 250.0
  beam_resource_value: float = 0.0
  wind_memory: int = 0

  def checked(self) -> 'PlannerConfig':
    """This config with its values checked (one line per bad value).

    Raises:
      errors.ConfigError: Naming the planner's gin parameter.
    """
    def name(field):
      return f'planner parameter {field}'
    gin_values.require(self.mode in MODES, name('mode'), f'one of {MODES}',
                       self.mode)
    for field in ('iterations', 'horizon', 'num_segments', 'replan_every'):
      gin_values.check_int(name(field), getattr(self, field), minimum=1)
    # Two of the samples are always the warm start and "float here".
    gin_values.check_int(name('num_samples'), self.num_samples, minimum=2)
    for field in ('grad_starts', 'grad_steps', 'grid_levels', 'scenarios',
                  'wind_memory'):
      gin_values.check_int(name(field), getattr(self, field), minimum=0)
    gin_values.require(self.num_segments <= self.horizon, name('num_segments'),
                       f'at most horizon ({self.horizon})', self.num_segments)
    gin_values.require(self.replan_every <= self.horizon, name('replan_every'),
                       f'at most horizon ({self.horizon})', self.replan_every)
    gin_values.require(self.grad_starts <= self.num_samples,
                       name('grad_starts'),
                       f'at most num_samples ({self.num_samples})',
                       self.grad_starts)
    gin_values.check_number(name('elite_fraction'), self.elite_fraction,
                            above=0.0, maximum=1.0)
    gin_values.check_number(name('float_probability'), self.float_probability,
                            minimum=0.0, maximum=1.0)
    gin_values.check_number(name('discount'), self.discount, above=0.0,
                            maximum=1.0)
    low, high = float(jax_env.ACTION_LOW[1]), float(jax_env.ACTION_HIGH[1])
    gin_values.check_number(name('time_factor'), self.time_factor,
                            minimum=low, maximum=high)
    low, high = float(jax_env.ACTION_LOW[0]), float(jax_env.ACTION_HIGH[0])
    gin_values.check_number(name('altitude_low_m'), self.altitude_low_m,
                            minimum=low, maximum=high)
    gin_values.check_number(name('altitude_high_m'), self.altitude_high_m,
                            minimum=self.altitude_low_m, maximum=high)
    for field in ('init_std_m', 'min_std_m', 'radius_km', 'radius_width_km',
                  'halflife_km', 'wind_correction_pa', 'grad_step_m'):
      gin_values.check_number(name(field), getattr(self, field), above=0.0)
    for field in ('shaping', 'progress', 'sand_cost', 'helium_cost', 'terminal_cost',
                  'wind_correction_hours'):
      gin_values.check_number(name(field), getattr(self, field), minimum=0.0)
    gin_values.check_bool(name('plan_float'), self.plan_float)
    gin_values.require(self.search in SEARCHES, name('search'),
                       f'one of {SEARCHES}', self.search)
    gin_values.check_int(name('beam_width'), self.beam_width, minimum=1)
    gin_values.check_number(name('beam_cell_km'), self.beam_cell_km,
                            minimum=0.0)
    gin_values.check_number(name('beam_cell_m'), self.beam_cell_m, above=0.0)
    gin_values.check_number(name('beam_resource_value'),
                            self.beam_resource_value, minimum=0.0)
    gin_values.require(not (self.wind_memory and self.scenarios),
                       name('wind_memory'),
                       f'0 with scenarios ({self.scenarios})', self.wind_memory)
    if self.search == BEAM:
      gin_values.require(
          self.horizon % self.num_segments == 0, name('num_segments'),
          f'a divisor of horizon ({self.horizon}) for search={BEAM!r}',
          self.num_segments)
      gin_values.require(self.grid_levels >= 1, name('grid_levels'),
                         f'>= 1 for search={BEAM!r} (its choices)',
                         self.grid_levels)
    return self

  @property
  def num_elites(self) -> int:
    return max(1, int(round(self.elite_fraction * self.num_samples)))


class Plan(NamedTuple):
  """A piecewise-constant plan and the CEM distribution it came from.

  Attributes:
    targets_m: [num_segments] altitude targets a0. # [m]
    floats: [num_segments] float flags a2 in {-1, +1}.
    mean_m: [num_segments] CEM mean of the targets (the next warm start). # [m]
    float_p: [num_segments] CEM probability of a float segment.
    score: The plan's objective.
    memory: The measured winds so far (`wind_memory` rows, at least one;
      none valid while `wind_memory` is 0).
  """
  targets_m: Array
  floats: Array
  mean_m: Array
  float_p: Array
  score: Array
  memory: noise_gp.Measurements


def blind(state: jax_env.EnvState) -> jax_env.EnvState:
  """The state without its noise (what a forecast planner may read).

  The simplex noise of the flight (and with it the future true wind) is
  replaced by zeros; the forecast, the balloon and its measured wind (an
  observation) stay.
  """
  zeros = lambda tree: jax.tree.map(jnp.zeros_like, tree)
  return state.replace(noise_u=zeros(state.noise_u),
                       noise_v=zeros(state.noise_v))


def measurement(wind: jax_env.Wind, state: jax_env.EnvState
                ) -> Tuple[Array, Array, Array]:
  """Where the balloon is and its measured-minus-forecast wind there.

  Args:
    wind: The env's wind.
    state: The balloon's env state (its measured wind at the balloon; the
      forecast is read from the `blind` state).

  Returns:
    (point (x [km], y [km], pressure [Pa], time [h]), du, dv [m/s]).
  """
  f = state.flight
  u0, v0 = wind.forecast_column(blind(state), f.x_m, f.y_m, f.pressure_pa,
                                f.time_s)
  point = jnp.stack([f.x_m / 1000.0, f.y_m / 1000.0, f.pressure_pa,
                     f.time_s / 3600.0])
  return point, state.wind_u - u0, state.wind_v - v0


def planning_wind(config: PlannerConfig, wind: jax_env.Wind,
                  state: jax_env.EnvState, noise: Optional[Tuple[Any, Any]] = None,
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
  if config.mode == ORACLE:
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
      point = jnp.stack([x_m / 1000.0, y_m / 1000.0, pressure_pa,
                         t_s / 3600.0]).astype(memory.du.dtype)
      du, dv = noise_gp.posterior_mean(memory, weights, point)
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


def scenario_noise(config: PlannerConfig, key: Array) -> Tuple[Any, Any]:
  """`config.scenarios` simplex noise fields of BLE's model (stacked).

  Args:
    config: The planner (scenarios > 0).
    key: The planner's key for them (never the flight's noise key).

  Returns:
    (noise_u, noise_v) with a leading axis of `config.scenarios`.
  """
  return jax.vmap(simplex.reset_uv_noise_params)(
      jax.random.split(key, config.scenarios))


def plan_actions(config: PlannerConfig, targets_m: Array,
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


def objective(config: PlannerConfig, params: jax_env.EnvParams,
              state: jax_env.EnvState, wind_fn: Callable[..., Any],
              targets_m: Array, floats: Array) -> Array:
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

  Returns:
    The objective (a scalar, higher is better): discounted in-radius value
    plus shaping and progress, minus resource and terminal costs.
  """
  actions = plan_actions(config, targets_m, floats)
  f_end, (distance_km, status) = _fly(params, state, wind_fn, state.flight,
                                      actions)
  t = jnp.arange(config.horizon)
  value = jnp.sum(_stride_values(config, params, state, distance_km, status,
                                 t))
  left = params.episode_steps - state.steps  # Strides left in the episode.
  # The plan's last stride inside the episode.
  last = jnp.clip(jnp.minimum(left, config.horizon) - 1, 0, config.horizon - 1)
  # The flight ended inside the plan (before the episode's end).
  ended = status[last] != state_lib.FlightStatus.OK
  return _total(value, _end_terms(config, params, state, f_end,
                                  distance_km[last], ended))


def _total(value: Array, end_terms: Tuple[Array, Array, Array]) -> Array:
  """The objective: value + progress - resource cost - terminal cost."""
  progress, cost, terminal = end_terms
  return value + progress - cost - terminal


def _fly(params: jax_env.EnvParams, state: jax_env.EnvState,
         wind_fn: Callable[..., Any], f: Any, actions: Array
         ) -> Tuple[Any, Tuple[Array, Array]]:
  """Flies `actions` ([T, 3], one per stride) from flight `f` on the core.

  Plans fly the expected dynamics: realistic physics' free-lift random walk
  is a disturbance no controller foresees, so the walk so far is held, with
  no new steps; the sun, overpressure, drag and burst are flown as they are.

  Returns:
    The flight after the last stride, and per stride its distance to the
    station [km] and its `FlightStatus`.
  """
  flight = params.flight.replace(lift_walk=False)

  def stride(f, action):
    f = dynamics.step(flight, state.atmosphere, f, action, wind_fn,
                      params.stride_s)
    return f, (jnp.hypot(f.x_m, f.y_m) / 1000.0, f.status)

  return jax.lax.scan(stride, f, actions)


def _stride_values(config: PlannerConfig, params: jax_env.EnvParams,
                   state: jax_env.EnvState, distance_km: Array,
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


def _end_terms(config: PlannerConfig, params: jax_env.EnvParams,
               state: jax_env.EnvState, f_end: Any, d_end_km: Array,
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
  cost = time_left * (
      config.sand_cost * dropped / jnp.maximum(sand_margin / initial, 0.05) +
      config.helium_cost * vented / jnp.maximum(helium_margin / initial, 0.05))
  return progress, cost, config.terminal_cost * ended.astype(dtype)


def resource_margins(params: jax_env.EnvParams, f: Any) -> Tuple[Array, Array]:
  """The sand that can still be dropped and the lift that can be vented.

  Args:
    params: The env parameters (`flight.min_drop_kg`).
    f: A `FlightState`.

  Returns:
    (sand_kg - min_drop_kg, free_lift_kg + sand_kg), each at least 0. # [kg]
  """
  return (jnp.maximum(f.sand_kg - params.flight.min_drop_kg, 0.0),
          jnp.maximum(f.free_lift_kg + f.sand_kg, 0.0))


def best_per_cell(x_m: Array, y_m: Array, altitude_m: Array, scores: Array,
                  cell_km: float, cell_m: float) -> Array:
  """`scores` with all but the best of each cell set to -inf.

  A cell is a cell_km x cell_km square of (x, y) and a cell_m bin of
  altitude; of the entries in one cell, the one with the highest score
  keeps it (ties: the first in order), the others get -inf.

  Args:
    x_m: [n] eastward positions. # [m]
    y_m: [n] northward positions. # [m]
    altitude_m: [n] altitudes. # [m]
    scores: [n] scores (-inf: already dropped).
    cell_km: Side of a cell's square. # [km]
    cell_m: Height of its altitude bin. # [m]

  Returns:
    [n] scores, -inf for every entry but the best of its cell.
  """
  cell = [jnp.floor(a / size).astype(jnp.int32) for a, size in
          ((x_m, 1000.0 * cell_km), (y_m, 1000.0 * cell_km),
           (altitude_m, cell_m))]
  # Sorted by cell, best score first within a cell (a stable sort); the
  # first entry of each run of one cell is its best.
  order = jnp.lexsort((-scores, cell[2], cell[1], cell[0]))
  cells = jnp.stack(cell)[:, order]
  first = jnp.concatenate([jnp.ones((1,), bool),
                           jnp.any(cells[:, 1:] != cells[:, :-1], axis=0)])
  best = jnp.zeros(order.shape, bool).at[order].set(first)
  return jnp.where(best, scores, -jnp.inf)


def beam_search(config: PlannerConfig, params: jax_env.EnvParams,
                state: jax_env.EnvState, wind_fn: Callable[..., Any]
                ) -> Tuple[Array, Array]:
  """Plans segment by segment, keeping the `beam_width` best partial plans.

  Each segment (horizon / num_segments strides) of each kept plan is
  extended by every choice: "go to level k and stay" for the `grid_levels`
  altitudes over [altitude_low_m, altitude_high_m], and "float" (when
  `plan_float`). A partial plan is scored by the objective as if it ended
  there (its strides' terms, plus progress and costs so far; plus the
  worth of its resource margins when `beam_resource_value` > 0); the best
  `beam_width` children are kept. Tree search over the whole horizon, where
  CEM samples whole plans: the choices late in a plan are searched from
  the states that the early ones reach.

  Args:
    config: The planner (search=BEAM; horizon divisible by num_segments).
    params: The env parameters.
    state: The balloon's env state the plans start from.
    wind_fn: The wind plans are flown in (`planning_wind`).

  Returns:
    [beam_width, num_segments] targets a0 [m] and float flags a2 of the
    final beam (score them with `objective`).
  """
  m, width = config.num_segments, config.beam_width
  length = config.horizon // m
  f0 = state.flight
  dtype = f0.altitude_m.dtype
  h = jnp.clip(f0.altitude_m, config.altitude_low_m, config.altitude_high_m)
  levels = jnp.linspace(config.altitude_low_m, config.altitude_high_m,
                        config.grid_levels, dtype=dtype)
  stay = -jnp.ones((config.grid_levels,), dtype)
  if config.plan_float:
    choice_targets = jnp.concatenate([levels, h[None]])
    choice_floats = jnp.concatenate([stay, jnp.ones((1,), dtype)])
  else:
    choice_targets, choice_floats = levels, stay
  c = choice_targets.shape[0]
  left = params.episode_steps - state.steps

  def fly(f, target, flag):
    action = jnp.stack([target, jnp.asarray(config.time_factor, dtype), flag])
    return _fly(params, state, wind_fn, f,
                jnp.broadcast_to(action, (length, 3)))

  def segment(beam, j):
    flights, value, d_last, ended, score, targets, floats = beam
    parent = jnp.repeat(jnp.arange(width), c)
    choice = jnp.tile(jnp.arange(c), width)
    f, (distance_km, status) = jax.vmap(fly)(
        jax.tree.map(lambda a: a[parent], flights), choice_targets[choice],
        choice_floats[choice])
    t = j * length + jnp.arange(length)
    value = value[parent] + jnp.sum(jax.vmap(
        lambda d, s: _stride_values(config, params, state, d, s, t))(
            distance_km, status), axis=-1)
    # The last stride inside the episode (none: the parent's values hold).
    inside = t < left
    last = jnp.clip(jnp.sum(inside) - 1, 0, length - 1)
    d_last = jnp.where(inside.any(), distance_km[:, last], d_last[parent])
    ended = jnp.where(inside.any(),
                      status[:, last] != state_lib.FlightStatus.OK,
                      ended[parent])
    scores = _total(value, jax.vmap(
        lambda f, d, e: _end_terms(config, params, state, f, d, e))(
            f, d_last, ended))
    scores = jnp.where(jnp.isfinite(scores) & (score[parent] > -jnp.inf),
                       scores, -jnp.inf)
    if config.beam_resource_value > 0.0:
      # What the resources kept are worth to the rest of the episode.
      after = jnp.clip((left - (j + 1) * length) / params.episode_steps,
                       0.0, 1.0)
      sand, helium = resource_margins(params, f)  # Elementwise: batched.
      scores = scores + config.beam_resource_value * after * (sand + helium)
    if config.beam_cell_km > 0.0:
      scores = best_per_cell(f.x_m, f.y_m, f.altitude_m, scores,
                             config.beam_cell_km, config.beam_cell_m)
    score, keep = jax.lax.top_k(scores, width)
    source = parent[keep]
    targets = targets[source].at[:, j].set(choice_targets[choice[keep]])
    floats = floats[source].at[:, j].set(choice_floats[choice[keep]])
    beam = (jax.tree.map(lambda a: a[keep], f), value[keep], d_last[keep],
            ended[keep], score, targets, floats)
    return beam, None

  d0 = jnp.hypot(f0.x_m, f0.y_m) / 1000.0
  # One root: the other rows start at -inf and their children are dropped.
  beam0 = (jax.tree.map(lambda a: jnp.broadcast_to(a, (width,) + a.shape), f0),
           jnp.zeros((width,), dtype), jnp.full((width,), d0, dtype),
           jnp.zeros((width,), bool),
           jnp.full((width,), -jnp.inf, dtype).at[0].set(0.0),
           jnp.broadcast_to(h, (width, m)), -jnp.ones((width, m), dtype))
  beam, _ = jax.lax.scan(segment, beam0, jnp.arange(m))
  return beam[5], beam[6]


def initial_plan(config: PlannerConfig, state: jax_env.EnvState) -> Plan:
  """The first warm start: hold the current altitude, floats at the prior.

  Args:
    config: The planner (altitude band, num_segments, float_probability).
    state: The balloon's env state.

  Returns:
    A `Plan` whose targets are the current altitude clipped into
    [altitude_low_m, altitude_high_m], score 0.
  """
  h = jnp.clip(state.flight.altitude_m, config.altitude_low_m,
               config.altitude_high_m)
  shape = (config.num_segments,)
  targets = jnp.broadcast_to(h, shape)
  return Plan(targets_m=targets, floats=jnp.ones(shape, h.dtype),
              mean_m=targets,
              float_p=jnp.full(shape, config.float_probability, h.dtype),
              score=jnp.zeros((), h.dtype),
              memory=noise_gp.empty(max(config.wind_memory, 1), h.dtype))


def shift(config: PlannerConfig, previous: Plan) -> Plan:
  """The previous plan moved on by `replan_every` strides (warm start).

  Args:
    config: The planner (replan_every, num_segments, horizon).
    previous: The last plan.

  Returns:
    `previous` with its segments shifted forward and the last one
    repeated; `previous` itself when less than a segment has passed.
  """
  k = int(round(config.replan_every * config.num_segments / config.horizon))
  if k == 0:
    return previous
  def move(a):
    return jnp.concatenate([a[k:], jnp.repeat(a[-1:], k)])
  return previous._replace(targets_m=move(previous.targets_m),
                           floats=move(previous.floats),
                           mean_m=move(previous.mean_m),
                           float_p=move(previous.float_p))


def plan(config: PlannerConfig, params: jax_env.EnvParams,
         state: jax_env.EnvState, key: Array, previous: Plan,
         wind: jax_env.Wind = jax_env.GENERATIVE_WIND) -> Plan:
  """Plans from one balloon's state (pure; vmap over balloons).

  Args:
    config: The planner (static).
    params: The env parameters.
    state: The balloon's env state (FORECAST and GRADIENT read it `blind`).
    key: PRNG key of the samples.
    previous: The last plan (`initial_plan` at the start of a flight); its
      shifted CEM mean and best plan seed this one (warm start).
    wind: The env's wind (`LatexBalloonJaxEnv.wind_for(params)`).

  Returns:
    The best plan found and the CEM distribution for the next warm start.
  """
  measured = state
  if config.mode != ORACLE:
    state = blind(state)
  dtype = state.flight.altitude_m.dtype
  warm = shift(config, previous)
  memory = None
  if config.mode != ORACLE and config.wind_memory:
    memory = noise_gp.add(previous.memory, *measurement(wind, measured))
  # The wind of the beam search and of the plans' scores (one Gaussian-
  # process fit per decision); scenarios score over their own winds.
  wind_fn = planning_wind(config, wind, measured, memory=memory)
  if config.mode != ORACLE and config.scenarios:
    key, noise_key = jax.random.split(key)
    noises = scenario_noise(config, noise_key)

    def score_fn(targets_m, floats):
      def one(noise):
        return objective(config, params, state,
                         planning_wind(config, wind, measured, noise),
                         targets_m, floats)
      return jnp.mean(jax.vmap(one)(noises))
  else:
    score_fn = functools.partial(objective, config, params, state, wind_fn)
  scores_of = jax.vmap(score_fn)
  n, m = config.num_samples, config.num_segments
  low, high = config.altitude_low_m, config.altitude_high_m
  h = jnp.clip(state.flight.altitude_m, low, high)
  fixed_targets = jnp.stack([warm.targets_m, jnp.broadcast_to(h, (m,))])
  fixed_floats = jnp.stack([warm.floats, jnp.ones((m,), dtype)])
  levels = jnp.linspace(low, high, config.grid_levels, dtype=dtype)
  grid = jnp.broadcast_to(levels[:, None], (config.grid_levels, m))
  stay = -jnp.ones((config.grid_levels, m), dtype)
  grid_targets = jnp.concatenate([grid, grid])
  grid_floats = jnp.concatenate([stay, stay.at[:, 1:].set(1.0)])
  if not config.plan_float:
    fixed_floats = -jnp.ones_like(fixed_floats)
    grid_floats = -jnp.ones_like(grid_floats)

  def sample(key, mean, std, float_p):
    k_targets, k_floats = jax.random.split(key)
    targets = mean + std * jax.random.normal(k_targets, (n, m), dtype)
    targets = jnp.clip(targets, low, high).at[:2].set(fixed_targets)
    floats = jnp.where(jax.random.uniform(k_floats, (n, m)) < float_p, 1.0,
                       -1.0).astype(dtype)
    if not config.plan_float:
      floats = -jnp.ones_like(floats)
    floats = floats.at[:2].set(fixed_floats)
    return (jnp.concatenate([targets, grid_targets]),
            jnp.concatenate([floats, grid_floats]))

  def iteration(carry, key):
    mean, std, float_p, best = carry
    targets, floats = sample(key, mean, std, float_p)
    scores = scores_of(targets, floats)
    scores = jnp.where(jnp.isfinite(scores), scores, -jnp.inf)
    elite = jnp.argsort(-scores)[:config.num_elites]
    mean = jnp.mean(targets[elite], axis=0)
    std = jnp.maximum(jnp.std(targets[elite], axis=0), config.min_std_m)
    float_p = jnp.clip(jnp.mean(floats[elite] > 0.0, axis=0), 0.05, 0.95)
    i = elite[0]
    candidate = (targets[i], floats[i], scores[i])
    best = jax.tree.map(lambda a, b: jnp.where(scores[i] > best[2], a, b),
                        candidate, best)
    return (mean, std, float_p, best), (targets, floats, scores)

  if config.search == BEAM:
    # The final beam, the warm start and "float here", scored exactly.
    targets, floats = beam_search(config, params, state, wind_fn)
    targets = jnp.concatenate([targets, fixed_targets])[None]
    floats = jnp.concatenate([floats, fixed_floats])[None]
    scores = scores_of(targets[0], floats[0])
    scores = jnp.where(jnp.isfinite(scores), scores, -jnp.inf)[None]
    i = jnp.argmax(scores[0])
    best = (targets[0, i], floats[0, i], scores[0, i])
    mean = best[0]
    float_p = jnp.clip(jnp.where(best[1] > 0.0, 1.0, 0.0), 0.05, 0.95)
  else:
    std0 = jnp.full((m,), config.init_std_m, dtype)
    best0 = (warm.targets_m, warm.floats, jnp.asarray(-jnp.inf, dtype))
    keys = jax.random.split(key, config.iterations)
    (mean, std, float_p, best), (targets, floats, scores) = jax.lax.scan(
        iteration, (warm.mean_m, std0, warm.float_p, best0), keys)
    del std
  if config.mode == GRADIENT and config.grad_starts and config.grad_steps:
    # Refine the best samples of the last iteration by gradient ascent.
    order = jnp.argsort(-scores[-1])[:config.grad_starts]
    starts, start_floats = targets[-1][order], floats[-1][order]
    grad_fn = jax.grad(score_fn)

    def ascend(x, flags):
      def one(x, _):
        g = grad_fn(x, flags)
        g = jnp.where(jnp.isfinite(g), g, 0.0)
        step = config.grad_step_m * g / (jnp.linalg.norm(g) + 1e-12)
        return jnp.clip(x + step, low, high), None
      x, _ = jax.lax.scan(one, x, None, length=config.grad_steps)
      return x

    refined = jax.vmap(ascend)(starts, start_floats)
    refined_scores = scores_of(refined, start_floats)
    refined_scores = jnp.where(jnp.isfinite(refined_scores), refined_scores,
                               -jnp.inf)
    i = jnp.argmax(refined_scores)
    candidate = (refined[i], start_floats[i], refined_scores[i])
    best = jax.tree.map(
        lambda a, b: jnp.where(refined_scores[i] > best[2], a, b),
        candidate, best)
  return Plan(targets_m=best[0], floats=best[1], mean_m=mean,
              float_p=float_p, score=best[2],
              memory=previous.memory if memory is None else memory)


def plan_key(seed: Any, state: jax_env.EnvState) -> Array:
  """The planner's key at a state: its seed, the flight and the stride.

  The flight is told apart by its start time (drawn from the env seed), so
  the agent in `ble-latex-eval` and `plan_batch` sample the same plans for
  the same env seed and agent seed.

  Args:
    seed: The agent seed (int or int32 scalar).
    state: The balloon's env state (start_time_offset_s, steps).

  Returns:
    A PRNG key.
  """
  key = jax.random.fold_in(jax.random.PRNGKey(seed), state.start_time_offset_s)
  return jax.random.fold_in(key, state.steps)


@functools.partial(jax.jit, static_argnums=(0, 5))
def plan_batch(config: PlannerConfig, params: jax_env.EnvParams,
               states: jax_env.EnvState, seed: Array, previous: Plan,
               wind: jax_env.Wind = jax_env.GENERATIVE_WIND) -> Plan:
  """`plan` for a batch of balloons in one vmapped call (jitted).

  Args:
    config: The planner (static).
    params: The env parameters (shared).
    states: [N] env states.
    seed: The agent seed (int32 scalar).
    previous: [N] plans (the warm starts).
    wind: The env's wind (static).

  Returns:
    [N] plans.
  """
  def one(state, prev):
    return plan(config, params, state, plan_key(seed, state), prev, wind)
  return jax.vmap(one)(states, previous)


@functools.partial(jax.jit, static_argnums=0)
def initial_plans(config: PlannerConfig, states: jax_env.EnvState) -> Plan:
  """`initial_plan` of [N] states (jitted).

  Args:
    config: The planner (static).
    states: [N] env states.

  Returns:
    [N] plans.
  """
  return jax.vmap(functools.partial(initial_plan, config))(states)


def flown_actions(config: PlannerConfig, plans: Plan) -> Array:
  """The actions [N] plans fly before the next replan (`plan_actions`).

  Args:
    config: The planner (replan_every, horizon, num_segments, time_factor).
    plans: [N] plans (`plan_batch`).

  Returns:
    [replan_every, N, 3] actions (a0 [m], a1, a2), stride first (what a
    `lax.scan` over the strides reads).
  """
  actions = jax.vmap(functools.partial(plan_actions, config))(
      plans.targets_m, plans.floats)
  return jnp.swapaxes(actions[:, :config.replan_every], 0, 1)


def next_action(config: PlannerConfig, current: Plan,
                strides_since_plan: int) -> np.ndarray:
  """The action of stride `strides_since_plan` of a plan (host NumPy).

  Args:
    config: The planner (horizon, num_segments, time_factor).
    current: The plan being flown.
    strides_since_plan: Strides since `current` was made (past the last
      segment, the last segment is flown).

  Returns:
    The action (a0 [m], a1, a2), float64 shape (3,).
  """
  segment = (strides_since_plan * config.num_segments) // config.horizon
  segment = min(segment, config.num_segments - 1)
  targets, floats = jax.device_get((current.targets_m, current.floats))
  return np.array([targets[segment], config.time_factor, floats[segment]],
                  np.float64)


# ---------------------------------------------------------------------------
# Agents (BLE's Agent API, Box actions).


def core_of(env: Any) -> Tuple[Any, jax_env.Wind]:
  """The core balloon an env flies, and its JAX wind.

  Accepts BLE's `LatexBalloon-v0` (its arena's driver) or the Gymnasium
  `LatexBalloonGymnasiumEnv` (anything with `state` and `params`).

  Raises:
    errors.ConfigError: An env without a JAX core state, or one that flies
      a BLE wind field through host callbacks (a planner needs JAX winds).
  """
  env = getattr(env, 'unwrapped', env)
  arena = getattr(env, 'arena', None)
  driver = getattr(arena, 'driver', None) if arena is not None else None
  driver = driver if driver is not None else env
  if not (hasattr(driver, 'state') and hasattr(driver, 'params')):
    raise errors.ConfigError(
        f'the planners fly LatexBalloon-v0 (a JAX core state); {env!r} has '
        'none')
  if getattr(driver, '_wind_field', None) is not None:
    raise errors.ConfigError(
        'the planners need JAX winds (the generative field, or ERA5 in the '
        'env params); this env flies a BLE wind field through host callbacks')
  return driver, jax_env.LatexBalloonJaxEnv().wind_for(driver.params)


class PlannerAgent(agent.Agent):
  """An MPC agent over the core state of the env it is attached to.

  `run.runner.create_agent` calls `attach_env(env)`; the agent then reads
  the env's `EnvState` at every decision (FORECAST and GRADIENT read it
  without the noise, `blind`), plans every `replan_every` strides and flies
  the plan's actions in between. The observation is not used.

  Args:
    num_actions: Size of the action (must be 3: a0, a1, a2).
    observation_shape: The observation's shape (unused).
    action_low: The action Box's lower bounds; actions are clipped to it.
    action_high: The action Box's upper bounds.
    seed: The agent seed (with the flight and stride, `plan_key`).
    **config: `PlannerConfig` fields (checked, `PlannerConfig.checked`).

  Raises:
    errors.ConfigError: `num_actions` other than 3, or a bad config value.
  """

  supports_box_actions = True
  needs_env = True
  mode = FORECAST

  def __init__(self, num_actions: int, observation_shape: Sequence[int], *,
               action_low: Sequence[float], action_high: Sequence[float],
               seed: int = 0, **config: Any):
    super().__init__(num_actions, observation_shape)
    if num_actions != 3:
      raise errors.ConfigError(
          f'the planners act in the (a0, a1, a2) Box; got {num_actions} '
          'actions')
    self._low = np.asarray(action_low, np.float64)
    self._high = np.asarray(action_high, np.float64)
    self.config = PlannerConfig(mode=self.mode, **config).checked()
    self._seed = int(seed)
    self._driver = None
    self._wind = None
    self._plan: Optional[Plan] = None
    self._since = 0
    self.decision_seconds: List[float] = []  # Wall time of each plan. # [s]

  def attach_env(self, env: Any) -> None:
    """Flies `env`'s core from now on (see `core_of`)."""
    self._driver, self._wind = core_of(env)

  def _act(self) -> np.ndarray:
    if self._driver is None:
      raise RuntimeError('PlannerAgent.attach_env(env) was not called')
    if self._plan is None or self._since >= self.config.replan_every:
      start = time.perf_counter()
      state = jax.tree.map(lambda a: a[None], self._driver.state)
      previous = (initial_plans(self.config, state) if self._plan is None
                  else jax.tree.map(lambda a: a[None], self._plan))
      new = plan_batch(self.config, self._driver.params, state,
                       jnp.int32(self._seed), previous, self._wind)
      self._plan = jax.tree.map(lambda a: a[0], jax.block_until_ready(new))
      self.decision_seconds.append(time.perf_counter() - start)
      self._since = 0
    action = next_action(self.config, self._plan, self._since)
    self._since += 1
    return np.clip(action, self._low, self._high)

  def begin_episode(self, observation: np.ndarray) -> np.ndarray:
    """Drops the last plan and plans from the env's new flight.

    Args:
      observation: Unused (the agent reads the env's core state).

    Returns:
      The first action (a0 [m], a1, a2), clipped into the Box.

    Raises:
      RuntimeError: `attach_env` was not called.
    """
    self._plan, self._since = None, 0
    return self._act()

  def step(self, reward: float, observation: np.ndarray) -> np.ndarray:
    """The next action of the plan (replanning every `replan_every`).

    Args:
      reward: Unused.
      observation: Unused (the agent reads the env's core state).

    Returns:
      The action (a0 [m], a1, a2), clipped into the Box.

    Raises:
      RuntimeError: `attach_env` was not called.
    """
    return self._act()

  def end_episode(self, reward: float, terminal: bool = True) -> None:
    """Drops the current plan.

    Args:
      reward: Unused.
      terminal: Unused.
    """
    self._plan = None


_DENY = ['num_actions', 'observation_shape', 'action_low', 'action_high']
_FIELDS = [f.name for f in dataclasses.fields(PlannerConfig)
           if f.name != 'mode']


def _configurable(name: str, mode: str, doc: str, **overrides: Any):
  """A gin-configurable `PlannerAgent` of `mode`, every config field a kwarg.

  `overrides` are the class's own defaults (else `PlannerConfig`'s).
  """
  defaults = PlannerConfig(mode=mode, **overrides)

  def __init__(self, num_actions, observation_shape, *, action_low,
               action_high, seed: int = 0, **config):
    for key in config:
      if key not in _FIELDS:
        raise errors.ConfigError(f'{name}: unknown parameter {key!r} (one of '
                                 f'{_FIELDS})')
    merged = {f: getattr(defaults, f) for f in _FIELDS}
    merged.update(config)
    PlannerAgent.__init__(self, num_actions, observation_shape,
                          action_low=action_low, action_high=action_high,
                          seed=seed, **merged)

  cls = type(name, (PlannerAgent,), {'mode': mode, '__doc__': doc,
                                     '__init__': __init__})
  # gin sees the config fields as keyword arguments of the constructor.
  parameters = [
      inspect.Parameter('self', inspect.Parameter.POSITIONAL_OR_KEYWORD),
      inspect.Parameter('num_actions', inspect.Parameter.POSITIONAL_OR_KEYWORD),
      inspect.Parameter('observation_shape',
                        inspect.Parameter.POSITIONAL_OR_KEYWORD)]
  parameters += [inspect.Parameter(k, inspect.Parameter.KEYWORD_ONLY)
                 for k in ('action_low', 'action_high')]
  parameters.append(inspect.Parameter('seed', inspect.Parameter.KEYWORD_ONLY,
                                      default=0))
  parameters += [inspect.Parameter(f, inspect.Parameter.KEYWORD_ONLY,
                                   default=getattr(defaults, f))
                 for f in _FIELDS]
  __init__.__signature__ = inspect.Signature(parameters)
  return gin.configurable(name, denylist=_DENY)(cls)


LatexMpcAgent = _configurable(
    'LatexMpcAgent', FORECAST,
    'Beam-search MPC on the forecast (agent latex_mpc); never reads the '
    'noise.', search=BEAM, wind_memory=16)
LatexMpcOracleAgent = _configurable(
    'LatexMpcOracleAgent', ORACLE,
    'Beam search over the whole episode on the true wind (agent '
    'latex_mpc_oracle): an upper bound.',
    search=BEAM, horizon=216, num_segments=216, replan_every=216,
    beam_width=512, beam_cell_km=10.0, beam_resource_value=20.0,
    discount=1.0)
LatexMpcGradAgent = _configurable(
    'LatexMpcGradAgent', GRADIENT,
    'First-order MPC on the forecast (agent latex_mpc_grad).',
    iterations=1)
AGENTS: Dict[str, Any] = {'latex_mpc': LatexMpcAgent,
                          'latex_mpc_oracle': LatexMpcOracleAgent,
                          'latex_mpc_grad': LatexMpcGradAgent}
