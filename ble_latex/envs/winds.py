# coding=utf-8
"""Where the functional env's winds come from (`Wind` adapters).

A `Wind` is two pure functions of the env state: the ground truth the
balloon flies in and the forecast column the features read (BLE's
`WindField.get_ground_truth` / `get_forecast_column`).

- `GENERATIVE_WIND`: BLE's generative field, the VAE forecast drawn at
  reset (`wind.generative`) plus BLE's simplex noise (`wind.simplex`).
- `era5_wind(grid)`: ERA5 winds (`wind.gridded_jax`) plus the same noise, the
  grid a traced argument shared by every balloon (`EnvParams.wind_grid`).
- BLE's other wind fields fly through host callbacks (`ble_latex.ble.wind`).

`is_era5` and `era5_grid_from_gin` turn gin's wind-file settings
(`latex_episode.wind_field_factory = @GriddedWindField`, plain values read
by `wind.gridded`) into the grid the env flies; nothing here is a BLE object.
`gin_factory` and `bound_settings` read them under the configurable's old
name `Era5WindField` too (an alias until `gin_aliases.REMOVAL`).
"""

import os
from typing import Any, Callable, Dict, NamedTuple, Optional, Tuple

import gin
import jax

from ble_latex import errors
from ble_latex.envs import env_types
from ble_latex.wind import generative
from ble_latex.wind import gridded
from ble_latex.wind import gridded_jax
from ble_latex.wind import members
from ble_latex.wind import simplex
from ble_latex.wind import stations

Array = jax.Array


def ground_truth_wind(state: env_types.EnvState, x_m: Array, y_m: Array,
                      pressure_pa: Array, t_s: Array) -> Tuple[Array, Array]:
  """BLE's `WindField.get_ground_truth`: forecast plus simplex noise. # [m/s]

  Args:
    state: The env state (its forecast and noise).
    x_m: East of the station. # [m]
    y_m: North of the station. # [m]
    pressure_pa: Pressure. # [Pa]
    t_s: Time since the start of the flight. # [s]

  Returns:
    (u, v) eastward and northward wind.
  """
  u, v = generative.forecast(state.forecast, x_m, y_m, pressure_pa, t_s)
  return _add_noise(state, u, v, x_m, y_m, pressure_pa, t_s)


def _add_noise(state: env_types.EnvState, u: Array, v: Array, x_m: Array,
               y_m: Array, pressure_pa: Array, t_s: Array,
               scale: float = 1.0) -> Tuple[Array, Array]:
  """(u, v) plus `scale` x BLE's simplex noise of the flight. # [m/s]"""
  x_km, y_km, hours = x_m / 1000.0, y_m / 1000.0, t_s / 3600.0
  noise_u, noise_v = simplex.wind_noise_uv(state.noise_u, state.noise_v, x_km,
                                           y_km, pressure_pa, hours)
  if scale != 1.0:  # Static (`Era5Grid.noise_scale`).
    noise_u, noise_v = scale * noise_u, scale * noise_v
  return u + noise_u, v + noise_v


def forecast_column(state: env_types.EnvState, x_m: Array, y_m: Array,
                    pressures_pa: Array, t_s: Array) -> Tuple[Array, Array]:
  """BLE's `WindField.get_forecast_column` of this flight's forecast. # [m/s]

  Args:
    state: The env state (its forecast).
    x_m: East of the station. # [m]
    y_m: North of the station. # [m]
    pressures_pa: The column's pressure levels. # [Pa]
    t_s: Time since the start of the flight. # [s]

  Returns:
    (u, v) eastward and northward wind columns, one value per pressure
    level. # [m/s]
  """
  return generative.forecast_column(state.forecast, x_m, y_m, pressures_pa,
                                    t_s)


class Wind(NamedTuple):
  """Where the winds come from: two functions of the env state (static).

  Attributes:
    ground_truth: (state, x [m], y [m], pressure [Pa], t [s]) -> (u, v):
      the wind the balloon flies in (BLE's `get_ground_truth`). # [m/s]
    forecast_column: (state, x [m], y [m], pressures [Pa], t [s]) -> (u, v)
      columns: the forecast the features read (BLE's
      `get_forecast_column`). # [m/s]
    outside: None (winds everywhere), or (state, x [m], y [m]) -> bool:
      the position has left the source's data; the env ends the flight
      (`FlightStatus.LEFT_WIND_DOMAIN`).
    host: False: `forecast_column` takes positions of the pressures' shape
      (one per level); True: it is asked on the host (a BLE `WindField`
      through callbacks) at one scalar position per call.
  """
  ground_truth: Callable[..., Tuple[Array, Array]]
  forecast_column: Callable[..., Tuple[Array, Array]]
  outside: Optional[Callable[..., Array]] = None
  host: bool = False


# BLE's generative field (VAE forecast + simplex noise), drawn at reset.
GENERATIVE_WIND = Wind(ground_truth_wind, forecast_column)
# `START_EPOCH` after 1970-01-01 UTC. # [min]
_EPOCH_MIN = int(env_types.START_EPOCH.timestamp()) // 60


def era5_start_offset_s(grid: gridded_jax.Era5Grid, key: Array) -> Array:
  """A flight's start in the ERA5 data, drawn from `key`. # [s]

  `GriddedWindField.reset_forecast`'s start (`gridded_jax.draw_start_minute`),
  counted from `env_types.START_EPOCH` (the env's `start_time_offset_s`).

  Args:
    grid: The ERA5 grid (its first time and start range).
    key: The forecast key of the reset (BLE's wind key's second half).

  Returns:
    The start, seconds after `START_EPOCH` (int scalar).
  """
  minute = gridded_jax.draw_start_minute(grid, key)
  return (grid.first_time_min - _EPOCH_MIN + minute) * 60


def era5_wind(grid: gridded_jax.Era5Grid) -> Wind:
  """ERA5 winds plus BLE's simplex noise (BLE's `GriddedWindField`).

  The env flies it when `EnvParams.wind_grid` is set
  (`LatexBalloonJaxEnv.wind_for`): the grid is then a traced argument, read
  by every balloon (not a compile-time constant, not copied per balloon).
  The flight's start in the data is its `start_time_offset_s` (int32
  seconds after `START_EPOCH`: data from 1943 to 2079).

  Args:
    grid: The ERA5 grid (`gridded_jax.grid_from_data`).

  Returns:
    The wind: ground truth = ERA5 forecast + `grid.noise_scale` x BLE's
    simplex noise (`wind.forecast_error`; forecast only if not
    `grid.add_noise` or a scale of 0), forecast columns of the ERA5 forecast,
    both around the flight's station (`EnvState.station`, per-seed
    stations) or the grid's fixed target; `outside` where
    `grid.end_outside_domain`.
  """
  def data_time_s(state, t_s):
    start_s = state.start_time_offset_s - (grid.first_time_min -
                                           _EPOCH_MIN) * 60
    return start_s.astype(t_s.dtype) + t_s

  # The two-source mode: the truth is a second file on the same nodes, or
  # one of an ensemble's members (the flight's `truth_member`).
  truth = grid if grid.truth_uv is None else grid.replace(uv=grid.truth_uv)

  def ground_truth(state, x_m, y_m, pressure_pa, t_s):
    u, v = gridded_jax.forecast(truth, data_time_s(state, t_s), x_m, y_m,
                                pressure_pa, state.station, state.truth_member)
    if not grid.add_noise or grid.noise_scale == 0.0:
      return u, v
    return _add_noise(state, u, v, x_m, y_m, pressure_pa, t_s,
                      grid.noise_scale)

  def column(state, x_m, y_m, pressures_pa, t_s):
    return gridded_jax.forecast(grid, data_time_s(state, t_s), x_m, y_m,
                                pressures_pa, state.station)

  def outside(state, x_m, y_m):
    return gridded_jax.outside(grid, x_m, y_m, state.station)

  return Wind(ground_truth, column,
              outside if grid.end_outside_domain else None)


def gin_factory(factory: Any) -> Any:
  """A `latex_episode.wind_field_factory` value, gin's names made one.

  gin's `@GriddedWindField` and `@Era5WindField` (its old name) are two
  registered functions, each reading its own name's bindings: both are
  `gridded.settings`, which reads the two. Any other factory is itself.
  """
  names = (gridded.settings.gin_name, gridded.settings.gin_alias)
  if any(factory is gin.get_configurable(name) for name in names):
    return gridded.settings
  return factory


def bound_settings() -> Dict[str, Any]:
  """The values gin binds to `GriddedWindField.*` or `Era5WindField.*`.

  By name, those of the new name winning (`gridded.settings` refuses the
  two names bound to different values).
  """
  return {**gin.get_bindings(gridded.settings.gin_alias),
          **gin.get_bindings(gridded.settings.gin_name)}


def is_era5(factory: Any) -> bool:
  """Whether a `latex_episode.wind_field_factory` value is ERA5's settings.

  True for gin's `@GriddedWindField` (`gridded.settings`, plain settings,
  no BLE object; `gin_factory`) and for `gridded.Era5Settings`: the envs
  fly their grid (`EnvParams.wind_grid`). BLE `WindField`s are the gym envs' affair
  (`ble_latex.ble.arena`).
  """
  return factory is gridded.settings or isinstance(factory,
                                                  gridded.Era5Settings)


def era5_grid_from_gin(factory: Any) -> Optional[gridded_jax.Era5Grid]:
  """The ERA5 grid of a `latex_episode.wind_field_factory` value, or None.

  With `factory` gin's `@GriddedWindField` (`gridded.settings`) the
  `GriddedWindField.*` bindings (path, target, episode_hours, add_noise,
  start_dates) are read as plain settings, the file(s) by the one reader
  (`gridded.load`), into the grid every env flies (`EnvParams.wind_grid`,
  `gridded_jax.grid_from_settings`: one device copy per file and settings).
  Any other factory: None.

  Raises:
    errors.ConfigError: `GriddedWindField.path` unbound, or a bad binding.
    FileNotFoundError, errors.BadFileError: As `gridded.load`.
  """
  if factory is not gridded.settings:
    return None
  if 'path' not in bound_settings():
    raise errors.ConfigError(
        'latex_episode.wind_field_factory = @GriddedWindField needs the wind '
        "file: bind GriddedWindField.path = 'era5_paper.nc' (or --wind_file)")
  try:
    return gridded_jax.grid_from_settings(factory())
  except errors.BadFileError:
    raise
  except ValueError as e:
    raise errors.ConfigError(str(e).split('\n', 1)[0]) from e


def grid_from_file(wind_file: Any, **settings: Any) -> gridded_jax.Era5Grid:
  """The grid a wind file flies, as --wind_file flies it (issue 64).

  The file(s) by the one reader (`gridded.load`), with the station the file
  implies (`stations.file_defaults`: per-seed stations on a gridded
  snapshot, a sounding's site) unless `settings` names one, and flights
  starting anywhere in the data.

  Args:
    wind_file: A file, glob pattern or list of them (`gridded.load`).
    **settings: `gridded.Era5Settings` values (center_lat, center_lon,
      stations, add_noise, start_dates, ...).

  Raises:
    FileNotFoundError, errors.BadFileError: as `gridded.load`;
    errors.ConfigError: a bad setting, or a target the file does not hold.
  """
  path = (os.path.abspath(os.path.expanduser(wind_file))
          if isinstance(wind_file, (str, os.PathLike)) else tuple(wind_file))
  if not {'stations', 'center_lat', 'center_lon'} & set(settings):
    settings = {**stations.file_defaults(gridded.load(path)), **settings}
  try:
    return gridded_jax.grid_from_settings(gridded.Era5Settings(path=path,
                                                         **settings))
  except errors.BadFileError:
    raise
  except (TypeError, ValueError) as e:
    raise errors.ConfigError(
        f'wind_file={wind_file!r}: {str(e).splitlines()[0]}') from e


def wind_source_from_gin(factory: Any) -> str:
  """What a `latex_episode.wind_field_factory` value flies, for records.

  'BLE generative (VAE)' for BLE's winds; for a wind file (`@GriddedWindField`)
  its source and files, e.g. "GRIB2 run 2011-10-08T00Z +72 h
  (time-invariant): ['/data/gfs.grib2']" (`gridded.Era5Data.description`:
  snapshots say "time-invariant", forecasts their run and lead times).
  """
  settings = factory() if factory is gridded.settings else factory
  if isinstance(settings, gridded.Era5Settings):
    data = settings.load()
    if settings.truth_members:
      truth = members.truth_label(members.size_of(data.member),
                                  settings.member)
      return f'{data.description}: {list(data.paths)}; truth {truth}'
    if settings.truth_path is None:
      return f'{data.description}: {list(data.paths)}'
    truth = gridded.load(settings.truth_path)
    return (f'{data.description}: {list(data.paths)}; truth '
            f'{truth.description}: {list(truth.paths)}')
  return 'BLE generative (VAE)'
