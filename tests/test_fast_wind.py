"""ble_latex.fast_wind gives BLE's generative wind field's answers, faster."""

# pylint: disable=protected-access

import datetime as dt

import ble_latex  # noqa: F401  (fixes first)
from ble_latex import balloon as balloon_lib
from ble_latex import env as env_lib
from ble_latex import fast_wind
from balloon_learning_environment.env import generative_wind_field
from balloon_learning_environment.env import simplex_wind_noise
from balloon_learning_environment.env import wind_field
from balloon_learning_environment.utils import units
import jax
import numpy as np
import pytest

_START = dt.datetime(2022, 11, 1)
_LATLNG = np.linspace(-500.0, 500.0, 21)  # [km] BLE's VAE grid
_PRESSURES = np.linspace(5000.0, 14000.0, 10)  # [Pa]
_HOURS = np.arange(0.0, 49.0, 6.0)  # [h]


@pytest.fixture(scope='module')
def fields():
  """(BLE's field, fast field), both reset with the same key."""
  ble = generative_wind_field.GenerativeWindField()
  fast = fast_wind.FastGenerativeWindField()
  key = jax.random.PRNGKey(7)
  ble.reset(key, _START)
  fast.reset(key, _START)
  return ble, fast


def _queries(n: int, seed: int):
  """Random (x, y, pressure, elapsed) incl. off-grid, grid nodes, > 48 h."""
  rng = np.random.default_rng(seed)
  for i in range(n):
    if i % 5 == 0:  # Exactly on grid nodes and edges.
      x, y = rng.choice(_LATLNG, 2)
      p, h = rng.choice(_PRESSURES), rng.choice(_HOURS)
    else:  # Inside and outside the grid, up to 10 days.
      x, y = rng.uniform(-800.0, 800.0, 2)
      p, h = rng.uniform(2000.0, 18000.0), rng.uniform(0.0, 240.0)
    yield (units.Distance(km=float(x)), units.Distance(km=float(y)), float(p),
           dt.timedelta(hours=float(h)))


def _uv(vector: wind_field.WindVector):
  return vector.u.meters_per_second, vector.v.meters_per_second


def test_same_key_gives_the_same_field_and_noise(fields):
  ble, fast = fields
  np.testing.assert_array_equal(fast.field, ble.field)
  assert isinstance(fast, generative_wind_field.GenerativeWindField)
  for which in ('noise_u', 'noise_v'):
    ble_component = getattr(ble._noise_model, which)
    fast_component = getattr(fast._noise_model, which)
    for a, b in zip(ble_component._harmonics, fast_component._harmonics):
      assert a._offsets == b._offsets
      assert a._simplex_generator._perm == b._simplex_generator._perm


def test_forecast_equals_ble(fields):
  ble, fast = fields
  for query in _queries(600, seed=0):
    expected = _uv(ble.get_forecast(*query))
    got = _uv(fast.get_forecast(*query))
    np.testing.assert_allclose(got, expected, rtol=0.0, atol=1e-9)
    # np.float64 as BLE's: float32 noise added to it must promote the same.
    assert isinstance(got[0], np.float64)
    assert isinstance(expected[0], np.float64)


def test_forecast_column_equals_ble(fields):
  ble, fast = fields
  rng = np.random.default_rng(1)
  for x, y, _, elapsed in _queries(60, seed=1):
    pressures = np.concatenate([rng.uniform(3000.0, 16000.0, 20), _PRESSURES])
    expected = ble.get_forecast_column(x, y, pressures, elapsed)
    got = fast.get_forecast_column(x, y, pressures, elapsed)
    np.testing.assert_allclose([_uv(w) for w in got],
                               [_uv(w) for w in expected], rtol=0.0, atol=1e-9)
  assert not fast.get_forecast_column(x, y, [], elapsed)


def test_noise_is_bles_exactly(fields):
  ble, fast = fields
  for query in _queries(200, seed=2):
    expected = ble._noise_model.get_wind_noise(*query)
    got = fast._noise_model.get_wind_noise(*query)
    assert _uv(got) == _uv(expected)
  # The component API too, and with numpy-typed inputs (types matter there).
  x, y, p, elapsed = next(_queries(1, seed=3))
  x64 = units.Distance(m=np.float64(x.meters))
  for which in ('noise_u', 'noise_v'):
    ble_component = getattr(ble._noise_model, which)
    fast_component = getattr(fast._noise_model, which)
    assert isinstance(fast_component, simplex_wind_noise.NoisyWindComponent)
    for args in ((x, y, p, elapsed), (x64, y, np.float64(p), elapsed)):
      assert fast_component.get_noise(*args) == ble_component.get_noise(*args)


def test_ground_truth_equals_ble_including_repeats(fields):
  ble, fast = fields
  for query in _queries(100, seed=4):
    expected = _uv(ble.get_ground_truth(*query))
    np.testing.assert_allclose(_uv(fast.get_ground_truth(*query)), expected,
                               rtol=1e-12, atol=1e-9)
    # The remembered repeat, and the same values with other operand types.
    np.testing.assert_allclose(_uv(fast.get_ground_truth(*query)), expected,
                               rtol=1e-12, atol=1e-9)
    x, y, p, elapsed = query
    typed = (units.Distance(m=np.float64(x.meters)), y, np.float64(p), elapsed)
    np.testing.assert_allclose(_uv(fast.get_ground_truth(*typed)),
                               _uv(ble.get_ground_truth(*typed)),
                               rtol=1e-12, atol=1e-9)


def test_reset_forgets_the_last_answer():
  fast = fast_wind.FastGenerativeWindField()
  ble = generative_wind_field.GenerativeWindField()
  query = next(_queries(1, seed=5))
  for seed in (1, 2):
    key = jax.random.PRNGKey(seed)
    fast.reset(key, _START)
    ble.reset(key, _START)
    np.testing.assert_allclose(_uv(fast.get_ground_truth(*query)),
                               _uv(ble.get_ground_truth(*query)),
                               rtol=1e-12, atol=1e-9)


def test_bad_queries_raise_like_ble(fields):
  ble, fast = fields
  ok = units.Distance(km=1.0)
  bad = [
      (units.Distance(m=float('nan')), ok, 8000.0, dt.timedelta(hours=1)),
      (ok, ok, float('nan'), dt.timedelta(hours=1)),
      (ok, ok, 8000.0, dt.timedelta(hours=-1)),
  ]
  for query in bad:
    for field in (ble, fast):
      with pytest.raises(ValueError):
        field.get_forecast(*query)
      with pytest.raises(ValueError):
        field.get_forecast_column(query[0], query[1], [query[2]], query[3])
  unset = fast_wind.FastGenerativeWindField()
  with pytest.raises(RuntimeError):
    unset.get_forecast(ok, ok, 8000.0, dt.timedelta())
  with pytest.raises(RuntimeError):
    unset.get_forecast_column(ok, ok, [8000.0], dt.timedelta())


def _rollout(env, seed: int, steps: int):
  rng = np.random.default_rng(seed)
  out = [env.reset(seed=seed)]
  for _ in range(steps):
    obs, reward, done, info = env.step(
        rng.uniform(env.action_space.low, env.action_space.high))
    s = env.arena.get_balloon_state()
    out.append(np.concatenate([
        obs, [reward, s.x.meters, s.y.meters, s.altitude_m, s.ascent_rate_mps,
              s.helium_mols, s.sand_kg, info['distance_km']]]))
    if done:
      break
  return np.stack(out[1:]), out[0]


def test_env_default_trajectory_equals_ble_field():
  fast_env = env_lib.LatexBalloonEnv()
  assert isinstance(fast_env.arena._wind_field,
                    fast_wind.FastGenerativeWindField)
  ble_env = env_lib.LatexBalloonEnv(
      wind_field_factory=generative_wind_field.GenerativeWindField)
  for seed in (0, 3):
    got, got0 = _rollout(fast_env, seed, 40)
    expected, expected0 = _rollout(ble_env, seed, 40)
    np.testing.assert_array_equal(got0, expected0)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-9)


def test_step_atmosphere_memo_changes_nothing(monkeypatch):
  env = env_lib.LatexBalloonEnv()
  expected, _ = _rollout(env, 5, 20)
  monkeypatch.setattr(balloon_lib, '_StepAtmosphere', lambda atmosphere:
                      atmosphere)
  got, _ = _rollout(env, 5, 20)
  np.testing.assert_array_equal(got, expected)
