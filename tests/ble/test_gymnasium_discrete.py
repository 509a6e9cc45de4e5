"""ble_latex/LatexBalloonDiscrete-v0's vector env (`ble/gymnasium_discrete.py`)."""

import gymnasium
import numpy as np
import pytest

from tests.envs import gymnasium_cases as cases


def test_discrete_make_vec_checks_every_action_before_stepping_any():
  """A bad action for balloon 1 leaves balloon 0 unstepped (was stepped)."""
  envs = gymnasium.make_vec(cases.DISCRETE_ID, num_envs=2)
  try:
    envs.reset(seed=0)
    inner = [e.unwrapped.gym_env for e in envs.envs]
    states = [e.arena.driver.state for e in inner]
    for bad in ([1, 5], [1, 1.5], [None, 1]):
      with pytest.raises(ValueError, match=r'^actions\[\d\]: action must be 0'):
        envs.step(np.array(bad, dtype=object) if None in bad else
                  np.array(bad))
      assert [int(e.arena.driver.state.steps) for e in inner] == [0, 0]
      assert all(e.arena.driver.state is s for e, s in zip(inner, states))
    envs.step(np.array([1, 2]))
    assert [int(e.arena.driver.state.steps) for e in inner] == [1, 1]
  finally:
    envs.close()


def test_discrete_make_vec_takes_gymnasiums_seeds():
  """An int (NumPy's too) or one seed or None per balloon (issue 48 item 23);
  each checked by the single env's seed rule."""
  envs = gymnasium.make_vec(cases.DISCRETE_ID, num_envs=2)
  try:
    by_list, _ = envs.reset(seed=[8, 3])
    by_int, _ = envs.reset(seed=np.int64(3))
    np.testing.assert_array_equal(by_list[1], by_int[0])
    envs.reset(seed=[None, 4])
    for bad, match in (([1], 'one seed per balloon'),
                       ([1, 2, 3], 'one seed per balloon'),
                       ([1, -1], r'seed must be in \[0, 2\*\*32\)'),
                       ([1, 1.5], 'seed must be None or an int'),
                       (True, 'seed must be None or an int')):
      with pytest.raises(ValueError, match=match):
        envs.reset(seed=bad)
  finally:
    envs.close()
