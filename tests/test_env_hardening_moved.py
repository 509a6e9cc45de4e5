"""Env hardening tests from tests/test_hardening.py, to be placed by module.

The gym env (ble_latex/envs/gym_env.py) refuses bad seeds, actions and reward
bindings before anything changes.
"""

import ble_latex  # noqa: F401  pylint: disable=unused-import
from ble_latex.ble import gym_env as env_lib
import gin
import gym
import numpy as np
import pytest


@pytest.fixture(scope='module')
def latex_env():
  return gym.make('LatexBalloon-v0').unwrapped


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


@pytest.fixture(scope='module')
def discrete_env():
  return gym.make('LatexBalloonDiscrete-v0').unwrapped


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
    ('perciatelli_reward_function.station_keeping_radius_km', -5.0),
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
