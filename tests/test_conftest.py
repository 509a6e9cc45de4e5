"""The suite's shared setup (tests/conftest.py) keeps test modules apart."""

import gin

_BINDS = '''
import gin
import ble_latex.envs.env_params  # noqa: F401  (registers latex_episode)


def test_binds():
  gin.bind_parameter('latex_episode.episode_steps', 7)
  assert gin.query_parameter('latex_episode.episode_steps') == 7
'''

_READS = '''
import gin
import pytest


def test_finds_nothing_bound():
  with pytest.raises(ValueError):
    gin.query_parameter('latex_episode.episode_steps')
'''


def test_a_gin_binding_does_not_reach_the_next_module(pytester):
  """One worker runs many modules: a module's binding is cleared after it."""
  pytester.makeconftest('from tests.conftest import _fresh_gin  # noqa: F401')
  pytester.makepyfile(test_a_binds=_BINDS, test_b_reads=_READS)
  result = pytester.runpytest_inprocess('-p', 'no:cacheprovider', '-p',
                                        'no:xdist', '-q')
  result.assert_outcomes(passed=2)
  # Nor does it stay in this process.
  try:
    gin.query_parameter('latex_episode.episode_steps')
  except ValueError:
    return
  raise AssertionError('the inner session left a gin binding behind')
