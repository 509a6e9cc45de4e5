# coding=utf-8
"""`LatexBalloon-v0` as a functional, batched JAX env (gymnax 1.0 style).

  import jax
  from ble_latex.envs import jax_env

  env = jax_env.LatexBalloonJaxEnv()   # actions in [-1, 1]^3
  params = env.default_params          # gin-bound constants
  # Optional: auto-reset from 256 pre-drawn worlds (cheap `step`).
  params = env.with_reset_pool(jax.random.PRNGKey(1), params, 256)
  keys = jax.random.split(jax.random.PRNGKey(0), 1024)
  obs, state = jax.vmap(env.reset, in_axes=(0, None))(keys, params)
  obs, state, reward, terminated, truncated, info = jax.vmap(
      env.step, in_axes=(0, 0, 0, None))(keys, state, actions, params)

gymnax 1.0's contract: `reset(key, params) -> (obs, state)`;
`step(key, state, action, params) -> (obs, state, reward, terminated,
truncated, info)` resets a finished episode (gymnax's key split: `key,
key_reset = jax.random.split(key)`; the world of `reset(key_reset)`, or with
`EnvParams.reset_pool` a world of the pool; the finished step's observation
in `info['final_observation']`); `step_env` is the step without reset,
`(obs, state, reward, terminated, info)`. All are pure: jit them, vmap them
over balloons, scan them over time (`rollout`). `terminated`: out of sand
or helium, burst or grounded; `truncated`: the time limit
(`EnvParams.episode_steps`, gymnax's `max_steps_in_episode`) without a
terminal status. `observation_space(params)`, `action_space(params)`,
`num_actions` and `default_params` are gymnax's names.

The env's parts, one concern each (as gymnax and jumanji split an env):
`env_types` (`EnvParams`, `EnvState`, `ResetPool`), `env_params` (gin and
the checks of every `EnvParams` value), `winds` (the `Wind` adapters:
BLE's generative field, ERA5), `reset_pool` (the auto-reset pool); this
module holds the env itself, its observation and info, the one action
mapping `to_box` and `rollout`.

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
at their boundary; +-inf clip onto the Box's edges), and an action with any
NaN component, which no clipping can place, is flown as the float (hold)
action (clip(h), 1, +1) (`flight.controller.float_if_nan`), flagged by
`info['invalid_action']`, so NaN never reaches the state or the features.
The winds are `winds.GENERATIVE_WIND` unless a `winds.Wind` is given (BLE's
other wind fields fly through host callbacks, `ble_latex.ble.wind`) or the
params hold an ERA5 grid (`EnvParams.wind_grid`, `winds.era5_wind`: ERA5
plus BLE's simplex noise, the paper's winds, shared by all balloons);
everything runs in JAX's default float32 (see docs/jax-env.md).
"""

import datetime as dt
import functools
from typing import Any, Dict, Mapping, Optional, Tuple

import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import gin_values
from ble_latex.envs import env_params
from ble_latex.envs import env_types
from ble_latex.envs import jax_features
from ble_latex.envs import observed_sun_gas
from ble_latex.envs import observed_winds
from ble_latex.envs import reset_pool
from ble_latex.envs import rollout as rollout_lib
from ble_latex.envs import winds
from ble_latex.flight import atmosphere as atmosphere_lib
from ble_latex.flight import controller as controller_lib
from ble_latex.flight import dynamics
from ble_latex.flight import launch as launch_lib
from ble_latex.flight import state as state_lib
from ble_latex.wind import generative
from ble_latex.wind import gridded_jax
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
# Per-seed stations (issue 45): the station's key is folded out of the
# arena key with this, so every other draw stays as it was.
_STATION_KEY_DATA = 45_001
# Folded into the arena key for a flight's truth member (`gridded_jax.
# draw_truth_member`): eval seed s flies the same member on any file.
_TRUTH_MEMBER_KEY_DATA = 64_001


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


def observation(state: env_types.EnvState, params: env_types.EnvParams,
                wind: winds.Wind = winds.GENERATIVE_WIND) -> Array:
  """The features of `state` (`jax_features` order), float32.

  Args:
    state: The env state (its flight, measured wind and history).
    params: The env parameters (the payload mass, the observation's
      options).
    wind: Where the forecast columns come from.

  Returns:
    The observation, shape (`env_params.num_features(params)`,) (71 by
    default), float32; its wind column corrected by the measured winds
    where `params.wind_memory` > 0 and averaged over drifts where
    `params.wind_lookahead` > 0 (`observed_winds.column`); the sun's and
    the gas's features appended where `params.sun` / `gas_temperature`
    (`observed_sun_gas`).
  """
  levels = jnp.asarray(jax_features.PRESSURE_LEVELS, state.flight.x_m.dtype)
  column_u, column_v = observed_winds.column(state, params, wind, levels)
  return observation_of_column(state, params, column_u, column_v)


def observation_of_column(state: env_types.EnvState,
                          params: env_types.EnvParams, column_u: Array,
                          column_v: Array) -> Array:
  """`observation` of `state` given its wind column (u, v at each of
  `jax_features.PRESSURE_LEVELS` [m/s]): the column's features are read
  against the balloon's position and measured wind in `state`, the options'
  features (`observed_sun_gas`) appended."""
  f = state.flight
  features = jax_features.features(
      column_u, column_v, f.x_m, f.y_m, f.altitude_m, f.ascent_rate_mps,
      state.wind_u, state.wind_v, f.helium_mols, f.sand_kg,
      params.flight.payload_kg, f.temperature_k, f.pressure_pa, state.initial,
      state.history)
  if not (params.sun or params.gas_temperature):
    return features
  return jnp.concatenate([features,
                          observed_sun_gas.features(state, params)])


def measure(state: env_types.EnvState,
            wind: winds.Wind = winds.GENERATIVE_WIND) -> env_types.EnvState:
  """The arena's measurement: the ground-truth wind at the balloon.

  Args:
    state: The env state.
    wind: Where the ground-truth wind comes from.

  Returns:
    `state` with `wind_u`, `wind_v` set to the wind at the balloon, which
    its `wind_memory` (if any) remembers (`observed_winds.remember`).
    # [m/s]
  """
  f = state.flight
  u, v = wind.ground_truth(state, f.x_m, f.y_m, f.pressure_pa, f.time_s)
  return observed_winds.remember(state.replace(wind_u=u, wind_v=v), wind)


def stride_state(state: env_types.EnvState, flight: Any,
                 action: Array) -> env_types.EnvState:
  """`state` after a stride that flew `action` (the Box's) to `flight`: the
  state after it becomes history slot t-1 (`jax_features.push_history`) and
  the step count grows; its measured wind is not yet set (`measure`)."""
  return state.replace(
      flight=flight,
      history=jax_features.push_history(state.history, flight.altitude_m,
                                        flight.ascent_rate_mps, action[2]),
      steps=state.steps + 1)


def stride_reward(params: env_types.EnvParams, before: Any,
                  after: Any) -> Array:
  """The env's reward of a stride from flight `before` to `after`
  (`jax_features.reward`: BLE's Perciatelli reward at the distance reached
  minus the penalties of the helium vented and sand dropped on the way)."""
  return jax_features.reward(
      jax_features.distance_km(after.x_m, after.y_m), params.radius_km,
      params.reward_dropoff, params.reward_halflife_km,
      after.helium_vented_mols - before.helium_vented_mols,
      after.sand_dropped_kg - before.sand_dropped_kg,
      params.helium_penalty_per_mol, params.sand_penalty_per_kg,
      params.reward_tanh_scale_km)


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


def place(world: env_types.EnvState, params: env_types.EnvParams, *,
          x_m: Any, y_m: Any, altitude_m: Any, time_s: Any = 0.0,
          burst_key: Optional[Array] = None,
          wind: Optional[winds.Wind] = None) -> env_types.EnvState:
  """A new balloon placed in a drawn world (its position, altitude and time).

  The balloon of `flight.state.initial_state` (the params' sand; their
  helium, or neutral buoyancy) at (x, y, altitude), its flight clock at
  `time_s` (the winds, BLE's noise and the sun read the flight time),
  refilled neutral in the gas of the bound physics
  (`flight.launch.neutral_launch`, issue 44) when the helium follows the sun
  or the latex holds overpressure; its resource references and feature
  history start there, `steps` 0. `draw` places its Beta-distributed start
  with it; the launch planner (`launch.scoring.launch_state`) places each
  candidate launch.

  Args:
    world: A drawn world (`draw`'s state; its atmosphere, forecast, noise,
      start time and station are kept, its balloon replaced).
    params: The env parameters.
    x_m: Offset east of the station. # [m]
    y_m: Offset north of the station. # [m]
    altitude_m: Start altitude. # [m]
    time_s: The flight clock at the start (a launch delay). # [s]
    burst_key: The burst diameter's key (used only when
      `params.flight.burst_spread`).
    wind: Measure the balloon's wind with it (`measure`); None: left zero
      (`draw`: the host envs measure through their own winds).

  Returns:
    The env state.
  """
  flight = state_lib.initial_state(
      params.flight, altitude_m, x_m, y_m, atm_params=world.atmosphere,
      time_s=time_s,
      key=burst_key if params.flight.burst_spread else None)
  zero = jnp.zeros_like(flight.altitude_m)
  state = world.replace(flight=flight, wind_u=zero, wind_v=zero,
                        wind_memory=observed_winds.start(params, zero.dtype),
                        steps=jnp.zeros((), jnp.int32),
                        pending_world=jnp.full((), -1, jnp.int32))
  if (params.flight.gas_superheat or params.flight.latex_overpressure or
      params.flight.gas_state):
    flight = launch_lib.neutral_launch(
        env_types.flight_params_of(params, state), world.atmosphere, flight)
  state = state.replace(
      flight=flight,
      initial=jax_features.initial_resources(
          params.flight.payload_kg, flight.sand_kg, flight.helium_mols),
      history=jax_features.init_history(flight.altitude_m,
                                        flight.ascent_rate_mps))
  return state if wind is None else measure(state, wind)


def station_of(key: Array, grid: Any) -> Array:
  """A flight's per-seed station from its arena key (`gridded_jax`'s draw).

  Args:
    key: The arena key (`arena_key(env_key)`).
    grid: A `gridded_jax.Era5Grid` with a `station_box`.

  Returns:
    [2] (latitude [deg N], longitude [deg E]). # [deg]
  """
  return gridded_jax.draw_station(grid, jax.random.fold_in(key,
                                                           _STATION_KEY_DATA))


def flight_stations(params: env_types.EnvParams,
                    seeds: Any) -> Any:
  """The station (lat, lon) of each env seed's flight under `params`, or None.

  What `reset(PRNGKey(seed), params)` flies around, for records: per-seed
  stations drawn as `draw` draws them, the fixed target otherwise (a
  sounding's: its centre); None on BLE's winds (no lat/lon).

  Args:
    params: The env params (their `wind_grid`).
    seeds: Env seeds (ints in [0, 2**32)).

  Returns:
    [N, 2] float64 (latitude [deg N], longitude [deg E] in -180..180), or
    None. # [deg]
  """
  grid = params.wind_grid
  if grid is None:
    return None
  seeds = np.asarray(seeds, np.uint32).reshape(-1)
  if grid.station_box is None:
    lat, lon = jax.device_get(gridded_jax.latlng(grid, 0.0, 0.0))
    out = np.tile([float(lat), float(lon)], (seeds.size, 1))
  else:
    out = np.asarray(jax.device_get(jax.jit(jax.vmap(
        lambda s: station_of(arena_key(jax.random.PRNGKey(s)), grid)))(
            seeds)), np.float64).reshape(-1, 2)
  out[:, 1] = (out[:, 1] + 180.0) % 360.0 - 180.0
  return out


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
  # Without the observation options (`observation_space(params)` has them).
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
    jitted call: `size` VAE decodes, ~0.33 MB each). With the pool, `step`
    auto-resets a finished flight with world `pool_index(key_reset, size)`
    of the step's reset key instead of `reset(key_reset)`'s world, and
    writes only the finished balloons (see `step`). Build it from the params
    you fly: the worlds are drawn with these params' start band, flight
    system and winds. Explicit `reset(key, params)` calls are unchanged.

    Args:
      key: The pool's key.
      params: The env parameters (any pool they hold is replaced).
      size: K worlds, 1 <= K <= `reset_pool.MAX_POOL_SIZE`.

    Returns:
      params.replace(reset_pool=env_types.ResetPool(...)).

    Raises:
      errors.ConfigError: `size` not an int in [1, MAX_POOL_SIZE], before
        anything is traced, compiled or allocated.
    """
    size = reset_pool.check_pool_size(size)
    params = params.replace(reset_pool=None)
    obs, state = jax.jit(jax.vmap(self.reset, in_axes=(0, None)))(
        jax.random.split(key, size), params)
    return params.replace(reset_pool=env_types.ResetPool(obs=obs, state=state))

  @property
  def default_params(self) -> env_types.EnvParams:
    """Parameters from the current gin bindings (defaults where unbound)."""
    return env_params.params_from_gin()

  def observation_space(self, params: env_types.EnvParams) -> Any:
    """The features in [-1, 1] (a `gymnasium.spaces.Box`): 71, plus the
    options' of `params` (`env_params.num_features`)."""
    import gymnasium  # pylint: disable=g-import-not-at-top
    return gymnasium.spaces.Box(-1.0, 1.0,
                                (env_params.num_features(params),),
                                np.float32)

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
    station = truth_member = None
    if params.wind_grid is None:
      forecast = generative.reset_forecast(forecast_key, params.decoder)
    else:  # ERA5: `GriddedWindField.reset_forecast`'s start, no VAE forecast.
      forecast = None
      start_time = winds.era5_start_offset_s(params.wind_grid, forecast_key)
      if params.wind_grid.station_box is not None:  # Per-seed stations.
        station = station_of(key, params.wind_grid)
      if gridded_jax.has_truth_members(params.wind_grid):
        truth_member = gridded_jax.draw_truth_member(
            params.wind_grid, jax.random.fold_in(key, _TRUTH_MEMBER_KEY_DATA))

    # The world; its balloon is `place`d in it. Realistic physics' burst
    # draw: a key of its own (folded in, so the paper's draws above are
    # unchanged); unused unless burst_spread.
    world = env_types.EnvState(
        flight=None, atmosphere=atmosphere, forecast=forecast,
        noise_u=noise_u, noise_v=noise_v, initial=None, history=None,
        wind_u=None, wind_v=None,
        start_time_offset_s=start_time.astype(jnp.int32), steps=None,
        pending_world=None, station=station, truth_member=truth_member)
    state = place(world, params, x_m=jnp.cos(theta) * radius_km * 1000.0,
                  y_m=jnp.sin(theta) * radius_km * 1000.0,
                  altitude_m=altitude,
                  burst_key=jax.random.fold_in(key, _BURST_KEY_DATA))
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
      state = reset_pool.install_world(state, params)
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
        key=env_types.walk_key(state) if params.flight.stochastic else None)
    if wind.outside is not None:  # The flight ends where the data end.
      flight = flight.replace(status=jnp.where(
          (flight.status == state_lib.FlightStatus.OK) &
          wind.outside(state, flight.x_m, flight.y_m),
          state_lib.FlightStatus.LEFT_WIND_DOMAIN, flight.status).astype(
              flight.status.dtype))
    state = measure(stride_state(state, flight, action), wind)
    info = step_info(state, params, invalid_action=invalid)
    reward = stride_reward(params, before, flight)
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

    The step key is split as gymnax splits it, `key, key_reset =
    jax.random.split(key)`: `key` goes to `step_env`, `key_reset` draws the
    new flight's world:
    - `params.reset_pool` None: `reset(key_reset, params)`'s world (the
      world of an explicit reset with that key). Under `jax.vmap` this reset
      (VAE decode included) is computed for every balloon at every step,
      ~7x the cost of `step_env`.
    - a `ResetPool` (`with_reset_pool`): world
      `reset_pool.pool_index(key_reset, K)` of the pool, i.e.
      `reset(jax.random.split(pool_key, K)[pool_index(key_reset, K)])`.
      The observation and the small state leaves are the world's at once;
      its large leaves (forecast grid, noise permutations) are pending and
      installed at the start of the next `step_env` (`install_world`), where
      under `jax.vmap` only those balloons' rows are written: a step costs
      about `step_env`'s. Auto-reset worlds then repeat (K of them);
      explicit `reset` calls still draw from their key.

    Args:
      key: The step's PRNG key (split into the step's and the new flight's
        world's, see above).
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
    key, key_reset = jax.random.split(key)
    obs, state, reward, terminated, info = self.step_env(key, state, action,
                                                         params)
    truncated = info['truncated']
    done = terminated | truncated
    pool = params.reset_pool
    if pool is None:
      reset_obs, reset_state = self.reset(key_reset, params)
      state = jax.tree.map(lambda r, s: jnp.where(done, r, s), reset_state,
                           state)
      new_obs = jnp.where(done, reset_obs, obs)
    else:
      state, new_obs = reset_pool.reset_from_pool(
          done, reset_pool.pool_index(key_reset, pool.size), state, obs, pool)
    info = {**info, 'final_observation': obs}
    return new_obs, state, reward, terminated, truncated, info


# `rollout`'s largest batch: each balloon's world holds ~0.33 MB on the device
# (its forecast grid), so 65 536 balloons hold ~21 GB; and its most
# observation values, (num_steps + 1) x N x 71 float32 (~8 GiB, the int32
# element count XLA indexes a buffer with).
MAX_ROLLOUT_BALLOONS = 65_536
MAX_ROLLOUT_VALUES = 2**31 - 1


def rollout(env: LatexBalloonJaxEnv, keys: Array, actions: Array,
            params: env_types.EnvParams, num_steps: int
            ) -> Tuple[Array, Array, Array]:
  """Flies N balloons for `num_steps` strides in one jitted call.

  Args:
    env: The env (static).
    keys: [N] reset keys (`jax.random.PRNGKey(s)`: the gym env's seed s),
      N <= `MAX_ROLLOUT_BALLOONS`.
    actions: [num_steps, N, 3] actions, or [N, 3] held for every step.
    params: The env parameters.
    num_steps: Strides to fly (static), an int >= 1 with (num_steps + 1) x
      N x features (71 without options) <= `MAX_ROLLOUT_VALUES`.

  Returns:
    (observations [num_steps + 1, N, 71], rewards [num_steps, N], done
    [num_steps, N]: terminated or time limit); episodes that end are not
    reset (`step_env`).

  Raises:
    errors.ConfigError: N or `num_steps` beyond the bounds above, before
      anything is traced, compiled or allocated.
  """
  balloons = gin_values.check_int('rollout balloons (len(keys))',
                                  np.shape(keys)[0] if np.ndim(keys) else 0,
                                  minimum=1, maximum=MAX_ROLLOUT_BALLOONS)
  features = env_params.num_features(params)
  most = MAX_ROLLOUT_VALUES // (balloons * features) - 1
  num_steps = gin_values.check_int(
      f'rollout num_steps (x {balloons} balloons)', num_steps, minimum=1,
      maximum=most)
  return _rollout(env, keys, actions, params, num_steps)


@functools.partial(jax.jit, static_argnums=(0, 4))
def _rollout(env: LatexBalloonJaxEnv, keys: Array, actions: Array,
             params: env_types.EnvParams, num_steps: int
             ) -> Tuple[Array, Array, Array]:
  """`rollout`, jitted (its sizes checked)."""
  obs0, state = rollout_lib.reset_batch(env, keys, params)
  if actions.ndim == 2:
    actions = jnp.broadcast_to(actions, (num_steps,) + actions.shape)

  def record(carry, action, observations, actions, step):
    del action, observations, actions
    obs, _, reward, terminated, info = step
    return carry, (obs, reward, terminated | info['time_limit'])

  _, (obs, rewards, done) = rollout_lib.fly(
      env, params, state, None, rollout_lib.planned, record, xs=actions,
      keys=keys)
  return jnp.concatenate([obs0[None], obs]), rewards, done
