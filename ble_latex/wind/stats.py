# coding=utf-8
"""Two wind sources side by side: distributions, distances, direction diversity.

A source is sampled into columns: at many (time, place) samples, the wind
(u, v) at the same pressure levels. `compare` then measures, per pressure
level and pooled over levels, the 1-Wasserstein distance between the two
sources' u and between their v (`scipy.stats.wasserstein_distance`, in m/s:
for two samples that differ by a constant shift c it is |c|), and each
source's direction diversity.

Direction diversity is what station-keeping lives on: a balloon can only
steer by choosing an altitude whose wind points where it wants to go. Two
levels' winds *oppose* when the angle between them exceeds 90 degrees, i.e.
u_i u_j + v_i v_j < 0. Per source:
  - `opposing_pair_fraction`: over all pairs of levels (i < j) in the band
    and all samples, the fraction of (sample, pair) whose winds oppose;
  - `opposing_any_fraction`: the fraction of samples (columns) in which at
    least one pair of levels opposes;
  - `opposing_by_level`: per level i, the fraction of samples in which the
    wind at i opposes the wind at some other level;
  - `pairs`: the L x L matrix of per-pair fractions (diagonal 0).

Samplers:
  - `sample_vae`: BLE's generative (VAE) forecast, decoded in JAX
    (`generative.reset_forecasts`, `generative.forecast`): `num_fields`
    forecast keys from a key, each queried at `points_per_field` places at a
    uniform distance 50-200 km from the station (uniform over the annulus'
    area) and uniform times in the field's 48 h; deterministic in the key.
  - `sample_era5`: any wind file the readers take (ERA5, a GFS-style NetCDF
    analysis, GRIB2, a University of Wyoming sounding; `gridded.load`):
    `region='station'`: the station at the centre of the file's area, the
    same annulus (BLE's offset-to-lat/lng geometry,
    `globe.latlng_of_offset`); `region='domain'`: uniform over the area of
    the whole grid; uniform times over the file's span; deterministic in the
    seed. The area must contain the annulus (else the winds would be clipped
    edge values). A sounding is one column: one sample
    (`WindSamples.single_column`), never copies of it.

One source's profile in the flight band 15-25 km (`profile`, heights by the
US Standard Atmosphere 1976, `height_of_pressure`): per level the speed's
mean and 5/25/50/75/95 % quantiles; the fraction of columns in which two
levels' winds are >= 90 and >= 135 deg apart (`apart_fractions`); the
vertical shear between adjacent levels [m/s/km] and each column's spread
(the largest wind difference between two of its levels) (`shear`).
`compare_file` is what `ble-latex-plot --wind_stats` computes: `compare` of
a file with the VAE (or a second file) and both sources' profiles.
"""

import dataclasses
import functools
from typing import Any, Dict, Optional, Sequence, Union

import jax
import jax.numpy as jnp
import numpy as np
import scipy.stats

from ble_latex import errors
from ble_latex.wind import analysis
from ble_latex.wind import generative
from ble_latex.wind import globe
from ble_latex.wind import gridded

# The generative field's pressure range (BLE's VAE grid). # [Pa]
BAND_PA = (5000.0, 14000.0)
# Distances from the station sampled (the start region of BLE's
# station-keeping task and beyond). # [km]
RADIUS_KM = (50.0, 200.0)
VAE_HORIZON_S = 48 * 3600.0  # [s] The VAE field's time grid.
# Where a grid is sampled: around the centre of its area, or all of it.
REGIONS = ('station', 'domain')
# Samples (columns) one call may draw: a file's grid samples, or the VAE's
# fields x points. Checked before anything is allocated (2e9 asked 15 GiB).
MAX_SAMPLES = 1_000_000


@dataclasses.dataclass(frozen=True)
class WindSamples:
  """Wind columns of one source.

  Attributes:
    label: Name of the source (e.g. 'VAE', the ERA5 file).
    pressures_pa: [L] pressure levels, ascending. # [Pa]
    u: [N, L] eastward wind per sample and level. # [m/s]
    v: [N, L] northward wind. # [m/s]
  """
  label: str
  pressures_pa: np.ndarray
  u: np.ndarray
  v: np.ndarray

  @property
  def single_column(self) -> bool:
    """One column (e.g. a sounding): a single sample, no distribution."""
    return self.u.shape[0] == 1

  def __post_init__(self):
    pressures = np.asarray(self.pressures_pa, dtype=np.float64)
    shape = (np.asarray(self.u).shape[0], pressures.size)
    for name in ('u', 'v'):
      value = np.asarray(getattr(self, name), dtype=np.float64)
      if value.ndim != 2 or value.shape != shape or not value.size:
        raise ValueError(f'{self.label}: {name} has shape {value.shape}, '
                         f'expected (samples, {pressures.size}) with samples '
                         '> 0')
      if not np.all(np.isfinite(value)):
        raise ValueError(f'{self.label}: {name} has non-finite winds')
      object.__setattr__(self, name, value)
    object.__setattr__(self, 'pressures_pa', pressures)


def band_levels(pressures_pa: Sequence[float],
                band: Sequence[float] = BAND_PA) -> np.ndarray:
  """The levels inside the band, ascending. # [Pa]

  Args:
    pressures_pa: Pressure levels, any order. # [Pa]
    band: (low, high) pressures kept, inclusive. # [Pa]

  Returns:
    The levels in the band, ascending. # [Pa]
  """
  pressures = np.sort(np.asarray(pressures_pa, dtype=np.float64))
  return pressures[(pressures >= band[0]) & (pressures <= band[1])]


def check_levels(pressures_pa: Sequence[float], low: float, high: float,
                 source: str) -> np.ndarray:
  """Levels inside a source's pressure range, as float64.

  Outside it a source's winds are its edge level's (clamped), which would
  be reported under levels the source does not hold.

  Args:
    pressures_pa: The levels asked for. # [Pa]
    low: The source's lowest pressure. # [Pa]
    high: The source's highest pressure. # [Pa]
    source: The source, for the message.

  Raises:
    errors.ConfigError: A level outside [low, high] or not finite (one line).
  """
  pressures = np.asarray(pressures_pa, dtype=np.float64)
  bad = pressures[~(np.isfinite(pressures) & (pressures >= low) &
                    (pressures <= high))]
  if bad.size:
    raise errors.ConfigError(
        f'pressure levels {bad.tolist()} Pa are outside {source} '
        f'({low:g}..{high:g} Pa): its winds there would be clamped')
  return pressures


def _annulus(uniform_radius: np.ndarray, uniform_angle: np.ndarray,
             radius_km: Sequence[float]) -> Any:
  """(x, y) [km] uniform over an annulus' area from two uniforms in [0, 1)."""
  low, high = radius_km
  radius = np.sqrt(low**2 + uniform_radius * (high**2 - low**2))
  angle = 2.0 * np.pi * uniform_angle
  return radius * np.cos(angle), radius * np.sin(angle)


def sample_vae(key: jnp.ndarray, pressures_pa: Sequence[float], *,
               num_fields: int, points_per_field: int,
               radius_km: Sequence[float] = RADIUS_KM,
               params: Optional[Any] = None) -> WindSamples:
  """Columns of BLE's generative (VAE) forecast.

  Args:
    key: JAX PRNG key; the same key gives the same samples.
    pressures_pa: [L] levels. # [Pa]
    num_fields: Forecast keys (decoded fields).
    points_per_field: Samples (place, time) per field.
    radius_km: (min, max) distance from the station. # [km]
    params: Decoder weights (default `generative.decoder_params()`).

  Returns:
    num_fields * points_per_field columns, labelled 'VAE'.
  """
  if num_fields < 1 or points_per_field < 1:
    raise ValueError(f'num_fields and points_per_field must be >= 1, got '
                     f'{num_fields}, {points_per_field}')
  if num_fields * points_per_field > MAX_SAMPLES:
    raise errors.ConfigError(
        f'wind stats: {num_fields} VAE fields x {points_per_field} points = '
        f'{num_fields * points_per_field} samples, more than {MAX_SAMPLES} '
        '(--wind_stats_fields, --wind_stats_points)')
  check_levels(pressures_pa, BAND_PA[0], BAND_PA[1], "the VAE forecast's grid")
  params = generative.decoder_params() if params is None else params
  field_key, point_key = jax.random.split(key)
  fields = generative.reset_forecasts(
      jax.random.split(field_key, num_fields), params)
  uniforms = np.asarray(jax.random.uniform(
      point_key, (3, num_fields, points_per_field)), dtype=np.float64)
  x_km, y_km = _annulus(uniforms[0], uniforms[1], radius_km)
  t_s = uniforms[2] * VAE_HORIZON_S
  pressures = np.asarray(pressures_pa, dtype=np.float32)
  columns = jax.vmap(generative.forecast, in_axes=(0, 0, 0, None, 0))
  u, v = columns(fields, jnp.asarray(x_km * 1000.0, jnp.float32)[..., None],
                 jnp.asarray(y_km * 1000.0, jnp.float32)[..., None],
                 jnp.asarray(pressures), jnp.asarray(t_s, jnp.float32)[...,
                                                                       None])
  shape = (num_fields * points_per_field, pressures.size)
  return WindSamples('VAE', np.asarray(pressures_pa, dtype=np.float64),
                     np.asarray(u).reshape(shape), np.asarray(v).reshape(shape))


def sample_era5(path: Union[str, Sequence[str]],
                pressures_pa: Optional[Sequence[float]] = None, *,
                num_samples: int, seed: int = 0,
                radius_km: Sequence[float] = RADIUS_KM,
                label: Optional[str] = None,
                region: str = 'station',
                band: Sequence[float] = BAND_PA) -> WindSamples:
  """Columns of any wind file the readers accept (`gridded.load`).

  ERA5, other CF NetCDF analyses and GRIB2 are sampled at `num_samples`
  places and times: `region='station'` in the annulus around the centre of
  the file's area (`radius_km`), `'domain'` uniformly over the area of the
  whole grid (uniform in sin(latitude) and longitude); times uniform over
  the file's span (a snapshot has one). A sounding is one column, the same
  at every place: it gives one sample (`WindSamples.single_column`), never
  `num_samples` copies of it.

  Args:
    path: Wind file(s) (`gridded.load`).
    pressures_pa: [L] levels (default: the file's levels in `band`). # [Pa]
    num_samples: Samples (place, time) of a grid.
    seed: Seed of the samples' places and times.
    radius_km: (min, max) distance from the centre (`region='station'`).
      # [km]
    label: Name of the source (default: the path).
    region: 'station' or 'domain'.
    band: (low, high) pressures of the default levels. # [Pa]

  Returns:
    The columns.

  Raises:
    FileNotFoundError, IsADirectoryError, ValueError: a bad file (see
      `gridded.load`), fewer than 2 levels in the band, or an area that does
      not contain the sampled annulus.
  """
  if num_samples < 1:
    raise ValueError(f'num_samples must be >= 1, got {num_samples}')
  if num_samples > MAX_SAMPLES:
    raise errors.ConfigError(
        f'wind stats: {num_samples} samples, more than {MAX_SAMPLES} '
        '(--wind_stats_samples)')
  if region not in REGIONS:
    raise ValueError(f'region must be one of {REGIONS}, got {region!r}')
  data = gridded.load(path)
  where = f'{data.source} file(s) {list(data.paths)}'
  if pressures_pa is None:
    pressures_pa = band_levels(data.pressure, band)
    if pressures_pa.size < 2:
      raise ValueError(
          f'{where} hold {pressures_pa.size} pressure level(s) in '
          f'{band[0]:g}..{band[1]:g} Pa (levels {list(data.pressure)} '
          'Pa); the comparison needs 2 or more')
  else:
    check_levels(pressures_pa, float(np.min(data.pressure)),
                 float(np.max(data.pressure)), where)
  pressures = np.asarray(pressures_pa, np.float64)
  label = label or ', '.join(data.paths)
  if data.source == 'sounding':
    uv = data.interpolate(0.0, pressures, 0.0, 0.0)
    return WindSamples(label, pressures, uv[None, :, 0], uv[None, :, 1])
  rng = np.random.default_rng(seed)
  if region == 'station':
    lat, lon = _annulus_points(data, rng, num_samples, radius_km, where)
  else:
    sin_lat = np.sin(np.deg2rad(data.latitude[[0, -1]]))
    lat = np.rad2deg(np.arcsin(rng.uniform(sin_lat[0], sin_lat[1],
                                           num_samples)))
    lon = rng.uniform(data.longitude[0], data.longitude[-1], num_samples)
  t_s = rng.random(num_samples) * float(data.time_s[-1])
  uv = data.interpolate(t_s[:, None], pressures[None, :], lat[:, None],
                        lon[:, None])
  return WindSamples(label, pressures, uv[..., 0], uv[..., 1])


def _annulus_points(data: gridded.Era5Data, rng: np.random.Generator,
                    num_samples: int, radius_km: Sequence[float],
                    where: str) -> Any:
  """(lat, lon) [deg] uniform over the annulus around the area's centre."""
  center_lat = 0.5 * (data.latitude[0] + data.latitude[-1])
  center_lon = 0.5 * (data.longitude[0] + data.longitude[-1])
  edge = float(radius_km[1])  # [km]
  for x, y in ((edge, 0.0), (-edge, 0.0), (0.0, edge), (0.0, -edge)):
    lat, lon = globe.latlng_of_offset(center_lat, center_lon, x * 1000.0,
                                      y * 1000.0)
    if not data.covers(lat, lon):
      lon = float(data.wrap_longitude(lon))
      raise ValueError(
          f'{where} cover lat {data.latitude[0]:g}..{data.latitude[-1]:g}, '
          f'lon {data.longitude[0]:g}..{data.longitude[-1]:g}: too small for '
          f'samples up to {radius_km[1]:g} km from its centre (lat '
          f'{center_lat:g}, lon {center_lon:g}), which reach lat {lat:.3g}, '
          f'lon {lon:.4g}')
  x_km, y_km = _annulus(rng.random(num_samples), rng.random(num_samples),
                        radius_km)
  points = [globe.latlng_of_offset(center_lat, center_lon, float(x) * 1000.0,
                                   float(y) * 1000.0)
            for x, y in zip(x_km, y_km)]
  return (np.array([p[0] for p in points]), np.array([p[1] for p in points]))


def direction_diversity(samples: WindSamples) -> Dict[str, Any]:
  """How often the winds at two levels oppose (angle > 90 deg), see module.

  Args:
    samples: The columns (2 or more levels).

  Returns:
    {'opposing_pair_fraction', 'opposing_any_fraction',
    'opposing_by_level' [L], 'pairs' [L, L]}.
  """
  levels = samples.pressures_pa.size
  if levels < 2:
    raise ValueError(f'{samples.label}: direction diversity needs 2 or more '
                     f'levels, got {levels}')
  dot = (samples.u[:, :, None] * samples.u[:, None, :] +
         samples.v[:, :, None] * samples.v[:, None, :])  # [N, L, L]
  opposing = dot < 0.0
  pairs = opposing.mean(axis=0)
  upper = np.triu_indices(levels, k=1)
  return {
      'opposing_pair_fraction': float(pairs[upper].mean()),
      'opposing_any_fraction': float(opposing.any(axis=(1, 2)).mean()),
      'opposing_by_level': opposing.any(axis=2).mean(axis=0).tolist(),
      'pairs': pairs.tolist(),
  }


def compare(a: WindSamples, b: WindSamples) -> Dict[str, Any]:
  """Distributions, Wasserstein distances and direction diversity of a and b.

  Args:
    a: Columns of the first source.
    b: Columns of the second, at the same levels.

  Returns:
    A JSON-ready dict: 'sources', 'pressures_pa', 'samples',
    'wasserstein_u_mps' / 'wasserstein_v_mps' (pooled over levels),
    'per_level' (per level: the distances and each source's mean, std and
    5/50/95 percentiles of u and v), 'direction_diversity' (per source).

  Raises:
    ValueError: the sources have different levels.
  """
  if (a.pressures_pa.shape != b.pressures_pa.shape or
      not np.allclose(a.pressures_pa, b.pressures_pa)):
    raise ValueError(f'{a.label} and {b.label} are sampled at different '
                     f'pressure levels ({a.pressures_pa.tolist()} vs '
                     f'{b.pressures_pa.tolist()} Pa)')

  def summary(values: np.ndarray) -> Dict[str, float]:
    p5, p50, p95 = np.percentile(values, [5, 50, 95])
    return {'mean': float(values.mean()), 'std': float(values.std()),
            'p5': float(p5), 'p50': float(p50), 'p95': float(p95)}

  per_level = []
  for i, pressure in enumerate(a.pressures_pa):
    per_level.append({
        'pressure_pa': float(pressure),
        'wasserstein_u_mps': float(scipy.stats.wasserstein_distance(
            a.u[:, i], b.u[:, i])),
        'wasserstein_v_mps': float(scipy.stats.wasserstein_distance(
            a.v[:, i], b.v[:, i])),
        'u_mps': {'a': summary(a.u[:, i]), 'b': summary(b.u[:, i])},
        'v_mps': {'a': summary(a.v[:, i]), 'b': summary(b.v[:, i])},
    })
  return {
      'sources': {'a': a.label, 'b': b.label},
      'pressures_pa': a.pressures_pa.tolist(),
      'samples': {'a': int(a.u.shape[0]), 'b': int(b.u.shape[0])},
      'wasserstein_u_mps': float(scipy.stats.wasserstein_distance(
          a.u.ravel(), b.u.ravel())),
      'wasserstein_v_mps': float(scipy.stats.wasserstein_distance(
          a.v.ravel(), b.v.ravel())),
      'per_level': per_level,
      'direction_diversity': {'a': direction_diversity(a),
                              'b': direction_diversity(b)},
      'opposing_definition': (
          'two levels oppose when the angle between their winds exceeds 90 '
          'deg (u_i u_j + v_i v_j < 0)'),
  }



# --- One source's profile in the flight band. -------------------------------

# The band the profiles compare, 15-25 km (benchmarks/records/wind_compare.json was
# measured on it; the readers accept files by `reach.flight_band_m`) as
# pressures, US Standard Atmosphere 1976: (25 km, 15 km). # [Pa]
PROFILE_BAND_M = (15_000.0, 25_000.0)  # [m]
FLIGHT_BAND_PA = (analysis.pressure_of_height(PROFILE_BAND_M[1]),
                  analysis.pressure_of_height(PROFILE_BAND_M[0]))
# Direction-diversity thresholds: two levels whose winds are at least this
# far apart. # [deg]
APART_DEG = (90.0, 135.0)
# Speed quantiles reported per level. # [%]
SPEED_PERCENTILES = (5, 25, 50, 75, 95)
SINGLE_COLUMN_NOTE = ('one column (a sounding): a single sample, not a '
                      'distribution; its fractions are 0 or 1')


def height_of_pressure(pressure_pa: Union[float, Sequence[float]]
                       ) -> np.ndarray:
  """Geopotential height of a pressure, US Standard Atmosphere 1976. # [m]

  The inverse of `analysis.pressure_of_height` (NOAA/NASA/USAF 1976, eq.
  33a/33b), found by bracketing (brentq) between 0 and 47 km.

  Args:
    pressure_pa: Pressures in 101 325 .. 111 Pa (0-47 km). # [Pa]

  Returns:
    Heights, the shape of `pressure_pa`. # [m]
  """
  import scipy.optimize  # pylint: disable=g-import-not-at-top
  pressures = np.asarray(pressure_pa, np.float64)
  heights = [scipy.optimize.brentq(
      lambda h, p=p: analysis.pressure_of_height(h) - p, 0.0, 47_000.0,
      xtol=1e-6) for p in pressures.ravel()]
  return np.array(heights).reshape(pressures.shape)


def _quantiles(values: np.ndarray) -> Dict[str, float]:
  out = {'mean': float(values.mean())}
  for q, value in zip(SPEED_PERCENTILES,
                      np.percentile(values, SPEED_PERCENTILES)):
    out[f'p{q}'] = float(value)
  return out


def apart_fractions(samples: WindSamples) -> Dict[str, float]:
  """Fractions of columns with two levels' winds >= each `APART_DEG` apart.

  The angle between two winds is arccos(u_i.u_j / (|u_i| |u_j|)); a level
  with no wind (|u| = 0) has no direction and pairs with nothing.

  Returns:
    {'ge90': fraction, 'ge135': fraction} over the columns.
  """
  speed = np.hypot(samples.u, samples.v)
  dot = (samples.u[:, :, None] * samples.u[:, None, :] +
         samples.v[:, :, None] * samples.v[:, None, :])
  norm = speed[:, :, None] * speed[:, None, :]
  with np.errstate(invalid='ignore', divide='ignore'):
    cosine = np.where(norm > 0.0, dot / np.where(norm > 0.0, norm, 1.0), 1.0)
  out = {}
  for deg in APART_DEG:
    # cos <= cos(deg), with a hair of slack for exactly opposite winds.
    apart = cosine <= np.cos(np.deg2rad(deg)) + 1e-12
    out[f'ge{deg:.0f}'] = float(apart.any(axis=(1, 2)).mean())
  return out


def shear(samples: WindSamples) -> Dict[str, Any]:
  """Vertical shear between adjacent levels, and each column's spread.

  Shear |(u, v)_{i+1} - (u, v)_i| / (z_{i+1} - z_i) with the levels' US
  Standard Atmosphere heights, over every column and pair of adjacent
  levels (it grows as levels get closer: compare sources at the same
  levels); the spread: per column the largest |(u, v)_i - (u, v)_j| over
  any two levels, which does not depend on the levels between.

  Returns:
    {'shear_mps_per_km': quantiles, 'spread_mps': quantiles}.
  """
  heights_km = height_of_pressure(samples.pressures_pa) / 1000.0
  du = np.diff(samples.u, axis=1)
  dv = np.diff(samples.v, axis=1)
  dz = np.abs(np.diff(heights_km))
  per_km = np.hypot(du, dv) / dz[None, :]
  spread = np.hypot(samples.u[:, :, None] - samples.u[:, None, :],
                    samples.v[:, :, None] - samples.v[:, None, :]).max(
                        axis=(1, 2))
  return {'shear_mps_per_km': _quantiles(per_km.ravel()),
          'spread_mps': _quantiles(spread)}


def profile(samples: WindSamples,
            band: Sequence[float] = FLIGHT_BAND_PA) -> Dict[str, Any]:
  """One source's winds in the flight band (15-25 km), JSON-ready.

  Args:
    samples: Its columns (the levels in `band` are used; 2 or more).
    band: (low, high) pressures. # [Pa]

  Returns:
    'label', 'columns', 'single_column' (+ 'note'), 'pressures_pa',
    'heights_m' (US Standard Atmosphere), per level 'speed_mps' quantiles
    (mean, 5/25/50/75/95 %), 'apart' (`apart_fractions`), 'shear' (`shear`).

  Raises:
    ValueError: fewer than 2 levels in `band`.
  """
  keep = (samples.pressures_pa >= band[0]) & (samples.pressures_pa <= band[1])
  if keep.sum() < 2:
    raise ValueError(
        f'{samples.label}: {int(keep.sum())} level(s) in {band[0]:.0f}..'
        f'{band[1]:.0f} Pa (levels {samples.pressures_pa.tolist()}); a '
        'profile needs 2 or more')
  inside = WindSamples(samples.label, samples.pressures_pa[keep],
                       samples.u[:, keep], samples.v[:, keep])
  speed = np.hypot(inside.u, inside.v)
  out = {
      'label': inside.label,
      'columns': int(inside.u.shape[0]),
      'single_column': inside.single_column,
      'pressures_pa': inside.pressures_pa.tolist(),
      'heights_m': [round(float(h), 1)
                    for h in height_of_pressure(inside.pressures_pa)],
      'speed_mps': [_quantiles(speed[:, i]) for i in range(speed.shape[1])],
      'apart': apart_fractions(inside),
      'shear': shear(inside),
  }
  if inside.single_column:
    out['note'] = SINGLE_COLUMN_NOTE
  return out


def vae_levels(band: Sequence[float] = FLIGHT_BAND_PA) -> np.ndarray:
  """The VAE grid's pressure levels inside `band`, ascending. # [Pa]"""
  return band_levels(generative.ble_grid_axes()[2], band)


def compare_file(path: Union[str, Sequence[str]], *,
                 against: Optional[Union[str, Sequence[str]]] = None,
                 pressures_pa: Optional[Sequence[float]] = None,
                 num_samples: int = 2000, seed: int = 0,
                 num_fields: int = 64, points_per_field: int = 32,
                 region: str = 'station') -> Any:
  """A wind file against BLE's VAE winds (or another file), JSON-ready.

  What `ble-latex-plot --wind_stats` computes: `compare` at the file's
  levels inside the VAE's grid (or `pressures_pa`), and each source's
  `profile` in the flight band at its own levels (the VAE: its grid's
  levels; a file: its levels in 15-25 km).

  Args:
    path: Any wind file the readers accept (`sample_era5`).
    against: None for the VAE forecast, or another wind file.
    pressures_pa: Levels compared (default: the file's in `BAND_PA`). # [Pa]
    num_samples: Samples (place, time) of a grid file.
    seed: Seed of the samples (the VAE's key: `PRNGKey(seed)`).
    num_fields: VAE forecast keys.
    points_per_field: Samples per VAE field.
    region: Where a grid is sampled (`REGIONS`).

  Returns:
    (the other source's samples, the file's samples, the comparison with
    'profiles': {'a': ..., 'b': ...} added).
  """
  sample = functools.partial(sample_era5, num_samples=num_samples,
                             region=region)
  ours = sample(path, pressures_pa, seed=seed)

  def band_profile(source, label, source_seed):
    try:
      return profile(sample(source, band=FLIGHT_BAND_PA, seed=source_seed,
                            label=label))
    except ValueError as error:  # Fewer than 2 levels in 15-25 km.
      return {'label': label, 'error': str(error)}

  if against is None:
    # One decode at both sets of levels (the key fixes places and times).
    levels = np.union1d(ours.pressures_pa, vae_levels())
    both = sample_vae(jax.random.PRNGKey(seed), levels, num_fields=num_fields,
                      points_per_field=points_per_field)

    def at(pressures):
      index = np.searchsorted(levels, pressures)
      return WindSamples(both.label, np.asarray(pressures, np.float64),
                         both.u[:, index], both.v[:, index])

    other, other_profile = at(ours.pressures_pa), profile(at(vae_levels()))
  else:
    other = sample(against, ours.pressures_pa, seed=seed + 1)
    other_profile = band_profile(against, other.label, seed + 1)
  comparison = compare(other, ours)
  comparison['profiles'] = {'a': other_profile,
                            'b': band_profile(path, ours.label, seed)}
  comparison['region'] = region
  if ours.single_column or other.single_column:
    comparison['note'] = SINGLE_COLUMN_NOTE
  return other, ours, comparison
