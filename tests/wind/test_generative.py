"""ble_latex.wind.generative reproduces BLE's generative forecast in JAX.

Reference: BLE's `GenerativeWindField` (scipy `interpn` per query). Query
points are float32 values with times in
whole multiples of 1/64 s, so that BLE's timedelta (microseconds) and the
JAX inputs hold the same point.
"""

# pylint: disable=protected-access

import datetime as dt

import ble_latex  # noqa: F401  (fixes first)
from ble_latex.wind import generative
from balloon_learning_environment.env import generative_wind_field
from balloon_learning_environment.utils import units
import jax
import jax.numpy as jnp
import numpy as np
import pytest

_START = dt.datetime(2022, 11, 1)
_HORIZON_S = 48 * 3600.0  # [s]
# Measured on CPU (see the test bodies): float32 <= 2.0e-6 m/s on these
# points, float64 <= 1e-14 m/s.
_ATOL_F32 = 5e-6  # [m/s]
_ATOL_F64 = 1e-12  # [m/s]


@pytest.fixture(scope='module')
def params():
  return generative.decoder_params()


@pytest.fixture(scope='module')
def ble_fields():
  """(BLE's field, the same field) reset with a key, and that key."""
  key = jax.random.PRNGKey(11)
  ble = generative_wind_field.GenerativeWindField()
  ble.reset(key, _START)
  return ble, ble, key


def _queries(n: int, seed: int):
  """float32 (x [m], y [m], pressure [Pa], t [s]) arrays of n points.

  A fifth exactly on grid nodes / edges, the rest inside and outside the
  grid (clipping), times up to 10 days (boomerang) including exact
  multiples of the 48-h horizon.
  """
  rng = np.random.default_rng(seed)
  x = rng.uniform(-800e3, 800e3, n)
  y = rng.uniform(-800e3, 800e3, n)
  p = rng.uniform(2000.0, 18000.0, n)
  t = rng.uniform(0.0, 240 * 3600.0, n)
  nodes = np.arange(n) % 5 == 0
  x[nodes] = rng.choice(np.arange(-500e3, 501e3, 50e3), nodes.sum())
  y[nodes] = rng.choice(np.arange(-500e3, 501e3, 50e3), nodes.sum())
  p[nodes] = rng.choice(np.linspace(5000.0, 14000.0, 10), nodes.sum())
  t[nodes] = rng.choice(np.arange(0.0, 241.0, 6.0), nodes.sum()) * 3600.0
  t[1:8] = np.array([47.999, 48.0, 48.001, 95.999, 96.0, 96.001, 144.0]
                    ) * 3600.0
  t = np.round(t * 64.0) / 64.0
  return tuple(a.astype(np.float32) for a in (x, y, p, t))


def _ble_forecasts(field, x, y, p, t) -> np.ndarray:
  out = []
  for xi, yi, pi, ti in zip(x, y, p, t):
    w = field.get_forecast(units.Distance(m=float(xi)),
                           units.Distance(m=float(yi)), float(pi),
                           dt.timedelta(seconds=float(ti)))
    out.append((w.u.meters_per_second, w.v.meters_per_second))
  return np.array(out)


def test_grid_axes_are_bles():
  ble = generative_wind_field.GenerativeWindField()
  for ours, theirs in zip(generative.ble_grid_axes(), ble._grid):
    np.testing.assert_array_equal(np.array(ours), np.asarray(theirs,
                                                             np.float64))
  # BLE's lat/lng axis is an eager float32 linspace with rounding (e.g.
  # -49.99997 km), the same from inside a trace or an x64 scope.
  assert generative.ble_grid_axes()[0][9] != -50.0
  with jax.enable_x64(True):
    assert generative._compute_ble_grid_axes() == generative.ble_grid_axes()


def test_decoded_field_is_bles(params):
  ble = generative_wind_field.GenerativeWindField()
  keys = [jax.random.PRNGKey(s) for s in (0, 1, 2, 12345)]
  single = []
  for key in keys:
    ble.reset_forecast(key, _START)
    field = generative.reset_forecast(key, params)
    assert field.grid.shape == (21, 21, 10, 9, 2)
    assert field.grid.dtype == jnp.float32
    single.append(np.abs(np.asarray(field.grid) - ble.field).max())
  # Measured: 0 (bit-identical to BLE's eager decode on CPU).
  assert max(single) <= 1e-5, single
  with jax.enable_x64(True):  # Decoded as without x64.
    np.testing.assert_array_equal(
        generative.reset_forecast(keys[-1], params).grid, field.grid)

  batch = generative.reset_forecasts(jnp.stack(keys), params)
  exact = generative.reset_forecasts(jnp.stack(keys), params, exact=True)
  assert batch.grid.shape == (4, 21, 21, 10, 9, 2)
  vmapped, mapped = [], []
  for i, key in enumerate(keys):
    ble.reset_forecast(key, _START)
    vmapped.append(np.abs(np.asarray(batch.grid[i]) - ble.field).max())
    mapped.append(np.abs(np.asarray(exact.grid[i]) - ble.field).max())
  # vmap: matrix-matrix kernels, another float32 summation order. Measured
  # <= 1.6e-4 m/s (winds up to ~20 m/s); lax.map: 0.
  assert max(vmapped) <= 1e-3, vmapped
  assert max(mapped) <= 1e-5, mapped


def test_split_wind_key_is_bles_reset(ble_fields, params):
  ble, _, key = ble_fields
  _, forecast_key = generative.split_wind_key(key)
  field = generative.reset_forecast(forecast_key, params)
  np.testing.assert_allclose(np.asarray(field.grid), ble.field, rtol=0,
                             atol=1e-5)


def test_forecast_float32_matches_ble(ble_fields):
  ble, _, _ = ble_fields
  field = generative.ForecastField.from_array(ble.field)
  query = jax.jit(generative.forecast)
  x, y, p, t = _queries(300, seed=0)
  u, v = query(field, x, y, p, t)
  assert u.dtype == jnp.float32 and u.shape == (300,)
  ours = np.stack([u, v], axis=-1)
  reference = _ble_forecasts(ble, x, y, p, t)
  err = np.abs(ours - reference).max()
  assert err <= _ATOL_F32, err

  x, y, p, t = _queries(3000, seed=1)  # More points.
  ours = np.stack(query(field, x, y, p, t), axis=-1)
  err = np.abs(ours - _ble_forecasts(ble, x, y, p, t)).max()
  assert err <= _ATOL_F32, err


def test_forecast_float64_is_bles(ble_fields):
  ble, _, _ = ble_fields
  field = generative.ForecastField.from_array(ble.field)
  x, y, p, t = (a.astype(np.float64) for a in _queries(1000, seed=2))
  with jax.enable_x64(True):
    u, v = jax.jit(generative.forecast)(field, x, y, p, t)
    assert u.dtype == jnp.float64
    ours = np.stack([u, v], axis=-1)
  np.testing.assert_allclose(ours, _ble_forecasts(ble, x, y, p, t), rtol=0,
                             atol=_ATOL_F64)
  np.testing.assert_allclose(ours[:200], _ble_forecasts(ble, x[:200], y[:200],
                                                        p[:200], t[:200]),
                             rtol=0, atol=_ATOL_F64)


def test_clipping_and_boomerang(ble_fields):
  ble, _, _ = ble_fields
  field = generative.ForecastField.from_array(ble.field)
  f = jax.jit(generative.forecast)
  p, t = np.float32(9000.0), np.float32(7 * 3600.0)
  # Outside the grid: the value at the boundary.
  for x, x_edge in ((-2e6, -5e5), (7e5, 5e5)):
    np.testing.assert_array_equal(f(field, x, 1e5, p, t),
                                  f(field, x_edge, 1e5, p, t))
  np.testing.assert_array_equal(f(field, 0.0, 0.0, 100.0, t),
                                f(field, 0.0, 0.0, 5000.0, t))
  np.testing.assert_array_equal(f(field, 0.0, 0.0, 3e4, t),
                                f(field, 0.0, 0.0, 14000.0, t))
  # The boomerang: 48 h + s mirrors 48 h - s, 96 h + s is s.
  for s in (0.0, 1800.0, 6 * 3600.0, 30 * 3600.0):
    for folded, original in ((_HORIZON_S + s, _HORIZON_S - s),
                             (2 * _HORIZON_S + s, s),
                             (3 * _HORIZON_S + s, _HORIZON_S - s)):
      np.testing.assert_allclose(
          f(field, 1e5, -2e5, p, np.float32(folded)),
          f(field, 1e5, -2e5, p, np.float32(original)), rtol=0, atol=1e-6)
  # Before the start (BLE raises): clamped to 0 h.
  np.testing.assert_array_equal(f(field, 0.0, 0.0, p, -600.0),
                                f(field, 0.0, 0.0, p, 0.0))
  u, v = f(field, np.nan, 0.0, p, t)
  assert np.isnan(u) and np.isnan(v)


def test_forecast_column_matches_ble(ble_fields):
  ble, _, _ = ble_fields
  field = generative.ForecastField.from_array(ble.field)
  levels = np.linspace(5000.0, 14000.0, 25)
  column = jax.jit(generative.forecast_column)
  for x, y, t in ((1.2345e5, -3.21e5, 3600.0 * 5.5),
                  (-6.1e5, 4.4e5, 3600.0 * 50.25),
                  (0.0, 0.0, 0.0)):
    reference = np.array([
        (w.u.meters_per_second, w.v.meters_per_second)
        for w in ble.get_forecast_column(
            units.Distance(m=x), units.Distance(m=y), levels,
            dt.timedelta(seconds=t))])
    u, v = column(field, np.float32(x), np.float32(y),
                  levels.astype(np.float32), np.float32(t))
    assert u.shape == (25,)
    np.testing.assert_allclose(np.stack([u, v], -1), reference, rtol=0,
                               atol=_ATOL_F32)
    with jax.enable_x64(True):
      u, v = column(field, x, y, levels, t)
      np.testing.assert_allclose(np.stack([u, v], -1), reference, rtol=0,
                                 atol=_ATOL_F64)


def test_batched_fields_and_queries(params):
  keys = jax.random.split(jax.random.PRNGKey(3), 3)
  fields = generative.reset_forecasts(keys, params)
  x, y, p, t = (jnp.asarray(a) for a in _queries(64, seed=4))
  batched = jax.jit(jax.vmap(
      jax.vmap(generative.forecast, in_axes=(None, 0, 0, 0, 0)),
      in_axes=(0, None, None, None, None)))
  u, v = batched(fields, x, y, p, t)
  assert u.shape == (3, 64)
  for i in range(3):
    one = generative.ForecastField(grid=fields.grid[i])
    ui, vi = generative.forecast(one, x, y, p, t)  # Eager, broadcasting.
    np.testing.assert_allclose(u[i], ui, rtol=0, atol=1e-6)
    np.testing.assert_allclose(v[i], vi, rtol=0, atol=1e-6)
