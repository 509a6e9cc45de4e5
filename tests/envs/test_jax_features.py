"""ble_latex.envs.jax_features: the 71 features and the reward.

References: the observations recorded from the NumPy features before the
refactor (tests/data golden files), BLE's reward function, and the test's
own bearing-error oracle.
"""

# pylint: disable=protected-access

import datetime as dt
import math
import types

import ble_latex  # noqa: F401  (fixes first)
from ble_latex.ble import features as features_lib
from ble_latex.envs import jax_features
from ble_latex.ble import reward as reward_lib
from ble_latex.wind import generative
from balloon_learning_environment.env import balloon_env
from balloon_learning_environment.env import wind_field
from balloon_learning_environment.env.balloon import control
from balloon_learning_environment.env.balloon import standard_atmosphere
from balloon_learning_environment.utils import units
import jax
import hypothesis
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
import jax.numpy as jnp
import numpy as np
import pytest

from tests.ble import test_golden

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


def _bearing_error_reference(u, v, x_m, y_m):
  """The angle between the wind and the direction to the target (float64).

  The test's own oracle: |atan2(cross, dot)| of the wind (u, v) and the
  vector (-x, -y) from the balloon to the station; 0 at the station
  (closer than 1e-5 m), pi in calm air (slower than 1e-5 m/s). # [rad]
  """
  u, v, x_m, y_m = (float(a) for a in (u, v, x_m, y_m))
  if math.hypot(x_m, y_m) < 1e-5:
    return 0.0
  if math.hypot(u, v) < 1e-5:
    return math.pi
  return abs(math.atan2(u * -y_m - v * -x_m, u * -x_m + v * -y_m))


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
    reference = _bearing_error_reference(np.float32(u[i]), np.float32(v[i]),
                                         x32, y32)
    assert abs(float(ours) - reference) <= 1e-6, (i, float(ours), reference)


def test_constructor_is_the_core_features():
  """`features.LatexFeatureConstructor` (BLE interface) = jax_features."""
  rng = np.random.default_rng(1)
  forecast = _ColumnForecast()
  atmosphere = standard_atmosphere.Atmosphere(jax.random.PRNGKey(0))
  constructor = features_lib.LatexFeatureConstructor(forecast, atmosphere)
  np.testing.assert_array_equal(constructor.pressure_levels,
                                jax_features.PRESSURE_LEVELS)
  features = jax.jit(jax_features.features)
  history = initial = None
  for i in range(6):
    state = _random_state(rng, i)
    wind_u, wind_v = rng.normal(0.0, 15.0, 2)
    forecast.u, forecast.v = rng.normal(0.0, 15.0, (2, 25))
    constructor.observe(_observation(state, wind_u, wind_v))
    if i == 0:
      initial = jax_features.initial_resources(
          state.payload_kg, state.sand_kg, state.helium_mols)
      history = jax_features.init_history(state.altitude_m,
                                          state.ascent_rate_mps)
    else:  # The observed (post-step) state becomes t-1.
      history = jax_features.push_history(
          history, state.altitude_m, state.ascent_rate_mps,
          state.last_float_action)
    ambient = atmosphere.at_height(units.Distance(m=state.altitude_m))
    ours = features(
        forecast.u, forecast.v, state.x.meters, state.y.meters,
        state.altitude_m, state.ascent_rate_mps, wind_u, wind_v,
        state.helium_mols, state.sand_kg, state.payload_kg,
        ambient.temperature, ambient.pressure, initial, history)
    np.testing.assert_allclose(constructor.get_features(), ours, rtol=0,
                               atol=1e-6)
  with pytest.raises(ValueError, match='min_pressure'):
    features_lib.LatexFeatureConstructor(forecast, atmosphere,
                                         min_pressure=4000.0)


def _forecast_key(seed: int) -> jnp.ndarray:
  """The forecast key BLE's env/arena derive from a reset seed."""
  rng = jax.random.PRNGKey(seed)  # BalloonEnv.seed
  _, rng = jax.random.split(rng)  # BalloonEnv.reset: arena_rng
  rng, _, _ = jax.random.split(rng, 3)  # atmosphere, time
  rng, *_ = jax.random.split(rng, num=5)  # LatexBalloonArena balloon
  _, wind_key = jax.random.split(rng, 2)
  return generative.split_wind_key(wind_key)[1]


@pytest.mark.parametrize('source', ['random', 'scripted'])
def test_features_of_recorded_states_are_the_recorded_observations(source):
  """Golden data (recorded from the NumPy features before the refactor).

  The recorded states, measured winds and ambient values, with the forecast
  column of the seed's field, give the recorded observations: the 71
  features are the ones `ble_latex.ble.features` computed.
  """
  golden = test_golden.load_golden(source)
  features = jax.jit(jax_features.features)
  column = jax.jit(generative.forecast_column)
  levels = jax_features.PRESSURE_LEVELS.astype(np.float32)
  worst = 0.0
  for i in (0, 9):
    episode, n = golden.episode(i), golden.lengths[i]
    field = generative.reset_forecast(_forecast_key(golden.seeds[i]),
                                      generative.decoder_params())
    s = lambda name, t: np.float32(episode['state_' + name][t])  # pylint: disable=unnecessary-lambda-assignment,cell-var-from-loop
    initial = jax_features.initial_resources(
        np.float32(2.2), s('sand_kg', 0), s('helium_mols', 0))
    history = jax_features.init_history(s('altitude_m', 0),
                                        s('ascent_rate_mps', 0))
    for t in range(0, n + 1, 7):
      if t:
        for k in range(t - 6, t + 1):
          history = jax_features.push_history(
              history, s('altitude_m', k), s('ascent_rate_mps', k),
              s('last_float_action', k))
      u, v = column(field, s('x_m', t), s('y_m', t), levels,
                    s('time_elapsed_s', t))
      ours = features(
          u, v, s('x_m', t), s('y_m', t), s('altitude_m', t),
          s('ascent_rate_mps', t), np.float32(episode['wind_u_mps'][t]),
          np.float32(episode['wind_v_mps'][t]), s('helium_mols', t),
          s('sand_kg', t), np.float32(2.2), s('ambient_temperature_k', t),
          s('pressure_pa', t), initial, history)
      err = np.abs(np.asarray(ours) - episode['obs'][t]).max()
      worst = max(worst, err)
      assert err <= _ATOL_FEATURES, (golden.seeds[i], t, err)
  assert worst > 0.0  # float32 vs the recorded float64: not bit-identical.


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


@hypothesis.settings(max_examples=40, deadline=None)
@hypothesis.given(
    speeds=hnp.arrays(np.float64, 25, elements=st.floats(0.0, 60.0)),
    x_km=st.floats(-300.0, 300.0), y_km=st.floats(-300.0, 300.0),
    altitude_m=st.floats(14_000.0, 21_000.0),
    ascent_rate_mps=st.floats(-4.9, 4.9),
    sand_left=st.floats(0.0, 1.0), helium_left=st.floats(0.05, 1.0))
def test_named_features_decode_what_was_encoded(speeds, x_km, y_km,
                                                altitude_m, ascent_rate_mps,
                                                sand_left, helium_left):
  # Wind blowing east at the given speeds; the decoder undoes the scalings.
  initial = jax_features.initial_resources(60.0, 10.0, 400.0)
  history = jax_features.init_history(altitude_m, ascent_rate_mps)
  f = np.asarray(jax_features.features(
      speeds, np.zeros(25), x_km * 1000.0, y_km * 1000.0, altitude_m,
      ascent_rate_mps, 5.0, 0.0, 400.0 * helium_left, 10.0 * sand_left, 60.0,
      216.0, 7500.0, initial, history))
  named = jax_features.NamedLatexFeatures(f)
  # float32 features: ~1e-7 relative, amplified where the squash is steep.
  np.testing.assert_allclose(named.wind_speeds_mps, speeds, rtol=2e-4,
                             atol=2e-3)
  assert named.altitude_m == pytest.approx(altitude_m, abs=0.01)
  assert named.ascent_rate_mps == pytest.approx(ascent_rate_mps, abs=1e-5)
  assert named.wind_speed_mps == pytest.approx(5.0, rel=1e-5)
  assert named.distance_km == pytest.approx(math.hypot(x_km, y_km),
                                            rel=1e-5, abs=1e-4)
  np.testing.assert_allclose(named.altitude_history_m, altitude_m, atol=0.01)
  assert named.sand_fraction == pytest.approx(sand_left, abs=1e-6)
  assert named.helium_fraction == pytest.approx(helium_left, abs=1e-6)
  expected_bearing = np.asarray(jax_features.bearing_errors(
      speeds, np.zeros(25), x_km * 1000.0, y_km * 1000.0), np.float64)
  np.testing.assert_allclose(named.bearing_errors_rad, expected_bearing,
                             atol=1e-5)


def test_named_features_reject_other_shapes():
  with pytest.raises(ValueError, match='71 features'):
    jax_features.NamedLatexFeatures(np.zeros(70))
