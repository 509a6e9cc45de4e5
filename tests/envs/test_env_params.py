"""ble_latex.envs.env_params: the env's gin bindings, checked (issues 48, 67)."""

import gin
import pytest

from tests.envs import gymnasium_cases as cases


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


_PARAMS_FROM_GIN = '''
import sys
import ble_latex, gin, jax, numpy as np
from ble_latex.envs import env_params

def same(a, b):
  leaves = jax.tree.map(lambda x, y: bool(np.array_equal(x, y)), a, b)
  return (jax.tree.structure(a) == jax.tree.structure(b) and
          all(jax.tree.leaves(leaves)))

light = env_params.params_from_gin()
# Every gin name of the env is the core's own: bound without BLE or gym.
gin.parse_config(['latex_controller.min_vent_mols = 0.3',
                  'latex_launch.sand_kg = 1.5', 'latex_episode.episode_steps = 9',
                  'latex_start.max_start_distance_km = 150.0',
                  'latex_reward.helium_penalty_per_mol = 0.1',
                  'latex_flight.guard_within_stride = False'])
p = env_params.params_from_gin()
assert float(p.flight.min_vent_mols) == np.float32(0.3)
assert (p.flight.initial_sand_kg, p.episode_steps, p.max_start_distance_km,
        p.helium_penalty_per_mol, p.flight.guard_within_stride) == (
            1.5, 9, 150.0, 0.1, False)
heavy = [m for m in ('tensorflow', 'ble_latex.ble.gym_env',
                     'ble_latex.ble.balloon', 'balloon_learning_environment.env.balloon_env')
         if m in sys.modules]
assert not heavy, heavy
gin.clear_config()
import ble_latex.ble.gym_env  # The gin-file import (BLE, TF) changes nothing.
assert same(light, env_params.params_from_gin()), 'defaults differ'
gin.parse_config([
    'latex_episode.episode_steps = 7',
    'latex_start.start_altitude_range_m = (16000.0, 17000.0)',
    'latex_start.max_start_distance_km = 100.0',
    'latex_launch.payload_kg = 2.5',
    'latex_reward.sand_penalty_per_kg = 0.5',
    'latex_reward.reward_dropoff = 0.3',
    'balloon_env.perciatelli_reward_function.reward_dropoff = 0.3',  # Repeats.
])
p = env_params.params_from_gin()
print(p.episode_steps, p.start_altitude_low_m, p.start_altitude_high_m,
      p.max_start_distance_km, float(p.flight.payload_kg),
      p.sand_penalty_per_kg, p.reward_dropoff)
gin.parse_config('latex_reward.sand_penalty_per_kg = -1.0')
try:
  env_params.params_from_gin()
except ValueError as e:
  print('refused:', 'latex_reward.sand_penalty_per_kg' in str(e))
'''


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
def test_params_from_gin_without_the_gym_modules():
  """Unimported configurables read as defaults; imported ones as bound."""
  result = cases.python(_PARAMS_FROM_GIN, timeout=300)
  assert result.returncode == 0, result.stderr[-3000:]
  lines = result.stdout.strip().splitlines()
  assert lines[-2].split() == ['7', '16000.0', '17000.0', '100.0', '2.5',
                               '0.5', '0.3']
  assert lines[-1] == 'refused: True'
