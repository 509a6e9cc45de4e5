"""The Gymnasium ids' registration (`envs/gymnasium_registration.py`): cheap
imports, conventional defaults, the spec's time limit."""

import gymnasium
import numpy as np
import pytest

from ble_latex.envs import gymnasium_registration

from tests.envs import gymnasium_cases as cases


# -- Registration. ------------------------------------------------------------
@pytest.mark.parametrize('order', ['ble_latex first', 'gymnasium first'])
def test_import_registers_ids_cheaply(order):
  imports = ('import ble_latex, sys\n'
             "assert 'gymnasium' not in sys.modules, 'imported gymnasium'\n"
             'import gymnasium\n' if order == 'ble_latex first' else
             'import gymnasium, ble_latex, sys\n')
  code = imports + (
      "print(sorted(k for k in gymnasium.registry if k.startswith('ble_latex/'"
      ')))\n'
      "heavy = [m for m in ('gym', 'jax', 'tensorflow', 'balloon_learning_"
      "environment') if m in sys.modules]\n"
      "assert not heavy, heavy\n"
      'gymnasium.register_envs(ble_latex)\n')
  result = cases.python(code, timeout=60)
  assert result.returncode == 0, result.stderr
  assert result.stdout.strip() == str(sorted(gymnasium_registration.ENV_IDS))


# -- Conventional defaults of the ids (issue 31). ---------------------------
def test_ids_default_to_normalized_actions_and_a_216_step_spec():
  env = gymnasium.make(cases.ID)
  assert env.action_space == gymnasium.spaces.Box(-1, 1, (3,), np.float32)
  assert env.unwrapped.normalize_actions
  assert env.spec.max_episode_steps == 216
  assert env.spec.kwargs == {'normalize_actions': True}
  assert gymnasium.spec(cases.DISCRETE_ID).max_episode_steps == 216
  raw = gymnasium.make(cases.ID, normalize_actions=False)
  assert raw.action_space.low[0] == 14000.0
  # CleanRL's form: the module is imported by gymnasium itself.
  assert gymnasium.make(f'ble_latex:{cases.ID}').spec.id == cases.ID


@pytest.mark.slow
@pytest.mark.ci
def test_spec_time_limit_ends_with_the_core_not_twice():
  """make()'s TimeLimit(216) and the core's 216 strides end one episode."""
  env = gymnasium.make(cases.ID, episode_steps=3)  # The core's own limit.
  assert env.spec.max_episode_steps == 216
  env.reset(seed=1)
  ends = [env.step(np.zeros(3, np.float32))[2:4] for _ in range(3)]
  assert ends == [(False, False), (False, False), (False, True)]
  env.reset(seed=1)  # The wrapper's count restarts with the core's.
  assert env.step(np.zeros(3, np.float32))[2:4] == (False, False)
  # make_vec hands the spec's limit to the batched core (no wrapper).
  envs = gymnasium.make_vec(cases.ID, num_envs=2, max_episode_steps=2)
  assert envs.unwrapped.params.episode_steps == 2
  envs.reset(seed=0)
  envs.step(np.zeros((2, 3), np.float32))
  assert np.all(envs.step(np.zeros((2, 3), np.float32))[3])
  envs.close()
