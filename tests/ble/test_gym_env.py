"""LatexBalloon-v0 and LatexBalloonDiscrete-v0: the gym contract."""

import ble_latex  # noqa: F401  (fixes first)
from ble_latex.ble import features as latex_features
from ble_latex.ble import gym_env as env_lib
import gin
import gym
from gym.utils import env_checker
import numpy as np
import pytest

_RNG_ACTIONS = 12


@pytest.fixture(scope='module')
def latex_env():
  return gym.make('LatexBalloon-v0').unwrapped


@pytest.fixture(scope='module')
def discrete_env():
  return gym.make('LatexBalloonDiscrete-v0').unwrapped


def _actions(n: int, seed: int) -> np.ndarray:
  space = env_lib.LatexBalloonEnv.action_space.fget(None)
  rng = np.random.default_rng(seed)
  return rng.uniform(space.low, space.high, size=(n, 3))


def test_gym_make_wraps_the_latex_envs():
  assert isinstance(gym.make('LatexBalloon-v0').unwrapped,
                    env_lib.LatexBalloonEnv)


def test_env_checker_continuous(latex_env):
  env_checker.check_env(latex_env, skip_render_check=True)


def test_env_checker_discrete(discrete_env):
  env_checker.check_env(discrete_env, skip_render_check=True)


def test_spaces(latex_env, discrete_env):
  space = latex_env.action_space
  np.testing.assert_array_equal(space.low, [14000, 1, -1])
  np.testing.assert_array_equal(space.high, [21000, 5, 1])
  assert space.dtype == np.float32
  assert latex_env.observation_space.shape == (latex_features.NUM_FEATURES,)
  assert discrete_env.action_space.n == 3
  assert discrete_env.observation_space.shape == (1099,)


def _rollout(env, seed, actions):
  obs = [env.reset(seed=seed)]
  rewards, infos = [], []
  for a in actions:
    o, r, done, info = env.step(a)
    obs.append(o)
    rewards.append(r)
    infos.append(info)
    if done:
      break
  return np.array(obs), np.array(rewards), infos


def test_same_seed_same_trajectory(latex_env):
  actions = _actions(_RNG_ACTIONS, seed=1)
  obs1, rew1, info1 = _rollout(latex_env, 7, actions)
  obs2, rew2, info2 = _rollout(latex_env, 7, actions)
  np.testing.assert_array_equal(obs1, obs2)
  np.testing.assert_array_equal(rew1, rew2)
  assert [i['distance_km'] for i in info1] == [i['distance_km'] for i in info2]
  obs3, _, _ = _rollout(latex_env, 8, actions)
  assert not np.array_equal(obs1[0], obs3[0])


def test_observation_bounds_and_info_keys(latex_env):
  obs, rewards, infos = _rollout(latex_env, 3, _actions(_RNG_ACTIONS, seed=2))
  assert obs.dtype == np.float32
  assert np.all(obs >= -1.0) and np.all(obs <= 1.0)
  assert np.all(np.isfinite(obs))
  assert np.all(rewards <= 1.0)
  for info in infos:
    assert set(env_lib.INFO_KEYS) <= set(info)
    assert info['controller_decision'] in ('float', 'vent', 'ballast',
                                           'nothing')
    assert info['sand_kg'] >= 0.0 and info['helium_mols'] >= 0.0
  vented = [i['helium_vented_mols'] for i in infos]
  assert vented == sorted(vented)  # Cumulative.


@pytest.mark.parametrize('bad', [
    [np.nan, 1.0, 0.0], [18000.0, np.inf, 0.0], [18000.0, 1.0, -np.inf],
    [13000.0, 1.0, 0.0], [18000.0, 0.5, 0.0], [18000.0, 1.0, 1.5],
    [18000.0, 1.0], 'up'])
def test_bad_action_raises_and_leaves_state(latex_env, bad):
  latex_env.reset(seed=5)
  before = repr(latex_env.arena.get_balloon_state())
  with pytest.raises(ValueError):
    latex_env.step(bad)
  assert repr(latex_env.arena.get_balloon_state()) == before


def test_reward_matches_paper_formula(latex_env):
  _, rewards, infos = _rollout(latex_env, 11, _actions(4, seed=3))
  for r, info in zip(rewards, infos):
    d = info['distance_km']
    expected = 1.0 if d <= 50.0 else 0.4 * 2.0 ** (-(d - 50.0) / 100.0)
    assert r == pytest.approx(expected, rel=1e-6)


def test_full_random_episode_generative_wind(latex_env):
  obs, rewards, infos = _rollout(latex_env, 0, _actions(216, seed=4))
  last = infos[-1]
  assert last['time_limit'] or last['out_of_resources'] or (
      last['envelope_burst'])
  if last['time_limit']:
    assert len(infos) == 216
    assert last['time_elapsed'].total_seconds() == 216 * 20 * 60
  with pytest.raises(RuntimeError):
    latex_env.step([18000.0, 1.0, 1.0])


def test_floating_balloon_survives_three_days():
  env = gym.make('LatexBalloon-v0').unwrapped
  env.reset(seed=2)
  done, steps = False, 0
  while not done:
    _, _, done, info = env.step([17500.0, 1.0, 1.0])
    steps += 1
  assert steps == 216 and info['time_limit']
  assert not info['out_of_resources']
  assert info.get('TimeLimit.truncated')


def test_station_seeker_flies_discrete_env(discrete_env):
  from balloon_learning_environment.utils import run_helpers
  agent = run_helpers.create_agent(
      'station_seeker', discrete_env.action_space.n,
      observation_shape=discrete_env.observation_space.shape)
  obs = discrete_env.reset(seed=0)
  action = agent.begin_episode(obs)
  actions = []
  for _ in range(30):
    obs, reward, done, info = discrete_env.step(action)
    actions.append(int(action))
    assert 0.0 <= reward <= 1.0
    if done:
      break
    action = agent.step(reward, obs)
  assert len(set(actions)) > 1  # It steers, not just floats.
  assert info['helium_vented_mols'] > 0 or info['sand_dropped_kg'] > 0


def test_discrete_action_validation(discrete_env):
  discrete_env.reset(seed=0)
  for bad in (3, -1, 1.5):
    with pytest.raises(ValueError):
      discrete_env.step(bad)


def test_shipped_env_gin_file_parses_and_binds():
  import gin
  from ble_latex import configs
  try:
    gin.parse_config_files_and_bindings(configs.env_gin_files(), [])
    assert gin.query_parameter('latex_episode.episode_steps') == 216
    assert gin.query_parameter('latex_launch.sand_kg') == 2.0
    env = gym.make('LatexBalloon-v0').unwrapped
    assert env.reset(seed=0).shape == (latex_features.NUM_FEATURES,)
  finally:
    gin.clear_config()


def test_bad_gin_binding_is_a_clear_error():
  import gin
  try:
    with pytest.raises(ValueError, match='no_such_param'):
      gin.parse_config('latex_episode.no_such_param = 3')
  finally:
    gin.clear_config()


# -- Refused input: seeds, actions, reward bindings (nothing changes). ----
@pytest.mark.parametrize('seed', [2**64, 2**32, -1, 1.5, True, '3'])
def test_bad_seed_is_refused_before_anything_changes(latex_env, seed):
  action = [17000.0, 2.0, -1.0]
  latex_env.reset(seed=3)
  latex_env.step(action)
  before = repr(latex_env.arena.get_balloon_state())
  steps = int(latex_env.arena.driver.state.steps)
  with pytest.raises(ValueError, match='seed'):
    latex_env.reset(seed=seed)
  assert int(latex_env.arena.driver.state.steps) == steps
  assert repr(latex_env.arena.get_balloon_state()) == before


def test_largest_seed_is_accepted(latex_env):
  assert latex_env.reset(seed=2**32 - 1).shape == (71,)
  assert latex_env.reset(seed=np.uint32(7)).shape == (71,)


@pytest.mark.parametrize('bad', [
    np.array([[18000.0, 1.0, 0.0]]), np.array([[18000.0], [1.0], [0.0]]),
    [[18000.0, 1.0, 0.0]], np.array(['18000', '1', '0']), [18000.0, None, 0.0],
    None])
def test_wrong_shape_or_type_actions_are_refused(latex_env, bad):
  latex_env.reset(seed=5)
  before = repr(latex_env.arena.get_balloon_state())
  with pytest.raises(ValueError, match='action'):
    latex_env.step(bad)
  assert repr(latex_env.arena.get_balloon_state()) == before


@pytest.mark.parametrize('bad', [None, [1], 1e30, float('nan'), float('inf'),
                                 1.5, 3, -1, True, '1', np.array([2])])
def test_bad_discrete_actions_are_value_errors(discrete_env, bad):
  discrete_env.reset(seed=0)
  before = repr(discrete_env.arena.get_balloon_state())
  with pytest.raises(ValueError, match='0 \\(DOWN\\), 1 \\(STAY\\) or 2'):
    discrete_env.step(bad)
  assert repr(discrete_env.arena.get_balloon_state()) == before


def test_good_discrete_actions(discrete_env):
  discrete_env.reset(seed=0)
  for action in (0, 1, 2, np.int64(1), 2.0, np.array(1)):
    discrete_env.step(action)


@pytest.mark.parametrize('binding,value', [
    ('latex_reward.helium_penalty_per_mol', -1.0),
    ('latex_reward.sand_penalty_per_kg', float('nan')),
    ('latex_reward.sand_penalty_per_kg', float('inf')),
    ('perciatelli_reward_function.reward_halflife', 0.0),
    ('perciatelli_reward_function.reward_dropoff', 1.5),
    ('latex_episode.station_keeping_radius_km', -5.0),
])
def test_bad_reward_bindings_are_refused_at_construction(binding, value):
  try:
    gin.bind_parameter(binding, value)  # Gin has no NaN literal.
    with pytest.raises(ValueError, match=binding.replace('.', '\\.')):
      env_lib.LatexBalloonEnv()
  finally:
    gin.clear_config()


def test_bad_reward_binding_from_gin_text():
  try:
    gin.parse_config('latex_reward.helium_penalty_per_mol = -0.5')
    with pytest.raises(ValueError, match='helium_penalty_per_mol'):
      gym.make('LatexBalloon-v0')
  finally:
    gin.clear_config()
