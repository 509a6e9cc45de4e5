"""The observation options (issue 63 item 2): the sun's elevation and rate
(`latex_observation.sun`) and the helium-air temperature difference
(`latex_observation.gas_temperature`), appended after the 71 features.

One functional-env reset is compiled for the module (`flight`); every option
is observed on its state. The Gymnasium and BLE gym flights (their own
compiles) run in CI (`make test-ci`). Bad bindings of the options are
refused in tests/envs/test_observed_winds.py with the wind settings'."""

import datetime as dt
import types

import gin
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex import errors
from ble_latex.agents.sac import core as sac_core
from ble_latex.agents.sac import ensemble
from ble_latex.agents.sac import pretrained
from ble_latex.agents.sac import trainer as sac_trainer
from ble_latex.envs import env_params
from ble_latex.envs import env_types
from ble_latex.envs import jax_env
from ble_latex.envs import jax_features
from ble_latex.envs import observed_sun_gas
from ble_latex.flight import atmosphere
from ble_latex.flight import solar
from ble_latex.flight import thermal
from ble_latex.run import jax_train
from tests.envs import test_observed_winds

_OPTIONS = {'none': {}, 'sun': {'sun': True},
            'gas': {'gas_temperature': True},
            'both': {'sun': True, 'gas_temperature': True}}
_SIZES = {'none': 71, 'sun': 73, 'gas': 72, 'both': 74}


@pytest.fixture(scope='module')
def flight():
  """(params, observation, state) of one reset under the defaults."""
  env = jax_env.LatexBalloonJaxEnv()
  params = env_params.params_from_gin()
  obs, state = jax.jit(env.reset)(jax.random.PRNGKey(7), params)
  return params, np.asarray(obs), state


@pytest.fixture(scope='module')
def observe():
  """`jax_env.observation`, jitted (params static by their options)."""
  return jax.jit(jax_env.observation)


def _with(params, name):
  return env_params.check_params(params.replace(**_OPTIONS[name]))


@pytest.mark.parametrize('name', list(_OPTIONS))
def test_spaces_follow_the_options(name):
  """The functional, Gymnasium (single and vector) and BLE envs' observation
  spaces have the options' size (no compile)."""
  from ble_latex.ble import features  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import gymnasium_env  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import gymnasium_vector  # pylint: disable=g-import-not-at-top
  params = _with(env_params.params_from_gin(), name)
  size = _SIZES[name]
  assert env_params.num_features(params) == size
  assert jax_env.LatexBalloonJaxEnv().observation_space(params).shape == (
      size,)
  single = gymnasium_env.LatexBalloonGymnasiumEnv(params=params)
  assert single.observation_space.shape == (size,)
  vector = gymnasium_vector.LatexBalloonVectorEnv(3, params=params)
  assert vector.observation_space.shape == (3, size)
  with gin.unlock_config():
    for key, value in _OPTIONS[name].items():
      gin.bind_parameter(f'latex_observation.{key}', value)
  try:
    constructor = features.LatexFeatureConstructor(None, None)
    assert constructor.observation_space.shape == (size,)
  finally:
    gin.clear_config()


def test_options_off_leave_the_observation_as_it_was(flight, observe):
  """Off (the defaults): the 71 features, bit-identical to the reset's;
  on: the same 71 first, the options' appended."""
  params, obs, state = flight
  assert obs.shape == (71,)
  np.testing.assert_array_equal(np.asarray(observe(state, params)), obs)
  for name in ('sun', 'gas', 'both'):
    seen = np.asarray(observe(state, _with(params, name)))
    assert seen.shape == (_SIZES[name],)
    np.testing.assert_array_equal(seen[:71], obs)


def _independent_sun(params, state, time_s):
  """The sun's elevation [deg] at the balloon, from the flight's start as a
  date (START_EPOCH + offset) read by `solar.solar_clock`."""
  start = env_types.START_EPOCH + dt.timedelta(
      seconds=int(state.start_time_offset_s))
  day, second = solar.solar_clock(start, 'start')
  f = state.flight
  lat, lon = thermal.position_lat_lon(
      np.float64(params.flight.latitude_deg),
      np.float64(params.flight.longitude_deg), np.float64(f.x_m),
      np.float64(f.y_m))
  return float(solar.sun_elevation_deg(day, second, time_s, lat, lon)), (
      float(lat), float(lon), start)


def test_sun_features_are_the_suns_elevation_and_rate(flight, observe):
  """Features 71, 72: the NOAA elevation at the balloon's position on the
  flight's own clock (under the paper's physics too), within 0.7 deg of
  BLE's own solar calculator; its rate the elevation's change per hour."""
  from balloon_learning_environment.env.balloon import solar as ble_solar  # pylint: disable=g-import-not-at-top
  import s2sphere  # pylint: disable=g-import-not-at-top
  params, _, state = flight
  assert not params.flight.gas_superheat  # The paper's physics.
  seen = jax_features.NamedLatexFeatures(
      np.asarray(observe(state, _with(params, 'sun'))))
  t = float(state.flight.time_s)
  elevation, (lat, lon, start) = _independent_sun(params, state, t)
  assert seen.sun_elevation_deg == pytest.approx(elevation, abs=2e-3)
  ble = ble_solar.solar_calculator(
      s2sphere.LatLng.from_degrees(lat, lon), start)[0]
  assert seen.sun_elevation_deg == pytest.approx(ble, abs=0.7)
  later = _independent_sun(params, state, t + 60.0)[0]
  earlier = _independent_sun(params, state, t - 60.0)[0]
  assert seen.sun_rate_deg_per_h == pytest.approx(
      (later - earlier) / 120.0 * 3600.0, abs=0.05)
  assert seen.gas_excess_k is None


def test_sun_tells_morning_from_evening(flight):
  """The same elevation rises before noon and sinks after it: the rate's
  sign tells them apart (6 h before and after local noon)."""
  params, _, state = flight
  hours = np.arange(0.0, 24.0, 0.25)

  def sun_at(h):
    return [np.asarray(v) for v in observed_sun_gas.sun(params, state.replace(
        flight=state.flight.replace(time_s=jnp.asarray(h * 3600.0,
                                                       jnp.float32))))]

  noon = hours[np.argmax(sun_at(hours)[0])]  # Local noon: the highest sun.
  (morning, evening), (rising, sinking) = sun_at(noon + np.array([-3.0, 3.0]))
  assert morning == pytest.approx(evening, abs=1.5)
  assert rising > 5.0 > -5.0 > sinking


def test_gas_feature_is_the_gas_minus_the_air(flight, observe):
  """The last feature: T_gas - T at the balloon over 20 K; 0 under the
  paper's physics; under gas_state the state's T_g minus the atmosphere's
  temperature at the altitude; under gas_superheat alone the lagged solar
  excess of `thermal.gas_excess_k` on the flight's clock."""
  params, _, state = flight
  both = _with(params, 'both')
  assert float(np.asarray(observe(state, both))[-1]) == 0.0
  f = state.flight
  air = float(atmosphere.at_height(state.atmosphere, f.altitude_m).temperature)
  warm = state.replace(flight=f.replace(
      gas_temperature_k=f.temperature_k + jnp.float32(3.7)))
  gas_state = both.replace(flight=params.flight.replace(
      gas_state=True, gas_superheat=True, superheat_day_k=8.1,
      cooling_night_k=3.3))
  seen = jax_features.NamedLatexFeatures(
      np.asarray(observe(warm, gas_state)))
  assert seen.gas_excess_k == pytest.approx(
      float(warm.flight.gas_temperature_k) - air, abs=1e-3)
  assert seen.gas_excess_k == pytest.approx(3.7, abs=1e-3)
  superheat = gas_state.replace(flight=gas_state.flight.replace(
      gas_state=False))
  start = env_types.START_EPOCH + dt.timedelta(
      seconds=int(state.start_time_offset_s))
  day, second = solar.solar_clock(start, 'start')
  clock = superheat.flight.replace(start_day_j2000=day,
                                   start_second_of_day=second)
  want = float(thermal.gas_excess_k(clock, f.time_s, f.x_m, f.y_m))
  got = float(np.asarray(observe(warm, superheat))[-1]) * 20.0
  assert got == pytest.approx(want, abs=1e-3)
  assert abs(want) > 1.0  # Day or night, not the smoothstep's zero.


def test_decoder_reads_every_size():
  """`NamedLatexFeatures` reads 71-74 features (the options by the size)
  and refuses other sizes in one line."""
  base = np.zeros(71, np.float32)
  sun = jax_features.NamedLatexFeatures(np.r_[base, 0.5, -0.2])
  assert (sun.sun_elevation_deg, sun.sun_rate_deg_per_h) == pytest.approx(
      (45.0, -3.0))
  assert sun.gas_excess_k is None
  gas = jax_features.NamedLatexFeatures(np.r_[base, 0.25])
  assert gas.gas_excess_k == pytest.approx(5.0)
  assert gas.sun_elevation_deg is None
  both = jax_features.NamedLatexFeatures(np.r_[base, 0.5, -0.2, -0.25])
  assert both.gas_excess_k == pytest.approx(-5.0)
  with pytest.raises(ValueError,
                     match=r'needs 71 features .*, or \[72, 73, 74\] with'):
    jax_features.NamedLatexFeatures(np.zeros(75))


def test_policy_records_its_options_and_a_warm_start_refuses_others(
    tmp_path):
  """A policy records the options it observed with (and their size); one
  trained without them (every shipped policy) reads as 0 and is refused as
  the start of a run that observes them, in one line."""
  shipped = pretrained.load_policy(pretrained.shipped_policy(False))
  assert shipped['config']['sun'] == 0
  assert shipped['config']['gas_temperature'] == 0
  with pytest.raises(ValueError, match='x: config.sun'):
    sac_core.file_config(dict(shipped['config'], sun=2), 'x')
  observation = env_params.observation_of(_OPTIONS['both'] | {
      'wind_memory': 0, 'wind_lookahead': 0})
  learner = types.SimpleNamespace(config=sac_trainer.TrainerConfig())
  state = types.SimpleNamespace(updates=0, network_params={},
                                log_alpha=np.zeros(1))
  bundle = sac_trainer.acting_bundle(learner, state, 0,
                                     observation=observation)
  assert bundle['config']['observation_shape'] == [74]
  assert (bundle['config']['sun'], bundle['config']['gas_temperature']) == (
      1, 1)
  path = str(tmp_path / 'paper.msgpack')
  pretrained.write_policy(shipped, path)
  with pytest.raises(errors.ConfigError,
                     match='latex_observation.sun = 0, this run observes '
                     'with 1'):
    jax_train.warm_start(None, None, path, observation)


@pytest.mark.slow
@pytest.mark.ci  # Network builds (~30 s on 2 busy cores); out of the default.
def test_a_policy_without_the_options_is_refused_in_flight(tmp_path):
  """The jitted trainer's networks take the options' features; the shipped
  policy (trained without them) is refused by `sac_pretrained` under them,
  in one line naming both settings."""
  from ble_latex.agents.sac import agent as sac  # pylint: disable=g-import-not-at-top
  config = sac_trainer.TrainerConfig(num_envs=2, hidden_units=8,
                                     replay_capacity=8)
  _, state = sac_trainer.make_learner(config, jax.random.PRNGKey(0),
                                      num_features=74)
  assert state.replay.obs.shape == (8, 74)
  assert 74 in {np.shape(leaf)[0] for leaf in jax.tree.leaves(
      state.network_params) if np.ndim(leaf) == 2}
  path = pretrained.shipped_policy(False)
  with gin.unlock_config():
    gin.bind_parameter('latex_observation.sun', True)
  try:
    with pytest.raises(ValueError) as refused:
      sac.SACPretrainedAgent(3, (73,), policy_path=path)
  finally:
    gin.clear_config()
  # One line (gin adds the configurable's name on a line of its own).
  message = str(refused.value).splitlines()[0]
  assert message.startswith(f'SAC policy {path}: its config has ')
  assert 'sun=0' in message and 'sun=1' in message


def test_ensemble_refuses_members_of_other_options():
  """Every member of `sac_ensemble` must observe the env's options (their
  features are the env's for every view)."""
  paper = ensemble.view_of(env_params.observation_of(
      {'wind_memory': 0, 'wind_lookahead': 0, 'sun': 0,
       'gas_temperature': 0}))
  sunny = ensemble.view_of(dict(paper, sun=1))
  assert ensemble.views_of([sunny, sunny], sunny)[1] == (0, 0)
  with pytest.raises(errors.ConfigError,
                     match='latex_observation.sun = 1: every member'):
    ensemble.views_of([sunny, paper], sunny)


@pytest.mark.slow
@pytest.mark.ci  # Two env compiles (~40 s); out of the default suite.
def test_every_entry_point_observes_the_options(flight):
  """Gymnasium's id and BLE's gym id, under the gin bindings, observe the
  functional env's 74 features at reset and after a stride."""
  params, _, _ = flight
  both = _with(params, 'both')
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  action = np.array([17_000.0, 1.0, -1.0], np.float32)
  obs0, state = jax.jit(env.reset)(jax.random.PRNGKey(7), both)
  obs1 = jax.jit(env.step_env)(None, state, jnp.asarray(action), both)[0]
  assert obs0.shape == (74,)
  test_observed_winds.assert_entry_points_observe(
      {f'latex_observation.{k}': v for k, v in _OPTIONS['both'].items()}, 7,
      [action], [np.asarray(obs0), np.asarray(obs1)])


@pytest.mark.slow
def test_envs_of_two_observation_sizes_share_a_process():
  """BLE's gym env with the paper's observation, then one with the sun's: the
  process-wide compiled set keeps a layout per output width (it kept the
  first trace's only, and the second env failed to unpack at reset)."""
  import gym  # pylint: disable=g-import-not-at-top
  gin.clear_config()
  try:
    paper = gym.make('LatexBalloon-v0').unwrapped
    assert np.shape(paper.reset(seed=1)) == (jax_features.NUM_FEATURES,)
    with gin.unlock_config():
      gin.bind_parameter('latex_observation.sun', True)
    sun = gym.make('LatexBalloon-v0').unwrapped
    assert np.shape(sun.reset(seed=1)) == (jax_features.NUM_FEATURES + 2,)
    assert np.shape(paper.reset(seed=2)) == (jax_features.NUM_FEATURES,)
  finally:
    gin.clear_config()
