# coding=utf-8
"""Gridded upper-air wind files: the reader, and a flight's settings on them.

The one reader of the wind files flights fly (u, v on pressure levels): ERA5
reanalyses, GFS analyses and forecasts (NetCDF, GRIB2) and soundings (read by
content, `analysis`). The paper flies ERA5 (1 Nov 2022 - 31 Jan 2023, around
lon -113, lat 1, 0.4 degree grid, 2000-17 500 Pa, 6-hourly) with BLE's simplex
noise on top as forecast error. No BLE object here (its name until issue 66,
`ble_latex.wind.era5`, stays an alias for one release):
  - `load`: file(s) -> `Era5Data`, plain NumPy arrays on ascending axes
    (pressure in Pa), every file checked (`gridded_checks`) and cached;
  - `Era5Settings`: the flight's plain settings on the data, built by gin's
    `GriddedWindField` (`settings`), which `latex_episode.wind_field_factory
    = @GriddedWindField` switches every env to; `start_window`: the start
    minutes they allow.
The JAX env flies `gridded_jax.grid_from_settings(settings)`; BLE's agents fly
`ble_latex.ble.gridded_field.GriddedWindField` over the same reader.
`era5_requests` and `era5_arco` download ERA5.

Files: NetCDF files of the CDS dataset `reanalysis-era5-pressure-levels` with
variables `u` and `v` [m/s], in either layout
  - new CDS (2024-): dims `valid_time`, `pressure_level`, `latitude`,
    `longitude`;
  - old CDS: dims `time`, `level`, `latitude`, `longitude`;
pressure levels in hPa (or Pa, from the `units` attribute), latitude in any
order (ERA5 stores it descending), longitude in -180..180 or 0..360. A list of
files or a glob pattern (e.g. one file per month) is joined along time.
`Layout` names a source's variables and dimensions (`ERA5`): a reader of
another CF-style source passes its own.

Loading refuses (`gridded_checks`, one line naming the file) truncated files,
pressure values that contradict their `units`, NaN winds and winds above
`gridded_checks.MAX_WIND_MPS`, coordinates no real file holds, and gaps in time.
"""

import dataclasses
import datetime as dt
import functools
import math
import os
from typing import Any, Optional, Sequence, Tuple, TYPE_CHECKING, Union

import gin
import numpy as np

if TYPE_CHECKING:  # xarray, pandas and SciPy load when a file is read (~2 s).
  import xarray as xr  # pylint: disable=g-bad-import-order

from ble_latex import errors
from ble_latex import gin_aliases
from ble_latex import gin_values
from ble_latex.wind import analysis
from ble_latex.wind import forecast_error
from ble_latex.wind import globe
from ble_latex.wind import gridded_checks
from ble_latex.wind import members
from ble_latex.wind import stations as stations_lib

# Dimension names accepted in the files, new CDS layout first.
TIME_DIMS = ('valid_time', 'time')
PRESSURE_DIMS = ('pressure_level', 'level', 'isobaricInhPa', 'plev')
LATITUDE_DIMS = ('latitude', 'lat')
LONGITUDE_DIMS = ('longitude', 'lon')
WIND_VARIABLES = ('u', 'v')


@dataclasses.dataclass(frozen=True)
class Layout:
  """How a source's files name their winds and axes (CF-style NetCDF).

  Attributes:
    label: The source's name in messages ('ERA5').
    variables: The names of the eastward and northward wind, (u, v).
    time: Accepted names of the time dimension, preferred first.
    pressure: Accepted names of the pressure dimension.
    latitude: Accepted names of the latitude dimension.
    longitude: Accepted names of the longitude dimension.
  """
  label: str
  variables: Tuple[str, str]
  time: Tuple[str, ...]
  pressure: Tuple[str, ...]
  latitude: Tuple[str, ...]
  longitude: Tuple[str, ...]


# The CDS files of `reanalysis-era5-pressure-levels`, both layouts.
ERA5 = Layout(label='ERA5', variables=WIND_VARIABLES, time=TIME_DIMS,
              pressure=PRESSURE_DIMS, latitude=LATITUDE_DIMS,
              longitude=LONGITUDE_DIMS)

# The paper's station-keeping target (Saunders et al. 2023, "RL problem",
# Wind).
PAPER_CENTER_LAT = 1.0  # [deg N]
PAPER_CENTER_LON = -113.0  # [deg E]
# The held-out split of the paper's period by dates: flights start inside
# [first, end) of their split (`GriddedWindField.start_dates`). Each gap is one
# 3-day episode, so a training flight never flies a validation or evaluation
# flight's winds (the last training start, 12 Dec 23:59, lands before 16 Dec).
DATE_SPLITS = {
    'train': ('2022-11-01', '2022-12-13'),
    'validation': ('2022-12-16', '2022-12-29'),
    'eval': ('2023-01-01', '2023-01-29'),
}
@dataclasses.dataclass(frozen=True, eq=False)
class Era5Data:
  """ERA5 u, v on a regular (time, pressure, latitude, longitude) grid.

  All axes are strictly ascending; the arrays are read-only.

  Attributes:
    paths: The files the data came from.
    times: Grid times, naive UTC.
    time_s: Grid times relative to times[0]. # [s]
    pressure: Pressure levels. # [Pa]
    latitude: Latitudes. # [deg N]
    longitude: Longitudes (the file's convention). # [deg E]
    uv: Winds (time, pressure, lat, lon, 2): eastward u, northward v. # [m/s]
    source: The wind source: 'ERA5', 'analysis' (another CF NetCDF file),
      'GRIB2' or 'sounding' (`analysis`).
    time_invariant: True for a snapshot (one time step in the files): its
      winds are stored twice, at times[0] and one hour later, and hold at
      every time (`interpolate` clips to the edges).
    site: A sounding's site and time as its file names them
      (`sounding.Site`: its time is times[0]); None for other sources.
    global_longitude: The longitudes go round the globe (`globe`):
      `longitude` and `uv` end with the wrapped column (the first at +360).
    forecast: A forecast's run and lead times (`analysis.ForecastRun`).
    member: An ensemble's member flown, e.g. 'member 2 of 31' (`members`).
  """
  paths: Tuple[str, ...]
  times: np.ndarray
  time_s: np.ndarray
  pressure: np.ndarray
  latitude: np.ndarray
  longitude: np.ndarray
  uv: np.ndarray
  source: str = 'ERA5'
  time_invariant: bool = False
  site: Any = None
  global_longitude: bool = False
  forecast: Any = None
  member: Optional[str] = None

  @property
  def description(self) -> str:
    """The source for records, e.g. 'GRIB2 run 2011-10-08T00Z +72 h
    (time-invariant)' (`forecast`), 'sounding BOI 72681 43.56N -116.21E
    2010-12-09T12:00Z (time-invariant; wind above its top, 32.3 km, held)'
    (`site`)."""
    about = self.site or self.forecast
    label = about.label if about is not None else ''
    notes = ['time-invariant'] * self.time_invariant + [self.member] * bool(
        self.member) + (about.notes if about is not None else [])
    return (self.source + (f' {label}' if label else '') +
            (f' ({"; ".join(notes)})' if notes else ''))

  @property
  def latitude_bounds(self) -> Tuple[float, float]:
    """The latitudes the area spans (`globe.latitude_bounds`). # [deg N]"""
    return globe.latitude_bounds(self.latitude, self.global_longitude)

  def __post_init__(self):
    import scipy.interpolate  # pylint: disable=g-import-not-at-top
    axes = (self.time_s, self.pressure, self.latitude, self.longitude)
    object.__setattr__(self, '_interpolator',
                       scipy.interpolate.RegularGridInterpolator(
                           axes, self.uv, method='linear', bounds_error=False,
                           fill_value=None))
    object.__setattr__(self, '_low', np.array([a[0] for a in axes]))
    object.__setattr__(self, '_high', np.array([a[-1] for a in axes]))

  @property
  def start(self) -> dt.datetime:
    """First time in the data, UTC."""
    return _to_datetime(self.times[0])

  @property
  def end(self) -> dt.datetime:
    """Last time in the data, UTC."""
    return _to_datetime(self.times[-1])

  def wrap_longitude(self, lon: Union[float, np.ndarray]) -> np.ndarray:
    """Maps longitudes to the file's convention (within 180 deg of its centre).

    Args:
      lon: Longitudes in any convention. # [deg E]

    Returns:
      The same longitudes, shifted by multiples of 360 to lie within 180 deg
      of the centre of the file's longitude range. # [deg E]
    """
    centre = 0.5 * (self.longitude[0] + self.longitude[-1])
    return (np.asarray(lon, dtype=np.float64) - centre + 180.0) % 360.0 - (
        180.0 - centre)

  def covers(self, lat: float, lon: float) -> bool:
    """Whether the file's area holds (lat [deg N], lon [deg E], any convention)."""
    lon = float(self.wrap_longitude(lon))
    low, high = self.latitude_bounds
    return bool(low <= lat <= high and
                self.longitude[0] <= lon <= self.longitude[-1])

  def interpolate(self, time_s: Union[float, np.ndarray],
                  pressure: Union[float, np.ndarray],
                  latitude: Union[float, np.ndarray],
                  longitude: Union[float, np.ndarray]) -> np.ndarray:
    """Multi-linear interpolation of (u, v), clipped to the grid's edges.

    Inputs broadcast against each other. Points outside the grid take the
    value at the nearest edge in each axis (as BLE's generative wind field
    extends itself beyond its limits), so the field is constant beyond its
    time range, pressure range and area.

    Args:
      time_s: Time since `times[0]`. # [s]
      pressure: Pressure. # [Pa]
      latitude: Latitude. # [deg N]
      longitude: Longitude, any convention. # [deg E]

    Returns:
      Array of shape broadcast(inputs) + (2,) holding (u, v). # [m/s]
    """
    t, p, lat, lon = np.broadcast_arrays(
        np.asarray(time_s, dtype=np.float64),
        np.asarray(pressure, dtype=np.float64),
        np.asarray(latitude, dtype=np.float64),
        self.wrap_longitude(longitude))
    points = np.stack([t, p, lat, lon], axis=-1)
    points = np.clip(points, self._low, self._high)  # pytype: disable=attribute-error
    uv = self._interpolator(points.reshape(-1, 4))  # pytype: disable=attribute-error
    return uv.reshape(t.shape + (2,))


def _to_datetime(time: np.datetime64) -> dt.datetime:
  """A numpy datetime64 (naive UTC) as a timezone-aware UTC datetime."""
  seconds = (time - np.datetime64('1970-01-01T00:00:00')) / np.timedelta64(
      1, 's')
  return dt.datetime(1970, 1, 1, tzinfo=dt.timezone.utc) + dt.timedelta(
      seconds=float(seconds))


def find_dim(dims: Sequence[str], candidates: Sequence[str], what: str,
             path: str, variable: str, label: str = 'ERA5') -> str:
  """The first of `candidates` in `dims`; else one line naming the file."""
  for name in candidates:
    if name in dims:
      return name
  raise errors.BadFileError(
      f'{label} file {path} has no {what} dimension (expected one of '
      f'{list(candidates)}; variable {variable!r} has dims {list(dims)})')


def find_time_dim(dataset: 'xr.Dataset', layout: Layout = ERA5
                  ) -> Optional[str]:
  """The name of the time dimension of a dataset, or None."""
  for name in layout.time:
    if name in dataset.dims:
      return name
  return None


def _read_variable(dataset: 'xr.Dataset', name: str, path: str,
                   layout: Layout, member: Any = 0) -> 'xr.DataArray':
  """Variable `name` (of ensemble `member`) as (time, pressure, lat, lon)."""
  label = layout.label
  if name not in dataset.data_vars:
    raise errors.BadFileError(
        f'{label} file {path} has no variable {name!r} (found: '
        f'{sorted(str(v) for v in dataset.data_vars)})')
  array = dataset[name]
  unit = str(array.attrs.get('units', '')).strip()
  if unit and unit not in gridded_checks.WIND_UNITS:
    raise errors.BadFileError(
        f'{label} file {path}: variable {name!r} has units {unit!r}, '
        f'expected m/s ({list(gridded_checks.WIND_UNITS)})')
  dims = [str(d) for d in array.dims]
  wanted = [find_dim(dims, candidates, what, path, name, label)
            for candidates, what in ((layout.time, 'time'),
                                     (layout.pressure, 'pressure-level'),
                                     (layout.latitude, 'latitude'),
                                     (layout.longitude, 'longitude'))]
  for dim in dims:
    if dim in wanted:
      continue
    if dim == 'expver':
      # Old CDS files mixing final ERA5 (expver 1) and preliminary ERA5T
      # (expver 5): each time is valid in exactly one of them.
      parts = [array.isel(expver=i) for i in range(array.sizes[dim])]
      array = functools.reduce(lambda a, b: a.combine_first(b), parts)
    elif array.sizes[dim] == 1 or dim in members.MEMBER_DIMS:
      array = members.select(array, dim, member)
    else:
      raise errors.BadFileError(
          f'{label} file {path}: variable {name!r} has an unexpected dimension '
          f'{dim!r} of size {array.sizes[dim]} (expected dims {wanted})')
  for dim in wanted:
    if dim not in array.coords:
      raise errors.BadFileError(
          f'{label} file {path} has no coordinate values for '
          f'dimension {dim!r}')
  return array.transpose(*wanted)


def _open(path: str, label: str) -> 'xr.Dataset':
  """Opens one NetCDF file, with errors that name the file."""
  gridded_checks.check_file(path, label=label)
  import xarray as xr  # pylint: disable=g-import-not-at-top,redefined-outer-name
  try:
    return xr.open_dataset(path)
  except Exception as error:  # pylint: disable=broad-except
    raise errors.BadFileError(f'{label} file {path} is not a readable NetCDF '
                              f'file ({type(error).__name__}: {error})'
                              ) from error


def read_source(path: str, member: Any = 0
                ) -> Tuple[str, Tuple[np.ndarray, ...], Any, Optional[str]]:
  """Reads a wind file by content (`analysis`): (source, arrays, site, member).

  ERA5 and other CF NetCDF files, GRIB2 and soundings; the arrays are
  `read_file`'s, the site a sounding's (`sounding.Site`; None otherwise).
  Other grids than ERA5 must hold a domain a flight fits in (`analysis.
  check_domain`; `load` checks their levels, `check_flight_band`).
  """
  if analysis.kind_of(path) == 'sounding':
    members.about({}, member, path, 'sounding')  # Raises for member > 0.
    return ('sounding',) + analysis.sounding_arrays(path) + (None,)
  dataset, label, names = analysis.open_dataset(path, ERA5.label)
  forecast = analysis.forecast_run(dataset)
  about = members.about(dict(dataset.sizes), member, path, label)
  arrays = read_file(path, Layout(label=label, **names), dataset, member)
  if label != ERA5.label:
    analysis.check_domain(path, arrays[2], arrays[3], label)
  return label, arrays, forecast, about


def read_file(path: str, layout: Layout = ERA5,
              dataset: Optional['xr.Dataset'] = None, member: Any = 0
              ) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                         np.ndarray]:
  """Reads and checks one file: its axes sorted ascending.

  Args:
    path: A NetCDF file.
    layout: How the file names its winds and axes.
    dataset: The file already opened (`analysis.open_dataset`), or None.
    member: The ensemble member read from a member dimension (`members`).

  Returns:
    (times (datetime64, naive UTC), pressure [Pa], latitude [deg N],
    longitude [deg E], uv [m/s] of shape (time, pressure, lat, lon, 2)).

  Raises:
    FileNotFoundError, IsADirectoryError, errors.BadFileError: As `load`.
  """
  label = layout.label
  opened = _open(path, label) if dataset is None else dataset
  with opened as dataset:
    u_name, v_name = layout.variables
    u = _read_variable(dataset, u_name, path, layout, member)
    v = _read_variable(dataset, v_name, path, layout, member)
    if u.dims != v.dims or u.shape != v.shape:
      raise errors.BadFileError(
          f'{label} file {path}: {u_name} has dims {u.dims} {u.shape} but '
          f'{v_name} has dims {v.dims} {v.shape}')
    time_dim, pressure_dim, lat_dim, lon_dim = u.dims
    times = u[time_dim].values
    if not np.issubdtype(times.dtype, np.datetime64):
      raise errors.BadFileError(
          f'{label} file {path}: time coordinate {time_dim!r} is '
          f'not a date/time (dtype {times.dtype})')
    if np.isnat(times).any():
      raise errors.BadFileError(
          f'{label} file {path}: time coordinate {time_dim!r} has '
          'missing (NaT) values')
    pressure = u[pressure_dim].values.astype(np.float64)
    latitude = u[lat_dim].values.astype(np.float64)
    longitude = u[lon_dim].values.astype(np.float64)
    gridded_checks.check_coordinates(path, times, pressure, latitude, longitude,
                                     label=label)
    pressure = pressure * gridded_checks.pressure_factor(u[pressure_dim], path,
                                                         label=label)
    gridded_checks.check_pressure_pa(path, pressure, label=label)
    gridded_checks.check_size(path, u.shape, label=label)
    try:
      uv = np.stack([u.values.astype(np.float64),
                     v.values.astype(np.float64)], axis=-1)
    except Exception as error:  # pylint: disable=broad-except
      raise errors.BadFileError(
          f'{label} file {path} is corrupt or truncated: reading '
          f'its winds failed ({type(error).__name__}: {error})') from error
  gridded_checks.check_winds(path, uv, names=layout.variables,
                             time_dim=time_dim, times=times, pressure=pressure,
                             latitude=latitude, longitude=longitude, label=label)
  orders = [np.argsort(a, kind='stable')
            for a in (times, pressure, latitude, longitude)]
  uv = uv[np.ix_(*orders)]
  return (times[orders[0]], pressure[orders[1]], latitude[orders[2]],
          longitude[orders[3]], uv)


def load(path: Union[str, Sequence[str]], layout: Layout = ERA5,
         member: Any = None) -> Era5Data:
  """Loads ERA5 u, v from one or more files (joined along time).

  Results are cached per (files, modification times), so several
  environments share one copy. With the default layout the reader is chosen
  by content (`read_source`: ERA5 or other CF NetCDF, GRIB2, a sounding); a
  single time step is a snapshot, flown time-invariant.

  Args:
    path: A file, a glob pattern, or a list of them
      (`gridded_checks.expand_paths`).
    layout: How the files name their winds and axes.
    member: The ensemble member flown (None: gin's, `members.bound`).

  Returns:
    The data on ascending axes, pressure in Pa.

  Raises:
    FileNotFoundError: a file is missing.
    IsADirectoryError: a path (or a glob's match) is a directory.
    errors.BadFileError (a ValueError): a file is not NetCDF, is
      truncated, lacks a variable, dimension or coordinate, has pressure
      values that contradict their units, NaN winds (e.g. declared fill
      values) or winds above `MAX_WIND_MPS` (e.g. undeclared fill values),
      impossible coordinates (`gridded_checks.check_coordinates`), a gap in
      time (`gridded_checks.check_time_steps`), or files do not share one grid.
  """
  paths = gridded_checks.expand_paths(path)
  for p in paths:
    if os.path.isdir(p) or not os.path.isfile(p):
      gridded_checks.check_file(p, label=layout.label)  # Raises.
  stamps = tuple((p, os.stat(p).st_mtime_ns, os.stat(p).st_size)
                 for p in paths)
  data = _load_cached(stamps, layout, members.bound(member))
  if layout is ERA5 and data.source not in (ERA5.label, 'sounding'):
    analysis.check_flight_band(', '.join(data.paths), data.pressure, data.source)
  return data


@functools.lru_cache(maxsize=4)
def _load_cached(stamps: Tuple[Tuple[str, int, int], ...],
                 layout: Layout, member: Any = 0) -> Era5Data:
  label = layout.label
  paths = [p for p, _, _ in stamps]
  if layout is ERA5:
    reads = [read_source(p, member) for p in paths]
    parts = [(p,) + r[1] for p, r in zip(paths, reads)]
    source, about = reads[0][0], [r[2] for r in reads]
    site = about[0] if source == 'sounding' else None
    forecast = None if site else analysis.ForecastRun.join(about)
    if len({r[0] for r in reads}) > 1:
      raise errors.BadFileError(
          f'Wind files {paths} mix sources {[r[0] for r in reads]}')
    label = source
  else:
    source, site, forecast, reads = label, None, None, [(None,) * 4]
    parts = [(p,) + read_file(p, layout, member=member) for p in paths]
  first_path, _, pressure, latitude, longitude, _ = parts[0]
  for p, _, other_p, other_lat, other_lon, _ in parts[1:]:
    for name, a, b in (('pressure levels', pressure, other_p),
                       ('latitudes', latitude, other_lat),
                       ('longitudes', longitude, other_lon)):
      if a.shape != b.shape or not np.allclose(a, b):
        raise errors.BadFileError(
            f'{label} files {first_path} and {p} have different {name}; they '
            'cannot be joined')
  times = np.concatenate([part[1] for part in parts])
  uv = np.concatenate([part[5] for part in parts], axis=0)
  order = np.argsort(times, kind='stable')
  times, uv = times[order], uv[order]
  sources = [paths[k] for k in np.repeat(
      np.arange(len(parts)), [len(part[1]) for part in parts])[order]]
  duplicate = np.nonzero(np.diff(times) == np.timedelta64(0))[0]
  if duplicate.size:
    i = int(duplicate[0])
    raise errors.BadFileError(
        f'{label} files {sources[i]} and {sources[i + 1]} both hold time '
        f'{gridded_checks.time_text(times[i])}')
  gridded_checks.check_time_steps(times, sources, label=label)
  time_invariant = times.size == 1
  if time_invariant:  # A snapshot: the same winds one hour later.
    times = np.concatenate([times, times + np.timedelta64(1, 'h')])
    uv = np.concatenate([uv, uv], axis=0)
  for name, axis in (('time', times), ('pressure level', pressure),
                     ('latitude', latitude), ('longitude', longitude)):
    if axis.size < 2:
      raise errors.BadFileError(
          f'{label} file(s) {[s[0] for s in stamps]} hold {axis.size} '
          f'{name} value(s); interpolation needs at least 2')
  global_longitude = globe.is_global_longitude(longitude)
  if global_longitude:  # Close the seam (`Era5Data.global_longitude`).
    longitude, uv = globe.with_wrapped_column(longitude, uv)
  time_s = (times - times[0]) / np.timedelta64(1, 's')
  arrays = [times, time_s, pressure, latitude, longitude, uv]
  for a in arrays:
    a.flags.writeable = False
  return Era5Data(tuple(s[0] for s in stamps), *arrays, source=source,
                  time_invariant=time_invariant, site=site,
                  global_longitude=global_longitude, forecast=forecast,
                  member=reads[0][3])


@dataclasses.dataclass(frozen=True)
class Era5Settings:
  """A flight's plain settings on ERA5 data (gin's `GriddedWindField.*`).

  Lists (of paths, of two dates) are kept as tuples, so settings compare
  and hash by value.

  Attributes:
    path: ERA5 NetCDF file, glob pattern (e.g. 'era5_paper_*.nc') or list of
      them; joined along time (`load`).
    center_lat: Latitude of the station-keeping target. # [deg N]
    center_lon: Longitude of the station-keeping target. # [deg E]
    episode_hours: Flight length that must fit in the data after the
      start. # [h]
    add_noise: Whether the ground truth adds BLE's simplex noise to the
      forecast (the paper does).
    start_dates: None: flights start anywhere in the data; a split of
      `DATE_SPLITS` ('train', 'validation', 'eval') or a (first, end) pair
      of ISO dates: flights start in [first, end) (`start_window`).
    stations: 'fixed' (every flight's station at center_lat/lon) or
      'per_seed' (drawn per flight from its reset key; `wind.stations`).
    station_margin_km: 'per_seed': wind around every station. # [km]
    end_outside_domain: Whether a flight that leaves the grid ends
      (`LEFT_WIND_DOMAIN`); None: the source decides
      (`stations.end_outside_domain`).
    snapshot_time: A time-invariant source's date (ISO date-time, UTC; the
      flight's sun clock): None: the file's time (a sounding's header).
    noise_scale: The truth's factor on BLE's simplex noise; None: the
      source decides (`forecast_error.noise_scale`: ERA5 1, others 2.39).
    truth_path: None, or a second file (glob, list) whose winds are the
      truth (`forecast_error.truth_on_forecast_grid`; noise 0 by default).
    member: The ensemble member the agents see (`members`; 0, the first:
      GEFS's control; 'mean': the ensemble mean).
    truth_members: The truth is another member, drawn per flight (`members`).
  """
  path: Union[str, Tuple[str, ...]]
  center_lat: float = PAPER_CENTER_LAT  # [deg N]
  center_lon: float = PAPER_CENTER_LON  # [deg E]
  episode_hours: float = 72.0  # [h]
  add_noise: bool = True
  start_dates: Any = None
  stations: str = 'fixed'
  station_margin_km: float = stations_lib.DEFAULT_MARGIN_KM  # [km]
  end_outside_domain: Optional[bool] = None
  snapshot_time: Any = None
  noise_scale: Optional[float] = None
  truth_path: Any = None
  member: Any = 0
  truth_members: bool = False

  def __post_init__(self):
    for name in ('path', 'start_dates', 'truth_path'):
      value = getattr(self, name)
      if isinstance(value, list):
        object.__setattr__(self, name, tuple(value))
    # The plain values, checked as they are bound (one line naming the
    # binding; the file, dates and snapshot time are checked when read).
    check_target(self.center_lat, self.center_lon, self.episode_hours)
    gin_values.check_bool('GriddedWindField.add_noise', self.add_noise)
    stations_lib.check_mode(self.stations)
    stations_lib.check_margin(self.station_margin_km)
    forecast_error.check_scale(self.noise_scale)
    members.check(self.member)
    members.check_truth(self.truth_members)

  def load(self) -> Era5Data:
    """The data of `path` (`load`: checked, cached)."""
    return load(self.path, member=self.member)

  def start_window(self, data: Era5Data) -> Tuple[int, int]:
    """`start_window` of these settings on `data` (their file's data)."""
    return start_window(data, center_lat=self.center_lat,
                        center_lon=self.center_lon,
                        episode_hours=self.episode_hours,
                        start_dates=self.start_dates)


@gin_aliases.renamed('GriddedWindField', module='ble_latex.wind.gridded',
                     old_name='Era5WindField', old_module='ble_latex.wind.era5')
def settings(*,
             path: Union[str, Sequence[str]] = gin.REQUIRED,
             center_lat: float = PAPER_CENTER_LAT,  # [deg N]
             center_lon: float = PAPER_CENTER_LON,  # [deg E]
             episode_hours: float = 72.0,  # [h]
             add_noise: bool = True,
             start_dates: Any = None,
             stations: str = 'fixed',
             station_margin_km: float = stations_lib.DEFAULT_MARGIN_KM,
             end_outside_domain: Optional[bool] = None,
             snapshot_time: Any = None,
             noise_scale: Optional[float] = None,
             truth_path: Any = None,
             member: Any = 0,
             truth_members: bool = False) -> Era5Settings:
  """A wind file's settings from gin: the configurable `GriddedWindField`.

  `latex_episode.wind_field_factory = @GriddedWindField` and the
  `GriddedWindField.*` bindings switch every env to the file: the JAX env
  reads them here (`envs.winds.era5_grid_from_gin`), BLE's gym envs too, and
  `ble_latex.ble.gridded_field.GriddedWindField.from_settings` builds BLE's
  `WindField` of them. Arguments given override gin's bindings. The old
  name `Era5WindField` binds it too until `gin_aliases.REMOVAL`.

  Args:
    path, add_noise, start_dates, stations: As `Era5Settings`.
    center_lat, center_lon, episode_hours: As `Era5Settings`. # [deg, deg, h]
    station_margin_km, end_outside_domain: As `Era5Settings`. # [km]
    snapshot_time, noise_scale, truth_path, member, truth_members: As above.

  Returns:
    The settings (unchecked: `load`, `start_window` and
    `gridded_jax.grid_from_data` check them).
  """
  return Era5Settings(**locals())


def check_target(center_lat: Any, center_lon: Any, episode_hours: Any) -> None:
  """Refuses a target or flight length that is no number or out of range.

  Args:
    center_lat: In [-90, 90]. # [deg N]
    center_lon: In [-360, 360]. # [deg E]
    episode_hours: >= 0. # [h]

  Raises:
    errors.ConfigError: One line naming the `GriddedWindField.*` binding.
  """
  gin_values.check_number('GriddedWindField.center_lat', center_lat,
                          minimum=-90.0, maximum=90.0)
  gin_values.check_number('GriddedWindField.center_lon', center_lon,
                          minimum=-360.0, maximum=360.0)
  gin_values.check_number('GriddedWindField.episode_hours', episode_hours,
                          minimum=0.0)


def start_dates_range(
    start_dates: Any, what: str = 'GriddedWindField.start_dates'
    ) -> Optional[Tuple[dt.datetime, dt.datetime]]:
  """The [first, end) start range of `GriddedWindField.start_dates`, UTC.

  Args:
    start_dates: None (any start in the data), a split of `DATE_SPLITS`
      ('train', 'validation', 'eval') or a (first, end) pair of ISO dates or
      date-times (strings, `datetime.date`s or `datetime.datetime`s; naive
      ones are UTC), first < end.
    what: The binding or flag named in errors.

  Returns:
    None, or (first, end) as aware UTC date-times.

  Raises:
    errors.ConfigError: anything else, in one line.
  """
  if start_dates is None:
    return None
  given = start_dates
  if isinstance(start_dates, str):
    if start_dates not in DATE_SPLITS:
      raise errors.ConfigError(
          f'{what} = {given!r}: not a split ({sorted(DATE_SPLITS)}) nor a '
          '(first, end) pair of dates')
    start_dates = DATE_SPLITS[start_dates]
  if not isinstance(start_dates, (tuple, list)) or len(start_dates) != 2:
    raise errors.ConfigError(
        f'{what} = {given!r}: expected a split ({sorted(DATE_SPLITS)}) or a '
        "(first, end) pair of dates, e.g. ('2022-11-01', '2022-12-13')")
  pair = []
  for value in start_dates:
    try:
      if isinstance(value, dt.datetime):
        when = value
      elif isinstance(value, dt.date):
        when = dt.datetime(value.year, value.month, value.day)
      else:
        when = dt.datetime.fromisoformat(str(value))
      if when.tzinfo is None:
        when = when.replace(tzinfo=dt.timezone.utc)
      # OverflowError: a date whose UTC time leaves years 1..9999.
      pair.append(when.astimezone(dt.timezone.utc))
    except (ValueError, OverflowError) as e:
      raise errors.ConfigError(
          f'{what} = {given!r}: {value!r} is not an ISO date (YYYY-MM-DD '
          'or YYYY-MM-DDTHH:MM) in years 1..9999 (UTC)') from e
  if not pair[0] < pair[1]:
    raise errors.ConfigError(f'{what} = {given!r}: the first date must come '
                             'before the end')
  return pair[0], pair[1]


def start_window(data: Era5Data, *, center_lat: float, center_lon: float,
                 episode_hours: float, start_dates: Any = None
                 ) -> Tuple[int, int]:
  """The minutes a flight may start at, after the data's first time.

  `last_start_minute`'s checks, and the starts restricted to `start_dates`
  (`start_dates_range`: [first, end), so the splits of `DATE_SPLITS` never
  share a start).

  Returns:
    (first, last) whole minutes after the data's first time, inclusive.

  Raises:
    ValueError: as `last_start_minute`; `errors.ConfigError`: bad
      `start_dates`, or no start of the range lies in the data with
      `episode_hours` after it.
  """
  last = last_start_minute(data, center_lat=center_lat, center_lon=center_lon,
                           episode_hours=episode_hours)
  window = start_dates_range(start_dates)
  if data.time_invariant:  # Every date flies the same winds: start at 0.
    return 0, 0
  if window is None:
    return 0, last
  first_s = (window[0] - data.start).total_seconds()
  end_s = (window[1] - data.start).total_seconds()
  first = max(0, math.ceil(first_s / 60.0))
  last = min(last, math.ceil(end_s / 60.0) - 1)
  if first > last:
    raise errors.ConfigError(
        f'GriddedWindField.start_dates = {start_dates!r}: no flight of '
        f'{episode_hours:g} h can start in [{window[0]:%Y-%m-%d %H:%M}, '
        f'{window[1]:%Y-%m-%d %H:%M}) inside {data.source} file(s) '
        f'{list(data.paths)} ({data.start:%Y-%m-%d %H:%M} to '
        f'{data.end:%Y-%m-%d %H:%M}); --era5_dates=all (or FIRST,END inside '
        'them) flies their dates')
  return int(first), int(last)


def last_start_minute(data: Era5Data, *, center_lat: float, center_lon: float,
                      episode_hours: float) -> int:
  """Checks a flight against the data; the last minute a flight may start.

  Args:
    data: The ERA5 data.
    center_lat: Latitude of the station-keeping target. # [deg N]
    center_lon: Longitude of the station-keeping target. # [deg E]
    episode_hours: Flight length that must fit in the data after the
      start. # [h]

  Returns:
    The latest start, in whole minutes after the data's first time, such
    that `episode_hours` fit.

  Raises:
    ValueError: non-finite arguments, target outside the data's area, or
      (`errors.BadFileError`) data shorter than `episode_hours`.
  """
  check_target(center_lat, center_lon, episode_hours)
  if data.time_invariant:  # Every start flies the same winds.
    if not data.covers(center_lat, center_lon):
      raise ValueError(
          f'Target (lat {center_lat}, lon {center_lon}) lies outside the '
          f'area of {data.source} file(s) {list(data.paths)}')
    return 0
  if not data.covers(center_lat, center_lon):
    raise ValueError(
        f'Target (lat {center_lat}, lon {center_lon}) lies outside the area '
        f'of {data.source} file(s) {list(data.paths)}: lat '
        f'[{data.latitude[0]}, {data.latitude[-1]}], lon [{data.longitude[0]}, '
        f'{data.longitude[-1]}]')
  span_s = float(data.time_s[-1])
  episode_s = episode_hours * 3600.0
  if episode_s > span_s:
    raise errors.BadFileError(
        f'{data.source} file(s) {list(data.paths)} cover {span_s / 3600:.1f} '
        f'h ({data.start} to {data.end}), shorter than episode_hours = '
        f'{episode_hours} (bind GriddedWindField.episode_hours to at most '
        'that)')
  return int((span_s - episode_s) // 60)

