# coding=utf-8
"""Where station-keeping is possible: zero inside the hull of reachable winds.

A balloon that steers only by altitude moves with the wind of the level it
floats at. Over a time-invariant column it can hold a station only if some
mix of the winds it can reach cancels: the origin of the (u, v) plane lies
inside the convex hull of the wind vectors of the altitudes it can reach
(issue 64 item 5; field notes, "Where station-keeping is possible"). Those
altitudes are the flight band, `reach.flight_band_m` (13-22 km by default,
the one home of that band). Between two levels the env interpolates the
wind linearly (in pressure on a grid), so every wind reachable inside the
band is a convex combination of the levels inside it and the interpolated
winds at the band's two ends: the hull of those points is the hull of every
reachable wind (`band_winds`).

Per column (`column`):
- `margin_mps`: the signed distance of the origin to the hull's boundary
  [m/s]: > 0 inside (the smallest wind error that could push zero out of
  the hull), < 0 outside (how far every reachable mix of winds is from
  calm, the slowest drift the balloon can manage), 0 on the boundary or for
  winds that all lie on one line through zero;
- `gap_deg`: the largest angle between two neighbouring wind directions
  [deg] (< 180 when zero is strictly inside, 360 for a single direction);
- `weakest_mps`: the slowest reachable wind [m/s].

Hulls are scipy's (`scipy.spatial.ConvexHull`, Qhull; its `equations` hold
each edge's unit outward normal n and offset c, n.x + c <= 0 inside, so
the origin's distance to an edge's line is -c). `grid_map` maps every column
of a gridded file, `sounding_column` a sounding's one column, `at` the
column at a place of a grid (bilinear between columns, as the env).
"""

import dataclasses
import math
from typing import Any, Dict, Optional, Sequence, Tuple

import numpy as np
import scipy.spatial

from ble_latex import errors
from ble_latex.wind import analysis
from ble_latex.wind import reach
from ble_latex.wind import sounding as sounding_lib

# Winds slower than this count as calm (their direction is not defined). # [m/s]
CALM_MPS = 1e-9


@dataclasses.dataclass(frozen=True)
class Column:
  """How a column's reachable winds surround zero.

  Attributes:
    inside: Zero lies in the hull (margin_mps >= 0).
    margin_mps: Signed distance of zero to the hull's boundary, > 0
      inside. # [m/s]
    gap_deg: Largest angle between neighbouring wind directions. # [deg]
    weakest_mps: Slowest reachable wind. # [m/s]
    points: The winds the hull is made of (band_winds). # [m/s]
  """
  inside: bool
  margin_mps: float
  gap_deg: float
  weakest_mps: float
  points: int

  def as_dict(self) -> Dict[str, Any]:
    return {'inside': self.inside, 'margin_mps': round(self.margin_mps, 4),
            'gap_deg': round(self.gap_deg, 2),
            'weakest_mps': round(self.weakest_mps, 4), 'points': self.points}


def _segment_distance(a: np.ndarray, b: np.ndarray) -> float:
  """Distance of the origin to the segment [a, b] (2-vectors). # [m/s]"""
  ab = b - a
  length2 = float(ab @ ab)
  s = 0.0 if length2 == 0.0 else min(1.0, max(0.0, -float(a @ ab) / length2))
  return float(np.hypot(*(a + s * ab)))


def hull_margin(uv: np.ndarray) -> float:
  """Signed distance of zero to the convex hull's boundary of winds. # [m/s]

  > 0: zero inside, the distance to the nearest edge; < 0: outside, minus
  the distance to the hull (the nearest point of its edges); a hull of
  winds on one line (Qhull refuses it: no area) is its segment, 0 when the
  segment holds zero.

  Args:
    uv: [N, 2] wind vectors (u east, v north), N >= 1. # [m/s]
  """
  uv = np.asarray(uv, np.float64).reshape(-1, 2)
  if uv.shape[0] == 0 or not np.all(np.isfinite(uv)):
    raise ValueError(f'hull_margin: {uv.shape[0]} winds, finite ones needed')
  try:
    hull = scipy.spatial.ConvexHull(uv)
  except scipy.spatial.QhullError:  # Fewer than 3 points, or on one line.
    centre = uv.mean(axis=0)
    spread = uv - centre
    direction = np.linalg.svd(spread, full_matrices=False)[2][0]
    along = spread @ direction
    ends = (centre + along.min() * direction, centre + along.max() * direction)
    return -_segment_distance(*ends)
  offsets = hull.equations[:, 2]  # n . 0 + c: -(distance to the edge line).
  if np.all(offsets <= 0.0):
    return float(-offsets.max())
  return -min(_segment_distance(uv[i], uv[j]) for i, j in hull.simplices)


def largest_gap_deg(uv: np.ndarray) -> float:
  """Largest angle between neighbouring directions of non-calm winds. # [deg]

  360 for one direction (or none), < 180 exactly when the directions
  surround zero.
  """
  uv = np.asarray(uv, np.float64).reshape(-1, 2)
  speed = np.hypot(uv[:, 0], uv[:, 1])
  angles = np.sort(np.degrees(np.arctan2(uv[speed > CALM_MPS, 1],
                                         uv[speed > CALM_MPS, 0])))
  if angles.size < 2:
    return 360.0
  gaps = np.diff(np.append(angles, angles[0] + 360.0))
  return float(gaps.max())


def _many(winds: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
  """(margin, gap, weakest) of K columns' winds [K, M, 2], as `column`.

  Columns whose directions leave a gap wider than 180 deg (zero outside
  the hull) are measured without Qhull: the distance of zero to a convex
  hull it lies outside is the least over the segments between two of its
  points (the hull's edges are among them, every segment lies inside it);
  the others go through `hull_margin`.
  """
  speed = np.hypot(winds[..., 0], winds[..., 1])
  angles = np.sort(np.degrees(np.arctan2(winds[..., 1], winds[..., 0])), -1)
  gap = np.diff(np.concatenate([angles, angles[:, :1] + 360.0], -1), axis=-1)
  gap = gap.max(axis=-1)
  calm = (speed <= CALM_MPS).any(axis=-1)
  gap[calm] = [largest_gap_deg(w) for w in winds[calm]]
  a = winds[:, :, None, :]
  ab = winds[:, None, :, :] - a
  length2 = (ab * ab).sum(-1)
  s = np.clip(-(a * ab).sum(-1) / np.where(length2 > 0, length2, 1.0),
              0.0, 1.0)
  nearest = a + s[..., None] * ab
  margin = -np.hypot(nearest[..., 0], nearest[..., 1]).min(axis=(1, 2))
  rest = calm | (gap <= 180.0 + 1e-9)
  margin[rest] = [hull_margin(w) for w in winds[rest]]
  return margin, gap, speed.min(axis=-1)


def column(uv: np.ndarray) -> Column:
  """How the winds `uv` [N, 2] (m/s) surround zero (`Column`)."""
  uv = np.asarray(uv, np.float64).reshape(-1, 2)
  margin = hull_margin(uv)
  return Column(inside=margin >= 0.0, margin_mps=margin,
                gap_deg=largest_gap_deg(uv),
                weakest_mps=float(np.hypot(uv[:, 0], uv[:, 1]).min()),
                points=int(uv.shape[0]))


def band_winds(coordinate: np.ndarray, uv: np.ndarray,
               band: Tuple[float, float]) -> np.ndarray:
  """The winds whose hull is every wind reachable in a band.

  The levels inside [band[0], band[1]] plus the winds linearly interpolated
  at the band's ends (held at the nearest level beyond the column's ends,
  as the env holds a sounding's top).

  Args:
    coordinate: [L] the levels' coordinate, ascending (height [m] or
      pressure [Pa]).
    uv: [L, 2] their winds. # [m/s]
    band: (low, high) of the same coordinate.

  Returns:
    [M, 2] winds. # [m/s]
  """
  coordinate = np.asarray(coordinate, np.float64)
  uv = np.asarray(uv, np.float64)
  inner = uv[(coordinate > band[0]) & (coordinate < band[1])]
  ends = np.stack([np.interp(band, coordinate, uv[:, k]) for k in (0, 1)],
                  axis=-1)
  return np.concatenate([ends[:1], inner, ends[1:]])


def pressure_band(band_m: Optional[Tuple[float, float]] = None
                  ) -> Tuple[float, float]:
  """The flight band in pressure (US Standard Atmosphere 1976), ascending.

  Args:
    band_m: (low, high) altitude; None: `reach.flight_band_m()`. # [m]

  Returns:
    (pressure at the top, pressure at the bottom). # [Pa]
  """
  low, high = reach.flight_band_m() if band_m is None else band_m
  return analysis.pressure_of_height(high), analysis.pressure_of_height(low)


@dataclasses.dataclass(frozen=True)
class FeasibilityMap:
  """`Column` fields of every column of a grid (arrays [lat, lon]).

  Attributes:
    latitude: [nlat] ascending. # [deg N]
    longitude: [nlon] ascending, the file's convention (a global grid
      without its wrapped column). # [deg E]
    margin_mps, gap_deg, weakest_mps: [nlat, nlon] as `Column`.
    band_m: The altitude band. # [m]
    band_pa: It in pressure (top, bottom). # [Pa]
    time: The file's time mapped (ISO, UTC).
  """
  latitude: np.ndarray
  longitude: np.ndarray
  margin_mps: np.ndarray
  gap_deg: np.ndarray
  weakest_mps: np.ndarray
  band_m: Tuple[float, float]
  band_pa: Tuple[float, float]
  time: str

  @property
  def inside(self) -> np.ndarray:
    return self.margin_mps >= 0.0

  def feasible_fraction(self) -> float:
    """Area-weighted (cos latitude) fraction of columns with zero inside."""
    weight = np.broadcast_to(np.cos(np.radians(self.latitude))[:, None],
                             self.margin_mps.shape)
    return float((weight * self.inside).sum() / weight.sum())

  def summary(self) -> Dict[str, Any]:
    margin = self.margin_mps
    return {
        'columns': int(margin.size),
        'inside_fraction': round(float(self.inside.mean()), 4),
        'inside_fraction_area': round(self.feasible_fraction(), 4),
        'margin_mps_percentiles_5_50_95': [
            round(float(q), 3) for q in np.percentile(margin, [5, 50, 95])],
        'band_m': list(self.band_m),
        'band_hpa': [round(p / 100.0, 2) for p in self.band_pa],
        'time': self.time}


def grid_map(data: Any, time_index: int = 0,
             band_m: Optional[Tuple[float, float]] = None) -> FeasibilityMap:
  """`column` of every column of a gridded file at one of its times.

  Args:
    data: A `gridded.Era5Data` of a grid (not a sounding: `sounding_column`).
    time_index: Which of its times.
    band_m: The altitude band; None: `reach.flight_band_m()`. # [m]

  Raises:
    errors.ConfigError: a sounding, or a time index the file does not hold.
  """
  if data.source == 'sounding':
    raise errors.ConfigError(f'{list(data.paths)}: a sounding is one column; '
                             'map it with sounding_column')
  if not 0 <= time_index < len(data.times):
    raise errors.ConfigError(f'time index {time_index}: the file holds '
                             f'{len(data.times)} time(s)')
  band_m = reach.flight_band_m() if band_m is None else band_m
  band_pa = pressure_band(band_m)
  n_lon = data.longitude.size - int(data.global_longitude)
  uv = np.asarray(data.uv[time_index, :, :, :n_lon], np.float64)
  # band_winds is linear in the winds: [M, L] weights of the L levels.
  eye = np.repeat(np.eye(data.pressure.size)[:, :, None], 2, axis=-1)
  weights = np.stack([band_winds(data.pressure, eye[:, k], band_pa)[:, 0]
                      for k in range(data.pressure.size)], axis=-1)
  winds = np.einsum('ml,lijc->ijmc', weights, uv)  # [lat, lon, M, 2]
  out = np.stack(_many(winds.reshape(-1, *winds.shape[-2:])), axis=0)
  out = out.reshape((3,) + uv.shape[1:3])
  time = str(np.datetime_as_string(np.datetime64(data.times[time_index]),
                                   unit='m')) + 'Z'
  return FeasibilityMap(np.asarray(data.latitude, np.float64),
                        np.asarray(data.longitude[:n_lon], np.float64),
                        out[0], out[1], out[2], tuple(band_m), band_pa, time)


def at(data: Any, lat: float, lon: float, time_s: float = 0.0,
       band_m: Optional[Tuple[float, float]] = None
       ) -> Tuple[Column, np.ndarray]:
  """`column` of a grid's winds at a place (bilinear, `Era5Data.interpolate`).

  Args:
    data: A `gridded.Era5Data`.
    lat: Latitude. # [deg N]
    lon: Longitude, any convention. # [deg E]
    time_s: Time after the file's first. # [s]
    band_m: The altitude band; None: `reach.flight_band_m()`. # [m]

  Returns:
    (the column's `Column`, its band winds [M, 2] in m/s).
  """
  band_pa = pressure_band(band_m)
  uv = data.interpolate(time_s, data.pressure, lat, lon)
  winds = band_winds(data.pressure, uv, band_pa)
  return column(winds), winds


@dataclasses.dataclass(frozen=True)
class SoundingColumn:
  """A sounding's column in the band (`sounding_column`).

  Attributes:
    column: Its `Column`.
    winds: [M, 2] the band's winds (`band_winds`). # [m/s]
    height_m: [M] their heights (the band's ends first and last). # [m]
    site: The file's `sounding.Site`.
  """
  column: Column
  winds: np.ndarray
  height_m: np.ndarray
  site: Any


def sounding_column(path: str, band_m: Optional[Tuple[float, float]] = None
                    ) -> SoundingColumn:
  """`column` of a sounding in the band, by its own heights.

  Above its top the wind is its top's (as the env holds it).

  Raises:
    errors.BadFileError: as `sounding.read`.
  """
  band = reach.flight_band_m() if band_m is None else band_m
  s = sounding_lib.read(path)
  uv = np.stack([s.u_mps, s.v_mps], axis=-1)
  height = np.asarray(s.height_m, np.float64)
  winds = band_winds(height, uv, band)
  inner = height[(height > band[0]) & (height < band[1])]
  return SoundingColumn(column(winds), winds,
                        np.concatenate([[band[0]], inner, [band[1]]]),
                        s.site)


def sites_feasible(data: Any, sites: Sequence[Tuple[float, float]],
                   min_margin_mps: float = 0.0,
                   band_m: Optional[Tuple[float, float]] = None
                   ) -> Tuple[np.ndarray, np.ndarray]:
  """Which sites' columns hold zero with at least `min_margin_mps`.

  Args:
    data: A `gridded.Era5Data` (a sounding: the same column everywhere).
    sites: (lat [deg N], lon [deg E]) pairs.
    min_margin_mps: The least margin kept (0: zero inside or on the
      hull; < 0 keeps columns that far outside too). # [m/s]
    band_m: The altitude band; None: `reach.flight_band_m()`. # [m]

  Returns:
    (keep [N] bool, margin [N] m/s).
  """
  if not math.isfinite(min_margin_mps):
    raise errors.ConfigError(f'min_margin_mps = {min_margin_mps!r}: expected '
                             'a finite number [m/s]')
  margin = np.array([at(data, lat, lon, band_m=band_m)[0].margin_mps
                     for lat, lon in sites], np.float64).reshape(-1)
  return margin >= min_margin_mps, margin
