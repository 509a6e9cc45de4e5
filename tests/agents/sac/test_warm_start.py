"""The jitted SAC trainer started from a policy file (`init_policy`) and its
critic-only warm-up (`actor_warmup_updates`), issue 47."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex import errors
from ble_latex.agents.sac import core as sac_core
from ble_latex.agents.sac import pretrained
from ble_latex.agents.sac import trainer as sac_trainer
from ble_latex.envs import env_params
from ble_latex.run import jax_train

CONFIG = dict(num_envs=2, updates_per_step=1, batch_size=8,
              min_replay_history=0, replay_capacity=32, hidden_units=16)
# The paper's observation, every setting 0.
_PAPER = {name: 0 for name in env_params.OBSERVATION_FIELDS}


def _filled(config):
  """A learner and a fresh state whose replay holds 32 random transitions."""
  learner, state = sac_trainer.make_learner(config, jax.random.PRNGKey(0))
  keys = jax.random.split(jax.random.PRNGKey(1), 4)
  r = state.replay
  replay = r.replace(
      obs=jax.random.uniform(keys[0], r.obs.shape, minval=-1.0),
      action=jax.random.uniform(keys[1], r.action.shape, minval=-1.0),
      reward=jax.random.uniform(keys[2], r.reward.shape),
      next_obs=jax.random.uniform(keys[3], r.next_obs.shape, minval=-1.0),
      size=jnp.int32(32))
  return learner, state.replace(replay=replay)


def _split(params):
  labels = sac_core.param_labels(params)
  leaves = lambda which: [np.asarray(p) for l, p in zip(
      jax.tree.leaves(labels), jax.tree.leaves(params)) if l == which]
  return leaves('actor'), leaves('critic')


@pytest.mark.slow
@pytest.mark.ci  # A SAC update compile (~5-10 s); out of the default suite.
def test_warmup_updates_train_the_critics_only():
  """For the first `actor_warmup_updates` updates the actor, its Adam state
  and the temperature stay; the critics learn. Then the actor learns too."""
  config = sac_trainer.TrainerConfig(**CONFIG, actor_warmup_updates=3)
  learner, state = _filled(config)
  update = jax.jit(lambda s, k: sac_trainer._update(learner, s, k)[0])  # pylint: disable=protected-access
  actor0, critic0 = _split(state.network_params)
  for i in range(3):
    state = update(state, jax.random.PRNGKey(10 + i))
  actor, critic = _split(state.network_params)
  for a, b in zip(actor, actor0):
    np.testing.assert_array_equal(a, b)
  assert any(not np.array_equal(a, b) for a, b in zip(critic, critic0))
  np.testing.assert_array_equal(state.log_alpha, jnp.zeros(1))
  for leaf in jax.tree.leaves(state.optimizer_state.inner_states['actor']):
    if leaf.dtype.kind == 'f':
      assert not np.any(np.asarray(leaf)), 'actor Adam moments moved'
  state = update(state, jax.random.PRNGKey(20))
  actor, _ = _split(state.network_params)
  assert any(not np.array_equal(a, b) for a, b in zip(actor, actor0))
  assert float(state.log_alpha[0]) != 0.0


def test_warm_start_takes_the_file_networks_and_temperature(tmp_path):
  """A fresh state from a policy file: its actor, critics (targets equal),
  log alpha; networks of another size are refused, naming the file."""
  config = sac_trainer.TrainerConfig(**CONFIG)
  learner, trained = _filled(config)
  trained = trained.replace(log_alpha=jnp.array([-1.25]))
  path = str(tmp_path / 'p.msgpack')
  pretrained.write_policy(pretrained.policy_from_bundle(
      sac_trainer.acting_bundle(learner, trained, 7, observation=_PAPER),
      'test'),
      path)
  _, fresh = sac_trainer.make_learner(config, jax.random.PRNGKey(99))
  started = jax_train.warm_start(learner, fresh, path, _PAPER)
  for a, b, c in zip(jax.tree.leaves(started.network_params),
                     jax.tree.leaves(trained.network_params),
                     jax.tree.leaves(started.target_params)):
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(c, b)
  assert float(started.log_alpha[0]) == -1.25
  assert int(started.updates) == 0
  other = sac_trainer.TrainerConfig(**{**CONFIG, 'hidden_units': 8})
  small_learner, small = sac_trainer.make_learner(other, jax.random.PRNGKey(0))
  with pytest.raises(ValueError, match='init_policy.*network_params'):
    jax_train.warm_start(small_learner, small, path, _PAPER)
  with pytest.raises(errors.ConfigError,
                     match='latex_observation.wind_memory = 0, this run '
                     'observes with 16'):
    jax_train.warm_start(learner, fresh, path, dict(_PAPER, wind_memory=16))
  with pytest.raises(errors.ConfigError,
                     match='latex_observation.wind_lookahead = 0, this run '
                     'observes with 12'):
    jax_train.warm_start(learner, fresh, path,
                         dict(_PAPER, wind_lookahead=12))


@pytest.mark.parametrize('name,value', [('init_policy', 3),
                                        ('actor_warmup_updates', -1),
                                        ('actor_warmup_updates', 0.5)])
def test_bad_warm_start_settings_name_the_binding(name, value):
  with pytest.raises(errors.ConfigError,
                     match=f'sac_trainer_config.{name}'):
    sac_trainer.TrainerConfig(**{name: value})
