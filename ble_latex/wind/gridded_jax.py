# coding=utf-8
"""ERA5 winds in JAX: the reader's data and settings as device arrays.

`Era5Grid` holds the ERA5 u, v of a `gridded.Era5Data` (time, pressure,
latitude, longitude; `gridded.load` stays the one reader: loading, validation,
errors) as float32 device arrays, with the station-keeping target and the
start-time range of plain `gridded.Era5Settings` (gin's `GriddedWindField.*`;
`grid_from_settings`, no BLE object). It is a pytree: put it in the env's
params (`env_types.EnvParams.wind_grid`) and every balloon of a vmapped batch
reads the same arrays (never copied per balloon), and a new grid of the
same shape does not recompile.

The functions are pure and jittable and answer as BLE's `WindField` of the
same settings (`ble_latex.ble.gridded_field.GriddedWindField`):
  - `latlng`: BLE's x (east) / y (north) offsets from the target to
    latitude/longitude (BLE's `spherical_geometry.
    calculate_latlng_from_offset`: great-circle destination on a sphere of
    radius 6371 km);
  - `interpolate`: `Era5Data.interpolate`, multi-linear in (time, pressure,
    latitude, longitude), each coordinate clipped to the grid's edges;
  - `draw_start_minute`: `GriddedWindField.reset_forecast`'s start time from
    the forecast key (the same `jax.random.randint` call);
  - `forecast`: `GriddedWindField.get_forecast(_column)`, around the grid's
    fixed target or a flight's own station;
  - `draw_station`: a flight's station drawn from its key (per-seed
    stations, `wind.stations`); `outside`: whether a position has left the
    grid's area (the env ends such a flight, `LEFT_WIND_DOMAIN`).
BLE's simplex noise (the paper's forecast error) is added by the env
(`jax_env`), as for BLE's generative field.

Everything is float32 (JAX's default). Latitudes and longitudes are kept
after the grid's first node (float32 steps ~1e-6 deg inside a 10 deg area,
not ~1e-5 deg at 250 deg), times after the data's first time (0.5 s steps
after 97 days). At the same float32 coordinates `interpolate` agrees with
`Era5Data.interpolate` (float64 scipy) to 1e-4 m/s on random winds of
15 m/s rms, and `latlng` with BLE's geometry to 2e-5 deg; the env on this
grid flies the BLE object's flight (host callbacks) to a few metres over
216 strides (tests/wind/test_gridded_jax.py).
"""

import datetime as dt
import logging
import math
from typing import Any, Dict, Optional, Sequence, Tuple

import flax
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import errors
from ble_latex.wind import forecast_error
from ble_latex.wind import gridded
from ble_latex.wind import members as members_lib
from ble_latex.wind import stations as stations_lib

Array = jax.Array
# BLE's spherical Earth (`spherical_geometry._EARTH_RADIUS`). # [m]
EARTH_RADIUS_M = 6_371_000.0


@flax.struct.dataclass
class Era5Grid:
  """ERA5 winds and the flight area of `GriddedWindField`, on the device.

  Axes are stored relative to their first value, which keeps float32's
  resolution of the coordinates (~1e-6 deg instead of ~1e-5 deg at 100 deg).

  Attributes:
    time_s: Grid times after the data's first time, [T]. # [s]
    pressure_pa: Pressure levels, ascending, [P]. # [Pa]
    latitude: Latitudes after `latitude_origin`, ascending, [La]. # [deg]
    longitude: Longitudes after `longitude_origin`, ascending, [Lo]. # [deg]
    uv: Winds (u east, v north), [T, P, La, Lo, 2]. # [m/s]
    latitude_origin: The first latitude. # [deg N]
    longitude_origin: The first longitude, the file's convention. # [deg E]
    sin_center_lat: sin of the target's latitude.
    cos_center_lat: cos of the target's latitude.
    center_lon: The target's longitude after `longitude_origin`, the
      file's convention. # [deg]
    first_start_minute: Earliest flight start after the first time (int32;
      `gridded.start_window`: 0, or the first minute of `start_dates`). # [min]
    last_start_minute: Latest flight start after the first time (int32;
      `gridded.start_window`). # [min]
    first_time_min: The data's first time after 1970-01-01 UTC (int32). # [min]
    add_noise: Whether the ground truth adds BLE's simplex noise to the
      forecast (`GriddedWindField.add_noise`). Static.
    noise_scale: The truth's factor on that noise (`forecast_error.
      noise_scale`: 1 on ERA5, 2.39 on other files, 0 with a truth file).
      Static.
    truth_uv: None: the truth is `uv` (+ noise); else a second file's winds
      on the same nodes (`forecast_error.truth_on_forecast_grid`), or an
      ensemble's members [M, T, P, La, Lo, 2] each flight draws its truth
      from (`members`, `draw_truth_member`). # [m/s]
    station_box: None: every flight keeps station at the target above
      (fixed); else [4] (lowest, highest latitude [deg N], lowest, highest
      longitude [deg E], the file's convention): each flight's station is
      drawn in it at reset (`draw_station`, `wind.stations`).
    end_outside_domain: Whether a flight that leaves the grid's area ends
      (`outside`; `stations.end_outside_domain`). Static.
    latitude_bounds: None: the area's latitudes are the first and last
      rows; else [2] (south, north edge after `latitude_origin`): a global
      grid's rows within one spacing of a pole reach it
      (`globe.latitude_bounds`). # [deg]

  A global grid (`gridded.Era5Data.global_longitude`) holds the wrapped column
  (its longitudes end 360 deg after `longitude_origin`): `_wrap` maps every
  longitude into it, so the wind is bilinear across the seam and no flight
  leaves it east or west.
  """
  time_s: Array
  pressure_pa: Array
  latitude: Array
  longitude: Array
  uv: Array
  latitude_origin: Array
  longitude_origin: Array
  sin_center_lat: Array
  cos_center_lat: Array
  center_lon: Array
  first_start_minute: Array
  last_start_minute: Array
  first_time_min: Array
  add_noise: bool = flax.struct.field(pytree_node=False, default=True)
  noise_scale: float = flax.struct.field(pytree_node=False, default=1.0)
  truth_uv: Optional[Array] = None
  station_box: Optional[Array] = None
  end_outside_domain: bool = flax.struct.field(pytree_node=False,
                                               default=False)
  latitude_bounds: Optional[Array] = None


def _snapshot_minute(data: gridded.Era5Data, when: Any) -> Optional[int]:
  """`Era5Settings.snapshot_time` in minutes after 1970, or None."""
  if when is None:
    return None
  if not data.time_invariant:
    raise errors.ConfigError(
        f'GriddedWindField.snapshot_time = {when!r}: only a time-invariant '
        f'source takes a date; {list(data.paths)} is a time series')
  try:
    if not isinstance(when, dt.datetime):
      when = dt.datetime.fromisoformat(str(when))
    if when.tzinfo is None:
      when = when.replace(tzinfo=dt.timezone.utc)
    seconds = when.timestamp()
  except (ValueError, OverflowError) as e:
    raise errors.ConfigError(
        f'GriddedWindField.snapshot_time = {when!r}: not an ISO date-time '
        '(UTC)') from e
  if seconds % 60 or not -1.5e9 < seconds < 3.4e9:  # int32 offsets.
    raise errors.ConfigError(
        f'GriddedWindField.snapshot_time = {when!r}: expected a whole minute '
        'in years 1943..2079')
  return int(seconds // 60)


def station_center(data: gridded.Era5Data, stations: str,
                   station_margin_km: float, center_lat: float,
                   center_lon: float) -> Tuple[float, float, Any]:
  """(target lat, lon, station box or None) of a station mode on `data`.

  'fixed': the given target, no box; 'per_seed': the box's centre and the
  box (`stations.station_box`; refused on a sounding: its winds are the
  same everywhere).
  """
  if stations_lib.check_mode(stations) == 'fixed':
    return center_lat, center_lon, None
  if data.source == 'sounding':
    raise errors.ConfigError(
        "GriddedWindField.stations = 'per_seed' needs a gridded source; "
        f'{list(data.paths)} is a sounding (the same winds everywhere)')
  box = stations_lib.station_box(data.latitude, data.longitude,
                                 station_margin_km, data.paths,
                                 global_longitude=data.global_longitude)
  return 0.5 * (box[0] + box[1]), 0.5 * (box[2] + box[3]), box


def _warn_unnamed_sounding(data: gridded.Era5Data, center_lat: float,
                           center_lon: float, snapshot_time: Any) -> None:
  """One logged line where a sounding names no site or time (issue 64).

  Such a file flies at the paper's target (1 N, -113 E) and 1970-01-01
  00:00 UTC unless bound: it says so, and how to choose them.
  """
  site = data.site
  if data.source != 'sounding' or site is None:
    return
  missing = []
  if (site.latitude is None and
      (center_lat, center_lon) == (gridded.PAPER_CENTER_LAT,
                                   gridded.PAPER_CENTER_LON)):
    missing.append(f'its station is the paper\'s target ({center_lat:g} N, '
                   f'{center_lon:g} E; --station_lat/--station_lon or '
                   'GriddedWindField.center_lat/center_lon choose it)')
  if site.time is None and snapshot_time is None:
    missing.append('its date is 1970-01-01 00:00 UTC (GriddedWindField.'
                   'snapshot_time chooses it)')
  if missing:
    unnamed = [n for n, m in (('site', site.latitude is None),
                              ('time', site.time is None)) if m]
    logging.getLogger(__name__).warning(
        'sounding %s names no %s: %s', list(data.paths), ' or '.join(unnamed),
        '; '.join(missing))


def grid_from_data(data: gridded.Era5Data, *,
                   center_lat: float = gridded.PAPER_CENTER_LAT,  # [deg N]
                   center_lon: float = gridded.PAPER_CENTER_LON,  # [deg E]
                   episode_hours: float = 72.0,  # [h]
                   add_noise: bool = True,
                   start_dates: Any = None,
                   stations: str = 'fixed',
                   station_margin_km: float = (
                       stations_lib.DEFAULT_MARGIN_KM),  # [km]
                   end_outside_domain: Optional[bool] = None,
                   snapshot_time: Any = None,
                   noise_scale: Optional[float] = None,
                   truth: Optional[gridded.Era5Data] = None,
                   truth_members: Sequence[gridded.Era5Data] = ()) -> Era5Grid:
  """The device grid of loaded ERA5 data (`gridded.load(path)`).

  The keyword arguments are `gridded.Era5Settings`'s, with its defaults
  (per-seed stations: the target is the station box's centre, and is used
  only for the start-window checks).

  Args:
    data: ERA5 data, read and checked by `gridded.load`.
    center_lat: Latitude of the station-keeping target. # [deg N]
    center_lon: Longitude of the station-keeping target. # [deg E]
    episode_hours: Flight length that must fit after the start. # [h]
    add_noise: Whether the ground truth adds BLE's simplex noise.
    noise_scale: Its factor; None: the source decides
      (`forecast_error.noise_scale`).
    truth: None, or a second file's data: the truth (two-source mode).
    truth_members: (), or an ensemble's members (`member_truths`): each
      flight's truth is one of them, drawn at reset (`draw_truth_member`).
    start_dates: None, a split of `gridded.DATE_SPLITS` or a (first, end)
      pair of dates: the range flights start in (`gridded.start_window`).

  Returns:
    The grid, float32 (int32 minutes).

  Raises:
    ValueError: as `gridded.start_window`, or a first
      time that is not a whole minute; errors.ConfigError: a bad station
      mode, margin, `end_outside_domain` or `snapshot_time`.
  """
  if truth is not None and truth_members:
    raise errors.ConfigError(
        'GriddedWindField.truth_path and GriddedWindField.truth_members = True '
        'both name the truth: bind one')
  center_lat, center_lon, box = station_center(
      data, stations, station_margin_km, center_lat, center_lon)
  _warn_unnamed_sounding(data, center_lat, center_lon, snapshot_time)
  ends = stations_lib.end_outside_domain(end_outside_domain, data.source,
                                         stations)
  snapshot = _snapshot_minute(data, snapshot_time)
  first, last = gridded.start_window(data, center_lat=center_lat,
                                     center_lon=center_lon,
                                     episode_hours=episode_hours,
                                     start_dates=start_dates)
  first_s = (data.times[0] - np.datetime64('1970-01-01T00:00:00')) / (
      np.timedelta64(1, 's'))
  if first_s % 60:
    raise ValueError(f'ERA5 data {list(data.paths)} start at {data.start}, '
                     'not a whole minute')
  lat_rad = math.radians(center_lat)

  def f32(value):
    return jnp.asarray(np.asarray(value, np.float64), jnp.float32)

  lat0 = np.float64(np.float32(data.latitude[0]))
  lon0 = np.float64(np.float32(data.longitude[0]))
  return Era5Grid(
      time_s=f32(data.time_s), pressure_pa=f32(data.pressure),
      latitude=f32(data.latitude - lat0), longitude=f32(data.longitude - lon0),
      uv=f32(data.uv), latitude_origin=f32(lat0), longitude_origin=f32(lon0),
      sin_center_lat=f32(math.sin(lat_rad)),
      cos_center_lat=f32(math.cos(lat_rad)),
      center_lon=f32(data.wrap_longitude(center_lon) - lon0),
      first_start_minute=jnp.asarray(first, jnp.int32),
      last_start_minute=jnp.asarray(last, jnp.int32),
      first_time_min=jnp.asarray(
          int(first_s // 60) if snapshot is None else snapshot, jnp.int32),
      add_noise=bool(add_noise),
      noise_scale=forecast_error.noise_scale(
          noise_scale, data.source, truth is not None or bool(truth_members)),
      truth_uv=_truth_uv(data, truth, truth_members),
      station_box=None if box is None else f32(box),
      end_outside_domain=ends,
      latitude_bounds=(f32(np.array(data.latitude_bounds) - lat0)
                       if data.global_longitude else None))


def _truth_uv(data: gridded.Era5Data, truth: Optional[gridded.Era5Data],
              truth_members: Sequence[gridded.Era5Data]) -> Optional[Array]:
  """`Era5Grid.truth_uv` of a truth file or of members (float32). # [m/s]"""
  if truth is not None:
    return jnp.asarray(forecast_error.truth_on_forecast_grid(data, truth),
                       jnp.float32)
  if not truth_members:
    return None
  for member in truth_members:
    if member.uv.shape != data.uv.shape:
      raise errors.ConfigError(
          f'GriddedWindField.truth_members: member {member.member} of '
          f'{list(member.paths)} has winds of shape {member.uv.shape}, the '
          f'forecast {data.uv.shape}')
  return jnp.asarray(np.stack([m.uv for m in truth_members]), jnp.float32)


def member_truths(path: Any, member: Any = None
                  ) -> Tuple[gridded.Era5Data, ...]:
  """The members an ensemble file's flights draw their truth from.

  Every member of `path`'s ensemble but the forecast's (`member`; None:
  gin's `GriddedWindField.member`), or every member under 'mean'
  (`members.truth_indices`), each read by `gridded.load`.

  Raises:
    errors.ConfigError: A file without a member dimension (one line).
  """
  member = members_lib.bound(member)
  forecast = gridded.load(path, member=member)
  size = members_lib.size_of(forecast.member)
  return tuple(gridded.load(path, member=k) for k in
               members_lib.truth_indices(size, member, list(forecast.paths)))


def draw_truth_member(grid: Era5Grid, key: Array) -> Array:
  """A flight's truth member: an index into `grid.truth_uv`'s members,
  uniform, from `key` (the env folds it out of the reset key: eval seed s
  always flies the same member) (int32)."""
  return jax.random.randint(key, (), 0, grid.truth_uv.shape[0])


def has_truth_members(grid: Era5Grid) -> bool:
  """Whether each flight draws its truth among members (static)."""
  return grid.truth_uv is not None and grid.truth_uv.ndim == 6


# Grids built from settings, by (data, target, flight, noise, dates): every
# env of a process shares one device copy of a file's winds.
_GRIDS: Dict[Tuple[Any, ...], Tuple[gridded.Era5Data, Era5Grid]] = {}


def grid_from_settings(settings: gridded.Era5Settings) -> Era5Grid:
  """The device grid of plain ERA5 settings (cached per data and settings).

  The file(s) are read by `gridded.load` (checked, cached per file and
  modification time). Two settings that differ only in `start_dates` share
  the winds' arrays (`with_start_dates`).

  Args:
    settings: The file, target, flight length, noise and start dates (gin's
      `GriddedWindField.*`: `gridded.settings()`).

  Returns:
    The grid.

  Raises:
    FileNotFoundError, IsADirectoryError, errors.BadFileError: As
      `gridded.load`; ValueError: as `grid_from_data`.
  """
  data = settings.load()
  # Values as their repr: a gin binding of any type (a list, a dict) is a
  # key here, and `grid_from_data` refuses it in one line.
  base = (id(data),) + tuple(repr(v) for v in (
      settings.center_lat, settings.center_lon, settings.episode_hours,
      settings.add_noise, settings.stations, settings.station_margin_km,
      settings.end_outside_domain, settings.snapshot_time,
      settings.noise_scale, settings.truth_path, settings.truth_members))
  key = base + (repr(settings.start_dates),)
  cached = _GRIDS.get(key)
  if cached is None or cached[0] is not data:
    shared = next((grid for k, (d, grid) in _GRIDS.items()
                   if k[:-1] == base and d is data), None)
    if shared is None:
      grid = grid_from_data(
          data, center_lat=settings.center_lat,
          center_lon=settings.center_lon,
          episode_hours=settings.episode_hours, add_noise=settings.add_noise,
          start_dates=settings.start_dates, stations=settings.stations,
          station_margin_km=settings.station_margin_km,
          end_outside_domain=settings.end_outside_domain,
          snapshot_time=settings.snapshot_time,
          noise_scale=settings.noise_scale,
          truth=(None if settings.truth_path is None else
                 gridded.load(settings.truth_path)),
          truth_members=(member_truths(settings.path, settings.member)
                         if settings.truth_members else ()))
    else:
      center_lat, center_lon, _ = station_center(
          data, settings.stations, settings.station_margin_km,
          settings.center_lat, settings.center_lon)
      grid = with_start_dates(
          shared, data, start_dates=settings.start_dates,
          center_lat=center_lat, center_lon=center_lon,
          episode_hours=settings.episode_hours)
    if len(_GRIDS) >= 8:
      _GRIDS.clear()
    _GRIDS[key] = (data, grid)
  return _GRIDS[key][1]


def with_start_dates(grid: Era5Grid, data: gridded.Era5Data, *,
                     start_dates: Any, center_lat: float, center_lon: float,
                     episode_hours: float) -> Era5Grid:
  """`grid` with flights starting in `start_dates` (same arrays, no copy).

  The start range is two traced int32 scalars: params differing only in
  it share every compiled function (e.g. training and validation splits).

  Args:
    grid: A grid of `data` (`grid_from_data`).
    data: The ERA5 data the grid holds.
    start_dates: As `grid_from_data`.
    center_lat: As `grid_from_data`. # [deg N]
    center_lon: As `grid_from_data`. # [deg E]
    episode_hours: As `grid_from_data`. # [h]
  """
  first, last = gridded.start_window(data, center_lat=center_lat,
                                     center_lon=center_lon,
                                     episode_hours=episode_hours,
                                     start_dates=start_dates)
  return grid.replace(first_start_minute=jnp.asarray(first, jnp.int32),
                      last_start_minute=jnp.asarray(last, jnp.int32))


def draw_start_minute(grid: Era5Grid, key: Array) -> Array:
  """`GriddedWindField.reset_forecast`'s start draw from the forecast key.

  Uniform over whole minutes in [`first_start_minute`,
  `last_start_minute`] after the data's first time: BLE's call
  `jax.random.randint(key, (), first, last + 1)`, so the same key gives
  the same start as the BLE object.

  Args:
    grid: The grid.
    key: The forecast key (the second half of BLE's `WindField.reset` key
      split, `generative.split_wind_key`).

  Returns:
    The start after the data's first time (int32). # [min]
  """
  return jax.random.randint(key, (), grid.first_start_minute,
                            grid.last_start_minute + 1)


def _wrap(grid: Era5Grid, lon: Array, origin: Array = 0.0) -> Array:
  """`Era5Data.wrap_longitude` of longitudes after `origin`. # [deg]

  Shifts by multiples of 360 deg to within 180 deg of the centre of the
  file's longitude range (`origin` 0: longitudes after `longitude_origin`).
  Only whole turns are subtracted: no rounding through values near 180.
  """
  centre = origin + 0.5 * grid.longitude[-1]
  return lon - 360.0 * jnp.floor((lon - centre + 180.0) / 360.0)


def draw_station(grid: Era5Grid, key: Array) -> Array:
  """A flight's station, uniform over the area of `grid.station_box`.

  sin(latitude) and longitude uniform in the box (equal areas equally
  likely), from `key` (the env folds it out of the reset key: eval seed s
  always flies station s).

  Args:
    grid: A grid with a `station_box` (per-seed stations).
    key: The station's key.

  Returns:
    [2] (latitude [deg N], longitude [deg E], the file's convention),
    float32.
  """
  box = grid.station_box
  u = jax.random.uniform(key, (2,), jnp.float32)
  sin_lo, sin_hi = jnp.sin(jnp.radians(box[0])), jnp.sin(jnp.radians(box[1]))
  lat = jnp.degrees(jnp.arcsin(jnp.clip(sin_lo + u[0] * (sin_hi - sin_lo),
                                        -1.0, 1.0)))
  lat = jnp.clip(lat, box[0], box[1])
  return jnp.stack([lat, box[2] + u[1] * (box[3] - box[2])])


def _target(grid: Era5Grid, station: Optional[Array]
            ) -> Tuple[Array, Array, Array]:
  """(sin lat, cos lat, lon after the origin) of the flight's target."""
  if station is None:
    return grid.sin_center_lat, grid.cos_center_lat, grid.center_lon
  lat = jnp.radians(station[..., 0])
  return (jnp.sin(lat), jnp.cos(lat),
          _wrap(grid, station[..., 1], grid.longitude_origin) -
          grid.longitude_origin)


def _offsets(grid: Era5Grid, x_m: Array, y_m: Array,
             station: Optional[Array] = None) -> Tuple[Array, Array]:
  """`latlng`, after the grid's origin (latitude, longitude). # [deg]"""
  sin_center, cos_center, center_lon = _target(grid, station)
  heading = jnp.arctan2(x_m, y_m)
  angle = jnp.hypot(x_m, y_m) / EARTH_RADIUS_M
  cos_angle, sin_angle = jnp.cos(angle), jnp.sin(angle)
  sin_lat = (cos_angle * sin_center +
             sin_angle * cos_center * jnp.cos(heading))
  d_lng = jnp.arctan2(sin_angle * cos_center * jnp.sin(heading),
                      cos_angle - sin_center * sin_lat)
  lat = jnp.degrees(jnp.arcsin(jnp.clip(sin_lat, -1.0, 1.0)))
  return (lat - grid.latitude_origin,
          _wrap(grid, center_lon + jnp.degrees(d_lng)))


def outside(grid: Era5Grid, x_m: Array, y_m: Array,
            station: Optional[Array] = None) -> Array:
  """Whether the offset (x east, y north) of the target has left the grid.

  Outside the latitudes (`latitude_bounds`) and longitudes of the data's
  nodes (the file's convention; never east or west of a global grid; `latlng` of the offset from the fixed target, or from a
  flight's `station`).

  Args:
    grid: The grid.
    x_m: Distance east of the target. # [m]
    y_m: Distance north of the target. # [m]
    station: A flight's (lat, lon) station, or None: the grid's target.

  Returns:
    bool, of the inputs' broadcast shape.
  """
  lat, lon = _offsets(grid, x_m, y_m, station)
  if grid.latitude_bounds is None:
    south, north = 0.0, grid.latitude[-1]
  else:
    south, north = grid.latitude_bounds[0], grid.latitude_bounds[1]
  return ((lat < south) | (lat > north) | (lon < 0.0) |
          (lon > grid.longitude[-1]))


def latlng(grid: Era5Grid, x_m: Array, y_m: Array,
           station: Optional[Array] = None) -> Tuple[Array, Array]:
  """(lat, lon) of the offset (x east, y north) from the target. # [deg]

  BLE's `spherical_geometry.calculate_latlng_from_offset` (`GriddedWindField.
  _latlng`): heading h = atan2(x, y) from north, angular distance d =
  hypot(x, y) / R, the great-circle destination (sin lat = cos d sin lat0 +
  sin d cos lat0 cos h; dlon = atan2(sin h sin d cos lat0, cos d -
  sin lat0 sin lat)); the longitude in the file's convention.

  Args:
    grid: The grid (its target).
    x_m: Distance east of the target. # [m]
    y_m: Distance north of the target. # [m]
    station: A flight's (lat, lon) station, or None: the grid's target.

  Returns:
    (latitude [deg N], longitude [deg E]), of the inputs' broadcast shape.
  """
  lat, lon = _offsets(grid, x_m, y_m, station)
  return lat + grid.latitude_origin, lon + grid.longitude_origin


def _cell(axis: Array, value: Array) -> Tuple[Array, Array]:
  """Lower index and weight of the upper node of `value`, clipped."""
  value = jnp.clip(value, axis[0], axis[-1])
  i = jnp.clip(jnp.searchsorted(axis, value, side='right') - 1, 0,
               axis.shape[0] - 2)
  low, high = axis[i], axis[i + 1]
  return i, (value - low) / (high - low)


def interpolate(grid: Era5Grid, time_s: Array, pressure_pa: Array,
                latitude: Array, longitude: Array) -> Array:
  """`Era5Data.interpolate`: multi-linear (u, v), clipped to the edges.

  Each coordinate is clipped to its axis (the field is constant beyond the
  time range, pressure range and area), then the 16 surrounding nodes are
  weighted multi-linearly (scipy's `RegularGridInterpolator`, 'linear').

  Args:
    grid: The grid.
    time_s: Time after the data's first time. # [s]
    pressure_pa: Pressure. # [Pa]
    latitude: Latitude. # [deg N]
    longitude: Longitude, any convention. # [deg E]

  Returns:
    [broadcast(inputs) + (2,)] (u, v), float32. # [m/s]
  """
  lat = jnp.asarray(latitude, jnp.float32) - grid.latitude_origin
  lon = _wrap(grid, jnp.asarray(longitude, jnp.float32),
              grid.longitude_origin) - grid.longitude_origin
  return _interpolate(grid, time_s, pressure_pa, lat, lon)


def _interpolate(grid: Era5Grid, time_s: Array, pressure_pa: Array,
                 lat: Array, lon: Array, member: Optional[Array] = None
                 ) -> Array:
  """`interpolate` of (lat, lon) after the grid's origin, in ensemble
  `member` of winds [M, T, P, La, Lo, 2] where given. # [m/s]"""
  coords = jnp.broadcast_arrays(
      *(jnp.asarray(c, jnp.float32) for c in (time_s, pressure_pa, lat, lon)))
  axes = (grid.time_s, grid.pressure_pa, grid.latitude, grid.longitude)
  cells = [_cell(axis, c) for axis, c in zip(axes, coords)]
  uv = jnp.zeros(coords[0].shape + (2,), jnp.float32)
  for corner in range(16):
    index = [] if member is None else [jnp.broadcast_to(member,
                                                        coords[0].shape)]
    weight = jnp.ones_like(coords[0])
    for axis, (i, w) in enumerate(cells):
      upper = (corner >> (3 - axis)) & 1
      index.append(i + upper)
      weight = weight * (w if upper else 1.0 - w)
    uv = uv + weight[..., None] * grid.uv[tuple(index)]
  return uv


def forecast(grid: Era5Grid, time_s: Array, x_m: Array, y_m: Array,
             pressure_pa: Array, station: Optional[Array] = None,
             member: Optional[Array] = None) -> Tuple[Array, Array]:
  """`GriddedWindField.get_forecast` / `get_forecast_column`. # [m/s]

  Args:
    grid: The grid.
    time_s: Time after the data's first time (flight start + elapsed). # [s]
    x_m: Distance east of the target. # [m]
    y_m: Distance north of the target. # [m]
    pressure_pa: Pressure, or pressures of a column. # [Pa]
    station: A flight's (lat, lon) station (per-seed stations), or None:
      the grid's fixed target.
    member: None, or the ensemble member read of winds [M, T, P, La, Lo,
      2] (a flight's truth member, `draw_truth_member`).

  Returns:
    (u, v) of pressure_pa's shape (broadcast with the others).
  """
  lat, lon = _offsets(grid, x_m, y_m, station)
  uv = _interpolate(grid, time_s, pressure_pa, lat, lon, member)
  return uv[..., 0], uv[..., 1]
