"""The follow-up paper's tanh reward: a gin option of the core's reward, off.

Saunders et al. 2024 (arXiv 2403.10784) shape the reward inside the station
circle with a tanh of the distance (`jax_features.tanh_inside`); the paper's
(2023) flat Perciatelli reward stays the default and exact.
"""

import gin
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex import errors
from ble_latex import gin_values
from ble_latex.envs import env_params
from ble_latex.envs import jax_env
from ble_latex.envs import jax_features


@pytest.fixture(autouse=True)
def _clear_gin():
  gin.clear_config()
  yield
  gin.clear_config()


DISTANCES_KM = np.array([0.0, 5.0, 20.0, 40.0, 49.9, 50.0, 50.1, 80.0, 300.0])


def test_off_by_default_is_the_flat_paper_reward():
  flat = jax_features.reward(DISTANCES_KM)
  off = jax_features.reward(DISTANCES_KM, tanh_scale_km=0.0)
  np.testing.assert_array_equal(np.asarray(off), np.asarray(flat))
  inside = DISTANCES_KM <= 50.0
  assert np.all(np.asarray(flat)[inside] == 1.0)
  assert env_params.params_from_gin().reward_tanh_scale_km == 0.0


def test_tanh_falls_from_one_to_the_dropoff_and_keeps_the_outside():
  flat = np.asarray(jax_features.reward(DISTANCES_KM))
  shaped = np.asarray(jax_features.reward(DISTANCES_KM, tanh_scale_km=25.0))
  inside = DISTANCES_KM <= 50.0
  assert shaped[0] == pytest.approx(1.0)
  assert shaped[5] == pytest.approx(0.4, abs=1e-6)  # Continuous at the edge.
  assert np.all(np.diff(shaped[inside]) < 0)  # Pulls towards the centre.
  np.testing.assert_array_equal(shaped[~inside], flat[~inside])
  # r(d) = 1 - (1 - c) tanh(d / w) / tanh(rho / w) at d = 25 km, w = 25 km.
  middle = float(jax_features.reward(25.0, tanh_scale_km=25.0))
  assert middle == pytest.approx(1 - 0.6 * np.tanh(1.0) / np.tanh(2.0),
                                 rel=1e-6)


def test_off_has_finite_gradients():
  grad = jax.grad(lambda d: jax_features.reward(d))(jnp.float32(20.0))
  assert np.isfinite(float(grad)) and float(grad) == 0.0


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
def test_the_gin_option_reaches_the_env_reward():
  """The functional env's step rewards with the bound shape."""
  gin.parse_config(['latex_start.max_start_distance_km = 10.0'])
  flat = env_params.params_from_gin()
  gin.parse_config(['latex_reward.reward_tanh_scale_km = 25.0'])
  shaped = env_params.params_from_gin()
  assert shaped.reward_tanh_scale_km == 25.0
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  step = jax.jit(env.step_env)
  _, state = jax.jit(env.reset)(jax.random.PRNGKey(3), flat)
  hold = jnp.array([17_500.0, 2.0, 1.0])
  _, _, r_flat, _, info = step(None, state, hold, flat)
  _, _, r_shaped, _, _ = step(None, state, hold, shaped)
  distance = float(info['distance_km'])
  assert distance < 50.0
  assert float(r_flat) == 1.0
  assert float(r_shaped) == pytest.approx(
      float(jax_features.reward(distance, tanh_scale_km=25.0)), rel=1e-5)
  assert float(r_shaped) < 1.0


@pytest.mark.parametrize('value', ['-1.0', "'wide'", 'None'])
def test_bad_scale_is_one_line_naming_the_binding(value):
  gin.parse_config([f'latex_reward.reward_tanh_scale_km = {value}'])
  with pytest.raises(errors.ConfigError,
                     match='latex_reward.reward_tanh_scale_km'):
    env_params.params_from_gin()


def test_tanh_scale_0_still_switches_the_reward_off():
  gin_values.check_reward_values({'reward_tanh_scale_km': 0.0})
