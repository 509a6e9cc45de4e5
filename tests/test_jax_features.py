"""ble_latex.jax_features reproduces ble_latex.features and the reward."""

# pylint: disable=protected-access

import datetime as dt
import math
import types

import ble_latex  # noqa: F401  (fixes first)
from ble_latex import features as features_lib
from ble_latex import jax_features
from ble_latex import reward as reward_lib
from ble_latex.wind import generative
from balloon_learning_environment.env import balloon_env
from balloon_learning_environment.env import wind_field
from balloon_learning_environment.env.balloon import control
from balloon_learning_environment.env.balloon import standard_atmosphere
from balloon_learning_environment.utils import units
import gym
import jax
import jax.numpy as jnp
import numpy as np
import pytest

# Measured (float32 JAX vs float64 numpy): features <= ~1e-6 (the float32
# output's own rounding is 6e-8), reward <= ~1e-7.
_ATOL_FEATURES = 1e-5
_ATOL_REWARD = 1e-6


class _ColumnForecast:
  """A stand-in forecast whose column is set by the test."""

  def __init__(self):
    self.u = self.v = None

  def get_forecast_column(self, x, y, pressures, elapsed_time):
    del x, y, elapsed_time
    assert len(pressures) == jax_features.N_LEVELS
    return [wind_field.WindVector(units.Velocity(mps=float(u)),
                                  units.Velocity(mps=float(v)))
            for u, v in zip(self.u, self.v)]


def _observation(state, wind_u, wind_v):
  return types.SimpleNamespace(
      balloon_observation=state,
      wind_at_balloon=wind_field.WindVector(units.Velocity(mps=wind_u),
                                            units.Velocity(mps=wind_v)))


def _random_state(rng, i):
  # Every fifth state far outside the scaled ranges (clipping).
  wild = i % 5 == 4
  return types.SimpleNamespace(
      x=units.Distance(m=rng.uniform(-3e6, 3e6) if wild else
                       rng.uniform(-4e5, 4e5)),
      y=units.Distance(m=rng.uniform(-4e5, 4e5)),
      altitude_m=rng.uniform(2e3, 3e4) if wild else rng.uniform(14e3, 21e3),
      ascent_rate_mps=rng.uniform(-12.0, 12.0) if wild else
      rng.uniform(-3.0, 3.0),
      helium_mols=rng.uniform(100.0, 400.0),
      sand_kg=rng.uniform(0.0, 3.0),
      payload_kg=4.0,
      time_elapsed=dt.timedelta(minutes=20 * i),
      last_float_action=float(rng.uniform(-1.0, 1.0)))


def test_bearing_errors_match():
  rng = np.random.default_rng(0)
  u, v = rng.normal(0.0, 10.0, (2, 500))
  x, y = rng.uniform(-3e5, 3e5, (2, 500))
  # Winds straight at / away from the target (arccos's worst case), calm
  # air, tiny winds and the target itself.
  u[:50], v[:50] = -x[:50] * 1e-4, -y[:50] * 1e-4
  u[50:100], v[50:100] = x[50:100] * 3e-5, y[50:100] * 3e-5
  u[100:110] = v[100:110] = 0.0
  u[110:120], v[110:120] = 3e-6, 4e-6
  for i in range(500):
    x32, y32 = np.float32(x[i]), np.float32(y[i])
    if i >= 490:
      x32 = y32 = np.float32(0.0)
    ours = jax_features.bearing_errors(np.float32(u[i]), np.float32(v[i]),
                                       x32, y32)
    reference = features_lib.bearing_errors(
        np.array([np.float32(u[i])], np.float64),
        np.array([np.float32(v[i])], np.float64), float(x32), float(y32))[0]
    assert abs(float(ours) - reference) <= 1e-6, (i, float(ours), reference)


def test_features_match_the_constructor():
  """Random states (incl. clipping) through LatexFeatureConstructor."""
  rng = np.random.default_rng(1)
  forecast = _ColumnForecast()
  atmosphere = standard_atmosphere.Atmosphere(jax.random.PRNGKey(0))
  constructor = features_lib.LatexFeatureConstructor(forecast, atmosphere)
  np.testing.assert_array_equal(constructor.pressure_levels,
                                jax_features.PRESSURE_LEVELS)
  features = jax.jit(jax_features.features)
  history = initial = previous = None
  worst = 0.0
  for i in range(25):
    state = _random_state(rng, i)
    wind_u, wind_v = rng.normal(0.0, 15.0, 2)
    forecast.u, forecast.v = rng.normal(0.0, 15.0, (2, 25))
    if i == 7:  # Calm column levels and wind.
      forecast.u[:5] = forecast.v[:5] = wind_u = wind_v = 0.0
    # A new state object per observation: the constructor pushes the
    # previous observation's altitude and ascent rate (documented t-1).
    constructor.observe(_observation(state, wind_u, wind_v))
    if i == 0:
      initial = jax_features.initial_resources(
          state.payload_kg, state.sand_kg, state.helium_mols)
      history = jax_features.init_history(state.altitude_m,
                                          state.ascent_rate_mps)
    else:
      history = jax_features.push_history(
          history, previous.altitude_m, previous.ascent_rate_mps,
          state.last_float_action)
    previous = state
    ambient = atmosphere.at_height(units.Distance(m=state.altitude_m))
    ours = features(
        forecast.u, forecast.v, state.x.meters, state.y.meters,
        state.altitude_m, state.ascent_rate_mps, wind_u, wind_v,
        state.helium_mols, state.sand_kg, state.payload_kg,
        ambient.temperature, ambient.pressure, initial, history)
    reference = constructor.get_features()
    assert ours.dtype == jnp.float32 and ours.shape == (71,)
    worst = max(worst, np.abs(np.asarray(ours) - reference).max())
    np.testing.assert_allclose(ours, reference, rtol=0, atol=_ATOL_FEATURES)
  assert worst <= _ATOL_FEATURES, worst


def _forecast_key(seed: int) -> jnp.ndarray:
  """The forecast key BLE's env/arena derive from a reset seed."""
  rng = jax.random.PRNGKey(seed)  # BalloonEnv.seed
  _, rng = jax.random.split(rng)  # BalloonEnv.reset: arena_rng
  rng, _, _ = jax.random.split(rng, 3)  # atmosphere, time
  rng, *_ = jax.random.split(rng, num=5)  # LatexBalloonArena balloon
  _, wind_key = jax.random.split(rng, 2)
  return generative.split_wind_key(wind_key)[1]


@pytest.fixture(scope='module')
def env():
  return gym.make('LatexBalloon-v0')


def test_features_and_reward_match_the_env(env):
  """The env's observations / rewards from its state, with the JAX field."""
  seed = 5
  observation = env.reset(seed=seed)
  arena = env.unwrapped.arena
  wind = arena._wind_field
  field = generative.reset_forecast(_forecast_key(seed),
                                    generative.decoder_params())
  np.testing.assert_allclose(np.asarray(field.grid), wind.field, rtol=0,
                             atol=1e-5)
  levels = jax_features.PRESSURE_LEVELS.astype(np.float32)
  features = jax.jit(jax_features.features)
  column = jax.jit(generative.forecast_column)
  point = jax.jit(generative.forecast)
  reward = jax.jit(jax_features.reward)

  state = arena.get_balloon_state()
  initial = jax_features.initial_resources(state.payload_kg, state.sand_kg,
                                           state.helium_mols)
  history = jax_features.init_history(state.altitude_m, state.ascent_rate_mps)
  actions = [(17_000.0, 2.0, 0.0), (19_500.0, 1.0, -1.0),
             (15_500.0, 3.0, 1.0), (18_000.0, 5.0, 0.3), (16_000.0, 1.5, 0.0)]
  for step in range(len(actions) + 1):
    if step:
      observation, r, _, info = env.step(np.array(actions[step - 1],
                                                  np.float32))
      state = arena.get_balloon_state()
      # BLE's arena hands the feature constructor its live state object,
      # already updated by the step: ble_latex.features pushes the
      # post-step altitude and ascent rate as t-1 (see push_history).
      history = jax_features.push_history(
          history, state.altitude_m, state.ascent_rate_mps,
          state.last_float_action)
      ours_r = reward(np.float32(info['distance_km']))
      assert abs(float(ours_r) - r) <= _ATOL_REWARD, (float(ours_r), r)
      ours_r = reward(jax_features.distance_km(np.float32(state.x.meters),
                                               np.float32(state.y.meters)))
      assert abs(float(ours_r) - r) <= _ATOL_REWARD, (float(ours_r), r)
    constructor = arena.feature_constructor
    for theirs, ours in ((constructor._altitudes, history.altitude_m),
                         (constructor._ascent_rates, history.ascent_rate_mps),
                         (constructor._float_actions, history.float_action)):
      np.testing.assert_array_equal(np.float32(theirs), ours)
    t_s = state.time_elapsed.total_seconds()
    x, y = np.float32(state.x.meters), np.float32(state.y.meters)
    u, v = column(field, x, y, levels, np.float32(t_s))
    # The forecast at the balloon equals the env's wind field's forecast.
    ours_uv = point(field, x, y, np.float32(state.pressure), np.float32(t_s))
    theirs = wind.get_forecast(state.x, state.y, state.pressure,
                               state.time_elapsed)
    np.testing.assert_allclose(
        ours_uv, (theirs.u.meters_per_second, theirs.v.meters_per_second),
        rtol=0, atol=2e-5)
    measured = constructor._wind_at_balloon
    ambient = arena._atmosphere.at_height(units.Distance(m=state.altitude_m))
    ours = features(
        u, v, x, y, np.float32(state.altitude_m),
        np.float32(state.ascent_rate_mps),
        np.float32(measured.u.meters_per_second),
        np.float32(measured.v.meters_per_second),
        np.float32(state.helium_mols), np.float32(state.sand_kg),
        np.float32(state.payload_kg), np.float32(ambient.temperature),
        np.float32(ambient.pressure), initial, history)
    np.testing.assert_allclose(ours, observation, rtol=0,
                               atol=_ATOL_FEATURES)


def test_reward_matches_ble():
  distances_km = np.concatenate([
      np.linspace(0.0, 400.0, 81), [49.999, 50.0, 50.001, 1234.5],
      np.random.default_rng(2).uniform(0.0, 600.0, 40)])
  reward = jax.jit(jax_features.reward)
  for d in distances_km:
    angle = 0.3 * d
    x_m, y_m = d * 1000.0 * math.cos(angle), d * 1000.0 * math.sin(angle)
    balloon_state = types.SimpleNamespace(
        x=units.Distance(m=x_m), y=units.Distance(m=y_m),
        last_command=control.AltitudeControlCommand.STAY)
    simulator_state = types.SimpleNamespace(balloon_state=balloon_state)
    ble_d = jax_features.distance_km(np.float32(x_m), np.float32(y_m))
    for radius, dropoff, halflife in ((50.0, 0.4, 100.0),
                                      (30.0, 0.2, 40.0)):
      reference = balloon_env.perciatelli_reward_function(
          simulator_state, station_keeping_radius_km=radius,
          reward_dropoff=dropoff, reward_halflife=halflife)
      ours = reward(ble_d, radius, dropoff, halflife)
      assert abs(float(ours) - reference) <= _ATOL_REWARD, (d, radius)
    reference = reward_lib.latex_reward(
        simulator_state, 0.7, 0.25, helium_penalty_per_mol=0.01,
        sand_penalty_per_kg=0.3)
    ours = reward(np.float32(d), vented=0.7, dropped=0.25,
                  helium_penalty=0.01, sand_penalty=0.3)
    assert abs(float(ours) - reference) <= _ATOL_REWARD, d


def test_batched_features():
  """vmap over balloons; history helpers keep their shapes."""
  n = 8
  rng = np.random.default_rng(3)
  altitude = jnp.asarray(rng.uniform(15e3, 20e3, n), jnp.float32)
  rate = jnp.asarray(rng.uniform(-1.0, 1.0, n), jnp.float32)
  history = jax_features.init_history(altitude, rate)
  assert history.altitude_m.shape == (n, 3)
  history = jax_features.push_history(history, altitude + 1.0, rate, 0.5)
  np.testing.assert_array_equal(history.altitude_m[:, 0], altitude + 1.0)
  np.testing.assert_array_equal(history.altitude_m[:, 1], altitude)
  np.testing.assert_array_equal(history.float_action[:, 0], 0.5)
  helium = jnp.full((n,), 200.0)
  initial = jax_features.initial_resources(4.0, jnp.full((n,), 2.0), helium)
  columns = jnp.asarray(rng.normal(0.0, 10.0, (2, n, 25)), jnp.float32)
  temperature = jnp.full((n,), 210.0)  # [K]
  pressure = jnp.full((n,), 8000.0)  # [Pa]
  batched = jax.jit(jax.vmap(jax_features.features))(
      columns[0], columns[1], altitude * 10.0, altitude * 5.0, altitude,
      rate, columns[0][:, 0], columns[1][:, 0], helium,
      jnp.full((n,), 1.5), jnp.full((n,), 4.0), temperature, pressure,
      initial, history)
  assert batched.shape == (n, 71) and batched.dtype == jnp.float32
  assert np.all(np.abs(batched) <= 1.0)
  for i in range(n):
    one = jax_features.features(
        columns[0, i], columns[1, i], altitude[i] * 10.0, altitude[i] * 5.0,
        altitude[i], rate[i], columns[0, i, 0], columns[1, i, 0], helium[i],
        1.5, 4.0, temperature[i], pressure[i],
        jax.tree_util.tree_map(lambda a, i=i: a[i], initial),
        jax.tree_util.tree_map(lambda a, i=i: a[i], history))
    np.testing.assert_allclose(batched[i], one, rtol=0, atol=1e-6)
