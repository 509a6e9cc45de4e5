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
  - `sample_era5`: an ERA5 file through the reader (BLE's offset-to-lat/lng
    geometry, `era5.latlng_of_offset`; `Era5Data.interpolate`), the station
    at the centre of the file's area, the same annulus and uniform times
    over the file's span; deterministic in the seed. The file's area must contain
    the annulus (else the winds would be clipped edge values).
"""

import dataclasses
from typing import Any, Dict, Optional, Sequence, Union

import jax
import jax.numpy as jnp
import numpy as np
import scipy.stats

from ble_latex import errors
from ble_latex.wind import era5
from ble_latex.wind import generative

# The generative field's pressure range (BLE's VAE grid). # [Pa]
BAND_PA = (5000.0, 14000.0)
# Distances from the station sampled (the start region of BLE's
# station-keeping task and beyond). # [km]
RADIUS_KM = (50.0, 200.0)
VAE_HORIZON_S = 48 * 3600.0  # [s] The VAE field's time grid.


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
                label: Optional[str] = None) -> WindSamples:
  """Columns of ERA5 winds around the centre of the file's area.

  Args:
    path: ERA5 file(s) (`era5.load`).
    pressures_pa: [L] levels (default: the file's levels in `BAND_PA`). # [Pa]
    num_samples: Samples (place, time).
    seed: Seed of the samples' places and times.
    radius_km: (min, max) distance from the centre. # [km]
    label: Name of the source (default: the path).

  Returns:
    The columns.

  Raises:
    FileNotFoundError, IsADirectoryError, ValueError: a bad file (see
      `era5.load`), fewer than 2 levels in the band, or an area that does
      not contain the sampled annulus.
  """
  if num_samples < 1:
    raise ValueError(f'num_samples must be >= 1, got {num_samples}')
  data = era5.load(path)
  where = f'ERA5 file(s) {list(data.paths)}'
  if pressures_pa is None:
    pressures_pa = band_levels(data.pressure)
    if pressures_pa.size < 2:
      raise ValueError(
          f'{where} hold {pressures_pa.size} pressure level(s) in '
          f'{BAND_PA[0]:g}..{BAND_PA[1]:g} Pa (levels {list(data.pressure)} '
          'Pa); the comparison needs 2 or more')
  else:
    check_levels(pressures_pa, float(np.min(data.pressure)),
                 float(np.max(data.pressure)), where)
  center_lat = 0.5 * (data.latitude[0] + data.latitude[-1])
  center_lon = 0.5 * (data.longitude[0] + data.longitude[-1])
  edge = float(radius_km[1])  # [km]
  for x, y in ((edge, 0.0), (-edge, 0.0), (0.0, edge), (0.0, -edge)):
    lat, lon = era5.latlng_of_offset(center_lat, center_lon, x * 1000.0,
                                     y * 1000.0)
    if not data.covers(lat, lon):
      lon = float(data.wrap_longitude(lon))
      raise ValueError(
          f'{where} cover lat {data.latitude[0]:g}..{data.latitude[-1]:g}, '
          f'lon {data.longitude[0]:g}..{data.longitude[-1]:g}: too small for '
          f'samples up to {radius_km[1]:g} km from its centre (lat '
          f'{center_lat:g}, lon {center_lon:g}), which reach lat {lat:.3g}, '
          f'lon {lon:.4g}')
  rng = np.random.default_rng(seed)
  x_km, y_km = _annulus(rng.random(num_samples), rng.random(num_samples),
                        radius_km)
  t_s = rng.random(num_samples) * float(data.time_s[-1])
  u = np.empty((num_samples, len(pressures_pa)))
  v = np.empty_like(u)
  for i in range(num_samples):
    lat, lon = era5.latlng_of_offset(center_lat, center_lon,
                                     float(x_km[i]) * 1000.0,
                                     float(y_km[i]) * 1000.0)
    uv = data.interpolate(float(t_s[i]), np.asarray(pressures_pa, np.float64),
                          lat, lon)
    u[i], v[i] = uv[:, 0], uv[:, 1]
  return WindSamples(label or ', '.join(data.paths), np.asarray(pressures_pa),
                     u, v)


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

