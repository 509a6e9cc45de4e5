# coding=utf-8
"""Beam search over a plan's segments (pure JAX).

The plan is built segment by segment from a fixed set of choices ("go to
level k and stay", "float"), keeping the `beam_width` best partial plans
(`beam_search`); with `beam_cell_km` > 0 at most one per coarse cell of the
state the flights reach (`best_per_cell`). Plans are scored by
`plan_objective`'s terms as if they ended where they are.
"""

from typing import Any, Callable, Optional, Tuple

import jax
import jax.numpy as jnp

from ble_latex.agents.planning import config as plan_config
from ble_latex.agents.planning import objective as plan_objective
from ble_latex.envs import env_types
from ble_latex.flight import state as state_lib

Array = jax.Array


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


def beam_search(config: plan_config.PlannerConfig, params: env_types.EnvParams,
                state: env_types.EnvState, wind_fn: Callable[..., Any],
                terminal: Optional[Callable[[Any], Array]] = None
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
    terminal: None, or V of a flight (`plan_value`): partial plans are
      scored with it where they end (`plan_objective.beyond`).

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
    return plan_objective.fly(params, state, wind_fn, f,
                              jnp.broadcast_to(action, (length, 3)),
                              exact=plan_objective.exact(config))

  def segment(beam, j):
    flights, value, d_last, ended, score, targets, floats = beam
    parent = jnp.repeat(jnp.arange(width), c)
    choice = jnp.tile(jnp.arange(c), width)
    f, (distance_km, status) = jax.vmap(fly)(
        jax.tree.map(lambda a: a[parent], flights), choice_targets[choice],
        choice_floats[choice])
    t = j * length + jnp.arange(length)
    value = value[parent] + jnp.sum(jax.vmap(
        lambda d, s: plan_objective.stride_values(config, params, state, d,
                                                  s, t))(
            distance_km, status), axis=-1)
    # The last stride inside the episode (none: the parent's values hold).
    inside = t < left
    last = jnp.clip(jnp.sum(inside) - 1, 0, length - 1)
    d_last = jnp.where(inside.any(), distance_km[:, last], d_last[parent])
    ended = jnp.where(inside.any(),
                      status[:, last] != state_lib.FlightStatus.OK,
                      ended[parent])
    scores = plan_objective.total(value, jax.vmap(
        lambda f, d, e: plan_objective.end_terms(config, params, state, f, d,
                                                 e))(f, d_last, ended))
    if terminal is not None:
      scores = scores + jax.vmap(
          lambda f, e: plan_objective.beyond(config, params, state, terminal,
                                             f, (j + 1) * length, e))(
              f, ended)
    scores = jnp.where(jnp.isfinite(scores) & (score[parent] > -jnp.inf),
                       scores, -jnp.inf)
    if config.beam_resource_value > 0.0:
      # What the resources kept are worth to the rest of the episode.
      after = jnp.clip((left - (j + 1) * length) / params.episode_steps,
                       0.0, 1.0)
      # Elementwise: on the batch as it is.
      sand, helium = plan_objective.resource_margins(params, f)
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
