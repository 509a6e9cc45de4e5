# coding=utf-8
"""The planners over the batched JAX flight core, pure JAX (issue 29).

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
  Under realistic physics it knows the disturbance's path too (it flies the
  env's own draws, `plan_objective.fly(exact=True)`), so the env flies its
  plan exactly there as well.
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

The pure functions here (`plan`, `plan_batch`, `initial_plans`,
`flown_actions`) take the env's `EnvState` of one balloon (vmap them over
balloons: `plan_batch`); the config and its gin names are `plan_config`'s,
the objective and winds `plan_objective`'s, the beam search `beam`'s. They
import no TensorFlow, Dopamine or BLE agent: the BLE `Agent`s that fly them
in `ble-latex-eval` are `agents/planning/agents.py`'s.
"""

import functools
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ble_latex.agents.planning import beam
from ble_latex.agents.planning import config as plan_config
from ble_latex.agents.planning import objective as plan_objective
from ble_latex.agents.planning import value as plan_value
from ble_latex.envs import env_types
from ble_latex.envs import winds
from ble_latex.wind import noise_gp

Array = jax.Array


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



def initial_plan(config: plan_config.PlannerConfig,
                 state: env_types.EnvState) -> Plan:
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


def shift(config: plan_config.PlannerConfig, previous: Plan) -> Plan:
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


def plan(config: plan_config.PlannerConfig, params: env_types.EnvParams,
         state: env_types.EnvState, key: Array, previous: Plan,
         wind: winds.Wind = winds.GENERATIVE_WIND) -> Plan:
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
  if config.mode != plan_config.ORACLE:
    state = plan_objective.blind(state)
  dtype = state.flight.altitude_m.dtype
  warm = shift(config, previous)
  memory = None
  if config.mode != plan_config.ORACLE and config.wind_memory:
    memory = noise_gp.add(previous.memory,
                          *plan_objective.measurement(wind, measured))
  # The wind of the beam search and of the plans' scores (one Gaussian-
  # process fit per decision); scenarios score over their own winds.
  wind_fn = plan_objective.planning_wind(config, wind, measured,
                                         memory=memory)
  terminal = (plan_value.terminal_fn(config.value_policy, params, state,
                                     wind, wind_fn)
              if config.value_policy else None)
  if config.mode != plan_config.ORACLE and config.scenarios:
    key, noise_key = jax.random.split(key)
    noises = plan_objective.scenario_noise(config, noise_key)

    def score_fn(targets_m, floats):
      def one(noise):
        noisy = plan_objective.planning_wind(config, wind, measured, noise)
        return plan_objective.objective(config, params, state, noisy,
                                        targets_m, floats, terminal)
      return jnp.mean(jax.vmap(one)(noises))
  else:
    score_fn = functools.partial(plan_objective.objective, config, params,
                                 state, wind_fn, terminal=terminal)
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

  if config.search == plan_config.BEAM:
    # The final beam, the warm start and "float here", scored exactly.
    targets, floats = beam.beam_search(config, params, state, wind_fn,
                                       terminal)
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
  if (config.mode == plan_config.GRADIENT and config.grad_starts and
      config.grad_steps):
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


def plan_key(seed: Any, state: env_types.EnvState) -> Array:
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


def plan_batch(config: plan_config.PlannerConfig, params: env_types.EnvParams,
               states: env_types.EnvState, seed: Array, previous: Plan,
               wind: winds.Wind = winds.GENERATIVE_WIND) -> Plan:
  """`plan` for a batch of balloons in one vmapped call (jitted).

  The batch is checked first (`plan_config.check_batch`): a call that would
  fly more than `plan_config.MAX_PLAN_STRIDES` plan strides at once is
  refused before it is compiled.

  Args:
    config: The planner (static).
    params: The env parameters (shared).
    states: [N] env states.
    seed: The agent seed (int32 scalar).
    previous: [N] plans (the warm starts).
    wind: The env's wind (static).

  Returns:
    [N] plans.

  Raises:
    errors.ConfigError: N x `config.plan_strides()` over the bound.
  """
  plan_config.check_batch(config, _balloons(states))
  return _plan_batch(config, params, states, seed, previous, wind)


def _balloons(states: env_types.EnvState) -> int:
  """N, the leading axis of [N] states."""
  return int(jax.tree.leaves(states.flight)[0].shape[0])


@functools.partial(jax.jit, static_argnums=(0, 5))
def _plan_batch(config: plan_config.PlannerConfig,
                params: env_types.EnvParams, states: env_types.EnvState,
                seed: Array, previous: Plan, wind: winds.Wind) -> Plan:
  """`plan_batch` after its check."""
  def one(state, prev):
    return plan(config, params, state, plan_key(seed, state), prev, wind)
  return jax.vmap(one)(states, previous)


def initial_plans(config: plan_config.PlannerConfig,
                  states: env_types.EnvState) -> Plan:
  """`initial_plan` of [N] states (jitted; N checked as by `plan_batch`).

  Args:
    config: The planner (static).
    states: [N] env states.

  Returns:
    [N] plans.

  Raises:
    errors.ConfigError: N x `config.plan_strides()` over the bound.
  """
  plan_config.check_batch(config, _balloons(states))
  return _initial_plans(config, states)


@functools.partial(jax.jit, static_argnums=0)
def _initial_plans(config: plan_config.PlannerConfig,
                   states: env_types.EnvState) -> Plan:
  return jax.vmap(functools.partial(initial_plan, config))(states)


def flown_actions(config: plan_config.PlannerConfig, plans: Plan) -> Array:
  """The actions [N] plans fly before the next replan (`plan_actions`).

  Args:
    config: The planner (replan_every, horizon, num_segments, time_factor).
    plans: [N] plans (`plan_batch`).

  Returns:
    [replan_every, N, 3] actions (a0 [m], a1, a2), stride first (what a
    `lax.scan` over the strides reads).
  """
  actions = jax.vmap(functools.partial(plan_objective.plan_actions, config))(
      plans.targets_m, plans.floats)
  return jnp.swapaxes(actions[:, :config.replan_every], 0, 1)


def next_action(config: plan_config.PlannerConfig, current: Plan,
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
