"""The gym env flies any BLE `WindField` on the core (host callbacks).

The default wind (BLE's generative field drawn inside the core,
`CoreGenerativeWindField`) and BLE's own `GenerativeWindField` object
queried through `jax.pure_callback` are the same field from the same key:
the flights agree to float32 rounding of the winds.
"""

from balloon_learning_environment.env import generative_wind_field
from balloon_learning_environment.utils import units
import datetime as dt
import numpy as np
import pytest

import ble_latex  # noqa: F401  (compat fixes first)
from ble_latex.ble import gym_env as env_lib
from ble_latex.ble import wind as ble_wind

_ACTIONS = [np.array([a0, 1.0, a2]) for a0, a2 in (
    (18_000.0, -1.0), (18_000.0, 1.0), (15_500.0, -1.0), (16_000.0, 1.0),
    (19_000.0, -1.0), (17_000.0, -1.0))]


def _fly(env, seed):
  obs = [env.reset(seed=seed)]
  states = []
  for action in _ACTIONS:
    o, _, done, info = env.step(action)
    s = env.arena.get_balloon_state()
    obs.append(o)
    states.append([s.x.meters, s.y.meters, s.altitude_m, info['distance_km']])
    if done:
      break
  return np.stack(obs), np.array(states)


@pytest.mark.slow
@pytest.mark.ci
def test_ble_generative_field_object_flies_like_the_core_field():
  core = env_lib.LatexBalloonEnv(seed=0)
  assert isinstance(core.arena._wind_field,  # pylint: disable=protected-access
                    ble_wind.CoreGenerativeWindField)
  ble = env_lib.LatexBalloonEnv(
      seed=0, wind_field_factory=generative_wind_field.GenerativeWindField)
  for seed in (0, 3):
    core_obs, core_states = _fly(core, seed)
    ble_obs, ble_states = _fly(ble, seed)
    np.testing.assert_allclose(ble_obs, core_obs, atol=1e-4, rtol=0)
    # x, y [m], altitude [m], distance [km] after 2 hours.
    np.testing.assert_allclose(ble_states[:, :3], core_states[:, :3],
                               atol=2.0, rtol=0)


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
def test_core_field_answers_bles_queries_like_bles_field():
  core = env_lib.LatexBalloonEnv(seed=0)
  core.reset(seed=4)
  field = core.arena.get_simulator_state().wind_field
  ble = generative_wind_field.GenerativeWindField()
  ble.reset(_wind_key(core), dt.datetime(2022, 1, 1))
  for x_km, y_km, p, hours in ((0.0, 0.0, 8000.0, 0.0),
                               (120.0, -40.0, 11000.0, 5.5),
                               (-300.0, 250.0, 6000.0, 30.0)):
    args = (units.Distance(km=x_km), units.Distance(km=y_km), p,
            dt.timedelta(hours=hours))
    for method in ('get_forecast', 'get_ground_truth'):
      got = getattr(field, method)(*args)
      expected = getattr(ble, method)(*args)
      assert got.u.meters_per_second == pytest.approx(
          expected.u.meters_per_second, abs=1e-4), method
      assert got.v.meters_per_second == pytest.approx(
          expected.v.meters_per_second, abs=1e-4), method


def _wind_key(env):
  """The wind key BLE's arena gives `WindField.reset` for env's flight."""
  import jax  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import jax_env  # pylint: disable=g-import-not-at-top
  key = jax_env.arena_key(jax.random.PRNGKey(4))
  _, keys = jax.jit(jax_env.LatexBalloonJaxEnv().draw)(key, env.arena.params)
  return keys['wind']


def test_unattached_core_field_says_what_to_do():
  with pytest.raises(RuntimeError, match='reset the env'):
    ble_wind.CoreGenerativeWindField().get_forecast(
        units.Distance(m=0.0), units.Distance(m=0.0), 8000.0,
        dt.timedelta(0))
