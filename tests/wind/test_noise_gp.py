"""`ble_latex.wind.noise_gp`: the covariance of BLE's simplex wind noise and
the Gaussian-process posterior mean of the noise given measured winds."""

from hypothesis import given
from hypothesis import settings
from hypothesis import strategies as st
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex.wind import noise_gp
from ble_latex.wind import simplex


def test_correlation_matches_opensimplex():
  """The Gaussian stand-in against OpenSimplex's measured autocorrelation
  (20 000 random points, one random direction per point): within 0.08 at
  every distance (the stand-in's largest gap is in the tail, r = 1).
  A length off by a third (0.3 or 0.6) fails by 0.2 or more."""
  perm = simplex.permutation(7)
  noise = jax.jit(jax.vmap(lambda p: simplex.noise4d(perm, *p)))
  key_points, key_directions = jax.random.split(jax.random.PRNGKey(0))
  points = jax.random.uniform(key_points, (20_000, 4)) * 200.0
  directions = jax.random.normal(key_directions, (20_000, 4))
  directions /= jnp.linalg.norm(directions, axis=1, keepdims=True)
  base = np.asarray(noise(points))
  for r in (0.2, 0.4, 0.6, 0.8, 1.0):
    moved = np.asarray(noise(points + r * directions))
    measured = np.corrcoef(base, moved)[0, 1]
    assert abs(measured - float(noise_gp.correlation(r))) < 0.08, r


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
def test_prior_variance_is_ble_noise_variance():
  """k(q, q) is the variance of BLE's noise (about 1.0 m^2/s^2 per
  component; measured over 4000 draws of the noise at one point)."""
  def at_origin(key):
    u, v = simplex.reset_uv_noise_params(key)
    return simplex.wind_noise_uv(u, v, 0.0, 0.0, 7000.0, 1.0)
  u, v = jax.jit(jax.vmap(at_origin))(
      jax.random.split(jax.random.PRNGKey(1), 4000))
  assert np.var(u) == pytest.approx(noise_gp.prior_variance('u'), rel=0.15)
  assert np.var(v) == pytest.approx(noise_gp.prior_variance('v'), rel=0.15)


def _memory(points, du, dv):
  k = len(du)
  return noise_gp.Measurements(points=jnp.asarray(points, jnp.float32),
                               du=jnp.asarray(du, jnp.float32),
                               dv=jnp.asarray(dv, jnp.float32),
                               valid=jnp.ones((k,), bool))


_FIT = jax.jit(noise_gp.fit)
_MEAN = jax.jit(noise_gp.posterior_mean)


@settings(max_examples=20, deadline=None)
@given(st.lists(st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0)),
                min_size=1, max_size=4))
def test_posterior_interpolates_and_forgets(winds):
  """At a measured point the posterior mean is the measurement (up to the
  jitter); ten days later it is the prior's zero."""
  k = len(winds)
  points = [[30.0 * i, -20.0 * i, 6000.0 + 800.0 * i, 2.0 * i]
            for i in range(k)]
  du, dv = zip(*winds)
  memory = _memory(points, du, dv)
  weights = _FIT(memory)
  for i in range(k):
    u, v = _MEAN(memory, weights, memory.points[i])
    assert float(u) == pytest.approx(du[i], abs=0.02)
    assert float(v) == pytest.approx(dv[i], abs=0.02)
  far = memory.points[-1] + jnp.array([0.0, 0.0, 0.0, 240.0 * 30])
  u, v = _MEAN(memory, weights, far)
  assert abs(float(u)) < 1e-3 and abs(float(v)) < 1e-3


def test_empty_rows_add_nothing():
  """Rows that hold no measurement change neither the weights nor the mean;
  `add` drops the oldest row."""
  memory = noise_gp.add(noise_gp.empty(3), jnp.array([0.0, 0.0, 7000.0, 1.0]),
                        0.5, -0.25)
  np.testing.assert_array_equal(memory.valid, [False, False, True])
  one = _memory([[0.0, 0.0, 7000.0, 1.0]], [0.5], [-0.25])
  q = jnp.array([10.0, 5.0, 7300.0, 2.0])
  np.testing.assert_allclose(
      noise_gp.posterior_mean(memory, noise_gp.fit(memory), q),
      noise_gp.posterior_mean(one, noise_gp.fit(one), q), rtol=1e-5)
  memory = noise_gp.add(memory, jnp.array([1.0, 1.0, 7100.0, 2.0]), 0.1, 0.2)
  memory = noise_gp.add(memory, jnp.array([2.0, 2.0, 7200.0, 3.0]), 0.3, 0.4)
  memory = noise_gp.add(memory, jnp.array([3.0, 3.0, 7300.0, 4.0]), 0.5, 0.6)
  np.testing.assert_array_equal(memory.valid, [True, True, True])
  np.testing.assert_allclose(memory.du, [0.1, 0.3, 0.5])


def test_posterior_predicts_ble_noise_better_than_nothing():
  """Over 40 drawn noise fields: the noise at points near a measured track
  (0-3 h later, within 1 500 Pa) is predicted with a smaller mean squared
  error by the posterior mean than by zero (the forecast alone)."""
  rng = np.random.default_rng(0)

  @jax.jit
  def trial(key, points, queries):
    """(true, guessed) noise at the queries [m/s], shapes (10, 2)."""
    u_params, v_params = simplex.reset_uv_noise_params(key)
    du, dv = simplex.wind_noise_uv(u_params, v_params, *points.T)
    memory = _memory(points, du, dv)
    weights = noise_gp.fit(memory)
    true = jnp.stack(simplex.wind_noise_uv(u_params, v_params, *queries.T), 1)
    guess = jax.vmap(lambda q: jnp.stack(
        noise_gp.posterior_mean(memory, weights, q)))(queries)
    return true, guess

  errors = {'forecast': [], 'posterior': []}
  for i in range(40):
    t = np.arange(12) * (40 / 60.0) + 10.0
    x, y = np.cumsum(rng.normal(0, 12, (2, 12)), axis=1)
    p = np.clip(7500 + np.cumsum(rng.normal(0, 400, 12)), 5000, 11000)
    points = np.stack([x, y, p, t], 1).astype(np.float32)
    queries = np.stack([
        x[-1] + rng.normal(0, 30, 10), y[-1] + rng.normal(0, 30, 10),
        np.clip(p[-1] + rng.uniform(-1500, 1500, 10), 5000, 11000),
        t[-1] + rng.uniform(0, 3, 10)], 1).astype(np.float32)
    true, guess = map(np.asarray, trial(jax.random.PRNGKey(i), points,
                                        queries))
    errors['forecast'].extend(np.sum(true**2, 1))
    errors['posterior'].extend(np.sum((true - guess)**2, 1))
  assert np.mean(errors['posterior']) < 0.85 * np.mean(errors['forecast'])
