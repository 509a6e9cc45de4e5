"""ble_latex.envs.env_params: the env's gin bindings, checked (issues 48, 67)."""

import gin
import pytest


@pytest.mark.parametrize('binding', [
    'latex_reward.sand_penalty_per_kg = 1e39',
    'latex_flight.superheat_day_k = 1e39',
    'latex_launch.payload_kg = -1e39',
])
def test_env_bindings_beyond_float32_are_refused(binding):
  from ble_latex.envs import env_params  # pylint: disable=g-import-not-at-top
  gin.clear_config()
  try:
    gin.parse_config(binding)
    with pytest.raises(ValueError, match=r'must be a finite number'):
      env_params.params_from_gin()
  finally:
    gin.clear_config()


@pytest.mark.parametrize('binding', [
    'latex_reward.reward_tanh_scale_km = 1e-40',
    'latex_reward.reward_halflife_km = 1e-45',
    'latex_episode.station_keeping_radius_km = 1e-40',
])
def test_reward_bindings_that_are_0_in_float32_are_refused(binding):
  from ble_latex.envs import env_params  # pylint: disable=g-import-not-at-top
  gin.clear_config()
  try:
    gin.parse_config(binding)
    with pytest.raises(ValueError, match=binding.split(' ')[0]):
      env_params.params_from_gin()
  finally:
    gin.clear_config()
