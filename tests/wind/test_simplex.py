# coding=utf-8
"""ble_latex.wind.simplex against opensimplex 0.3 and BLE 1.0.1's wind noise.

float64 checks run inside a local `jax.enable_x64(True)` scope (JAX 0.10's
thread-local context manager, restored on exit); the process-wide setting
stays float32.
"""
# pylint: disable=protected-access

import datetime as dt
import math

from balloon_learning_environment.env import simplex_wind_noise
from balloon_learning_environment.env import wind_field
from balloon_learning_environment.utils import units
from ble_latex.wind import simplex
from hypothesis import example
from hypothesis import given
from hypothesis import settings
from hypothesis import strategies as st
import jax
import jax.numpy as jnp
import numpy as np
import opensimplex
from opensimplex import opensimplex as opensimplex_module
import pytest

_noise4d = jax.jit(simplex.noise4d)
_noise4d_over_seeds = jax.jit(
    jax.vmap(simplex.noise4d, in_axes=(0, None, None, None, None)))
_permutations = jax.jit(jax.vmap(simplex.permutation))
_wind_noise_over_components = jax.jit(
    jax.vmap(simplex.wind_noise, in_axes=(0, None, None, None, None)))
_reset = jax.jit(simplex.reset_noise_params, static_argnames='which')
_reset_uv = jax.jit(simplex.reset_uv_noise_params)
_wind_noise = jax.jit(simplex.wind_noise)
_wind_noise_uv = jax.jit(simplex.wind_noise_uv)

_BULK = 1024  # points per bulk comparison (one compiled shape)

# Noise coordinates: anywhere, on integers (cell corners), on quarter grids
# (exact ties between in-cell coordinates), just off integers.
_COORDINATE = st.one_of(
    st.floats(-1e4, 1e4, allow_nan=False),
    st.integers(-300, 300).map(float),
    st.integers(-1200, 1200).map(lambda k: k / 4),
    st.tuples(st.integers(-300, 300),
              st.sampled_from([-1e-9, -1e-12, -2.0**-40, 2.0**-40, 1e-12,
                               1e-9])).map(lambda t: t[0] + t[1]))
_BLE_SEED = st.integers(0, simplex.BLE_SEED_RANGE - 1)


def _opensimplex_noise(seed, points):
  generator = opensimplex.OpenSimplex(seed)
  return np.array([generator.noise4d(*map(float, p)) for p in points])


def _columns(points, dtype):
  return [jnp.asarray(points[:, k], dtype) for k in range(4)]


def test_constants_match_opensimplex():
  assert simplex.STRETCH_CONSTANT_4D == opensimplex_module.STRETCH_CONSTANT_4D
  assert simplex.SQUISH_CONSTANT_4D == opensimplex_module.SQUISH_CONSTANT_4D
  assert simplex.NORM_CONSTANT_4D == opensimplex_module.NORM_CONSTANT_4D
  np.testing.assert_array_equal(
      simplex._GRADIENTS_4D.ravel(),
      opensimplex_module.GRADIENTS_4D)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(-2**63, 2**64))
@example(seed=0)
@example(seed=-1)
@example(seed=2**63 - 1)
@example(seed=-2**63)
@example(seed=simplex.BLE_SEED_RANGE - 1)
def test_permutation_matches_opensimplex(seed):
  np.testing.assert_array_equal(
      np.asarray(simplex.permutation(seed)),
      opensimplex.OpenSimplex(seed)._perm)


def test_permutation_vmaps_over_array_seeds():
  int32_seeds = [0, 1, 7, -1, -2**31, 2**31 - 1, simplex.BLE_SEED_RANGE - 1]
  uint32_seeds = [0, 2**31, 2**32 - 1]
  cases = [(np.array(int32_seeds, np.int32), int32_seeds),
           (np.array(uint32_seeds, np.uint32), uint32_seeds)]
  for array, seeds in cases:
    perms = np.asarray(_permutations(jnp.asarray(array)))
    for perm, seed in zip(perms, seeds):
      np.testing.assert_array_equal(
          perm, opensimplex.OpenSimplex(seed)._perm)
  int64_seeds = [2**62 + 5, -2**40 - 3, -2**63]
  with jax.enable_x64(True):
    perms = np.asarray(_permutations(jnp.asarray(int64_seeds, jnp.int64)))
  for perm, seed in zip(perms, int64_seeds):
    np.testing.assert_array_equal(
        perm, opensimplex.OpenSimplex(seed)._perm)


@settings(max_examples=200, deadline=None)
@given(seed=_BLE_SEED, x=_COORDINATE, y=_COORDINATE, z=_COORDINATE,
       w=_COORDINATE)
@example(seed=0, x=0.0, y=0.0, z=0.0, w=0.0)
@example(seed=1, x=-1.5, y=-0.75, z=0.5, w=-3.75)  # near-tie scores
def test_noise4d_float64_matches_opensimplex(seed, x, y, z, w):
  expected = opensimplex.OpenSimplex(seed).noise4d(x, y, z, w)
  with jax.enable_x64(True):
    value = _noise4d(simplex.permutation(seed), *map(jnp.float64, (x, y, z, w)))
    assert value.dtype == jnp.float64
  assert abs(float(value) - expected) <= 1e-9


def test_noise4d_float64_bulk_matches_opensimplex():
  """Every region and branch, ties included, on batches of points."""
  rng = np.random.default_rng(0)
  families = {
      'uniform': rng.uniform(-50, 50, (_BULK, 4)),
      'quarter_grid': np.round(rng.uniform(-8, 8, (_BULK, 4)) * 4) / 4,
      'eighth_grid_large': np.round(rng.uniform(-300, 300, (_BULK, 4)) * 8) / 8,
      'integers': np.round(rng.uniform(-20, 20, (_BULK, 4))),
      'near_integers': (np.round(rng.uniform(-20, 20, (_BULK, 4))) +
                        rng.choice([-1e-12, 0, 1e-12], (_BULK, 4))),
      'equal_fractions': (rng.uniform(-5, 5, (_BULK, 1)) +
                          np.round(rng.uniform(-3, 3, (_BULK, 4)))),
      'large': rng.uniform(-1e4, 1e4, (_BULK, 4)),
  }
  for seed in (0, 1634753848):
    perm = simplex.permutation(seed)
    for name, points in families.items():
      with jax.enable_x64(True):
        values = np.asarray(_noise4d(perm, *_columns(points, jnp.float64)))
      error = np.abs(values - _opensimplex_noise(seed, points)).max()
      assert error <= 1e-9, (seed, name, error)
  # The uniform points visit all four regions of the in-cell coordinate sum.
  points = families['uniform']
  stretched = points + points.sum(axis=1, keepdims=True) * (
      simplex.STRETCH_CONSTANT_4D)
  in_sum = (stretched - np.floor(stretched)).sum(axis=1)
  regions = np.digitize(in_sum, [1, 2, 3], right=True)
  assert set(regions) == {0, 1, 2, 3}


def _unstretch(stretched):
  """Noise coordinates whose stretched coordinates are ~`stretched` [..., 4].

  opensimplex stretches by x + S sum(x) (S = STRETCH_CONSTANT_4D); the
  inverse is xs + Q sum(xs) (Q = SQUISH_CONSTANT_4D). Rounded in float64,
  so the in-cell coordinates opensimplex sees are within a few ulps of the
  chosen ones: on either side of a region boundary or a tie.
  """
  stretched = np.asarray(stretched, np.float64)
  return stretched + stretched.sum(axis=-1, keepdims=True) * (
      simplex.SQUISH_CONSTANT_4D)


# A cell origin and in-cell coordinates on an eighth grid whose sum is a
# region boundary (1, 2 or 3) or ties each other: adversarial near-ties.
_NEAR_TIE = st.tuples(
    st.lists(st.integers(-300, 300), min_size=4, max_size=4),
    st.lists(st.integers(0, 8), min_size=3, max_size=3),
    st.sampled_from([1, 2, 3])).filter(
        lambda t: 0 <= 8 * t[2] - sum(t[1]) <= 8).map(
            lambda t: _unstretch(np.array(t[0]) + np.array(
                [*t[1], 8 * t[2] - sum(t[1])]) / 8))


@settings(max_examples=150, deadline=None)
@given(seed=_BLE_SEED, point=_NEAR_TIE)
@example(seed=0, point=_unstretch([0.25, 0.25, 0.25, 0.25]))  # in_sum 1
@example(seed=0, point=_unstretch([0.5, 0.5, 0.5, 0.5]))  # in_sum 2
@example(seed=0, point=_unstretch([0.75, 0.75, 0.75, 0.75]))  # in_sum 3
@example(seed=5, point=_unstretch([3.5, -2.5, 0.5, 7.5]))
@example(seed=5, point=np.array([0.5, 0.5, 0.5, 0.5]))
def test_noise4d_float64_matches_opensimplex_near_region_boundaries(seed,
                                                                    point):
  """Points within ulps of the region boundaries in_sum = 1, 2, 3, ties.

  The kernel reads the vertex set from a table of opensimplex's decisions,
  taking the upper regions' decisions on negated scores: these points check
  that every decision, ties included, is opensimplex's.
  """
  expected = opensimplex.OpenSimplex(seed).noise4d(*map(float, point))
  with jax.enable_x64(True):
    value = _noise4d(simplex.permutation(seed), *map(jnp.float64, point))
  assert abs(float(value) - expected) <= 1e-12


def test_noise4d_float64_bulk_near_region_boundaries():
  """Thousands of near-tie points in every region, against opensimplex."""
  rng = np.random.default_rng(3)
  origins = rng.integers(-300, 300, (_BULK, 4))
  families = {}
  for boundary in (1, 2, 3):  # in-cell sums on the boundary, eighth grid
    fractions = rng.integers(0, 9, (8 * _BULK, 3))
    last = 8 * boundary - fractions.sum(axis=1, keepdims=True)
    fractions = np.concatenate([fractions, last], axis=1)
    fractions = fractions[(0 <= last[:, 0]) & (last[:, 0] <= 8)][:_BULK]
    fractions = rng.permuted(fractions, axis=1)  # the derived one anywhere
    families[f'in_sum_{boundary}'] = _unstretch(origins + fractions / 8)
  # Ties between in-cell coordinates and pair sums, any region.
  families['quarter_ties'] = _unstretch(
      origins + rng.integers(0, 4, (_BULK, 4)) / 4)
  families['halves'] = np.round(rng.uniform(-20, 20, (_BULK, 4)) * 2) / 2
  for seed in (0, 1634753848):
    perm = simplex.permutation(seed)
    for name, points in families.items():
      assert points.shape == (_BULK, 4), name
      with jax.enable_x64(True):
        values = np.asarray(_noise4d(perm, *_columns(points, jnp.float64)))
      error = np.abs(values - _opensimplex_noise(seed, points)).max()
      assert error <= 1e-12, (seed, name, error)


@settings(max_examples=100, deadline=None)
@given(seed=_BLE_SEED,
       point=st.lists(st.floats(-300, 300, width=32), min_size=4, max_size=4))
@example(seed=1187, point=[-300.0, -300.0, -300.0, -300.0])
@example(seed=0, point=[1.6875, 7.25, -1.0530077677872729e-11, 242.0])
@example(seed=0, point=[1.625, 1.9999998807907104, 0.0, 168.5])
def test_noise4d_float32_close_to_opensimplex(seed, point):
  """float32 (JAX's default): error ~ eps32 x coordinate magnitudes.

  The bound is 2e-6 + 1e-6 x sum |c|: the skewed coordinates are sums of
  all four inputs, rounded to float32 (~1.2e-7 relative), and the noise's
  slope is a few units per unit of coordinate (hypothesis found 4.3e-7 x
  sum |c| at seed 0, (1.625, 2 - 1e-7, 0, 168.5)). A wrong kernel is off by
  ~0.1.
  """
  # (Broadcast to the bulk test's shape: one compilation for both tests.)
  values = _noise4d(simplex.permutation(seed),
                    *(jnp.full(_BULK, c, jnp.float32) for c in point))
  assert values.dtype == jnp.float32
  value = values[0]
  expected = opensimplex.OpenSimplex(seed).noise4d(*point)
  tolerance = 2e-6 + 1e-6 * sum(abs(c) for c in point)
  assert abs(float(value) - expected) <= tolerance


def test_noise4d_float32_bulk():
  rng = np.random.default_rng(1)
  perm = simplex.permutation(12345)
  for scale, tolerance in ((1.0, 1e-6), (30.0, 1e-5), (300.0, 1e-4)):
    points = rng.uniform(-scale, scale, (_BULK, 4)).astype(np.float32)
    values = np.asarray(_noise4d(perm, *_columns(points, jnp.float32)))
    error = np.abs(values - _opensimplex_noise(12345, points)).max()
    assert error <= tolerance, (scale, error)


def test_noise4d_vmaps_over_seeds_and_points():
  """A batch of 1024 points (and of seeds) gives the per-point values."""
  rng = np.random.default_rng(2)
  points = rng.uniform(-20, 20, (_BULK, 4))
  seeds = np.array([0, 3, 99, 1634753848], np.int32)
  perms = _permutations(jnp.asarray(seeds))
  with jax.enable_x64(True):
    columns = _columns(points, jnp.float64)
    batched = np.asarray(_noise4d_over_seeds(perms, *columns))
    one_seed = np.asarray(_noise4d(perms[1], *columns))
    loop = np.array([float(_noise4d(perms[1], *map(np.float64, p)))
                     for p in points])
  assert batched.shape == (4, 1024)
  np.testing.assert_allclose(batched[1], one_seed, rtol=0, atol=1e-12)
  np.testing.assert_allclose(one_seed, loop, rtol=0, atol=1e-12)
  for seed, values in zip(seeds, batched):
    np.testing.assert_allclose(values, _opensimplex_noise(int(seed), points),
                               rtol=0, atol=1e-9)


def test_noise4d_nan_gives_nan():
  perm = simplex.permutation(0)
  x = jnp.zeros(_BULK, jnp.float32).at[0].set(np.nan).at[1].set(-np.inf)
  values = np.asarray(_noise4d(perm, x, x[::-1], x, x))
  assert np.isnan(values[[0, 1, -2, -1]]).all()
  assert np.isfinite(values[2:-2]).all()


def _assert_params_equal(a, b):
  np.testing.assert_array_equal(np.asarray(a.perm), np.asarray(b.perm))
  np.testing.assert_array_equal(np.asarray(a.offsets), np.asarray(b.offsets))
  assert np.asarray(a.offsets).dtype == np.float32
  assert a.harmonics == b.harmonics


@settings(max_examples=8, deadline=None)
@given(key_seed=st.integers(0, 2**31 - 1), which=st.sampled_from('uv'))
def test_reset_matches_ble(key_seed, which):
  key = jax.random.PRNGKey(key_seed)
  component = simplex_wind_noise.NoisyWindComponent(which)
  component.reset(key)
  from_ble = simplex.noise_params_from_ble(component)
  _assert_params_equal(_reset(key, which), from_ble)
  with jax.enable_x64(True):  # explicit dtypes: BLE's draws in x64 too
    _assert_params_equal(_reset(key, which), from_ble)
  assert from_ble.harmonics == simplex.ble_harmonics(which)


def test_reset_uv_matches_ble_simplex_wind_noise():
  key = jax.random.PRNGKey(7)
  noise = wind_field.SimplexWindNoise()
  noise.reset_wind_noise(key, dt.datetime(2022, 1, 1))
  u_params, v_params = simplex.reset_uv_noise_params(key)
  _assert_params_equal(u_params, simplex.noise_params_from_ble(noise.noise_u))
  _assert_params_equal(v_params, simplex.noise_params_from_ble(noise.noise_v))


def _ble_formula_float64(component, x_km, y_km, pressure, hours):
  """BLE's get_noise evaluated in float64 (BLE's float32 offsets)."""
  weighted_noise = total_weight = total_weight_squared = 0.0
  for h in component._harmonics:
    offsets = h._offsets
    generator = h._simplex_generator
    noise = simplex_wind_noise.NOISE_MAGNITUDE * generator.noise4d(
        x_km / h.x_spacing + float(offsets.x),
        y_km / h.y_spacing + float(offsets.y),
        pressure / h.pressure_spacing + float(offsets.pressure),
        hours / h.time_spacing + float(offsets.time))
    weighted_noise += noise * h.weight
    total_weight += h.weight
    total_weight_squared += h.weight**2
  weighted_noise /= total_weight
  return weighted_noise * math.sqrt(total_weight / total_weight_squared)


def _ble_get_noise(component, x_km, y_km, pressure, hours):
  return component.get_noise(units.Distance(km=x_km), units.Distance(km=y_km),
                             pressure, dt.timedelta(hours=hours))


# BLE-like query points: x, y [km], pressure [Pa], elapsed time [h].
_BLE_POINT = st.tuples(st.floats(-2000, 2000, width=32),
                       st.floats(-2000, 2000, width=32),
                       st.floats(4000, 15000, width=32),
                       st.floats(0, 200, width=32))


@settings(max_examples=5, deadline=None)
@given(key_seeds=st.lists(st.integers(0, 2**31 - 1), min_size=4, max_size=4),
       which=st.sampled_from('uv'),
       points=st.lists(_BLE_POINT, min_size=16, max_size=16))
def test_wind_noise_matches_ble(key_seeds, which, points):
  """4 components (vmapped) at 16 points against BLE's.

  float64: BLE's formula to 1e-9; BLE's own values (float32) to 1e-4 m/s.
  """
  components = []
  for key_seed in key_seeds:
    components.append(simplex_wind_noise.NoisyWindComponent(which))
    components[-1].reset(jax.random.PRNGKey(key_seed))
  params = jax.tree_util.tree_map(
      lambda *leaves: jnp.stack(leaves),
      *[simplex.noise_params_from_ble(c) for c in components])
  points = np.array(points, dtype=np.float64)
  ble = np.array([[_ble_get_noise(c, *map(float, p)) for p in points]
                  for c in components])
  formula = np.array([[_ble_formula_float64(c, *map(float, p)) for p in points]
                      for c in components])
  with jax.enable_x64(True):
    noise64 = np.asarray(_wind_noise_over_components(
        params, *_columns(points, jnp.float64)))
  noise32 = np.asarray(_wind_noise_over_components(
      params, *_columns(points, jnp.float32)))
  assert noise64.dtype == np.float64 and noise32.dtype == np.float32
  assert noise64.shape == (4, 16)
  np.testing.assert_allclose(noise64, formula, rtol=0, atol=1e-9)
  # BLE computes in float32 (NumPy 2 promotes with its float32 offsets).
  np.testing.assert_allclose(noise64, ble, rtol=0, atol=1e-4)
  np.testing.assert_allclose(noise32, ble, rtol=0, atol=1e-4)


@settings(max_examples=4, deadline=None)
@given(key_seed=st.integers(0, 2**31 - 1),
       points=st.lists(_BLE_POINT, min_size=16, max_size=16))
def test_wind_noise_uv_equals_two_wind_noise_calls(key_seed, points):
  """One vectorised call over the 10 harmonics: the same u and v values."""
  u_params, v_params = _reset_uv(jax.random.PRNGKey(key_seed))
  points = np.array(points, dtype=np.float64)
  for dtype in (jnp.float64, jnp.float32):
    with jax.enable_x64(dtype == jnp.float64):
      columns = _columns(points, dtype)
      u, v = map(np.asarray, _wind_noise_uv(u_params, v_params, *columns))
      u_alone = np.asarray(_wind_noise(u_params, *columns))
      v_alone = np.asarray(_wind_noise(v_params, *columns))
    assert u.dtype == v.dtype == u_alone.dtype == np.dtype(dtype)
    if dtype == jnp.float64:
      np.testing.assert_array_equal(u, u_alone)
      np.testing.assert_array_equal(v, v_alone)
    else:  # float32: the compiler may round the two programs differently
      np.testing.assert_allclose(u, u_alone, rtol=0, atol=1e-5)
      np.testing.assert_allclose(v, v_alone, rtol=0, atol=1e-5)


def test_errors():
  with pytest.raises(ValueError):
    simplex.noise_params_from_ble(simplex_wind_noise.NoisyWindComponent('u'))
  with pytest.raises(ValueError):
    simplex.ble_harmonics('w')
  with pytest.raises(TypeError):
    simplex.permutation(jnp.float32(1.0))
