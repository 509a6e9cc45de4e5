"""The Gymnasium envs the tests of tests/envs/ share, one per test module."""

import gymnasium
import pytest

from tests.envs import gymnasium_cases as cases


@pytest.fixture(scope='module')
def env():
  e = gymnasium.make(cases.ID, normalize_actions=False)
  yield e
  e.close()


@pytest.fixture(scope='module')
def discrete_env():
  e = gymnasium.make(cases.DISCRETE_ID)
  yield e
  e.close()
