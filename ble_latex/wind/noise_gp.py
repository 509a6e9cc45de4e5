# coding=utf-8
"""What measured winds say about BLE's wind noise elsewhere (a Gaussian process).

BLE's generative winds are a forecast plus simplex noise
(`simplex_wind_noise.NoisyWindComponent`, mirrored in `wind.simplex`): per
component (u, v),

  noise(q) = c * sum_h w_h * M * n_h(q / s_h + o_h),
  c = sqrt(W / W2) / W,  W = sum_h w_h,  W2 = sum_h w_h^2,

with M = `NOISE_MAGNITUDE`, n_h an OpenSimplex 4-D field, s_h the
harmonic's spacings (x [km], y [km], pressure [Pa], time [h]) and o_h a
random offset. Over the random offsets and seeds the noise is a zero-mean
stationary field with covariance

  k(q, q') = c^2 M^2 var(n) sum_h w_h^2 rho(|(q - q') / s_h|),      (1)

where rho is OpenSimplex's autocorrelation at a distance r in lattice units.
Measured on 200 000 random points (`tests/wind/test_noise_gp.py` re-measures it
on 20 000):
rho(0.2) = 0.91, rho(0.4) = 0.68, rho(0.6) = 0.40, rho(0.8) = 0.17,
rho(1.0) = 0.03, the same along an axis and along the diagonal; a Gaussian
exp(-r^2 / (2 l^2)) with l = `CORRELATION_LENGTH` = 0.45 matches it within
0.06 (0.91, 0.67, 0.41, 0.21, 0.09) and keeps the kernel positive definite.

A balloon measures the true wind where it flies: forecast + noise. Given
measured-minus-forecast winds at points X, the Gaussian-process posterior
mean of the noise at q is

  E[noise(q) | X] = k(q, X) (K(X, X) + s^2 I)^-1 d(X),                   (2)

the best linear estimate of the noise under (1) (Rasmussen & Williams,
Gaussian Processes for Machine Learning, 2006, Eq. 2.23); s^2 is a small
measurement variance (`JITTER` of the prior variance) for numerical
conditioning. With one measurement this is a correction that decays with
distance in each harmonic's units, the shape the planners' exp-decay
correction approximates by hand.
"""

from typing import Tuple

from balloon_learning_environment.env import simplex_wind_noise
import flax
import jax
import jax.numpy as jnp

from ble_latex.wind import simplex

Array = jax.Array

# OpenSimplex's autocorrelation length as a Gaussian, lattice units (module
# docstring). # [.]
CORRELATION_LENGTH = 0.45
# Measurement variance as a fraction of the noise's prior variance. # [.]
JITTER = 1e-3
# The most measurements a memory holds (its K x K solve at every use): the
# bound of the observation's (`latex_observation.wind_memory`) and of the
# planners' (`LatexMpcAgent.wind_memory`).
MAX_MEASUREMENTS = 1_024


@flax.struct.dataclass
class Measurements:
  """The last K measured-minus-forecast winds (a ring, newest last).

  Attributes:
    points: [K, 4] where: x east of the station [km], y north [km],
      pressure [Pa], time [h].
    du: [K] measured minus forecast eastward wind. # [m/s]
    dv: [K] measured minus forecast northward wind. # [m/s]
    valid: [K] which rows hold a measurement (bool).
  """
  points: Array
  du: Array
  dv: Array
  valid: Array


def empty(k: int, dtype=jnp.float32) -> Measurements:
  """K rows, none valid."""
  return Measurements(points=jnp.zeros((k, 4), dtype),
                      du=jnp.zeros((k,), dtype), dv=jnp.zeros((k,), dtype),
                      valid=jnp.zeros((k,), bool))


def add(memory: Measurements, point: Array, du: Array,
        dv: Array) -> Measurements:
  """`memory` with the oldest row dropped and (point, du, dv) appended.

  Args:
    memory: K measurements.
    point: (x [km], y [km], pressure [Pa], time [h]).
    du: Measured minus forecast eastward wind at it. # [m/s]
    dv: The same, northward. # [m/s]

  Returns:
    The K newest measurements.
  """
  def push(rows, row):
    return jnp.concatenate([rows[1:], jnp.asarray(row, rows.dtype)[None]])
  return Measurements(points=push(memory.points, point),
                      du=push(memory.du, du), dv=push(memory.dv, dv),
                      valid=push(memory.valid, True))


def _scale(which: str) -> float:
  """c^2 M^2 var(n) of Eq. (1) for component `which`. # [m^2/s^2]"""
  weights = [h[0] for h in simplex.ble_harmonics(which)]
  total, total_squared = sum(weights), sum(w * w for w in weights)
  c_squared = (total / total_squared) / total**2
  return (c_squared * simplex.NOISE_MAGNITUDE**2 *
          simplex_wind_noise.OPENSIMPLEX_VARIANCE)


def covariance(which: str, a: Array, b: Array) -> Array:
  """Eq. (1): the noise covariance of component `which` between points.

  Args:
    which: 'u' or 'v'.
    a: [..., 4] points (x [km], y [km], pressure [Pa], time [h]).
    b: [..., 4] points, broadcastable against `a`.

  Returns:
    The covariance, of the broadcast shape. # [m^2/s^2]
  """
  diff = jnp.asarray(a) - jnp.asarray(b)
  total = 0.0
  for weight, *spacing in simplex.ble_harmonics(which):
    r2 = jnp.sum((diff / jnp.asarray(spacing, diff.dtype))**2, axis=-1)
    total = total + weight**2 * _gaussian(r2)
  return _scale(which) * total


def prior_variance(which: str) -> float:
  """k(q, q) of Eq. (1). # [m^2/s^2]"""
  weights = [h[0] for h in simplex.ble_harmonics(which)]
  return _scale(which) * sum(w * w for w in weights)


def fit(memory: Measurements) -> Tuple[Array, Array]:
  """The weights (K + s^2 I)^-1 d of Eq. (2) for u and v.

  Rows that hold no measurement get weight 0 (their kernel rows and columns
  are replaced by the identity's).

  Args:
    memory: The measurements.

  Returns:
    ([K] u weights, [K] v weights).
  """
  valid = memory.valid
  both = valid[:, None] & valid[None, :]
  eye = jnp.eye(valid.shape[0], dtype=memory.du.dtype)

  def weights(which, d):
    gram = covariance(which, memory.points[:, None], memory.points[None, :])
    gram = jnp.where(both, gram, 0.0) + eye * jnp.where(
        valid, JITTER * prior_variance(which), 1.0)
    factor = jax.scipy.linalg.cho_factor(gram, lower=True)
    return jax.scipy.linalg.cho_solve(factor, jnp.where(valid, d, 0.0))

  return weights('u', memory.du), weights('v', memory.dv)


def posterior_mean(memory: Measurements, weights: Tuple[Array, Array],
                   point: Array) -> Tuple[Array, Array]:
  """Eq. (2): the expected (u, v) noise at `point` given the measurements.

  Args:
    memory: The measurements.
    weights: `fit(memory)`.
    point: (x [km], y [km], pressure [Pa], time [h]).

  Returns:
    (u, v) expected noise. # [m/s]
  """
  out = []
  for which, w in zip(('u', 'v'), weights):
    k = covariance(which, memory.points, jnp.asarray(point, memory.du.dtype))
    out.append(jnp.sum(jnp.where(memory.valid, k, 0.0) * w))
  return out[0], out[1]


def _gaussian(r2: Array) -> Array:
  """exp(-r^2 / (2 l^2)) of a squared distance r^2 in lattice units."""
  return jnp.exp(-r2 / (2 * CORRELATION_LENGTH**2))


def correlation(r: Array) -> Array:
  """The Gaussian stand-in for OpenSimplex's autocorrelation at r. # [.]"""
  return _gaussian(jnp.asarray(r)**2)

