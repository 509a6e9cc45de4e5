# coding=utf-8
"""Where the station of a flight lies on a gridded wind source (issue 45).

Two modes (gin `GriddedWindField.stations`):
  - 'fixed' (default): every flight keeps station at `GriddedWindField.
    center_lat`/`center_lon` (the paper's ERA5 setting, as before);
  - 'per_seed': each flight's station is drawn from its reset key
    (`gridded_jax.draw_station`: eval seed s flies station s, the same on
    every run and machine) uniformly over the area of the box `station_box`
    returns: the grid less `GriddedWindField.station_margin_km` on every side,
    and within `MAX_STATION_ABS_LAT` of the equator.

The margin is measured along the meridian (latitude) and along the parallel
at the box's most poleward latitude (longitude), so every station of the box
has at least that much wind around it. The default, `DEFAULT_MARGIN_KM`, is
the start distance's scale (`latex_start.max_start_distance_km`,
200 km: a flight starts within it) plus 200 km of room to fly before the
flight leaves the data (`FlightStatus.LEFT_WIND_DOMAIN`).

`end_outside_domain` says whether a flight that leaves the grid ends (gin
`GriddedWindField.end_outside_domain`; None: the source decides).
"""

import math
from typing import Any, Dict, Optional, Sequence, Tuple

import numpy as np

from ble_latex import errors
from ble_latex.wind import globe

STATION_MODES = ('fixed', 'per_seed')
# 200 km (the start distance's scale) + 200 km to fly in. # [km]
DEFAULT_MARGIN_KM = 400.0
# Stations stay within this latitude (BLE's x/y station frame and the
# longitude margin degrade towards the poles). # [deg]
MAX_STATION_ABS_LAT = 70.0
# One degree of a great circle on BLE's sphere (R = 6371 km). # [km]
KM_PER_DEG = 6371.0 * math.pi / 180.0


def check_mode(stations: Any) -> str:
  """`GriddedWindField.stations`, checked (one line naming the binding)."""
  if stations not in STATION_MODES:
    raise errors.ConfigError(
        f'GriddedWindField.stations = {stations!r}: expected one of '
        f'{list(STATION_MODES)}')
  return stations


def check_margin(margin_km: Any) -> float:
  """`GriddedWindField.station_margin_km`, checked: a finite number >= 0."""
  if (isinstance(margin_km, bool) or not isinstance(margin_km, (int, float))
      or not math.isfinite(margin_km) or margin_km < 0):
    raise errors.ConfigError(
        f'GriddedWindField.station_margin_km = {margin_km!r}: expected a '
        'finite number >= 0 [km]')
  return float(margin_km)


def station_box(latitude: Sequence[float], longitude: Sequence[float],
                margin_km: float, paths: Sequence[str] = (),
                global_longitude: bool = False
                ) -> Tuple[float, float, float, float]:
  """The box per-seed stations are drawn in: the grid less its margins.

  A global grid (`global_longitude`) has no edge east or west nor at a pole
  its rows reach (`globe`): its box spans every longitude, and the margin
  applies only to a latitude edge short of a pole.

  Args:
    latitude: The grid's latitudes, ascending. # [deg N]
    longitude: The grid's longitudes, ascending (the file's convention;
      a global grid's end with the wrapped column). # [deg E]
    margin_km: Wind around every station, each side (checked). # [km]
    paths: The files, named in errors.
    global_longitude: The longitudes go round the globe.

  Returns:
    (lowest, highest latitude [deg N], lowest, highest longitude [deg E],
    the file's convention).

  Raises:
    errors.ConfigError: a bad margin, or a grid that holds no station with
      that margin (one line naming the files).
  """
  margin_km = check_margin(margin_km)
  lat0, lat1 = globe.latitude_bounds(np.asarray(latitude, np.float64),
                                     global_longitude)
  lon0, lon1 = float(longitude[0]), float(longitude[-1])
  margin_deg = margin_km / KM_PER_DEG
  lat_lo = max(lat0 + (margin_deg if lat0 > -90.0 else 0.0),
               -MAX_STATION_ABS_LAT)
  lat_hi = min(lat1 - (margin_deg if lat1 < 90.0 else 0.0),
               MAX_STATION_ABS_LAT)
  lon_lo = lon_hi = math.nan
  if lat_lo <= lat_hi and global_longitude:
    lon_lo, lon_hi = lon0, lon1
  elif lat_lo <= lat_hi:
    poleward = math.radians(max(abs(lat_lo), abs(lat_hi)))
    lon_margin = margin_km / (KM_PER_DEG * math.cos(poleward))
    lon_lo, lon_hi = lon0 + lon_margin, lon1 - lon_margin
  if not (lat_lo <= lat_hi and lon_lo <= lon_hi):
    raise errors.ConfigError(
        f'GriddedWindField.station_margin_km = {margin_km:g}: wind file(s) '
        f'{list(paths)} (lat {lat0:g}..{lat1:g}, lon {lon0:g}..{lon1:g}) hold '
        f'no station {margin_km:g} km from every edge within '
        f'{MAX_STATION_ABS_LAT:g} deg of the equator; bind a smaller margin')
  return lat_lo, lat_hi, lon_lo, lon_hi


def file_defaults(data: Any) -> Dict[str, Any]:
  """The station settings a wind file implies (`GriddedWindField.*`).

  A grid other than ERA5 (a GFS analysis, GRIB2; a snapshot or a time
  series): per-seed stations; a sounding whose file names its site: the
  station there; anything else (ERA5, a bare sounding): none (the target
  bound, or the paper's). Used by --wind_file and by the envs'
  `wind_file=`.

  Args:
    data: The file's `gridded.Era5Data`.

  Returns:
    `Era5Settings` keyword values, e.g. {'stations': 'per_seed'}.
  """
  site = data.site
  if data.source == 'sounding':
    if site is None or site.latitude is None or site.longitude is None:
      return {}
    return {'center_lat': site.latitude, 'center_lon': site.longitude}
  if data.source != 'ERA5':
    return {'stations': 'per_seed'}
  return {}


def end_outside_domain(setting: Optional[bool], source: str,
                       stations: str) -> bool:
  """Whether a flight that leaves the grid ends (`LEFT_WIND_DOMAIN`).

  Args:
    setting: gin `GriddedWindField.end_outside_domain`: True or False, or None
      (the default): True on a gridded real analysis ('analysis', 'GRIB2')
      and on per-seed stations; False on ERA5 files with a fixed station
      (the paper's setting: winds held at the edges, as BLE's field does)
      and on a sounding (the same winds everywhere: no edge).
    source: `gridded.Era5Data.source`.
    stations: The station mode (`STATION_MODES`).

  Raises:
    errors.ConfigError: a setting that is not None or a bool.
  """
  if setting is not None and not isinstance(setting, bool):
    raise errors.ConfigError(
        f'GriddedWindField.end_outside_domain = {setting!r}: expected True, '
        'False or None (the source decides)')
  if setting is not None:
    return setting and source != 'sounding'
  if source == 'sounding':
    return False
  return source != 'ERA5' or stations == 'per_seed'
