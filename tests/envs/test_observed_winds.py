"""`ble_latex.envs.observed_winds`: the observation's wind column corrected by
the balloon's measured winds (`latex_observation.wind_memory`) and drifted
(`latex_observation.wind_lookahead`).

The flights (env compiles, ~10-40 s) run in CI (`make test-ci`); the default
suite checks the column on a hand-made memory."""

import types

import gin
from hypothesis import given
from hypothesis import settings
from hypothesis import strategies as st
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex import errors
from ble_latex.agents.sac import core as sac_core
from ble_latex.agents.sac import pretrained
from ble_latex.envs import env_params
from ble_latex.envs import jax_env
from ble_latex.envs import jax_features
from ble_latex.envs import observed_winds
from ble_latex.envs import winds
from ble_latex.wind import noise_gp

_ACTIONS = np.array([[16_500.0, 1.0, -1.0], [18_500.0, 2.0, -1.0],
                     [17_000.0, 1.5, -1.0], [17_000.0, 1.0, 1.0],
                     [19_000.0, 1.0, -1.0]], np.float32)


def _flight(memory: int, seed: int = 3, lookahead: int = 0):
  """Reset and the five strides of `_ACTIONS` under `wind_memory` = memory
  and `wind_lookahead` = lookahead: [(obs, state)] after each."""
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  params = env_params.check_params(
      env.default_params.replace(wind_memory=memory,
                                 wind_lookahead=lookahead))
  obs, state = jax.jit(env.reset)(jax.random.PRNGKey(seed), params)
  step = jax.jit(env.step_env)
  out = [(obs, state)]
  for action in _ACTIONS:
    obs, state, *_ = step(None, state, jnp.asarray(action), params)
    out.append((obs, state))
  return out


def _assert_column_features(obs, u, v, flight):
  """Features 0-49 of `obs` are those of the wind column (u, v) [m/s]."""
  speed = 1.0 - np.exp(-np.hypot(u, v) / jax_features.SPEED_SQUASH_MPS)
  np.testing.assert_allclose(obs[:25], speed, atol=2e-5)
  bearing = np.asarray(jax_features.bearing_errors(
      jnp.asarray(u, jnp.float32), jnp.asarray(v, jnp.float32), flight.x_m,
      flight.y_m)) / np.pi
  np.testing.assert_allclose(obs[25:50], bearing, atol=2e-4)


@pytest.fixture(scope='module')
def flights():
  return {k: _flight(k) for k in (0, 3)}


@pytest.fixture(scope='module')
def drifted():
  """The same flight observed through 3-stride drifts."""
  return _flight(0, lookahead=3)


@pytest.mark.slow
@pytest.mark.ci  # Env compiles; out of the default suite (<= 8 min).
def test_memory_holds_the_measured_minus_forecast_winds(flights):
  """One row per measurement (reset and each stride), the newest last, the
  oldest dropped past K: the measured wind minus the forecast at the
  balloon, where and when it was measured."""
  wind = winds.GENERATIVE_WIND
  rows = []
  for n, (_, state) in enumerate(flights[3]):
    f = state.flight
    u0, v0 = wind.forecast_column(state, f.x_m, f.y_m, f.pressure_pa,
                                  f.time_s)
    rows.append((np.array([f.x_m / 1e3, f.y_m / 1e3, f.pressure_pa,
                           f.time_s / 3600.0]),
                 float(state.wind_u - u0), float(state.wind_v - v0)))
    memory = state.wind_memory
    assert memory.valid.tolist() == [False] * max(2 - n, 0) + [True] * min(
        n + 1, 3)
    for row, (point, du, dv) in zip(range(2, -1, -1), rows[::-1]):
      if not memory.valid[row]:
        break
      np.testing.assert_allclose(memory.points[row], point, rtol=1e-6)
      np.testing.assert_allclose([memory.du[row], memory.dv[row]], [du, dv],
                                 atol=1e-5)
  assert any(abs(du) > 0.05 for _, du, _ in rows)  # BLE's noise is there.


@pytest.mark.slow
@pytest.mark.ci  # Env compiles; out of the default suite (<= 8 min).
def test_observed_column_is_forecast_plus_posterior_mean(flights):
  """Features 0-49 are those of forecast + Eq. (2) at each level, computed
  here level by level with `noise_gp`; without a memory, the forecast's."""
  wind = winds.GENERATIVE_WIND
  levels = jax_features.PRESSURE_LEVELS
  for memory, flight in flights.items():
    obs, state = flight[-1]
    f = state.flight
    u, v = (np.asarray(c, np.float64) for c in wind.forecast_column(
        state, f.x_m, f.y_m, jnp.asarray(levels, jnp.float32), f.time_s))
    if memory:
      weights = noise_gp.fit(state.wind_memory)
      for i, level in enumerate(levels):
        du, dv = noise_gp.posterior_mean(
            state.wind_memory, weights,
            jnp.array([f.x_m / 1e3, f.y_m / 1e3, level, f.time_s / 3600.0]))
        u[i], v[i] = u[i] + float(du), v[i] + float(dv)
    _assert_column_features(obs, u, v, f)
  # The same flight: everything but the column agrees.
  np.testing.assert_array_equal(flights[0][-1][0][50:], flights[3][-1][0][50:])
  assert np.abs(flights[0][-1][0][:50] - flights[3][-1][0][:50]).max() > 1e-3


@pytest.mark.slow
@pytest.mark.ci  # Env compiles; out of the default suite (<= 8 min).
def test_column_at_a_measurement_is_the_measured_wind(flights):
  """The Gaussian process interpolates: at the balloon, just measured, the
  corrected forecast is the measured wind (within the jitter's share)."""
  state = flights[3][-1][1]
  f = state.flight
  wind = winds.GENERATIVE_WIND
  pressure = jnp.reshape(f.pressure_pa, (1,))
  u, v = observed_winds.column(state, _PARAMS, wind, pressure)
  np.testing.assert_allclose([float(u[0]), float(v[0])],
                             [float(state.wind_u), float(state.wind_v)],
                             atol=0.02)


@pytest.mark.slow
@pytest.mark.ci  # Env compiles; out of the default suite (<= 8 min).
def test_placing_a_balloon_starts_an_empty_memory(flights):
  """`place` (a reset, a launch candidate) forgets an earlier flight's
  measurements."""
  env = jax_env.LatexBalloonJaxEnv()
  params = env_params.check_params(env.default_params.replace(wind_memory=3))
  old = flights[3][-1][1]
  placed = jax_env.place(old, params, x_m=1e3, y_m=0.0, altitude_m=17e3)
  assert not placed.wind_memory.valid.any()
  measured = jax_env.measure(placed, winds.GENERATIVE_WIND)
  assert measured.wind_memory.valid.tolist() == [False, False, True]


# What `column` reads of the env params.
_PARAMS = types.SimpleNamespace(wind_lookahead=0, stride_s=1200.0)


def _fixed_wind(u, v):
  """A wind whose forecast column is (u, v) wherever the balloon is."""
  return winds.Wind(None, lambda state, x, y, p, t: (u, v))


def test_column_is_forecast_plus_posterior_mean_of_a_memory():
  """Without a memory the forecast; with one, forecast + Eq. (2) at each
  level (computed here level by level); with zero residuals, the forecast."""
  flight = types.SimpleNamespace(x_m=jnp.float32(12e3), y_m=jnp.float32(-5e3),
                                 time_s=jnp.float32(7200.0))
  memory = noise_gp.empty(4)
  for row, (pressure, du, dv) in enumerate(
      [(9000.0, 1.0, -0.5), (9500.0, 0.8, -0.2), (11000.0, -0.3, 0.4)]):
    memory = noise_gp.add(memory, jnp.array(
        [10.0 + row, -5.0, pressure, 1.0 + 0.3 * row]), du, dv)
  levels = jnp.asarray(jax_features.PRESSURE_LEVELS, jnp.float32)
  forecast_u = jnp.linspace(-10.0, 10.0, 25)
  forecast_v = jnp.linspace(5.0, -5.0, 25)
  wind = _fixed_wind(forecast_u, forecast_v)
  same = observed_winds.column(
      types.SimpleNamespace(flight=flight, wind_memory=None), _PARAMS, wind,
      levels)
  assert same[0] is forecast_u and same[1] is forecast_v
  u, v = observed_winds.column(
      types.SimpleNamespace(flight=flight, wind_memory=memory), _PARAMS, wind,
      levels)
  weights = noise_gp.fit(memory)
  for i, level in enumerate(levels):
    du, dv = noise_gp.posterior_mean(memory, weights, jnp.array(
        [12.0, -5.0, level, 2.0]))
    np.testing.assert_allclose([u[i], v[i]], [forecast_u[i] + du,
                                              forecast_v[i] + dv], atol=1e-5)
  assert float(jnp.abs(u - forecast_u).max()) > 0.1  # It corrects.
  calm = memory.replace(du=jnp.zeros(4), dv=jnp.zeros(4))
  u, v = observed_winds.column(
      types.SimpleNamespace(flight=flight, wind_memory=calm), _PARAMS, wind,
      levels)
  np.testing.assert_allclose(u, forecast_u, atol=1e-6)
  np.testing.assert_allclose(v, forecast_v, atol=1e-6)


def _sheared(x, y, p, t):
  """An analytic forecast that varies in x, y, pressure and time. # [m/s]"""
  u = 10.0 + 2e-5 * y + 1e-3 * (p - 9000.0) + 3e-4 * t
  v = -4.0 + 3e-5 * x - 5e-4 * (p - 9000.0)
  return u, v


def _host_sheared(state, x, y, pressures, t):
  """`_sheared` as a host column: one scalar position per call."""
  del state
  assert jnp.ndim(x) == 0 and jnp.ndim(y) == 0 and pressures.shape == (1,)
  return _sheared(x, y, pressures, t)


def test_lookahead_column_is_the_mean_wind_of_euler_drifts():
  """With N > 0 each level's entry is (x_N - x_0) / (N dt) of the drift
  x_{k+1} = x_k + w(x_k, P_i, t + k dt) dt (integrated here in NumPy), the
  same through a host wind (one position per call)."""
  flight = types.SimpleNamespace(x_m=jnp.float32(20e3), y_m=jnp.float32(-8e3),
                                 time_s=jnp.float32(3600.0))
  state = types.SimpleNamespace(flight=flight, wind_memory=None)
  levels = jnp.asarray(jax_features.PRESSURE_LEVELS, jnp.float32)
  params = types.SimpleNamespace(wind_lookahead=4, stride_s=1200.0)
  jax_wind = winds.Wind(None, lambda s, x, y, p, t: _sheared(x, y, p, t))
  host_wind = winds.Wind(None, _host_sheared, host=True)
  want = []
  for level in np.asarray(levels, np.float64):
    x, y = 20e3, -8e3
    for k in range(4):
      u, v = _sheared(x, y, level, 3600.0 + 1200.0 * k)
      x, y = x + 1200.0 * u, y + 1200.0 * v
    want.append([(x - 20e3) / 4800.0, (y + 8e3) / 4800.0])
  want = np.asarray(want)
  for wind in (jax_wind, host_wind):
    u, v = observed_winds.column(state, params, wind, levels)
    np.testing.assert_allclose(np.stack([u, v], 1), want, rtol=1e-5,
                               atol=1e-4)
  now = np.stack(_sheared(20e3, -8e3, np.asarray(levels), 3600.0), 1)
  assert np.abs(want - now).max() > 0.5  # The drift is not the wind now.


@settings(max_examples=20, deadline=None)
@given(st.integers(1, env_params.MAX_WIND_LOOKAHEAD),
       st.floats(-40.0, 40.0), st.floats(-40.0, 40.0))
def test_a_steady_uniform_wind_drifts_at_itself(lookahead, u0, v0):
  """Invariant: in a wind the same everywhere and always, every drift's
  mean wind is that wind, whatever its length."""
  flight = types.SimpleNamespace(x_m=jnp.float32(5e3), y_m=jnp.float32(1e3),
                                 time_s=jnp.float32(0.0))
  levels = jnp.asarray(jax_features.PRESSURE_LEVELS, jnp.float32)
  wind = winds.Wind(None, lambda s, x, y, p, t: (
      jnp.full(p.shape, u0, jnp.float32), jnp.full(p.shape, v0, jnp.float32)))
  u, v = observed_winds.column(
      types.SimpleNamespace(flight=flight, wind_memory=None),
      types.SimpleNamespace(wind_lookahead=lookahead, stride_s=1200.0), wind,
      levels)
  np.testing.assert_allclose(u, u0, atol=2e-3)
  np.testing.assert_allclose(v, v0, atol=2e-3)


def test_one_stride_drift_is_the_corrected_column_at_the_balloon():
  """N = 1: the drift's mean wind is the (memory-corrected) wind at the
  balloon now, the column without a lookahead."""
  flight = types.SimpleNamespace(x_m=jnp.float32(12e3), y_m=jnp.float32(-5e3),
                                 time_s=jnp.float32(7200.0))
  memory = noise_gp.add(noise_gp.empty(2), jnp.array([11.0, -5.0, 9500.0,
                                                      1.5]), 1.2, -0.7)
  state = types.SimpleNamespace(flight=flight, wind_memory=memory)
  levels = jnp.asarray(jax_features.PRESSURE_LEVELS, jnp.float32)
  wind = winds.Wind(None, lambda s, x, y, p, t: _sheared(x, y, p, t))
  now = observed_winds.column(state, _PARAMS, wind, levels)
  drift = observed_winds.column(
      state, types.SimpleNamespace(wind_lookahead=1, stride_s=1200.0), wind,
      levels)
  np.testing.assert_allclose(drift, now, rtol=1e-5, atol=1e-4)


@pytest.mark.parametrize('name,value', [
    ('wind_memory', -1), ('wind_memory', 2.5), ('wind_memory', True),
    ('wind_memory', env_params.MAX_WIND_MEMORY + 1), ('wind_lookahead', -1),
    ('wind_lookahead', 1.5), ('wind_lookahead', 'long'),
    ('wind_lookahead', env_params.MAX_WIND_LOOKAHEAD + 1),
    # The switches (tests/envs/test_observed_sun_gas.py) are bools.
    ('sun', 1), ('sun', 'yes'), ('gas_temperature', None)])
def test_bad_observation_binding_is_refused(name, value):
  with gin.unlock_config():
    gin.bind_parameter(f'latex_observation.{name}', value)
  try:
    with pytest.raises(errors.ConfigError,
                       match=f'latex_observation.{name}'):
      env_params.params_from_gin()
  finally:
    gin.clear_config()


def test_policy_records_and_checks_its_wind_memory(tmp_path):
  """A policy file records the memory it observed with; a file without it
  (from before) observed the forecast (0); a bad value is refused."""
  shipped = pretrained.load_policy(pretrained.shipped_policy(False))
  assert shipped['config']['wind_memory'] == 0
  assert shipped['config']['wind_lookahead'] == 0
  config = dict(shipped['config'], wind_memory=16)
  assert sac_core.file_config(config, 'x')['wind_memory'] == 16
  with pytest.raises(ValueError, match='x: config.wind_memory'):
    sac_core.file_config(dict(config, wind_memory=-2), 'x')
  config = dict(shipped['config'], wind_lookahead=12)
  assert sac_core.file_config(config, 'x')['wind_lookahead'] == 12
  with pytest.raises(ValueError, match='x: config.wind_lookahead'):
    sac_core.file_config(dict(config, wind_lookahead=73), 'x')


@pytest.mark.slow
@pytest.mark.ci  # Env compiles; out of the default suite (<= 8 min).
def test_pretrained_agent_refuses_a_policy_of_another_observation(tmp_path):
  """A policy trained on the corrected column flown on the paper's (or the
  reverse) is refused before anything is built, naming the setting."""
  from ble_latex.agents.sac import agent as sac  # pylint: disable=g-import-not-at-top
  shipped = pretrained.load_policy(pretrained.shipped_policy(False))
  path = str(tmp_path / 'memory16.msgpack')
  pretrained.write_policy(
      dict(shipped, config=dict(shipped['config'], wind_memory=16)), path)
  with pytest.raises(ValueError, match='wind_memory=16.*wind_memory=0'):
    sac.SACPretrainedAgent(3, (71,), policy_path=path)
  drifted_path = str(tmp_path / 'lookahead12.msgpack')
  pretrained.write_policy(
      dict(shipped, config=dict(shipped['config'], wind_lookahead=12)),
      drifted_path)
  with pytest.raises(ValueError,
                     match='wind_lookahead=12.*wind_lookahead=0'):
    sac.SACPretrainedAgent(3, (71,), policy_path=drifted_path)
  with gin.unlock_config():
    gin.bind_parameter('latex_observation.wind_memory', 16)
  try:
    agent = sac.SACPretrainedAgent(3, (71,), policy_path=path)
    assert agent.policy_info['iteration'] == shipped['iteration']
  finally:
    gin.clear_config()


@pytest.mark.slow
@pytest.mark.ci  # Env compiles; out of the default suite (<= 8 min).
def test_drifted_flight_observes_its_drifts(flights, drifted):
  """`wind_lookahead` changes what is observed, not the flight: the same
  states, features 50-70 equal, and features 0-49 those of each level's
  3-stride drift, integrated here level by level on the forecast."""
  wind = winds.GENERATIVE_WIND
  levels = np.asarray(jax_features.PRESSURE_LEVELS, np.float32)
  for (obs0, state0), (obs, state) in zip(flights[0], drifted):
    np.testing.assert_array_equal(np.asarray(state0.flight.x_m),
                                  np.asarray(state.flight.x_m))
    np.testing.assert_array_equal(obs0[50:], obs[50:])
  obs, state = drifted[-1]
  f = state.flight
  drift = []
  for level in levels:
    x, y = f.x_m, f.y_m
    for k in range(3):
      u, v = wind.forecast_column(state, x, y, jnp.asarray([level]),
                                  f.time_s + 1200.0 * k)
      x, y = x + 1200.0 * u[0], y + 1200.0 * v[0]
    drift.append([(x - f.x_m) / 3600.0, (y - f.y_m) / 3600.0])
  u, v = np.asarray(drift, np.float64).T
  _assert_column_features(obs, u, v, f)
  assert np.abs(obs[:50] - flights[0][-1][0][:50]).max() > 1e-3


@pytest.mark.slow
@pytest.mark.ci  # Two env compiles (~40 s) each; out of the default suite.
@pytest.mark.parametrize('name', ['wind_memory', 'wind_lookahead'])
def test_every_entry_point_observes_the_observed_column(flights, drifted,
                                                        name):
  """Gymnasium's id and BLE's gym id, under the gin binding, fly the
  functional env's observations (the step returns the memory to the host
  with the flight)."""
  want = [np.asarray(obs) for obs, _ in (
      flights[3] if name == 'wind_memory' else drifted)]
  assert_entry_points_observe({f'latex_observation.{name}': 3}, 3, _ACTIONS,
                              want)


def assert_entry_points_observe(bindings, seed, actions, want):
  """Gymnasium's id and BLE's gym id, under the gin `bindings`, observe
  `want`: the functional env's observations at reset (seed `seed`) and
  after each of `actions` (also tests/envs/test_observed_sun_gas.py)."""
  import gym  # pylint: disable=g-import-not-at-top
  import gymnasium  # pylint: disable=g-import-not-at-top
  with gin.unlock_config():
    for binding, value in bindings.items():
      gin.bind_parameter(binding, value)
  try:
    gymnasium_env = gymnasium.make('ble_latex/LatexBalloon-v0',
                                   normalize_actions=False)
    gym_env = gym.make('LatexBalloon-v0').unwrapped
    assert gymnasium_env.observation_space.shape == want[0].shape
    assert gym_env.observation_space.shape == want[0].shape
    np.testing.assert_allclose(gymnasium_env.reset(seed=seed)[0], want[0],
                               atol=1e-6)
    np.testing.assert_allclose(gym_env.reset(seed=seed), want[0], atol=1e-6)
    for action, obs in zip(actions, want[1:]):
      np.testing.assert_allclose(gymnasium_env.step(action)[0], obs,
                                 atol=1e-5)
      np.testing.assert_allclose(gym_env.step(action)[0], obs, atol=1e-5)
    gymnasium_env.close()
  finally:
    gin.clear_config()
