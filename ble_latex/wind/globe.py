# coding=utf-8
"""Global wind grids: the seam at the last longitude, and the poles (issue 64).

A file whose longitudes go round the globe (`is_global_longitude`: the gap
from the last longitude back to the first is one grid step) has no edge in
longitude: `gridded.load` closes it with the wrapped column
(`with_wrapped_column`: the first column again at +360 deg), so the wind is
interpolated bilinearly across the seam instead of held at the last column,
and no position leaves such a grid eastwards or westwards. Its latitudes
cover a pole when the last row is within one row spacing of it
(`latitude_bounds`): beyond that row the wind is held at the row's, and no
flight leaves the grid over the pole. `latlng_of_offset`: BLE's great-circle
offset from a station, on any grid.
"""

import math
from typing import Tuple

from balloon_learning_environment.utils import spherical_geometry
from balloon_learning_environment.utils import units
import numpy as np
import s2sphere as s2


def is_global_longitude(longitude: np.ndarray) -> bool:
  """Whether ascending longitudes go round the globe. # [deg E]

  True when the gap from the last longitude back to the first (+ 360 deg)
  is no wider than the axis's widest step (to 0.1 %): the seam is one more
  grid cell, e.g. 0..357.5 by 2.5 deg, -180..179.5 by 0.5 deg, or a
  sounding's (-180, 0).
  """
  longitude = np.asarray(longitude, np.float64)
  if longitude.size < 2:
    return False
  seam = longitude[0] + 360.0 - longitude[-1]
  return bool(0.0 < seam <= np.max(np.diff(longitude)) * 1.001 + 1e-9)


def with_wrapped_column(longitude: np.ndarray, uv: np.ndarray
                        ) -> Tuple[np.ndarray, np.ndarray]:
  """A global grid closed at its seam: the first column again at +360.

  Args:
    longitude: Ascending longitudes going round the globe. # [deg E]
    uv: Winds, longitude on axis -2. # [m/s]

  Returns:
    (longitude + [longitude[0] + 360], uv + its first column).
  """
  return (np.append(longitude, longitude[0] + 360.0),
          np.concatenate([uv, uv[..., :1, :]], axis=-2))


def latitude_bounds(latitude: np.ndarray, global_longitude: bool
                    ) -> Tuple[float, float]:
  """`Era5Data.latitude_bounds` of ascending latitudes. # [deg N]"""
  low, high = float(latitude[0]), float(latitude[-1])
  if global_longitude and latitude.size >= 2:
    step = float(np.max(np.diff(latitude)))
    if low - step <= -90.0:
      low = -90.0
    if high + step >= 90.0:
      high = 90.0
  return low, high


def latlng_of_offset(center_lat: float, center_lon: float, x_m: float,
                     y_m: float) -> Tuple[float, float]:
  """(lat, lon) of the offset (x east, y north) from a target. # [deg]

  BLE's `spherical_geometry.calculate_latlng_from_offset`: the great-circle
  destination at heading atan2(x, y) from north and angular distance
  hypot(x, y) / R on a sphere of R = 6371 km (`gridded_jax.latlng` is the same
  in JAX).

  Args:
    center_lat: The target's latitude. # [deg N]
    center_lon: The target's longitude. # [deg E]
    x_m: Distance east of the target (along the latitude parallel). # [m]
    y_m: Distance north of the target (along the meridian). # [m]

  Returns:
    (latitude [deg N], longitude [deg E], -180..180).

  Raises:
    ValueError: a non-finite offset.
  """
  if not (math.isfinite(x_m) and math.isfinite(y_m)):
    raise ValueError(f'Position must be finite, got x={x_m} m, y={y_m} m')
  latlng = spherical_geometry.calculate_latlng_from_offset(
      s2.LatLng.from_degrees(center_lat, center_lon), units.Distance(m=x_m),
      units.Distance(m=y_m))
  return latlng.lat().degrees, latlng.lng().degrees
