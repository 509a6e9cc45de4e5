"""The station radius has one home: one binding moves every reader of it.

`latex_episode.station_keeping_radius_km` -> `EnvParams.radius_km`, read by
the core's reward, the jitted trainer's score, the metrics of BLE's gym env
and the Gymnasium env's drawn circle.
"""

import gin
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex import errors
from ble_latex.agents.sac import trainer as sac_trainer
from ble_latex.envs import env_params
from ble_latex.envs import gymnasium_render
from ble_latex.envs import jax_env
from ble_latex.envs import jax_features

RADIUS_KM = 20.0


@pytest.fixture(name='bound')
def fixture_bound():
  gin.clear_config()
  gin.parse_config(
      f'latex_episode.station_keeping_radius_km = {RADIUS_KM}')
  yield
  gin.clear_config()


@pytest.mark.slow
@pytest.mark.ci
def test_one_binding_moves_reward_score_metrics_and_drawing(bound,
                                                            monkeypatch):
  del bound
  params = env_params.params_from_gin()
  assert params.radius_km == RADIUS_KM

  # The core's reward: 1 within 20 km, BLE's decaying cliff beyond it.
  reward = lambda d: float(jax_features.reward(  # pylint: disable=g-long-lambda
      jnp.float32(d), params.radius_km, params.reward_dropoff,
      params.reward_halflife_km, 0.0, 0.0, 0.0, 0.0))
  assert reward(19.0) == 1.0
  assert reward(30.0) == pytest.approx(0.4 * 2 ** (-10.0 / 100.0), rel=1e-5)

  # The jitted trainer's score counts steps within the params' radius.
  config = sac_trainer.TrainerConfig(num_envs=2, hidden_units=8)
  learner, state = sac_trainer.make_learner(config, jax.random.PRNGKey(0))
  seeds = jnp.arange(2, dtype=jnp.int32)
  env = jax_env.LatexBalloonJaxEnv()
  wide = sac_trainer.validate(learner, env, state.network_params, seeds, 2,
                              params.replace(radius_km=1e4))
  narrow = sac_trainer.validate(learner, env, state.network_params, seeds, 2,
                                params.replace(radius_km=1e-3))
  assert np.asarray(wide['within_steps']).tolist() == [2, 2]
  assert np.asarray(narrow['within_steps']).tolist() == [0, 0]

  # BLE's gym env (its metrics' radius, the core's reward) and the
  # Gymnasium env (the circle it draws) read the same binding.
  import gymnasium  # pylint: disable=g-import-not-at-top
  from ble_latex.ble import gym_env  # pylint: disable=g-import-not-at-top
  ble_env = gym_env.LatexBalloonEnv(seed=0)
  assert ble_env.radius.kilometers == pytest.approx(RADIUS_KM)
  assert ble_env.arena.params.radius_km == RADIUS_KM
  drawn = []
  monkeypatch.setattr(gymnasium_render, 'draw_flight',
                      lambda figure, path, radius: drawn.append(radius))
  monkeypatch.setattr(gymnasium_render, 'figure_rgb', lambda figure: None)
  # Raw actions, as BLE's env: the step its reset compiles ahead is the
  # program BLE's env compiled (a cache read, not a second compile).
  env = gymnasium.make('ble_latex/LatexBalloon-v0', normalize_actions=False,
                       render_mode='rgb_array').unwrapped
  assert env.params.radius_km == RADIUS_KM
  env.reset(seed=0)
  env.render()
  assert drawn == [RADIUS_KM]


def test_the_keyword_moves_the_reward_too():
  import gymnasium  # pylint: disable=g-import-not-at-top
  env = gymnasium.make('ble_latex/LatexBalloon-v0',
                       station_keeping_radius_km=RADIUS_KM).unwrapped
  assert env.params.radius_km == RADIUS_KM


def test_bles_reward_radius_may_only_repeat_it():
  env_params.check_one_radius(50.0, 50.0)
  with pytest.raises(errors.ConfigError, match='the station radius has one '
                     'home, bind latex_episode.station_keeping_radius_km'):
    env_params.check_one_radius(50.0, 30.0)
