# coding=utf-8
"""BLE's generative (VAE) wind field and simplex noise, with cheaper queries.

`FastGenerativeWindField` is BLE's `GenerativeWindField` with the same field,
noise, seeding and answers, bit for bit, at a fraction of the cost per query:

- `get_forecast` / `get_forecast_column`: BLE calls `scipy.interpolate.interpn`
  per query, which re-validates the grid and builds a `RegularGridInterpolator`
  each time (~0.2 ms). Here the multilinear interpolation on BLE's grid is
  evaluated directly, with scipy's arithmetic in scipy's order (interval
  search x[i] <= v < x[i + 1], normalised distances (v - x[i]) / (x[i + 1] -
  x[i]), corner weights multiplied dimension by dimension, the 16 corner terms
  summed in `itertools.product` order), on the same float32-rounded query
  point (BLE's clipping and time boomerang), so the result is identical.
- `get_wind_noise`: BLE's `NoisyWindComponent.get_noise` re-evaluates
  per-query invariants for each of its 5 harmonics; `FastSimplexWindNoise`
  hoists them and calls each harmonic's OpenSimplex `noise4d` with the same
  (float32) arguments, so the noise is BLE's exactly.
- `get_ground_truth`: remembers its last answer, so the arena's measurement at
  the end of a step and the balloon's first wind query of the next step (the
  same point and time) cost one query.

The latex env uses it by default (`ble_latex.env.LatexBalloonEnv`).
tests/test_fast_wind.py checks equality with BLE's classes.
"""

import bisect
import datetime as dt
import math
from typing import List, Optional, Sequence, Tuple

from balloon_learning_environment.env import generative_wind_field
from balloon_learning_environment.env import simplex_wind_noise
from balloon_learning_environment.env import wind_field
from balloon_learning_environment.utils import units
import gin
import jax.numpy as jnp
import numpy as np


class FastNoisyWindComponent(simplex_wind_noise.NoisyWindComponent):
  """BLE's noise for one wind component with per-query invariants hoisted."""

  def __init__(self, which: str):
    super().__init__(which)
    # BLE's normalisation, summed in BLE's order: identical constants.
    total_weight = 0.0
    total_weight_squared = 0.0
    for harmonic in self._harmonics:
      total_weight += harmonic.weight
      total_weight_squared += harmonic.weight**2
    self._total_weight = total_weight
    self._variance_factor = math.sqrt(total_weight / total_weight_squared)

  def noise_at(self, x_km: float, y_km: float, pressure: float,
               hours: float) -> float:
    """BLE's `get_noise` from x [km], y [km], pressure [Pa], time [h].

    Same operations on the same operand types as
    `simplex_wind_noise.NoisyWindComponent.get_noise` (the harmonics' offsets
    are float32, so the noise4d arguments are float32 as in BLE).

    Raises:
      ValueError: If reset() has not been called.
    """
    weighted_noise = 0.0
    for h in self._harmonics:
      generator = h._simplex_generator  # pylint: disable=protected-access
      offsets = h._offsets  # pylint: disable=protected-access
      if generator is None:
        raise ValueError('Must call reset before get_noise.')
      noise = simplex_wind_noise.NOISE_MAGNITUDE * generator.noise4d(
          x_km / h.x_spacing + offsets.x,
          y_km / h.y_spacing + offsets.y,
          pressure / h.pressure_spacing + offsets.pressure,
          hours / h.time_spacing + offsets.time)
      weighted_noise += noise * h.weight
    weighted_noise /= self._total_weight
    weighted_noise *= self._variance_factor
    return weighted_noise

  def get_noise(self, x: units.Distance, y: units.Distance, pressure: float,
                elapsed_time: dt.timedelta) -> float:
    return self.noise_at(x.km, y.km, pressure,
                         units.timedelta_to_hours(elapsed_time))


class FastSimplexWindNoise(wind_field.SimplexWindNoise):
  """BLE's simplex wind noise (same seeding, same values), cheaper queries."""

  def __init__(self):
    super().__init__()
    self.noise_u = FastNoisyWindComponent(which='u')
    self.noise_v = FastNoisyWindComponent(which='v')

  def get_wind_noise(self, x: units.Distance, y: units.Distance,
                     pressure: float,
                     elapsed_time: dt.timedelta) -> wind_field.WindVector:
    x_km, y_km = x.km, y.km
    hours = units.timedelta_to_hours(elapsed_time)
    return wind_field.WindVector(
        units.Velocity(meters_per_second=self.noise_u.noise_at(
            x_km, y_km, pressure, hours)),
        units.Velocity(meters_per_second=self.noise_v.noise_at(
            x_km, y_km, pressure, hours)))


def _locate(grid: Sequence[float], value: float,
            dimension: int) -> Tuple[int, float]:
  """scipy's interval search: (i, (v - g[i]) / (g[i+1] - g[i])), g[i] <= v.

  Raises:
    ValueError: v outside [g[0], g[-1]] or NaN (scipy's bounds error).
  """
  if not grid[0] <= value <= grid[-1]:
    raise ValueError(f'One of the requested xi is out of bounds in dimension '
                     f'{dimension}: {value}')
  i = min(bisect.bisect_right(grid, value) - 1, len(grid) - 2)
  return i, (value - grid[i]) / (grid[i + 1] - grid[i])


@gin.configurable(allowlist=[])
class FastGenerativeWindField(generative_wind_field.GenerativeWindField):
  """BLE's GenerativeWindField, identical values, fast point queries."""

  def __init__(self, key: Optional[jnp.ndarray] = None):
    """Constructor (BLE's).

    Args:
      key: BLE's constructor argument (unused: fields are sampled at reset).
    """
    super().__init__(key)
    self._noise_model = FastSimplexWindNoise()
    self._grid_lists = tuple(
        [float(g) for g in np.asarray(axis, dtype=np.float64)]
        for axis in self._grid)
    self._grid64 = tuple(np.asarray(axis, dtype=np.float64)
                         for axis in self._grid)
    # (query, answer) of the last get_ground_truth.
    self._last_truth = None

  def reset(self, key: jnp.ndarray, date_time: dt.datetime) -> None:
    self._last_truth = None
    super().reset(key, date_time)

  def reset_forecast(self, key: jnp.ndarray, date_time: dt.datetime) -> None:
    self._last_truth = None
    super().reset_forecast(key, date_time)

  def _query_point(self, x: units.Distance, y: units.Distance,
                   pressure: float,
                   elapsed_time: dt.timedelta) -> Tuple[float, ...]:
    """BLE's `_prepare_get_forecast_inputs` for one pressure, as floats.

    Clips x, y [km] and pressure [Pa] to the VAE grid, boomerangs the time
    [h] beyond the horizon, and rounds each coordinate to float32 as BLE's
    float32 point array does.
    """
    shape = self.field_shape
    d = shape.latlng_displacement_km
    x_km = min(max(x.kilometers, -d), d)  # NaN stays NaN.
    y_km = min(max(y.kilometers, -d), d)
    p = min(max(pressure, shape.min_pressure_pa), shape.max_pressure_pa)
    hours = units.timedelta_to_hours(elapsed_time)
    if hours >= shape.time_horizon_hours:
      hours = self._boomerang(hours, shape.time_horizon_hours)
    return (float(np.float32(x_km)), float(np.float32(y_km)),
            float(np.float32(p)), float(np.float32(hours)))

  def get_forecast(self, x: units.Distance, y: units.Distance, pressure: float,
                   elapsed_time: dt.timedelta) -> wind_field.WindVector:
    """BLE's forecast at one point (same value and types as BLE's).

    Raises:
      RuntimeError: if called before reset().
      ValueError: for a NaN coordinate or a time before the field's start.
    """
    if self.field is None:
      raise RuntimeError('Must call reset before get_forecast.')
    point = self._query_point(x, y, pressure, elapsed_time)
    located = [_locate(grid, value, d) for d, (grid, value) in enumerate(
        zip(self._grid_lists, point))]
    (i0, y0), (i1, y1), (i2, y2), (i3, y3) = located
    corners = self.field[i0:i0 + 2, i1:i1 + 2, i2:i2 + 2,
                         i3:i3 + 2].ravel().tolist()  # 16 corners x (u, v)
    u = v = 0.0
    k = 0
    for w0 in (1.0 - y0, y0):
      for w1 in (1.0 - y1, y1):
        w01 = w0 * w1
        for w2 in (1.0 - y2, y2):
          w012 = w01 * w2
          for w3 in (1.0 - y3, y3):
            weight = w012 * w3
            u += corners[k] * weight
            v += corners[k + 1] * weight
            k += 2
    # np.float64 as BLE's (it matters when float32 noise is added to it).
    return wind_field.WindVector(units.Velocity(mps=np.float64(u)),
                                 units.Velocity(mps=np.float64(v)))

  def get_forecast_column(
      self, x: units.Distance, y: units.Distance, pressures: Sequence[float],
      elapsed_time: dt.timedelta) -> List[wind_field.WindVector]:
    """BLE's forecast at several pressures (same values as BLE's).

    Raises:
      RuntimeError: if called before reset().
      ValueError: for a NaN coordinate or a time before the field's start.
    """
    if self.field is None:
      raise RuntimeError('Must call reset before get_forecast.')
    point = self._prepare_get_forecast_inputs(x, y, pressures, elapsed_time)
    if not len(point):  # pylint: disable=g-explicit-length-test
      return []
    # x, y and time are the same for the whole column; pressure varies.
    (i0, y0), (i1, y1), (i3, y3) = [
        _locate(self._grid_lists[d], float(point[0, d]), d) for d in (0, 1, 3)]
    grid = self._grid64[2]
    pressure = point[:, 2].astype(np.float64)
    if not np.all((grid[0] <= pressure) & (pressure <= grid[-1])):
      raise ValueError('One of the requested xi is out of bounds in '
                       'dimension 2')
    i2 = np.minimum(np.searchsorted(grid, pressure, side='right') - 1,
                    len(grid) - 2)
    y2 = (pressure - grid[i2]) / (grid[i2 + 1] - grid[i2])
    block = self.field[i0:i0 + 2, i1:i1 + 2, :, i3:i3 + 2]
    # Corner values (c0, c1, point, c3, uv) at the lower / upper pressure.
    levels = (block[:, :, i2], block[:, :, i2 + 1])
    uv = np.zeros((len(point), 2))
    for c0, w0 in enumerate((1.0 - y0, y0)):
      for c1, w1 in enumerate((1.0 - y1, y1)):
        w01 = w0 * w1
        for c2, w2 in enumerate((1.0 - y2, y2)):
          w012 = w01 * w2
          for c3, w3 in enumerate((1.0 - y3, y3)):
            uv = uv + levels[c2][c0, c1, :, c3] * (w012 * w3)[:, None]
    return [wind_field.WindVector(units.Velocity(mps=u),
                                  units.Velocity(mps=v)) for u, v in uv]

  def get_ground_truth(self, x: units.Distance, y: units.Distance,
                       pressure: float,
                       elapsed_time: dt.timedelta) -> wind_field.WindVector:
    """BLE's forecast + noise; a repeat of the last query is answered again.

    The repeat must have equal values of the same types (BLE's noise depends
    on the operand types: float32 offsets).
    """
    values = (x.meters, y.meters, pressure)
    key = values + (elapsed_time,) + tuple(type(value) for value in values)
    if self._last_truth is not None and self._last_truth[0] == key:
      return self._last_truth[1]
    truth = super().get_ground_truth(x, y, pressure, elapsed_time)
    self._last_truth = (key, truth)
    return truth
