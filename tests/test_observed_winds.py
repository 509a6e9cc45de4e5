"""`ble_latex.envs.observed_winds`: the observation's wind column corrected by
the balloon's measured winds (`latex_observation.wind_memory`).

The flights (env compiles, ~10-40 s) run in CI (`make test-ci`); the default
suite checks the column on a hand-made memory."""

import types

import gin
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex import errors
from ble_latex.agents import pretrained
from ble_latex.agents import sac_core
from ble_latex.envs import env_params
from ble_latex.envs import jax_env
from ble_latex.envs import jax_features
from ble_latex.envs import observed_winds
from ble_latex.envs import winds
from ble_latex.wind import noise_gp

_ACTIONS = np.array([[16_500.0, 1.0, -1.0], [18_500.0, 2.0, -1.0],
                     [17_000.0, 1.5, -1.0], [17_000.0, 1.0, 1.0],
                     [19_000.0, 1.0, -1.0]], np.float32)


def _flight(memory: int, seed: int = 3):
  """Reset and the five strides of `_ACTIONS` under `wind_memory` = memory:
  [(obs, state)] after each."""
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  params = env_params.check_params(
      env.default_params.replace(wind_memory=memory))
  obs, state = jax.jit(env.reset)(jax.random.PRNGKey(seed), params)
  step = jax.jit(env.step_env)
  out = [(obs, state)]
  for action in _ACTIONS:
    obs, state, *_ = step(None, state, jnp.asarray(action), params)
    out.append((obs, state))
  return out


@pytest.fixture(scope='module')
def flights():
  return {k: _flight(k) for k in (0, 3)}


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
    speed = 1.0 - np.exp(-np.hypot(u, v) / jax_features.SPEED_SQUASH_MPS)
    np.testing.assert_allclose(obs[:25], speed, atol=2e-5)
    bearing = np.asarray(jax_features.bearing_errors(
        jnp.asarray(u, jnp.float32), jnp.asarray(v, jnp.float32), f.x_m,
        f.y_m)) / np.pi
    np.testing.assert_allclose(obs[25:50], bearing, atol=2e-4)
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
  u, v = observed_winds.column(
      state, *wind.forecast_column(state, f.x_m, f.y_m, pressure, f.time_s),
      pressure)
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
  same = observed_winds.column(
      types.SimpleNamespace(flight=flight, wind_memory=None), forecast_u,
      forecast_v, levels)
  assert same[0] is forecast_u and same[1] is forecast_v
  u, v = observed_winds.column(
      types.SimpleNamespace(flight=flight, wind_memory=memory), forecast_u,
      forecast_v, levels)
  weights = noise_gp.fit(memory)
  for i, level in enumerate(levels):
    du, dv = noise_gp.posterior_mean(memory, weights, jnp.array(
        [12.0, -5.0, level, 2.0]))
    np.testing.assert_allclose([u[i], v[i]], [forecast_u[i] + du,
                                              forecast_v[i] + dv], atol=1e-5)
  assert float(jnp.abs(u - forecast_u).max()) > 0.1  # It corrects.
  calm = memory.replace(du=jnp.zeros(4), dv=jnp.zeros(4))
  u, v = observed_winds.column(
      types.SimpleNamespace(flight=flight, wind_memory=calm), forecast_u,
      forecast_v, levels)
  np.testing.assert_allclose(u, forecast_u, atol=1e-6)
  np.testing.assert_allclose(v, forecast_v, atol=1e-6)


@pytest.mark.parametrize('value', [-1, 2.5, True, env_params.MAX_WIND_MEMORY
                                   + 1])
def test_bad_wind_memory_binding_is_refused(value):
  with gin.unlock_config():
    gin.bind_parameter('latex_observation.wind_memory', value)
  try:
    with pytest.raises(errors.ConfigError,
                       match='latex_observation.wind_memory'):
      env_params.params_from_gin()
  finally:
    gin.clear_config()


def test_policy_records_and_checks_its_wind_memory(tmp_path):
  """A policy file records the memory it observed with; a file without it
  (from before) observed the forecast (0); a bad value is refused."""
  shipped = pretrained.load_policy(pretrained.shipped_policy(False))
  assert shipped['config']['wind_memory'] == 0
  config = dict(shipped['config'], wind_memory=16)
  assert sac_core.file_config(config, 'x')['wind_memory'] == 16
  with pytest.raises(ValueError, match='x: config.wind_memory'):
    sac_core.file_config(dict(config, wind_memory=-2), 'x')


@pytest.mark.slow
@pytest.mark.ci  # Env compiles; out of the default suite (<= 8 min).
def test_pretrained_agent_refuses_a_policy_of_another_observation(tmp_path):
  """A policy trained on the corrected column flown on the paper's (or the
  reverse) is refused before anything is built, naming the setting."""
  from ble_latex.agents import sac  # pylint: disable=g-import-not-at-top
  shipped = pretrained.load_policy(pretrained.shipped_policy(False))
  path = str(tmp_path / 'memory16.msgpack')
  pretrained.write_policy(
      dict(shipped, config=dict(shipped['config'], wind_memory=16)), path)
  with pytest.raises(ValueError, match='wind_memory=16.*wind_memory=0'):
    sac.SACPretrainedAgent(3, (71,), policy_path=path)
  with gin.unlock_config():
    gin.bind_parameter('latex_observation.wind_memory', 16)
  try:
    agent = sac.SACPretrainedAgent(3, (71,), policy_path=path)
    assert agent.policy_info['iteration'] == shipped['iteration']
  finally:
    gin.clear_config()


@pytest.mark.slow
@pytest.mark.ci  # Two env compiles (~40 s); out of the default suite.
def test_every_entry_point_observes_the_corrected_column(flights):
  """Gymnasium's id and BLE's gym id, under the gin binding, fly the
  functional env's observations (the step returns the memory to the host
  with the flight)."""
  import gym  # pylint: disable=g-import-not-at-top
  import gymnasium  # pylint: disable=g-import-not-at-top
  with gin.unlock_config():
    gin.bind_parameter('latex_observation.wind_memory', 3)
  try:
    gymnasium_env = gymnasium.make('ble_latex/LatexBalloon-v0',
                                   normalize_actions=False)
    gym_env = gym.make('LatexBalloon-v0').unwrapped
    want = [np.asarray(obs) for obs, _ in flights[3]]
    np.testing.assert_allclose(gymnasium_env.reset(seed=3)[0], want[0],
                               atol=1e-6)
    np.testing.assert_allclose(gym_env.reset(seed=3), want[0], atol=1e-6)
    for action, obs in zip(_ACTIONS, want[1:]):
      np.testing.assert_allclose(gymnasium_env.step(action)[0], obs,
                                 atol=1e-5)
      np.testing.assert_allclose(gym_env.step(action)[0], obs, atol=1e-5)
    gymnasium_env.close()
  finally:
    gin.clear_config()
