"""BLE's own environment and agents still work with the plugin installed."""

import subprocess
import sys

import ble_latex  # noqa: F401  (fixes first)
import gym
import numpy as np
import pytest


def test_ble_env_steps_via_gym_make():
  env = gym.make('BalloonLearningEnvironment-v0')
  obs = env.reset(seed=0)
  assert obs.shape == env.observation_space.shape
  for action in (0, 1, 2):
    obs, reward, done, info = env.step(action)
    assert np.all(np.isfinite(obs)) and 0.0 <= reward <= 1.0
    assert not done and 'time_elapsed' in info


def test_plain_import_gym_registers_all_envs_in_fresh_process():
  code = ('import gym\n'
          'from gym.envs import registration\n'
          'print(sorted(k for k in registration.registry if "Balloon" in k))')
  out = subprocess.run([sys.executable, '-c', code], capture_output=True,
                       text=True, timeout=120)
  assert out.returncode == 0, out.stderr[-2000:]
  assert out.stdout.strip().splitlines()[-1] == (
      "['BalloonLearningEnvironment-v0', 'LatexBalloon-v0', "
      "'LatexBalloonDiscrete-v0']")


def _station_seeker_micro_eval_reward() -> float:
  from balloon_learning_environment.eval import eval_lib
  from balloon_learning_environment.eval import suites
  from balloon_learning_environment.utils import run_helpers
  env = gym.make('BalloonLearningEnvironment-v0').unwrapped
  agent = run_helpers.create_agent(
      'station_seeker', env.action_space.n,
      observation_shape=env.observation_space.shape)
  result = eval_lib.eval_agent(agent, env, suites.get_eval_suite('micro_eval'))
  return result[0].cumulative_reward


@pytest.mark.slow
@pytest.mark.ci
def test_station_seeker_micro_eval_matches_old_stack():
  # BLE 1.0.1's published stack (old SciPy interp2d, old jax PRNG) gives
  # 144.573 for seed 0; a wrong ACS table order gave 229.7 here. One run
  # (960 BLE steps): agreeing with a recorded value also shows the run is
  # deterministic, so a second run would add ~17 s and nothing else.
  assert _station_seeker_micro_eval_reward() == pytest.approx(144.573,
                                                              abs=1e-3)
