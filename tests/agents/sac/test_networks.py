"""SAC critics (ble_latex/agents/sac/networks.py) in the update, agent and
trainer."""

import ble_latex  # noqa: F401  pylint: disable=unused-import
from dopamine.jax import continuous_networks
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex.agents.sac import agent as sac
from ble_latex.agents.sac import core as sac_core
from ble_latex.agents.sac import networks
from ble_latex.agents.sac import pretrained
from ble_latex.agents.sac import trainer as sac_trainer
from ble_latex.envs import jax_env
from ble_latex.run import jax_train

BATCH = 16


def _batch(seed=0):
  k = jax.random.split(jax.random.PRNGKey(seed), 6)
  return dict(
      states=jax.random.normal(k[0], (BATCH, 71)),
      actions=jax.random.uniform(k[1], (BATCH, 3), minval=-1, maxval=1),
      next_states=jax.random.normal(k[2], (BATCH, 71)) + 0.5,
      rewards=jax.random.uniform(k[3], (BATCH,)),
      terminals=jnp.zeros((BATCH,)), key=k[4])


def _update(network_def, params, target, batch):
  optimizer, alpha_optimizer = sac_core.make_optimizers(params, 1e-3, 1e-3,
                                                        1e-3)
  log_alpha = jnp.array([-0.3])
  return sac_core.update(
      network_def, optimizer, alpha_optimizer, optimizer.init(params),
      alpha_optimizer.init(log_alpha), params, target, log_alpha,
      batch['key'], batch['states'], batch['actions'], batch['next_states'],
      batch['rewards'], batch['terminals'], 0.99, 0.0, 1.0)


def _init(critic, seed=0):
  network_def = networks.make_network(3, 2, 32, critic)
  key = jax.random.PRNGKey(seed)
  return network_def, network_def.init(key, jnp.zeros(71), key)


@pytest.mark.parametrize('limits', [
    ((-1.0,) * 3, (1.0,) * 3),  # `make_network`'s, the agent's.
    ((14000.0, 1.0, -1.0), (21000.0, 5.0, 1.0)),
    None])
def test_mlp_network_is_dopamines_sac_network(limits):
  """Dopamine's SACNetwork's variables and outputs, bit for bit.

  So policies and checkpoints written with Dopamine's network load and act
  unchanged; the actor's log-probability is TFP's, also where tanh
  saturates (a final layer scaled up).
  """
  ours = networks.LatexSACNetwork((3,), 2, 32, limits)
  theirs = continuous_networks.SACNetwork((3,), 2, 32, limits)
  key = jax.random.PRNGKey(0)
  params = ours.init(key, jnp.zeros(71), key)
  expected = theirs.init(key, jnp.zeros(71), key)
  assert jax.tree_util.tree_structure(params) == (
      jax.tree_util.tree_structure(expected))
  for a, b in zip(jax.tree_util.tree_leaves(params),
                  jax.tree_util.tree_leaves(expected)):
    np.testing.assert_array_equal(a, b)
  states = 3.0 * jax.random.normal(jax.random.PRNGKey(1), (64, 71))
  keys = jax.random.split(jax.random.PRNGKey(2), 64)
  saturated = jax.tree_util.tree_map_with_path(
      lambda path, x: 8.0 * x if 'final' in jax.tree_util.keystr(path) else x,
      params)
  for p in (params, saturated):
    for mean_action in (True, False):
      out = jax.vmap(lambda s, k: ours.apply(p, s, k, mean_action))(
          states, keys)
      ref = jax.vmap(lambda s, k: theirs.apply(p, s, k, mean_action))(
          states, keys)
      for a, b in zip(jax.tree_util.tree_leaves(out),
                      jax.tree_util.tree_leaves(ref)):
        np.testing.assert_array_equal(a, b)
  if limits is not None:  # tanh saturated: |log-probability| is large.
    assert np.any(np.abs(out.actor.log_probability) > 100.0)


@pytest.mark.parametrize('critic', networks.CRITICS)
def test_every_critic_learns_in_the_one_update(critic):
  network_def, params = _init(critic)
  out = _update(network_def, params, params, _batch())
  assert all(np.all(np.isfinite(x))
             for x in jax.tree_util.tree_leaves(out))
  changed = [not np.allclose(a, b) for a, b in zip(
      jax.tree_util.tree_leaves(params['params']),
      jax.tree_util.tree_leaves(out['network_params']['params']))]
  assert all(changed)  # Actor and both critics moved.
  # The critics get the critic optimizer, the actor the actor's.
  labels = jax.tree_util.tree_leaves(sac_core.param_labels(params))
  assert labels.count('actor') == 6  # 3 dense layers x (kernel, bias).
  assert 'critic' in labels


def test_layernorm_critics_bootstrap_from_the_target_network():
  network_def, params = _init('layernorm')
  _, other = _init('layernorm', seed=1)
  batch = _batch()
  a = _update(network_def, params, params, batch)['Losses/Critic']
  b = _update(network_def, params, other, batch)['Losses/Critic']
  assert not np.isclose(a, b)


def test_crossq_has_no_target_network_and_normalises_both_batches_jointly():
  network_def, params = _init('crossq')
  _, other = _init('crossq', seed=1)
  batch = _batch()
  out = _update(network_def, params, params, batch)
  # The target parameters are not read.
  again = _update(network_def, params, other, batch)
  for x, y in zip(jax.tree_util.tree_leaves(out),
                  jax.tree_util.tree_leaves(again)):
    np.testing.assert_array_equal(x, y)
  # The input layer's running mean moved towards the mean of the 2B
  # state-action pairs: the B current ones and the B next ones with the
  # online actor's mean action.
  next_actions = jax.vmap(lambda s: network_def.apply(
      params, s, batch['key'], method=network_def.actor).mean_action)(
          batch['next_states'])
  joint = jnp.concatenate([
      jnp.concatenate([batch['states'], batch['actions']], axis=-1),
      jnp.concatenate([batch['next_states'], next_actions], axis=-1)])
  stats = out['network_params']['batch_stats']
  for critic in ('_critic_norm1', '_critic_norm2'):
    np.testing.assert_allclose(
        stats[critic]['BatchNorm_0']['mean'],
        (1 - networks.BATCH_NORM_MOMENTUM) * joint.mean(axis=0),
        rtol=1e-4, atol=1e-6)
  # The update returns the new running statistics.
  assert not np.allclose(stats['_critic_norm1']['BatchNorm_0']['mean'],
                         params['batch_stats']['_critic_norm1'][
                             'BatchNorm_0']['mean'])


@pytest.mark.parametrize('owner,make', [
    ('sac_trainer_config',
     lambda c: sac_trainer.TrainerConfig(critic=c)),
    ('SACAgent', lambda c: sac.SACAgent(3, (71,), critic=c)),
])
def test_bad_critic_names_the_binding(owner, make):
  with pytest.raises(ValueError, match=f'{owner}.critic must be one of'):
    make('resnet')


@pytest.mark.slow
@pytest.mark.ci
def test_agent_trains_and_checkpoints_a_layernorm_critic(tmp_path):
  agent = sac.SACAgent(3, (71,), critic='layernorm', min_replay_history=20,
                       batch_size=8, seed=1)
  rng = np.random.default_rng(0)
  agent.begin_episode(rng.normal(size=71).astype(np.float32))
  for _ in range(40):
    agent.step(float(rng.uniform()), rng.normal(size=71).astype(np.float32))
  agent.end_episode(1.0, terminal=True)
  assert agent.training_steps > 20
  bundle = agent.bundle_and_checkpoint(str(tmp_path), 0)
  assert bundle['config']['critic'] == 'layernorm'
  other = sac.SACAgent(3, (71,), critic='mlp')
  with pytest.raises(ValueError, match="critic='layernorm'"):
    other.unbundle(str(tmp_path), 0, bundle)
  same = sac.SACAgent(3, (71,), critic='layernorm', min_replay_history=20,
                      batch_size=8)
  assert same.unbundle(str(tmp_path), 0, bundle)


@pytest.mark.slow
@pytest.mark.ci
def test_crossq_trainer_snapshot_loads_in_sac_pretrained(tmp_path):
  """A CrossQ run's policy (batch stats included) flies as it was validated."""
  config = sac_trainer.TrainerConfig(
      num_envs=2, updates_per_step=2, batch_size=8, min_replay_history=8,
      replay_capacity=64, hidden_units=16, critic='crossq')
  params = jax_env.LatexBalloonJaxEnv().default_params.replace(
      episode_steps=6)
  final = jax_train.train(
      base_dir=str(tmp_path), num_iterations=1, seed=0, config=config,
      collectors=['episodes'], env_params=params)
  assert 'batch_stats' in final.network_params
  policy = pretrained.load_policy(
      str(tmp_path / 'policies' / 'policy_00000.msgpack'))
  assert policy['config']['critic'] == 'crossq'
  agent = sac.SACPretrainedAgent(
      3, (71,), action_low=jax_env.ACTION_LOW,
      action_high=jax_env.ACTION_HIGH,
      policy_path=str(tmp_path / 'policies' / 'policy_00000.msgpack'))
  for a, b in zip(jax.tree_util.tree_leaves(agent.network_params),
                  jax.tree_util.tree_leaves(final.network_params)):
    np.testing.assert_array_equal(a, b)
  obs = np.linspace(-1, 1, 71).astype(np.float32)
  agent.set_mode('eval')
  learner = sac_trainer.learner_for(config)
  expected = sac_trainer.to_box(learner.network_def.apply(
      final.network_params, jnp.asarray(obs), jax.random.PRNGKey(0),
      method=learner.network_def.actor).mean_action)
  np.testing.assert_allclose(agent.begin_episode(obs), expected, rtol=1e-5)
