"""The SAC update and hyperparameters both trainers share (`agents/sac/core.py`)."""

import dataclasses
import inspect

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex.agents.sac import agent as sac
from ble_latex.agents.sac import core as sac_core
from ble_latex.agents.sac import networks
from ble_latex.agents.sac import trainer as sac_trainer


@pytest.mark.parametrize('terminal_fraction,target_entropy', [(0.0, 0.0),
                                                             (0.5, -3.0)])
def test_batched_update_equals_dopamines_train(terminal_fraction,
                                               target_entropy):
  """`sac_core.update` computes Dopamine's `sac_agent.train` (same losses)."""
  from dopamine.jax.agents.sac import sac_agent  # pylint: disable=g-import-not-at-top
  network_def = networks.make_network(3, 2, 32)
  key = jax.random.PRNGKey(3)
  k = jax.random.split(key, 8)
  batch = 16
  states = jax.random.normal(k[0], (batch, 71))
  next_states = jax.random.normal(k[1], (batch, 71))
  actions = jax.random.uniform(k[2], (batch, 3), minval=-1, maxval=1)
  rewards = jax.random.uniform(k[3], (batch,))
  terminals = (jax.random.uniform(k[4], (batch,)) < terminal_fraction
               ).astype(jnp.float32)
  params = network_def.init(k[5], states[0], k[5])
  # Targets differ from the online network, as after some soft updates.
  target = jax.tree.map(lambda p: p * 0.9,
                        network_def.init(k[6], states[0], k[6]))
  optimizer, alpha_optimizer = sac_core.make_optimizers(params, 1e-3, 2e-3,
                                                        3e-3)
  log_alpha = jnp.array([-0.3])
  args = (network_def, optimizer, alpha_optimizer, optimizer.init(params),
          alpha_optimizer.init(log_alpha), params, target, log_alpha, k[7],
          states, actions, next_states, rewards, terminals, 0.99,
          target_entropy, 1.5)
  ours = sac_core.update(*args)
  theirs = sac_agent.train(*args)
  assert set(ours) == set(theirs)
  for name in ('network_params', 'log_alpha'):
    for a, b in zip(jax.tree_util.tree_leaves(ours[name]),
                    jax.tree_util.tree_leaves(theirs[name])):
      np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6, err_msg=name)
  for name in theirs:
    if name.startswith(('Losses', 'Values')):
      np.testing.assert_allclose(np.mean(ours[name]), np.mean(theirs[name]),
                                 rtol=1e-5, atol=1e-6, err_msg=name)
  # The update moved the parameters (so the comparison is not vacuous).
  moved = [np.max(np.abs(a - b)) for a, b in zip(
      jax.tree_util.tree_leaves(ours['network_params']),
      jax.tree_util.tree_leaves(params))]
  assert min(moved) > 0


def test_both_trainers_default_to_the_one_hyperparameter_record():
  agent_defaults = inspect.signature(sac.SACAgent.__init__).parameters
  trainer_defaults = {f.name: f.default for f in
                      dataclasses.fields(sac_trainer.TrainerConfig)}
  for name in sac_core.SAC_HYPERPARAMETERS:
    value = getattr(sac_core.SAC_DEFAULTS, name)
    assert agent_defaults[name].default == value, name
    assert trainer_defaults[name] == value, name
