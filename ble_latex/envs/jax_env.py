# coding=utf-8
"""`LatexBalloon-v0` as a functional, batched JAX environment (gymnax 1.0 style).

  import jax
  from ble_latex.envs import jax_env

  env = jax_env.LatexBalloonJaxEnv()   # actions in [-1, 1]^3
  params = env.default_params                       # gin-bound constants
  # Optional: auto-reset from 256 pre-drawn worlds (cheap `step`).
  params = env.with_reset_pool(jax.random.PRNGKey(1), params, 256)
  keys = jax.random.split(jax.random.PRNGKey(0), 1024)
  obs, state = jax.vmap(env.reset, in_axes=(0, None))(keys, params)
  obs, state, reward, terminated, truncated, info = jax.vmap(
      env.step, in_axes=(0, 0, 0, None))(keys, state, actions, params)

gymnax 1.0's contract: `reset(key, params) -> (obs, state)`;
`step(key, state, action, params) -> (obs, state, reward, terminated,
truncated, info)` resets a finished episode from `key` (the finished step's
observation in `info['final_observation']`; the world of `reset(key)`, or
with `EnvParams.reset_pool` a world of the pool, see `step`); `step_env` is the step without
reset, `(obs, state, reward, terminated, info)`. All are pure: jit them,
vmap them over balloons, scan them over time (`rollout`). `terminated`: out
of sand or helium, burst or grounded; `truncated`: the time limit
(`EnvParams.episode_steps`, gymnax's `max_steps_in_episode`) without a
terminal status. `observation_space(params)`, `action_space(params)`,
`num_actions` and `default_params` are gymnax's names.

`EnvParams` is the one home of every default (flight system, controller,
reward, task, episode); gin configures it through the configurables of this
module and `flight.params`, under the gin names existing gin files use.

The world is BLE's, drawn from the key exactly as BLE's gym env draws it
from `reset(seed=s)` with `key = jax.random.PRNGKey(s)` (BLE's key chain: the
arena key, then atmosphere and start-time keys, then the balloon's start
distance (Beta(1.2, 2) x 200 km), angle, location and altitude, then the wind
key split into noise and forecast): BLE's standard atmosphere with its
lapse-rate blend (`flight.atmosphere`), the generative VAE forecast
(`wind.generative`), BLE's simplex noise harmonics on an exact port of
opensimplex 0.3 (`wind.simplex`). The balloon is the flight core
(`flight.dynamics.step`): one controller action per 20-minute stride, the
ground-truth wind (forecast + noise) re-queried every <= 3 simulated minutes.
Observations are the 71 features (`jax_features`), the reward BLE's
Perciatelli reward minus the optional resource penalties.

Actions are in [-1, 1]^3 by default, mapped affinely onto the controller's
Box by `to_box` (`LatexBalloonJaxEnv(normalize_actions=False)`: the Box's raw
(a0 [m], a1, a2), as BLE's arena, the Gymnasium wrappers and the jitted
trainer fly it). Actions are clipped into the Box (the host envs validate
at their boundary; +-inf clip onto the Box's edges), and an action with any NaN
component, which no clipping can place, is flown as the float (hold) action
(clip(h), 1, +1) (`flight.controller.float_if_nan`), flagged by
`info['invalid_action']`, so NaN never reaches the state or the features.
The winds are `GENERATIVE_WIND` unless a `Wind` is given (BLE's other wind
fields fly through host callbacks, `ble_latex.ble.wind`) or the params hold
an ERA5 grid (`EnvParams.wind_grid`, `era5_wind`: ERA5 plus BLE's simplex
noise, the paper's winds, shared by all balloons); everything runs
in JAX's default float32 (see docs/jax-env.md).
"""

import dataclasses
import datetime as dt
import functools
from typing import Any, Callable, Dict, Mapping, Optional, Tuple

import gin
import jax
from jax import custom_batching
import jax.numpy as jnp
import numpy as np

from ble_latex import errors
from ble_latex import gin_values
from ble_latex import jax_cache
from ble_latex.envs import env_types
from ble_latex.envs import jax_features
from ble_latex.envs import winds
from ble_latex.flight import atmosphere as atmosphere_lib
from ble_latex.flight import controller as controller_lib
from ble_latex.flight import dynamics
from ble_latex.flight import params as flight_params_lib
from ble_latex.flight import physics
from ble_latex.flight import state as state_lib
from ble_latex.wind import era5
from ble_latex.wind import era5_jax
from ble_latex.wind import generative
from ble_latex.wind import simplex

Array = jax.Array
ACTION_LOW = controller_lib.ACTION_LOW  # The core's action Box.
ACTION_HIGH = controller_lib.ACTION_HIGH
# BLE's arena (balloon_arena.BalloonArena): start distance ~ Beta(1.2, 2).
_START_BETA = (1.2, 2.0)
# BLE's sampling.sample_time range: 2011-01-01 .. 2014-12-31, in seconds
# from `env_types.START_EPOCH`.
_START_TIME_RANGE_S = 126_230_400
# Realistic physics (issue 28): the key of the burst draw (from the reset
# key) is folded in with this, so the paper's draws stay as they were.
_BURST_KEY_DATA = 28_001


def to_box(normalized: Array) -> Array:
  """[-1, 1]^3 actions onto the core's Box, affinely (the one mapping).

  low + (u + 1) / 2 * (high - low) of u = clip(normalized, -1, 1), clipped
  into the Box, in float32: what the normalized `LatexBalloonJaxEnv` and the
  jitted SAC trainer fly (`sac_trainer.to_box` is this function). A NaN
  component stays NaN (`step_env` flies the float action).
  """
  low = jnp.asarray(ACTION_LOW, jnp.float32)
  high = jnp.asarray(ACTION_HIGH, jnp.float32)
  u = jnp.clip(normalized, -1.0, 1.0)
  return jnp.clip(low + 0.5 * (u + 1.0) * (high - low), low, high)


def pool_index(key: Array, size: int) -> Array:
  """The pool world `step` gives a flight that ends with step key `key`.

  `jax.random.randint(key, (), 0, size)`: uniform over the K worlds, drawn
  from the step's key (so the same keys give the same worlds).

  Args:
    key: The step's PRNG key.
    size: K, the number of worlds in the pool.

  Returns:
    The world's index in [0, K), int32 scalar.
  """
  return jax.random.randint(key, (), 0, size)


# Leaves with at least this many elements per balloon (the forecast grid,
# the noise permutations) are a pool world's "large" part: `step` leaves
# them to be installed at the start of the next step (`install_world`).
_LARGE_MIN_SIZE = 256


def _is_large(leaf: Any, batch: Tuple[int, ...] = ()) -> bool:
  return int(np.prod(np.shape(leaf)[len(batch):])) >= _LARGE_MIN_SIZE


def _broadcast_unbatched(axis_size: int, x: Any, batched: Any) -> Any:
  """`x`'s leaves with a leading batch axis of `axis_size`: the batched ones
  (`batched`: custom_vmap's per-leaf flags) as they are, the others
  broadcast."""
  return jax.tree.map(
      lambda a, b: a if b else jnp.broadcast_to(a, (axis_size,) + a.shape),
      x, batched)


@custom_batching.custom_vmap
def _install(pending: Array, large: Any, pool_large: Any) -> Any:
  """The large leaves of pool world `pending` where `pending` >= 0."""
  return jax.lax.cond(
      pending >= 0,
      lambda: jax.tree.map(lambda p: p[jnp.maximum(pending, 0)], pool_large),
      lambda: large)


@_install.def_vmap
def _install_batched(axis_size, in_batched, pending, large, pool_large):
  """Batched `_install`: only the balloons with a pending world are written.

  One `lax.dynamic_update_slice` per such balloon in a `lax.while_loop`
  that runs zero times when there is none: a select over every balloon
  would copy N forecast grids (~317 kB each) at every step, and XLA's
  scatter on CPU is an element loop. Installed before anything reads the
  state in the step, so XLA updates the buffers in place (no copy).
  """
  pending_b, large_b, pool_b = in_batched

  batch = functools.partial(_broadcast_unbatched, axis_size)
  pending, large = batch(pending, pending_b), batch(large, large_b)
  if any(jax.tree.leaves(pool_b)):  # A pool per balloon: select.
    out = jax.vmap(_install.fun)(pending, large, batch(pool_large, pool_b))
    return out, jax.tree.map(lambda _: True, out)
  def install(large):
    rows = jnp.nonzero(pending >= 0, size=axis_size, fill_value=0)[0]
    count = jnp.sum((pending >= 0).astype(jnp.int32))

    def body(carry):
      i, large = carry
      row = rows[i]
      world = pending[row]
      return i + 1, jax.tree.map(
          lambda w, p: jax.lax.dynamic_update_slice(
              w, jax.lax.dynamic_index_in_dim(p, world).astype(w.dtype),
              (row,) + (0,) * (w.ndim - 1)), large, pool_large)

    return jax.lax.while_loop(lambda c: c[0] < count, body,
                              (jnp.zeros((), jnp.int32), large))[1]

  # Nothing pending (most steps at small N): not even the row search.
  out = jax.lax.cond(jnp.any(pending >= 0), install, lambda large: large,
                     large)
  return out, jax.tree.map(lambda _: True, out)


def install_world(state: env_types.EnvState, params: env_types.EnvParams
                  ) -> env_types.EnvState:
  """`state` with its pending pool world's large parts in place.

  After an auto-reset from `EnvParams.reset_pool`, `step` returns the new
  world's observation and small state leaves at once, and marks its large
  leaves (forecast grid, noise permutations) as pending
  (`EnvState.pending_world`): `step_env` installs them first thing, where
  XLA can write only those balloons' rows in place. Call this to read such
  a state's winds outside `step_env` (e.g. `ground_truth_wind`). A state
  with nothing pending (`pending_world` < 0, every state of `reset` and of
  a step without a pool) is returned as it is.

  Args:
    state: The env state, possibly with a pending world.
    params: The env parameters holding the `reset_pool`.

  Returns:
    The state with the pending world's large leaves installed and
    `pending_world` set to -1.

  Raises:
    ValueError: `params.reset_pool` is None (nothing could be pending).
  """
  pool = params.reset_pool
  if pool is None:
    raise ValueError('install_world needs EnvParams.reset_pool (the pool '
                     'the pending world comes from)')
  leaves, treedef = jax.tree.flatten(state)
  pool_leaves = jax.tree.leaves(pool.state)
  large = [_is_large(x) for x in leaves]
  new = iter(_install(state.pending_world,
                      [x for x, b in zip(leaves, large) if b],
                      [p for p, b in zip(pool_leaves, large) if b]))
  state = treedef.unflatten([next(new) if b else x
                             for x, b in zip(leaves, large)])
  return state.replace(pending_world=jnp.full_like(state.pending_world, -1))


@custom_batching.custom_vmap
def _select_reset(done: Array, index: Array, small: Any,
                  pool_small: Any) -> Any:
  """Each leaf of `small` replaced by row `index` of its [K, ...] pool leaf
  in `pool_small` where `done`."""
  return jax.tree.map(
      lambda x, p: jnp.where(done, p[index], x).astype(x.dtype), small,
      pool_small)


@_select_reset.def_vmap
def _select_reset_batched(axis_size, in_batched, done, index, small,
                          pool_small):
  """Batched `_select_reset`: the same selects, skipped (`lax.cond`) in a
  step where no balloon's episode ended, so that the common step reads and
  writes none of the reset leaves."""
  done_b, index_b, small_b, pool_b = in_batched

  batch = functools.partial(_broadcast_unbatched, axis_size)
  done, index = batch(done, done_b), batch(index, index_b)
  small = batch(small, small_b)
  if any(jax.tree.leaves(pool_b)):  # A pool per balloon: no shared test.
    out = jax.vmap(_select_reset.fun)(done, index, small,
                                      batch(pool_small, pool_b))
  else:
    out = jax.lax.cond(
        jnp.any(done),
        lambda s: jax.vmap(_select_reset.fun, in_axes=(0, 0, 0, None))(
            done, index, s, pool_small),
        lambda s: s, small)
  return out, jax.tree.map(lambda _: True, out)


def _reset_from_pool(done: Array, index: Array, state: env_types.EnvState,
                     obs: Array, pool: env_types.ResetPool
                     ) -> Tuple[env_types.EnvState, Array]:
  """Where `done`: pool world `index`'s small leaves and observation now,
  its large leaves pending (`install_world`); elsewhere unchanged."""
  leaves, treedef = jax.tree.flatten(state)
  pool_leaves = jax.tree.leaves(pool.state)
  small = [not _is_large(x) for x in leaves]
  # `pending_world` becomes `index` (row `index` of 0..K-1).
  pending_at, = [i for i, x in enumerate(leaves)
                 if x is state.pending_world]
  pool_leaves[pending_at] = jnp.arange(pool.size, dtype=jnp.int32)
  new_leaves, new_obs = _select_reset(
      done, index, ([x for x, b in zip(leaves, small) if b], obs),
      ([p for p, b in zip(pool_leaves, small) if b], pool.obs))
  new = iter(new_leaves)
  return (treedef.unflatten([next(new) if b else x
                             for x, b in zip(leaves, small)]), new_obs)


def observation(state: env_types.EnvState, params: env_types.EnvParams,
                wind: winds.Wind = winds.GENERATIVE_WIND) -> Array:
  """The 71 features of `state` (`jax_features` order), float32.

  Args:
    state: The env state (its flight, measured wind and history).
    params: The env parameters (the payload mass).
    wind: Where the forecast columns come from.

  Returns:
    The observation, shape (71,), float32.
  """
  f = state.flight
  column_u, column_v = wind.forecast_column(
      state, f.x_m, f.y_m,
      jnp.asarray(jax_features.PRESSURE_LEVELS, f.x_m.dtype), f.time_s)
  return jax_features.features(
      column_u, column_v, f.x_m, f.y_m, f.altitude_m, f.ascent_rate_mps,
      state.wind_u, state.wind_v, f.helium_mols, f.sand_kg,
      params.flight.payload_kg, f.temperature_k, f.pressure_pa, state.initial,
      state.history)


def measure(state: env_types.EnvState,
            wind: winds.Wind = winds.GENERATIVE_WIND) -> env_types.EnvState:
  """The arena's measurement: the ground-truth wind at the balloon.

  Args:
    state: The env state.
    wind: Where the ground-truth wind comes from.

  Returns:
    `state` with `wind_u`, `wind_v` set to the wind at the balloon.
    # [m/s]
  """
  f = state.flight
  u, v = wind.ground_truth(state, f.x_m, f.y_m, f.pressure_pa, f.time_s)
  return state.replace(wind_u=u, wind_v=v)


def step_info(state: env_types.EnvState, params: env_types.EnvParams,
              invalid_action: Any = False) -> Dict[str, Array]:
  """The numbers behind the envs' `info` after a reset or step (arrays).

  Keys: `distance_km` [km], `altitude_m` [m], `ascent_rate_mps` [m/s],
  `helium_mols` [mol], `sand_kg` [kg], `helium_vented_mols` [mol],
  `sand_dropped_kg` [kg], `decision` (`flight.state.DecisionCode`),
  `status` (`flight.state.FlightStatus`), `time_s` [s], `steps`,
  `volume_m3` (envelope volume [m^3]),
  `time_limit` (steps reached `episode_steps`), `truncated` (time limit
  without a terminal status), `invalid_action` (the step's action had a NaN
  component and was flown as the float action; False after a reset).

  Args:
    state: The env state after the reset or step.
    params: The env parameters (`episode_steps`, the flight system).
    invalid_action: The step's `invalid_action` flag (bool array or
      False).

  Returns:
    The dict above, of arrays.
  """
  f = state.flight
  terminal = f.status != state_lib.FlightStatus.OK
  time_limit = state.steps >= params.episode_steps
  return {'distance_km': jax_features.distance_km(f.x_m, f.y_m),
          'altitude_m': f.altitude_m, 'ascent_rate_mps': f.ascent_rate_mps,
          'helium_mols': f.helium_mols, 'sand_kg': f.sand_kg,
          'helium_vented_mols': f.helium_vented_mols,
          'sand_dropped_kg': f.sand_dropped_kg,
          'decision': f.last_decision, 'status': f.status,
          'time_s': f.time_s, 'steps': state.steps,
          'volume_m3': f.volume_m3(),
          'time_limit': time_limit, 'truncated': time_limit & ~terminal,
          'invalid_action': jnp.broadcast_to(
              jnp.asarray(invalid_action, bool), state.steps.shape)}


# Info keys of the host envs at every step (README, "Environment contract").
INFO_KEYS = ('distance_km', 'altitude_m', 'ascent_rate_mps', 'helium_mols',
             'sand_kg', 'helium_vented_mols', 'sand_dropped_kg',
             'controller_decision', 'out_of_resources', 'envelope_burst',
             'time_limit', 'time_elapsed')


def info_dict(info: Mapping[str, Any]) -> Dict[str, Any]:
  """The host envs' `info` of one balloon from `step_info` numbers.

  Args:
    info: `step_info` of one balloon (arrays or NumPy scalars).

  Returns:
    Python values: INFO_KEYS plus `terminal_reason` (`FlightStatus` name,
    lower case), `out_of_power` and `zeropressure` (False; BLE's eval_lib
    reads them) and `TimeLimit.truncated` where the time limit cut a flight
    that had not ended.
  """
  status = state_lib.FlightStatus(int(info['status']))
  out = {
      'distance_km': float(info['distance_km']),
      'altitude_m': float(info['altitude_m']),
      'ascent_rate_mps': float(info['ascent_rate_mps']),
      'helium_mols': float(info['helium_mols']),
      'sand_kg': float(info['sand_kg']),
      'helium_vented_mols': float(info['helium_vented_mols']),
      'sand_dropped_kg': float(info['sand_dropped_kg']),
      'controller_decision': state_lib.DecisionCode(
          int(info['decision'])).name.lower(),
      'out_of_resources': status in state_lib.OUT_OF_RESOURCES,
      'envelope_burst': status == state_lib.FlightStatus.BURST,
      'time_limit': bool(info['time_limit']),
      'time_elapsed': dt.timedelta(seconds=float(info['time_s'])),
      'terminal_reason': status.name.lower(),
      'out_of_power': False,
      'zeropressure': False,
  }
  if bool(info['truncated']):
    out['TimeLimit.truncated'] = True
  return out


def arena_key(key: Array) -> Array:
  """The arena's key of the env key (BLE's `BalloonEnv.reset` split)."""
  return jax.random.split(key)[1]


class LatexBalloonJaxEnv:
  """Functional `LatexBalloon-v0` (gymnax 1.0's `Environment` contract).

  Args:
    wind: Where the winds come from (static). Default: BLE's generative
      field drawn from the reset key (`GENERATIVE_WIND`).
    normalize_actions: True (default, RL clients' convention): actions are
      in [-1, 1]^3, mapped onto the core's Box by `to_box`, and
      `action_space(params)` is [-1, 1]^3. False: actions are the Box's raw
      (a0 [m], a1, a2) (BLE's arena and the Gymnasium wrappers, which check
      and map actions at their boundary; the jitted trainer).
  """

  action_low = ACTION_LOW  # The core's Box (the raw actions).
  action_high = ACTION_HIGH
  num_features = jax_features.NUM_FEATURES
  num_actions = len(ACTION_LOW)  # gymnax: the action's size.

  def __init__(self, wind: winds.Wind = winds.GENERATIVE_WIND, *,
               normalize_actions: bool = True):
    self.wind = wind
    self.normalize_actions = bool(normalize_actions)

  # Equal envs are one static jit argument: a jitted function of the env
  # (the trainer's round, the planners) compiles once per process, not once
  # per env object.
  def _key(self) -> Tuple[Any, ...]:
    return type(self), self.wind, self.normalize_actions

  def __eq__(self, other: Any) -> bool:
    return (isinstance(other, LatexBalloonJaxEnv) and
            self._key() == other._key())

  def __hash__(self) -> int:
    return hash(self._key())

  def env_action(self, normalized: Array) -> Array:
    """What to give `step`/`step_env` for a [-1, 1]^3 action (`to_box`'d
    here if this env takes raw actions; the env maps it otherwise)."""
    return normalized if self.normalize_actions else to_box(normalized)

  def with_reset_pool(self, key: Array, params: env_types.EnvParams,
                      size: int) -> env_types.EnvParams:
    """`params` with a pool of `size` pre-drawn worlds for `step`'s resets.

    World k is `reset(jax.random.split(key, size)[k], params)` (vmapped, one
    jitted call: `size` VAE decodes, ~0.3 MB each). With the pool, `step`
    auto-resets a finished flight with world `pool_index(key, size)` of the
    step's `key` instead of `reset(key)`'s world, and writes only the
    finished balloons (see `step`). Build it from the params you fly: the
    worlds are drawn with these params' start band, flight system and
    winds. Explicit `reset(key, params)` calls are unchanged.

    Args:
      key: The pool's key.
      params: The env parameters (any pool they hold is replaced).
      size: K >= 1 worlds.

    Returns:
      params.replace(reset_pool=env_types.ResetPool(...)).
    """
    gin_values.check_int('reset pool size', size, minimum=1)
    params = params.replace(reset_pool=None)
    obs, state = jax.jit(jax.vmap(self.reset, in_axes=(0, None)))(
        jax.random.split(key, int(size)), params)
    return params.replace(reset_pool=env_types.ResetPool(obs=obs, state=state))

  @property
  def default_params(self) -> env_types.EnvParams:
    """Parameters from the current gin bindings (defaults where unbound)."""
    return params_from_gin()

  def observation_space(self, params: env_types.EnvParams) -> Any:
    """The 71 features in [-1, 1] (a `gymnasium.spaces.Box`)."""
    del params
    import gymnasium  # pylint: disable=g-import-not-at-top
    return gymnasium.spaces.Box(-1.0, 1.0, (self.num_features,), np.float32)

  def action_space(self, params: env_types.EnvParams) -> Any:
    """[-1, 1]^3 (`normalize_actions`), else (a0 [m], a1, a2) the
    controller's Box; a float32 `gymnasium.spaces.Box`."""
    del params
    import gymnasium  # pylint: disable=g-import-not-at-top
    if self.normalize_actions:
      return gymnasium.spaces.Box(-1.0, 1.0, (self.num_actions,), np.float32)
    return gymnasium.spaces.Box(np.asarray(ACTION_LOW, np.float32),
                                np.asarray(ACTION_HIGH, np.float32),
                                dtype=np.float32)

  def reset(self, key: Array, params: env_types.EnvParams
            ) -> Tuple[Array, env_types.EnvState]:
    """A new flight drawn from `key` (BLE's gym env's `reset(seed=s)` world).

    Args:
      key: `jax.random.PRNGKey(s)` gives the world of the gym env's seed s.
      params: The env parameters.

    Returns:
      (observation [71] float32, state).
    """
    state, _ = self.draw(arena_key(key), params)
    wind = self.wind_for(params)
    state = measure(state, wind)
    return observation(state, params, wind), state

  def wind_for(self, params: env_types.EnvParams) -> winds.Wind:
    """The winds flown under `params`: `era5_wind(params.wind_grid)` if set.

    Raises:
      ValueError: `params.wind_grid` set on an env given another `Wind`.
    """
    if params.wind_grid is None:
      return self.wind
    if self.wind is not winds.GENERATIVE_WIND:
      raise ValueError('EnvParams.wind_grid (ERA5) is set, and the env was '
                       'given another wind; give one of them')
    return winds.era5_wind(params.wind_grid)

  def draw(self, key: Array, params: env_types.EnvParams
           ) -> Tuple[env_types.EnvState, Dict[str, Array]]:
    """The world and balloon of BLE's `arena.reset(key)`, not yet measured.

    Args:
      key: The arena's key (`arena_key(env_key)`).
      params: The env parameters.

    Returns:
      (state with zero measured wind, keys): `keys['wind']` is the key
      BLE's arena gives `WindField.reset`, `keys['location']` the key of
      BLE's `sampling.sample_location` (the station's lat/lng),
      `keys['atmosphere']` the key of BLE's `Atmosphere.reset`.
    """
    rng, atmosphere_key, time_key = jax.random.split(key, 3)
    atmosphere = atmosphere_lib.reset(atmosphere_key)
    start_time = jax.random.choice(time_key, _START_TIME_RANGE_S, ())
    rng, distance_key, angle_key, location_key, altitude_key = (
        jax.random.split(rng, 5))
    radius_km = params.max_start_distance_km * jax.random.beta(
        distance_key, *_START_BETA)
    theta = jax.random.uniform(angle_key, (), minval=0.0,
                               maxval=2.0 * jnp.pi)
    altitude = jax.random.uniform(
        altitude_key, (), minval=params.start_altitude_low_m,
        maxval=params.start_altitude_high_m)
    _, wind_key = jax.random.split(rng, 2)
    noise_key, forecast_key = generative.split_wind_key(wind_key)
    noise_u, noise_v = simplex.reset_uv_noise_params(noise_key)
    if params.wind_grid is None:
      forecast = generative.reset_forecast(forecast_key, params.decoder)
    else:  # ERA5: `Era5WindField.reset_forecast`'s start, no VAE forecast.
      forecast = None
      start_time = winds.era5_start_offset_s(params.wind_grid, forecast_key)

    # Realistic physics' burst draw: a key of its own (folded in, so the
    # paper's draws above are unchanged); unused unless burst_spread.
    flight = state_lib.initial_state(
        params.flight, altitude, jnp.cos(theta) * radius_km * 1000.0,
        jnp.sin(theta) * radius_km * 1000.0, atm_params=atmosphere,
        key=(jax.random.fold_in(key, _BURST_KEY_DATA)
             if params.flight.burst_spread else None))
    state = env_types.EnvState(
        flight=flight, atmosphere=atmosphere, forecast=forecast,
        noise_u=noise_u, noise_v=noise_v,
        initial=jax_features.initial_resources(
            params.flight.payload_kg, flight.sand_kg, flight.helium_mols),
        history=jax_features.init_history(flight.altitude_m,
                                          flight.ascent_rate_mps),
        wind_u=jnp.zeros_like(altitude), wind_v=jnp.zeros_like(altitude),
        start_time_offset_s=start_time.astype(jnp.int32),
        steps=jnp.zeros((), jnp.int32),
        pending_world=jnp.full((), -1, jnp.int32))
    return state, {'wind': wind_key, 'location': location_key,
                   'atmosphere': atmosphere_key}

  def step_env(self, key: Array, state: env_types.EnvState, action: Array,
               params: env_types.EnvParams
               ) -> Tuple[Array, env_types.EnvState, Array, Array,
                          Dict[str, Array]]:
    """One 20-minute controller action, without auto-reset.

    Args:
      key: Unused (the world is fixed at reset, realistic physics' lift
        random walk included: `walk_key`); gymnax's signature.
      state: The env state; a finished flight stays as it is.
      action: (a0 desired altitude [m], a1 time factor, a2 float flag),
        clipped into the Box, without `normalize_actions`; with it, in
        [-1, 1]^3, clipped there and mapped onto the Box (`to_box`). An
        action with a NaN component is flown as the float action
        (`info['invalid_action']`).
      params: The env parameters.

    Returns:
      (observation, state, reward, terminated, info): `terminated` is a
      terminal status (out of sand or helium, burst, grounded); `info` is
      `step_info` (its `truncated` is the time limit without one).
    """
    wind = self.wind_for(params)
    if params.reset_pool is not None:
      state = install_world(state, params)
    before = state.flight
    if self.normalize_actions:
      action = to_box(action)
    action, invalid = controller_lib.float_if_nan(
        jnp.asarray(action, before.altitude_m.dtype), before.altitude_m)
    action = jnp.clip(action, ACTION_LOW, ACTION_HIGH)

    def wind_fn(x_m, y_m, pressure_pa, t_s):
      return wind.ground_truth(state, x_m, y_m, pressure_pa, t_s)

    flight = dynamics.step(
        env_types.flight_params_of(params, state), state.atmosphere, before,
        action, wind_fn, params.stride_s,
        key=env_types.walk_key(state) if params.flight.lift_walk else None)
    state = state.replace(
        flight=flight,
        # The state after the step becomes history slot t-1 (jax_features).
        history=jax_features.push_history(state.history, flight.altitude_m,
                                          flight.ascent_rate_mps, action[2]),
        steps=state.steps + 1)
    state = measure(state, wind)
    info = step_info(state, params, invalid_action=invalid)
    reward = jax_features.reward(
        info['distance_km'], params.radius_km, params.reward_dropoff,
        params.reward_halflife_km,
        flight.helium_vented_mols - before.helium_vented_mols,
        flight.sand_dropped_kg - before.sand_dropped_kg,
        params.helium_penalty_per_mol, params.sand_penalty_per_kg)
    terminated = flight.status != state_lib.FlightStatus.OK
    return (observation(state, params, wind), state, reward, terminated,
            info)

  def step(self, key: Array, state: env_types.EnvState, action: Array,
           params: env_types.EnvParams
           ) -> Tuple[Array, env_types.EnvState, Array, Array, Array,
                      Dict[str, Any]]:
    """`step_env`, then a new flight where the episode ended (auto-reset).

    gymnax 1.0's auto-reset: the returned observation and state are the new
    flight's where the episode ended (terminated or truncated); reward,
    terminated, truncated and info are the finished step's, and
    `info['final_observation']` is its observation.

    Which world the new flight is:
    - `params.reset_pool` None: `reset(key, params)`'s world (the world of
      an explicit reset with the step's key). Under `jax.vmap` this reset
      (VAE decode included) is computed for every balloon at every step,
      ~7x the cost of `step_env`.
    - a `ResetPool` (`with_reset_pool`): world `pool_index(key, K)` of the
      pool, i.e. `reset(jax.random.split(pool_key, K)[pool_index(key, K)])`.
      The observation and the small state leaves are the world's at once;
      its large leaves (forecast grid, noise permutations) are pending and
      installed at the start of the next `step_env` (`install_world`), where
      under `jax.vmap` only those balloons' rows are written: a step costs
      about `step_env`'s. Auto-reset worlds then repeat (K of them);
      explicit `reset` calls still draw from their key.

    Args:
      key: The step's PRNG key (and the new flight's world, see above).
      state: The env state.
      action: As in `step_env` (raw Box, or [-1, 1]^3 with
        `normalize_actions`).
      params: The env parameters.

    Returns:
      (observation, state, reward, terminated, truncated, info): the new
      flight's observation and state where the episode ended; reward,
      terminated, truncated and info (with `final_observation`) of the
      finished step.

    Raises:
      ValueError: `params.wind_grid` set on an env given another `Wind`
        (`wind_for`).
    """
    obs, state, reward, terminated, info = self.step_env(key, state, action,
                                                         params)
    truncated = info['truncated']
    done = terminated | truncated
    pool = params.reset_pool
    if pool is None:
      reset_obs, reset_state = self.reset(key, params)
      state = jax.tree.map(lambda r, s: jnp.where(done, r, s), reset_state,
                           state)
      new_obs = jnp.where(done, reset_obs, obs)
    else:
      state, new_obs = _reset_from_pool(done, pool_index(key, pool.size),
                                        state, obs, pool)
    info = {**info, 'final_observation': obs}
    return new_obs, state, reward, terminated, truncated, info


# The gin binding of each `EnvParams` value (the flight system's are in
# `flight.params`), for messages.
_BINDINGS = {
    'radius_km': 'perciatelli_reward_function.station_keeping_radius_km',
    'reward_dropoff': 'perciatelli_reward_function.reward_dropoff',
    'reward_halflife_km': 'perciatelli_reward_function.reward_halflife',
    'helium_penalty_per_mol': 'latex_reward.helium_penalty_per_mol',
    'sand_penalty_per_kg': 'latex_reward.sand_penalty_per_kg',
    'start_altitude_low_m': 'LatexBalloonArena.start_altitude_range_m',
    'start_altitude_high_m': 'LatexBalloonArena.start_altitude_range_m',
    'max_start_distance_km': 'LatexBalloonArena.max_start_distance_km',
    'stride_s': 'LatexBalloonArena.stride',
    'episode_steps': 'LatexBalloonEnv.episode_steps',
}
# Start altitudes must lie in (0, top of the atmosphere model): 0 m is the
# ground (`GROUNDED`), and BLE's standard atmosphere is defined below 85 km
# (its last layer boundary; BLE asserts above). The burst check
# (`start_volume_m3`) bounds the band far lower for a real balloon (~31 km
# with the default helium). # [m]
START_ALTITUDE_MAX_M = atmosphere_lib.HEIGHT_TRANSITIONS_M[-1]
# Atmosphere blends alpha at which the start volume is checked (BLE draws
# alpha uniform in [0, 1)).
_CHECK_ALPHAS = (0.0, 0.25, 0.5, 0.75, 1.0)


def start_volume_m3(flight: flight_params_lib.FlightParams,
                    altitude_m: float) -> float:
  """The largest envelope volume of a new balloon at `altitude_m`. # [m^3]

  V = nRT/P (`physics.volume`) of the launch helium (`initial_helium_mols`,
  or neutral buoyancy) in BLE's atmosphere at that height, the largest over
  the atmosphere blends `_CHECK_ALPHAS`. On the host, before the env
  compiles (`_start_volumes`).

  Args:
    flight: The flight system (payload, initial helium and sand).
    altitude_m: The start altitude. # [m]

  Returns:
    The largest start volume over the atmosphere blends. # [m^3]
  """
  helium = flight.initial_helium_mols
  if helium is None:
    helium = physics.neutral_helium_mols(flight.payload_kg,
                                         flight.initial_sand_kg)
  volume = _start_volumes_compiled()(np.float32(helium), np.float32(altitude_m))
  return float(np.max(np.asarray(volume)))


@functools.lru_cache(maxsize=None)
def _start_volumes_compiled() -> Callable[..., jax.Array]:
  """`_start_volumes` jitted (with the envs' fast compile options)."""
  return jax.jit(_start_volumes,
                 compiler_options=jax_cache.fast_compile_options())


def _start_volumes(helium: jax.Array, altitude_m: jax.Array) -> jax.Array:
  """`physics.volume` of `helium` at `altitude_m` per `_CHECK_ALPHAS`.

  One small compiled program (~0.1 s), where running it op by op compiled
  every primitive separately (~3 s on 2 busy cores at the first `make`).
  """
  ambient = jax.vmap(lambda alpha: atmosphere_lib.at_height(
      atmosphere_lib.params_from_alpha(alpha), altitude_m))(
          jnp.asarray(_CHECK_ALPHAS))
  return physics.volume(helium, ambient.temperature, ambient.pressure)


def start_band(value: Any) -> Tuple[Any, Any]:
  """`LatexBalloonArena.start_altitude_range_m` as a (low, high) pair.

  Raises:
    ValueError: Not a pair (its values are checked by `check_params`).
  """
  gin_values.require(
      isinstance(value, (tuple, list)) and len(value) == 2,
      f'gin binding {_BINDINGS["start_altitude_low_m"]}',
      '(low, high) start altitudes [m]', value)
  return value[0], value[1]


def check_params(params: env_types.EnvParams) -> env_types.EnvParams:
  """Checks every value of `EnvParams` (one validator for every path).

  Called where `EnvParams` is built (`params_from_gin`) and where params are
  given as they are (the Gymnasium envs of `gymnasium_env`, hence BLE's
  arena too). On the host, before any
  compilation: the flight system (`flight.params.check_flight_params`), the
  reward (`gin_values.check_reward_values`), the start band (finite, low <=
  high, inside (0, `START_ALTITUDE_MAX_M`)), `max_start_distance_km` (> 0),
  `episode_steps` (an int >= 1), the stride (>= 1 s; the physics sub-step,
  vertical step and release chunk no longer than it), the launch volume
  below the burst volume anywhere in the start band (`start_volume_m3`),
  and an ERA5 `wind_grid` (`check_wind_grid`).

  Returns:
    The params with Python floats (and an int `episode_steps`).

  Raises:
    ValueError: Naming the gin binding of the first bad value, e.g.
      "gin binding create_state.helium_mols = 1000000.0: the balloon would
      start at 329000 m^3 at 20000 m, above create_state.burst_volume_m3 =
      336.5".
  """
  def name(field: str) -> str:
    return f'gin binding {_BINDINGS[field]}'

  p = params
  flight_params_lib.check_flight_params(p.flight)
  gin_values.check_reward_values(
      {'helium_penalty_per_mol': p.helium_penalty_per_mol,
       'sand_penalty_per_kg': p.sand_penalty_per_kg},
      {'station_keeping_radius_km': p.radius_km,
       'reward_dropoff': p.reward_dropoff,
       'reward_halflife': p.reward_halflife_km})
  band = (p.start_altitude_low_m, p.start_altitude_high_m)
  within = f'in (0, {START_ALTITUDE_MAX_M:g}) m (above the ground, inside '
  within += 'the atmosphere model)'
  gin_values.require(
      all(gin_values.is_number(h) and 0.0 < float(h) < START_ALTITUDE_MAX_M
          for h in band) and float(band[0]) <= float(band[1]),
      name('start_altitude_low_m'), '(low, high) with low <= high, both '
      + within, band)
  gin_values.check_number(name('max_start_distance_km'),
                          p.max_start_distance_km, above=0.0)
  gin_values.check_int(name('episode_steps'), p.episode_steps, minimum=1)
  stride = flight_params_lib.seconds(p.stride_s, name('stride_s'))
  for field in ('max_substep_s', 'vertical_step_s', 'actuation_chunk_s'):
    gin_values.check_number(
        flight_params_lib.binding(field), getattr(p.flight, field),
        minimum=flight_params_lib.MIN_DURATION_S, maximum=stride,
        why=f': a step cannot be longer than {_BINDINGS["stride_s"]} '
        f'({stride:g} s)')
  top = float(band[1])
  volume = start_volume_m3(p.flight, top)
  burst = float(p.flight.burst_volume_m3)
  if not volume < burst:
    helium = p.flight.initial_helium_mols
    what = (f'{flight_params_lib.binding("initial_helium_mols")} = {helium!r}'
            if helium is not None else
            f'{name("start_altitude_high_m")} = {tuple(band)!r} (helium '
            'neutrally buoyant)')
    raise errors.ConfigError(
        f'{what}: the balloon would start at {volume:.4g} m^3 at {top:g} m, '
        f'above {flight_params_lib.gin_name("burst_volume_m3")} = '
        f'{burst:g} (it would burst at once)')
  if p.wind_grid is not None:
    check_wind_grid(p.wind_grid)
  floats = ('radius_km', 'reward_dropoff', 'reward_halflife_km',
            'helium_penalty_per_mol', 'sand_penalty_per_kg',
            'start_altitude_low_m', 'start_altitude_high_m',
            'max_start_distance_km')
  return p.replace(episode_steps=int(p.episode_steps), stride_s=stride,
                   **{f: float(getattr(p, f)) for f in floats})


# Grids `check_wind_grid` passed, by the ids of their arrays (kept alive
# here so an id is never reused): a grid is checked once, not at every env.
_CHECKED_GRIDS: Dict[Tuple[int, ...], Tuple[Any, ...]] = {}


def check_wind_grid(grid: Any) -> None:
  """Checks `EnvParams.wind_grid` on the host (one line per fault).

  An `era5_jax.Era5Grid` with 1-D axes of >= 2 finite, strictly ascending
  values (time from 0), winds of shape (time, pressure, latitude,
  longitude, 2), finite and below `era5.MAX_WIND_MPS`, finite target and
  origin values, and a start range 0 <= first <= last inside the time
  axis. Grids from `era5_jax.grid_from_data` pass (the reader checked the
  file); this catches grids built or edited by hand.

  Raises:
    errors.ConfigError: Naming the field, e.g. "EnvParams.wind_grid.uv has
      shape (3, 4, 5, 5, 2), expected (time 3, pressure 4, latitude 5,
      longitude 6, 2)".
  """
  what = 'EnvParams.wind_grid'
  if not isinstance(grid, era5_jax.Era5Grid):
    raise errors.ConfigError(f'{what} must be an era5_jax.Era5Grid '
                             f'(era5_jax.grid_from_data) or None, got '
                             f'{type(grid).__name__}')
  leaves = tuple(jax.tree.leaves(grid)) + (grid.add_noise,)
  key = tuple(id(leaf) for leaf in leaves)
  seen = _CHECKED_GRIDS.get(key)
  if seen is not None and all(a is b for a, b in zip(seen, leaves)):
    return
  axes = {}
  for name in ('time_s', 'pressure_pa', 'latitude', 'longitude'):
    axis = np.asarray(jax.device_get(getattr(grid, name)), np.float64)
    if axis.ndim != 1 or axis.size < 2:
      raise errors.ConfigError(f'{what}.{name} must be 1-D with >= 2 values, '
                               f'got shape {axis.shape}')
    if not np.all(np.isfinite(axis)):
      raise errors.ConfigError(f'{what}.{name} holds non-finite values')
    if not np.all(np.diff(axis) > 0):
      raise errors.ConfigError(f'{what}.{name} must be strictly ascending')
    axes[name] = axis
  if axes['time_s'][0] != 0.0:
    raise errors.ConfigError(f'{what}.time_s must start at 0 (seconds after '
                             f"the data's first time), got "
                             f'{axes["time_s"][0]:g}')
  if axes['pressure_pa'][0] <= 0.0:
    raise errors.ConfigError(f'{what}.pressure_pa must be > 0 Pa, got '
                             f'{axes["pressure_pa"][0]:g}')
  expected = tuple(a.size for a in axes.values()) + (2,)
  if tuple(grid.uv.shape) != expected:
    raise errors.ConfigError(
        f'{what}.uv has shape {tuple(grid.uv.shape)}, expected (time '
        f'{expected[0]}, pressure {expected[1]}, latitude {expected[2]}, '
        f'longitude {expected[3]}, 2)')
  uv = np.asarray(jax.device_get(grid.uv))
  if not np.all(np.isfinite(uv)):
    raise errors.ConfigError(f'{what}.uv holds non-finite winds')
  if np.max(np.abs(uv)) > era5.MAX_WIND_MPS:
    raise errors.ConfigError(
        f'{what}.uv holds |wind| {np.max(np.abs(uv)):.4g} m/s, above '
        f'{era5.MAX_WIND_MPS:g} m/s')
  for name in ('latitude_origin', 'longitude_origin', 'sin_center_lat',
               'cos_center_lat', 'center_lon'):
    value = np.asarray(jax.device_get(getattr(grid, name)))
    if value.shape != () or not np.isfinite(value):
      raise errors.ConfigError(f'{what}.{name} must be a finite scalar, got '
                               f'{value!r}')
  first, last = (np.asarray(jax.device_get(grid.first_start_minute)),
                 np.asarray(jax.device_get(grid.last_start_minute)))
  span_min = axes['time_s'][-1] / 60.0
  if (first.shape != () or last.shape != () or
      not 0 <= int(first) <= int(last) <= span_min):
    raise errors.ConfigError(
        f'{what}: start minutes [{first}, {last}] must satisfy 0 <= first '
        f'<= last <= {span_min:g} (the time axis)')
  if len(_CHECKED_GRIDS) >= 8:
    _CHECKED_GRIDS.clear()
  _CHECKED_GRIDS[key] = leaves


# The gin names of `EnvParams` (besides the flight system's, `flight.params`,
# and BLE's own `perciatelli_reward_function.*`, read where BLE registers
# it): the configurables below take the gin names of the classes that once
# held them, so existing gin files and commands keep working. Their defaults
# are `EnvParams`' field defaults, the one home of each.
_GIN_MODULE = 'ble_latex.envs.jax_env'
_DEFAULTS = {f.name: f.default for f in dataclasses.fields(env_types.EnvParams)
             if f.default is not dataclasses.MISSING}


@gin.configurable('latex_reward', module=_GIN_MODULE)
def resource_penalties(
    *, helium_penalty_per_mol: float = _DEFAULTS['helium_penalty_per_mol'],
    sand_penalty_per_kg: float = _DEFAULTS['sand_penalty_per_kg']
) -> Dict[str, Any]:
  """The reward's resource penalties (gin `latex_reward.*`).

  Args:
    helium_penalty_per_mol: Reward penalty per mol vented. # [1/mol]
    sand_penalty_per_kg: Reward penalty per kg dropped. # [1/kg]

  Returns:
    The values by `EnvParams` field (unchecked).
  """
  return dict(locals())  # The arguments above, by name.


@gin.configurable('LatexBalloonArena', module=_GIN_MODULE)
def start(*, start_altitude_range_m: Tuple[float, float] = (
    _DEFAULTS['start_altitude_low_m'], _DEFAULTS['start_altitude_high_m']),
          max_start_distance_km: float = _DEFAULTS['max_start_distance_km'],
          stride: Any = _DEFAULTS['stride_s']) -> Dict[str, Any]:
  """Where flights start and the stride (gin `LatexBalloonArena.*`).

  Args:
    start_altitude_range_m: (low, high) band of the start altitude. # [m]
    max_start_distance_km: Scale of the Beta start distance. # [km]
    stride: Simulated time per action (timedelta or seconds). # [s]

  Returns:
    The values by `EnvParams` field (unchecked but the band's shape).
  """
  low, high = start_band(start_altitude_range_m)
  return dict(start_altitude_low_m=low, start_altitude_high_m=high,
              max_start_distance_km=max_start_distance_km,
              stride_s=stride_seconds(stride))


@gin.configurable('LatexBalloonEnv', module=_GIN_MODULE)
def episode(*, episode_steps: int = _DEFAULTS['episode_steps'],
            station_keeping_radius_km: float = _DEFAULTS[
                'station_keeping_radius_km'],
            wind_field_factory: Optional[Callable[[], Any]] = None
            ) -> Dict[str, Any]:
  """The episode (gin `LatexBalloonEnv.*`).

  Args:
    episode_steps: Strides per episode (the time limit).
    station_keeping_radius_km: TW50 radius. # [km]
    wind_field_factory: None: BLE's generative field inside the core; else
      a factory of a BLE `WindField` (e.g. ERA5) that the single-balloon
      envs fly through host callbacks. Not an `EnvParams` value.

  Returns:
    `episode_steps` and `station_keeping_radius_km` by `EnvParams` field
    (unchecked) and `wind_field_factory`.
  """
  return dict(locals())  # The arguments above, by name.


def params_from_gin() -> env_types.EnvParams:
  """`EnvParams` from the gin bindings (the defaults where unbound).

  The configurables above, the flight system's
  (`flight.params.flight_params_from_gin`) and BLE's
  `balloon_env.perciatelli_reward_function.*`, read without importing BLE
  (a configurable whose module is not imported has no bindings,
  `ble_latex.gin_values`), so the JAX and Gymnasium envs stay free of BLE's
  balloon/env modules and TensorFlow.

  Raises:
    ValueError: A bad bound value, naming its gin binding (`check_params`).
  """
  ble = gin_values.imported_bindings(
      'balloon_learning_environment.env.balloon_env',
      'perciatelli_reward_function',
      {'station_keeping_radius_km': _DEFAULTS['radius_km'],
       'reward_dropoff': _DEFAULTS['reward_dropoff'],
       'reward_halflife': _DEFAULTS['reward_halflife_km']})
  values = episode()
  grid = winds.era5_grid_from_gin(values.pop('wind_field_factory'))
  params = check_params(env_types.EnvParams(
      flight=flight_params_lib.flight_params_from_gin(), decoder=None,
      radius_km=ble['station_keeping_radius_km'],
      reward_dropoff=ble['reward_dropoff'],
      reward_halflife_km=ble['reward_halflife'],
      **resource_penalties(), **start(), **values, wind_grid=grid))
  return params.replace(decoder=generative.decoder_params())


def stride_seconds(value: Any) -> float:
  """`LatexBalloonArena.stride` (timedelta or seconds) in seconds, checked."""
  return flight_params_lib.seconds(value,
                                   f'gin binding {_BINDINGS["stride_s"]}')


@functools.partial(jax.jit, static_argnums=(0, 4))
def rollout(env: LatexBalloonJaxEnv, keys: Array, actions: Array,
            params: env_types.EnvParams, num_steps: int
            ) -> Tuple[Array, Array, Array]:
  """Flies N balloons for `num_steps` strides in one jitted call.

  Args:
    env: The env (static).
    keys: [N] reset keys (`jax.random.PRNGKey(s)`: the gym env's seed s).
    actions: [num_steps, N, 3] actions, or [N, 3] held for every step.
    params: The env parameters.
    num_steps: Strides to fly (static).

  Returns:
    (observations [num_steps + 1, N, 71], rewards [num_steps, N], done
    [num_steps, N]: terminated or time limit); episodes that end are not
    reset (`step_env`).
  """
  obs0, state = jax.vmap(env.reset, in_axes=(0, None))(keys, params)
  if actions.ndim == 2:
    actions = jnp.broadcast_to(actions, (num_steps,) + actions.shape)

  def one(state, action):
    obs, state, reward, terminated, info = jax.vmap(
        env.step_env, in_axes=(0, 0, 0, None))(keys, state, action, params)
    return state, (obs, reward, terminated | info['time_limit'])

  _, (obs, rewards, done) = jax.lax.scan(one, state, actions)
  return jnp.concatenate([obs0[None], obs]), rewards, done
