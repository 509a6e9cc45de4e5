# coding=utf-8
"""A wind file (ERA5, GFS, a sounding) as a BLE `WindField`, for BLE's agents.

`GriddedWindField` is the paper's Wind (Saunders et al. 2023, "RL problem"):
a `wind_field.WindField` whose forecast is the wind of `gridded.load` (the
one reader, no BLE object; the paper's is ERA5) interpolated multi-linearly
in (time, pressure, latitude, longitude), and whose ground truth is forecast
+ BLE's `SimplexWindNoise` (switch the noise off with `add_noise=False`). Its
settings are the plain `gridded.Era5Settings` the JAX env flies
(`gridded_jax.grid_from_settings`); gin's `GriddedWindField.*` bindings are
those settings (`gridded.settings`), and
`GriddedWindField.from_settings(gridded.settings())` is BLE's field of them.
Its name until issue 66 was `Era5WindField` (module `ble.era5_field`). The gym envs fly a `GriddedWindField` as its grid in
the core (`ble_latex.ble.arena`); BLE's consumers that want a `WindField`
object on the host (scripts, `wind_field.WindField` users) build this one.
"""

import datetime as dt
import math
from typing import Any, List, Optional, Sequence, Tuple, Union

from balloon_learning_environment.env import wind_field
from balloon_learning_environment.utils import units
import jax
from jax import numpy as jnp
import numpy as np

from ble_latex import errors
from ble_latex.wind import forecast_error
from ble_latex.wind import globe
from ble_latex.wind import gridded


class GriddedWindField(wind_field.WindField):
  """ERA5 reanalysis winds around a station-keeping target (paper's Wind).

  Positions are BLE's x (east), y (north) offsets from the target at
  (center_lat, center_lon), converted to latitude/longitude with BLE's
  `spherical_geometry.calculate_latlng_from_offset` (`globe.latlng_of_offset`).
  The forecast is the ERA5 (u, v) interpolated multi-linearly in time,
  pressure, latitude and longitude (`gridded.Era5Data.interpolate`); outside
  the file's area, pressure range or time range the wind is clipped to the
  edge value (as BLE's generative field). The ground truth adds BLE's
  simplex noise unless `add_noise` is False.

  Each reset samples the flight's start time uniformly (whole minutes) from
  the file's time range such that `episode_hours` fit, and inside
  `start_dates` if given (the held-out split by dates, `gridded.DATE_SPLITS`),
  from the forecast key (same key, same start). The `date_time` BLE passes to
  `reset` is ignored (as BLE's generative field does); `start_date_time`
  holds the sampled start, and the arena uses it as the balloon's date and
  time. Not a gin configurable: gin's `GriddedWindField` is its settings
  (`gridded.settings`; `from_settings`).
  """

  def __init__(self,
               *,
               path: Union[str, Sequence[str]],
               center_lat: float = gridded.PAPER_CENTER_LAT,  # [deg N]
               center_lon: float = gridded.PAPER_CENTER_LON,  # [deg E]
               episode_hours: float = 72.0,  # [h]
               add_noise: bool = True,
               start_dates: Any = None,
               noise_scale: Optional[float] = None):
    """Loads the ERA5 file(s).

    Args:
      path: ERA5 NetCDF file, glob pattern (e.g. 'era5_paper_*.nc') or list
        of them; joined along time.
      center_lat: Latitude of the station-keeping target. # [deg N]
      center_lon: Longitude of the station-keeping target. # [deg E]
      episode_hours: Flight length that must fit in the data after the
        sampled start. # [h]
      add_noise: Whether the ground truth adds BLE's simplex noise to the
        forecast (the paper does).
      start_dates: None: flights start anywhere in the data; a split of
        `gridded.DATE_SPLITS` ('train', 'validation', 'eval') or a (first, end)
        pair of ISO dates: flights start in [first, end)
        (`gridded.start_window`).
      noise_scale: The truth's factor on BLE's noise; None: the source
        decides (`forecast_error.noise_scale`: 1 on ERA5).

    Raises:
      FileNotFoundError: a file is missing.
      IsADirectoryError: a path is a directory.
      ValueError: bad file (see `gridded.load`), target outside the file's area,
        non-finite arguments, or data shorter than `episode_hours`.
    """
    super().__init__()  # BLE's simplex noise (`SimplexWindNoise`).
    self.settings = gridded.Era5Settings(
        path=path, center_lat=center_lat, center_lon=center_lon,
        episode_hours=episode_hours, add_noise=add_noise,
        start_dates=start_dates, noise_scale=noise_scale)
    self._data = self.settings.load()
    self.noise_scale = forecast_error.noise_scale(noise_scale,
                                                  self._data.source)
    self._first_start, self._start_minutes = self.settings.start_window(
        self._data)
    self.center_lat, self.center_lon = float(center_lat), float(center_lon)
    self.start_dates = self.settings.start_dates
    self.episode_hours = float(episode_hours)
    self.add_noise = bool(add_noise)
    self.start_date_time: Optional[dt.datetime] = None
    self._start_offset_s: Optional[float] = None

  @classmethod
  def from_settings(cls, settings: gridded.Era5Settings) -> 'GriddedWindField':
    """BLE's field of plain settings (e.g. gin's, `gridded.settings()`).

    Raises:
      errors.ConfigError: per-seed stations (this BLE object keeps one
        fixed station; the envs fly them in the core's grid).
    """
    if settings.truth_path is not None or settings.truth_members:
      name = 'truth_members' if settings.truth_members else 'truth_path'
      raise errors.ConfigError(
          f"GriddedWindField.{name}: BLE's GriddedWindField object flies one "
          'truth, the file; a truth of its own flies in the envs '
          '(latex_episode.wind_field_factory = @GriddedWindField)')
    if settings.stations != 'fixed':
      raise errors.ConfigError(
          f"GriddedWindField.stations = {settings.stations!r}: BLE's "
          'GriddedWindField object keeps one fixed station; per-seed stations '
          'fly in the envs (latex_episode.wind_field_factory = '
          '@GriddedWindField)')
    return cls(path=settings.path, center_lat=settings.center_lat,
               center_lon=settings.center_lon,
               episode_hours=settings.episode_hours,
               add_noise=settings.add_noise,
               start_dates=settings.start_dates,
               noise_scale=settings.noise_scale)

  @property
  def data(self) -> gridded.Era5Data:
    """The loaded ERA5 data."""
    return self._data

  def reset_forecast(self, key: jnp.ndarray, date_time: dt.datetime) -> None:
    """Samples the flight's start time from the data's time range.

    The start is uniform over whole minutes in [first time, last time -
    episode_hours] (inside `start_dates`), drawn from `key` (the same key
    gives the same start).

    Args:
      key: A jax PRNGKey used for sampling the start time.
      date_time: Ignored (BLE's random date); see `start_date_time`.
    """
    del date_time
    minutes = jax.random.randint(key, (), self._first_start,
                                 self._start_minutes + 1).item()
    self.set_start_date_time(self._data.start + dt.timedelta(minutes=minutes))

  def set_start_date_time(self, start: dt.datetime) -> None:
    """Sets the flight's start time (e.g. to show the winds of a date).

    Args:
      start: Start time; naive times are taken as UTC. It must lie in the
        data's time range (the flight may run past its end: clipped).

    Raises:
      ValueError: if `start` is outside the data's time range.
    """
    if start.tzinfo is None:
      start = start.replace(tzinfo=dt.timezone.utc)
    if not self._data.start <= start <= self._data.end:
      raise ValueError(f'Start {start} is outside the ERA5 data '
                       f'({self._data.start} to {self._data.end})')
    self.start_date_time = start
    self._start_offset_s = (start - self._data.start).total_seconds()

  def _time_s(self, elapsed_time: dt.timedelta) -> float:
    """Time since the data's first time. # [s]"""
    if self._start_offset_s is None:
      raise RuntimeError('Must call reset before get_forecast.')
    return self._start_offset_s + elapsed_time.total_seconds()

  def _latlng(self, x: units.Distance,
              y: units.Distance) -> Tuple[float, float]:
    """(lat, lon) of the offset (x east, y north) from the target. # [deg]"""
    if not (math.isfinite(x.meters) and math.isfinite(y.meters)):
      raise ValueError(f'Position must be finite, got x={x}, y={y}')
    return globe.latlng_of_offset(self.center_lat, self.center_lon, x.meters,
                                  y.meters)

  def get_forecast(self, x: units.Distance, y: units.Distance, pressure: float,
                   elapsed_time: dt.timedelta) -> wind_field.WindVector:
    """ERA5 wind at a point (clipped to the data's edges outside it).

    Args:
      x: Distance east of the target (along the latitude parallel).
      y: Distance north of the target (along the meridian).
      pressure: Pressure. # [Pa]
      elapsed_time: Time since the start of the flight.

    Returns:
      The interpolated wind.

    Raises:
      RuntimeError: if called before reset().
      ValueError: for non-finite positions or pressure.
    """
    return self.get_forecast_column(x, y, [pressure], elapsed_time)[0]

  def get_forecast_column(
      self, x: units.Distance, y: units.Distance, pressures: Sequence[float],
      elapsed_time: dt.timedelta) -> List[wind_field.WindVector]:
    """ERA5 winds at several pressures above one point (one vectorised call).

    Args:
      x: Distance east of the target (along the latitude parallel).
      y: Distance north of the target (along the meridian).
      pressures: Pressures. # [Pa]
      elapsed_time: Time since the start of the flight.

    Returns:
      One interpolated wind per pressure.

    Raises:
      RuntimeError: if called before reset().
      ValueError: for non-finite positions or pressures.
    """
    time_s = self._time_s(elapsed_time)
    pressures = np.asarray(pressures, dtype=np.float64).reshape(-1)
    if not np.all(np.isfinite(pressures)):
      raise ValueError(f'Pressure must be finite, got {pressures}')
    lat, lon = self._latlng(x, y)
    uv = self._data.interpolate(time_s, pressures, lat, lon)
    return [wind_field.WindVector(units.Velocity(mps=float(u)),
                                  units.Velocity(mps=float(v)))
            for u, v in uv]

  def get_ground_truth(self, x: units.Distance, y: units.Distance,
                       pressure: float,
                       elapsed_time: dt.timedelta) -> wind_field.WindVector:
    """Forecast plus `noise_scale` x BLE's simplex noise (forecast only if
    not add_noise)."""
    if not self.add_noise or self.noise_scale == 0.0:
      return self.get_forecast(x, y, pressure, elapsed_time)
    truth = super().get_ground_truth(x, y, pressure, elapsed_time)
    if self.noise_scale == 1.0:
      return truth
    forecast = self.get_forecast(x, y, pressure, elapsed_time)
    return wind_field.WindVector(*(
        units.Velocity(mps=f.meters_per_second + self.noise_scale * (
            t.meters_per_second - f.meters_per_second))
        for f, t in ((forecast.u, truth.u), (forecast.v, truth.v))))


def grid_settings(wind: Any) -> Optional[gridded.Era5Settings]:
  """The ERA5 settings a gym env flies as a grid in the core, or None.

  A `GriddedWindField` (not a subclass: those fly through host callbacks, as
  any third-party `WindField`) gives its settings; `gridded.Era5Settings`
  (what gin's `@GriddedWindField` factory returns) are themselves; anything
  else is None.

  Args:
    wind: What a gym env's wind field factory returned.
  """
  if type(wind) is GriddedWindField:  # pylint: disable=unidiomatic-typecheck
    return wind.settings
  if isinstance(wind, gridded.Era5Settings):
    return wind
  return None
