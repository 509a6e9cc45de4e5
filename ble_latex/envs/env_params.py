# coding=utf-8
"""`EnvParams` from gin, and the one validator of every `EnvParams` value.

- `params_from_gin`: `EnvParams` from the gin bindings (defaults where
  unbound): this module's configurables `latex_reward`, `latex_start`,
  `latex_episode` and `latex_observation` and the flight system's
  (`flight.params`); BLE's
  `perciatelli_reward_function.*` may only repeat them (`check_ble_repeat`),
  read without importing BLE.
- `check_params`: checks every value on the host before anything compiles
  (start band, start volume below burst, stride, episode, an ERA5
  `wind_grid` by `check_wind_grid`), naming the gin binding of a bad one.

The gin names say what they bind (module string `ble_latex.envs.env_params`);
`latex_episode` and `latex_start` were `LatexBalloonEnv` and
`LatexBalloonArena` (module string `ble_latex.envs.jax_env`), old names kept
as aliases until the next release (`gin_aliases`; docs/commands.md).
"""

from collections import abc
import dataclasses
import functools
from typing import Any, Callable, Dict, Optional, Tuple

import gin
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import errors
from ble_latex import gin_aliases
from ble_latex import gin_values
from ble_latex import jax_cache
from ble_latex.envs import env_types
from ble_latex.envs import jax_features
from ble_latex.envs import winds
from ble_latex.flight import atmosphere as atmosphere_lib
from ble_latex.flight import params as flight_params_lib
from ble_latex.flight import physics
from ble_latex.wind import generative
from ble_latex.wind import gridded_checks
from ble_latex.wind import gridded_jax
from ble_latex.wind import noise_gp

# The gin binding of each `EnvParams` value (the flight system's are in
# `flight.params`), for messages.
_BINDINGS = {
    'radius_km': 'latex_episode.station_keeping_radius_km',
    'reward_dropoff': 'latex_reward.reward_dropoff',
    'reward_halflife_km': 'latex_reward.reward_halflife_km',
    'reward_tanh_scale_km': 'latex_reward.reward_tanh_scale_km',
    'helium_penalty_per_mol': 'latex_reward.helium_penalty_per_mol',
    'sand_penalty_per_kg': 'latex_reward.sand_penalty_per_kg',
    'start_altitude_low_m': 'latex_start.start_altitude_range_m',
    'start_altitude_high_m': 'latex_start.start_altitude_range_m',
    'max_start_distance_km': 'latex_start.max_start_distance_km',
    'stride_s': 'latex_start.stride',
    'episode_steps': 'latex_episode.episode_steps',
    'wind_memory': 'latex_observation.wind_memory',
    'wind_lookahead': 'latex_observation.wind_lookahead',
    'sun': 'latex_observation.sun',
    'gas_temperature': 'latex_observation.gas_temperature',
}
# The most measurements the observation's Gaussian process keeps.
MAX_WIND_MEMORY = noise_gp.MAX_MEASUREMENTS
# The longest drift the observation's column averages over: one day of
# 20-minute strides (72). # [strides]
MAX_WIND_LOOKAHEAD = 72
# The `EnvParams` fields that fix what the features mean and how many there
# are (gin `latex_observation.*`): a policy records them and is flown only
# under the same (`observation_of`).
OBSERVATION_FIELDS = ('wind_memory', 'wind_lookahead', 'sun',
                      'gas_temperature')
# Those of them that switch features on (bools; a policy file records 0 or
# 1).
OBSERVATION_SWITCHES = ('sun', 'gas_temperature')
# The largest value of each (what `check_params` and a policy file's
# config accept).
OBSERVATION_MAXIMA = {'wind_memory': MAX_WIND_MEMORY,
                      'wind_lookahead': MAX_WIND_LOOKAHEAD,
                      'sun': 1, 'gas_temperature': 1}
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
  """`latex_start.start_altitude_range_m` as a (low, high) pair.

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
       'sand_penalty_per_kg': p.sand_penalty_per_kg,
       'reward_dropoff': p.reward_dropoff,
       'reward_halflife_km': p.reward_halflife_km,
       'reward_tanh_scale_km': p.reward_tanh_scale_km})
  gin_values.check_number(name('radius_km'), p.radius_km, above=0.0)
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
  for field in OBSERVATION_FIELDS:
    if field in OBSERVATION_SWITCHES:
      gin_values.check_bool(name(field), getattr(p, field))
    else:
      gin_values.check_int(name(field), getattr(p, field), minimum=0,
                           maximum=OBSERVATION_MAXIMA[field])
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
            'reward_tanh_scale_km',
            'helium_penalty_per_mol', 'sand_penalty_per_kg',
            'start_altitude_low_m', 'start_altitude_high_m',
            'max_start_distance_km')
  return p.replace(episode_steps=int(p.episode_steps), stride_s=stride,
                   wind_memory=int(p.wind_memory),
                   wind_lookahead=int(p.wind_lookahead),
                   sun=bool(p.sun), gas_temperature=bool(p.gas_temperature),
                   **{f: float(getattr(p, f)) for f in floats})


# Grids `check_wind_grid` passed, by the ids of their arrays (kept alive
# here so an id is never reused): a grid is checked once, not at every env.
_CHECKED_GRIDS: Dict[Tuple[int, ...], Tuple[Any, ...]] = {}


def check_wind_grid(grid: Any) -> None:
  """Checks `EnvParams.wind_grid` on the host (one line per fault).

  A `gridded_jax.Era5Grid` with 1-D axes of >= 2 finite, strictly ascending
  values (time from 0), winds of shape (time, pressure, latitude,
  longitude, 2), finite and below `gridded_checks.MAX_WIND_MPS`, finite
  target and origin values, and a start range 0 <= first <= last inside the time
  axis. Grids from `gridded_jax.grid_from_data` pass (the reader checked the
  file); this catches grids built or edited by hand.

  Raises:
    errors.ConfigError: Naming the field, e.g. "EnvParams.wind_grid.uv has
      shape (3, 4, 5, 5, 2), expected (time 3, pressure 4, latitude 5,
      longitude 6, 2)".
  """
  what = 'EnvParams.wind_grid'
  if not isinstance(grid, gridded_jax.Era5Grid):
    raise errors.ConfigError(f'{what} must be a gridded_jax.Era5Grid '
                             f'(gridded_jax.grid_from_data) or None, got '
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
  if np.max(np.abs(uv)) > gridded_checks.MAX_WIND_MPS:
    raise errors.ConfigError(
        f'{what}.uv holds |wind| {np.max(np.abs(uv)):.4g} m/s, above '
        f'{gridded_checks.MAX_WIND_MPS:g} m/s')
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


# The gin names of `EnvParams` (besides the flight system's, `flight.params`;
# BLE's own `perciatelli_reward_function.*` may only repeat them), named
# after what they bind. Their defaults are `EnvParams`' field defaults, the
# one home of each.
_GIN_MODULE = 'ble_latex.envs.env_params'
# The module string of the old names (`LatexBalloonEnv`, `LatexBalloonArena`,
# the classes that once held the values in `jax_env`), kept with them so a
# binding that spells it (`ble_latex.envs.jax_env.latex_episode.x`) works
# until the aliases go (`gin_aliases.REMOVAL`).
_OLD_GIN_MODULE = 'ble_latex.envs.jax_env'
_DEFAULTS = {f.name: f.default for f in dataclasses.fields(env_types.EnvParams)
             if f.default is not dataclasses.MISSING}


@gin.configurable('latex_reward', module=_GIN_MODULE)
def reward_settings(
    *, reward_dropoff: float = _DEFAULTS['reward_dropoff'],
    reward_halflife_km: float = _DEFAULTS['reward_halflife_km'],
    reward_tanh_scale_km: float = _DEFAULTS['reward_tanh_scale_km'],
    helium_penalty_per_mol: float = _DEFAULTS['helium_penalty_per_mol'],
    sand_penalty_per_kg: float = _DEFAULTS['sand_penalty_per_kg']
) -> Dict[str, Any]:
  """The reward (gin `latex_reward.*`; Eq. reward_function's constants).

  Args:
    reward_dropoff: Reward just outside the radius (c; BLE's
      `perciatelli_reward_function.reward_dropoff` may only repeat it). # [.]
    reward_halflife_km: Half-life of the reward outside the radius (tau;
      BLE's `reward_halflife` may only repeat it). # [km]
    reward_tanh_scale_km: 0 (default): the paper's flat reward 1 inside the
      circle; w > 0: the follow-up paper's tanh shape inside it, from 1 at
      the station to the drop-off at the edge
      (`jax_features.tanh_inside`). # [km]
    helium_penalty_per_mol: Reward penalty per mol vented. # [1/mol]
    sand_penalty_per_kg: Reward penalty per kg dropped. # [1/kg]

  Returns:
    The values by `EnvParams` field (unchecked).
  """
  return dict(locals())  # The arguments above, by name.


@gin_aliases.renamed('latex_start', module=_GIN_MODULE,
                     old_name='LatexBalloonArena', old_module=_OLD_GIN_MODULE)
def start(*, start_altitude_range_m: Tuple[float, float] = (
    _DEFAULTS['start_altitude_low_m'], _DEFAULTS['start_altitude_high_m']),
          max_start_distance_km: float = _DEFAULTS['max_start_distance_km'],
          stride: Any = _DEFAULTS['stride_s']) -> Dict[str, Any]:
  """Where flights start and the stride (gin `latex_start.*`).

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


@gin.configurable('latex_observation', module=_GIN_MODULE)
def observation_settings(
    *, wind_memory: int = _DEFAULTS['wind_memory'],
    wind_lookahead: int = _DEFAULTS['wind_lookahead'],
    sun: bool = _DEFAULTS['sun'],
    gas_temperature: bool = _DEFAULTS['gas_temperature']) -> Dict[str, Any]:
  """The observation (gin `latex_observation.*`).

  All off (the defaults): the paper's 71 features, the wind column the
  forecast at the balloon. The wind settings give the same 71 features
  with another wind column (`observed_winds.column`); the switches append
  features the balloon measures (`jax_features.option_features`).

  Args:
    wind_memory: K > 0: the column corrected by the last K measured winds
      (`EnvParams.wind_memory`).
    wind_lookahead: N > 0: each level's mean wind over a drift of N strides
      at that level (`EnvParams.wind_lookahead`).
    sun: True: append the sun's elevation at the balloon and its rate
      (`EnvParams.sun`).
    gas_temperature: True: append the helium's minus the air's temperature
      (`EnvParams.gas_temperature`).

  Returns:
    The values by `EnvParams` field (unchecked).
  """
  return dict(locals())  # The arguments above, by name.


def observation_of(params: Any) -> Dict[str, int]:
  """What `params`' features mean: its `OBSERVATION_FIELDS`, by name, as
  ints (a switch 0 or 1: what a policy file records). `params`: the
  `EnvParams`, or a mapping of the fields (`observation_settings()`)."""
  get = params.get if isinstance(params, abc.Mapping) else functools.partial(
      getattr, params)
  return {f: int(get(f)) for f in OBSERVATION_FIELDS}


def num_features(params: Any) -> int:
  """The observation's size under `params` (`observation_of`'s argument):
  the 71 features plus the switched-on options'."""
  on = observation_of(params)
  return jax_features.num_features(sun=bool(on['sun']),
                                   gas_temperature=bool(on['gas_temperature']))


@gin_aliases.renamed('latex_episode', module=_GIN_MODULE,
                     old_name='LatexBalloonEnv', old_module=_OLD_GIN_MODULE)
def episode(*, episode_steps: int = _DEFAULTS['episode_steps'],
            station_keeping_radius_km: float = _DEFAULTS['radius_km'],
            wind_field_factory: Optional[Callable[[], Any]] = None
            ) -> Dict[str, Any]:
  """The episode (gin `latex_episode.*`).

  Args:
    episode_steps: Strides per episode (the time limit).
    station_keeping_radius_km: The station-keeping radius: the reward's,
      TW50's and the drawn circle's (`EnvParams.radius_km`). # [km]
    wind_field_factory: None: BLE's generative field inside the core; else
      a factory of a BLE `WindField` (e.g. ERA5) that the single-balloon
      envs fly through host callbacks, or a wind file's settings
      (`@GriddedWindField`, its old name too: `winds.gin_factory`). Not an
      `EnvParams` value.

  Returns:
    `episode_steps` and `station_keeping_radius_km` by `EnvParams` field
    (unchecked) and `wind_field_factory`.
  """
  wind_field_factory = winds.gin_factory(wind_field_factory)
  return dict(locals())  # The arguments above, by name.


# BLE's `perciatelli_reward_function` parameters that may only repeat the
# env's: BLE name -> (the env's gin binding, what it is).
BLE_REPEATS = {
    'station_keeping_radius_km': ('latex_episode.station_keeping_radius_km',
                                  'the station radius'),
    'reward_dropoff': ('latex_reward.reward_dropoff', "the reward's dropoff"),
    'reward_halflife': ('latex_reward.reward_halflife_km',
                        "the reward's half-life"),
}


def check_ble_repeat(name: str, value: Any, ble_value: Any) -> None:
  """Refuses a BLE `perciatelli_reward_function.NAME` binding that differs.

  The station radius, the reward's dropoff and its half-life each have one
  home, the env's gin binding (`BLE_REPEATS`): the core's reward, TW50 and
  BLE's view and reward (`ble_latex.ble.reward`) all read it. BLE's own
  `perciatelli_reward_function.*` (bound only where BLE's balloon_env is
  imported) may only repeat it.

  Args:
    name: BLE's parameter name (a key of `BLE_REPEATS`).
    value: The env's value.
    ble_value: BLE's bound value.

  Raises:
    errors.ConfigError: naming both bindings when they differ.
  """
  ours, what = BLE_REPEATS[name]
  if not gin_values.is_number(value) or (
      gin_values.is_number(ble_value) and float(value) == float(ble_value)):
    return  # A bad value of the env's own is named by `check_params`.
  raise errors.ConfigError(
      f'gin binding perciatelli_reward_function.{name} = {ble_value!r} '
      f'differs from {ours} = {value!r}: {what} has one home, bind {ours}')


def check_one_radius(radius_km: Any, ble_radius_km: Any) -> None:
  """`check_ble_repeat` of BLE's reward radius (`station_keeping_radius_km`)."""
  check_ble_repeat('station_keeping_radius_km', radius_km, ble_radius_km)


def wind_source() -> str:
  """What the bound winds are, for records (`winds.wind_source_from_gin`).

  E.g. 'BLE generative (VAE)' or "GRIB2 (time-invariant): ['gfs.grib2']".
  """
  return winds.wind_source_from_gin(episode()['wind_field_factory'])


def params_from_gin(*, wind_file: Any = None) -> env_types.EnvParams:
  """`EnvParams` from the gin bindings (the defaults where unbound).

  `wind_file` (a file, glob or list): the params fly it, as --wind_file
  does (`winds.grid_from_file`), whatever gin's wind field factory.

  The configurables above and the flight system's
  (`flight.params.flight_params_from_gin`). BLE's
  `balloon_env.perciatelli_reward_function.*` bindings, read without
  importing BLE (a configurable whose module is not imported has no
  bindings, `ble_latex.gin_values`), may only repeat the env's
  (`check_ble_repeat`), so the JAX and Gymnasium envs stay free of BLE's
  balloon/env modules and TensorFlow.

  Raises:
    ValueError: A bad bound value, naming its gin binding (`check_params`).
  """
  values = episode()
  radius_km = values.pop('station_keeping_radius_km')
  reward = reward_settings()
  ble_bound = gin_values.imported_bindings(
      'balloon_learning_environment.env.balloon_env',
      'perciatelli_reward_function', {}, bound_only=True)
  ours = {'station_keeping_radius_km': radius_km,
          'reward_dropoff': reward['reward_dropoff'],
          'reward_halflife': reward['reward_halflife_km']}
  for name, value in ours.items():
    if name in ble_bound:
      check_ble_repeat(name, value, ble_bound[name])
  factory = values.pop('wind_field_factory')
  grid = (winds.era5_grid_from_gin(factory) if wind_file is None else
          winds.grid_from_file(wind_file))
  params = check_params(env_types.EnvParams(
      flight=flight_params_lib.flight_params_from_gin(), decoder=None,
      radius_km=radius_km, **reward, **start(), **values,
      **observation_settings(), wind_grid=grid))
  return params.replace(decoder=generative.decoder_params())



def stride_seconds(value: Any) -> float:
  """`latex_start.stride` (timedelta or seconds) in seconds, checked."""
  return flight_params_lib.seconds(value,
                                   f'gin binding {_BINDINGS["stride_s"]}')
