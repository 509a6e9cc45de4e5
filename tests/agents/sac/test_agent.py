# coding=utf-8
"""Tests of ble_latex's SAC agent (ble_latex/agents/sac/agent.py)."""

import dataclasses
import inspect
import os
import pickle

import ble_latex  # noqa: F401  pylint: disable=unused-import
from balloon_learning_environment.agents import agent as base_agent
from balloon_learning_environment.agents import agent_registry
from balloon_learning_environment.utils import run_helpers
from dopamine.replay_memory import circular_replay_buffer
import gin
from hypothesis import given
from hypothesis import settings
from hypothesis import strategies as st
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex import agents as latex_agents
from ble_latex import errors
from ble_latex import run_files
from ble_latex import safe_io
from ble_latex.agents.sac import agent as sac
from ble_latex.agents.sac import core as sac_core
from ble_latex.agents.sac import networks
from ble_latex.agents.sac import pretrained
from ble_latex.agents.sac import trainer as sac_trainer
from tests.agents.sac.test_pretrained import _HIGH, _LOW, _sac  # pylint: disable=g-bad-import-order
from tests.agents.sac.test_pretrained import _crafted_pickle, _train_a_little  # pylint: disable=g-bad-import-order

# The latex env's action box: a0 altitude [m], a1 time factor, a2 float flag.
LOW = np.array([14_000.0, 1.0, -1.0])
HIGH = np.array([21_000.0, 5.0, 1.0])
TARGET = np.array([19_100.0, 2.0, 0.5])
OBS = np.array([0.5, -0.25, 1.0, 0.0], dtype=np.float32)

# Small networks and batches keep the tests fast on one core.
SMALL = dict(hidden_units=32, batch_size=16, min_replay_history=16,
             summary_writing_frequency=10**9)


def _agent(seed=0, obs_dim=OBS.size, **kwargs):
  return sac.SACAgent(3, (obs_dim,), action_low=LOW, action_high=HIGH,
                      seed=seed, **{**SMALL, **kwargs})


def _bandit_reward(action):
  """-||u - t||^2 on the normalised action: best at TARGET, 0 there."""
  u = 2.0 * (action - LOW) / (HIGH - LOW) - 1.0
  t = 2.0 * (TARGET - LOW) / (HIGH - LOW) - 1.0
  return -float(np.sum((u - t) ** 2))


def _eval_bandit(agent):
  agent.set_mode(base_agent.AgentMode.EVAL)
  action = agent.begin_episode(OBS)
  reward = _bandit_reward(action)
  agent.end_episode(reward, True)
  agent.set_mode(base_agent.AgentMode.TRAIN)
  return reward


class _WalkEnv:
  """Deterministic 4-step task; episodes end by time limit (not terminal)."""

  steps = 4

  def reset(self):
    self._h, self._t = 0.0, 0
    return self._obs()

  def _obs(self):
    return np.array([self._h, self._t / self.steps, np.sin(self._h), 1.0],
                    dtype=np.float32)

  def step(self, action):
    u = 2.0 * (action - LOW) / (HIGH - LOW) - 1.0
    self._h = float(np.clip(self._h + 0.5 * u[0] * u[1], -2.0, 2.0))
    self._t += 1
    return self._obs(), -abs(self._h - 1.0), self._t >= self.steps


def _run_episodes(agent, env, n):
  """BLE train_lib's loop; returns every action taken."""
  actions = []
  for _ in range(n):
    obs = env.reset()
    action = agent.begin_episode(obs)
    actions.append(action)
    while True:
      obs, reward, done = env.step(action)
      if done:
        break
      action = agent.step(reward, obs)
      actions.append(action)
    agent.end_episode(reward, False)  # Time limit: not a terminal state.
  return np.array(actions)


@pytest.mark.slow
@pytest.mark.ci
def test_learns_one_step_task_deterministic_eval_improves():
  agent = _agent(seed=0, batch_size=32, min_replay_history=32,
                 actor_learning_rate=1e-3, critic_learning_rate=1e-3,
                 alpha_learning_rate=1e-3)
  before = _eval_bandit(agent)
  for _ in range(300):  # One SAC update per 1-step episode.
    action = agent.begin_episode(OBS)
    agent.end_episode(_bandit_reward(action), True)
  after = _eval_bandit(agent)
  assert before < -0.5
  assert after > -0.1
  assert after > before + 0.5
  assert agent.training_steps == 300  # The two eval episodes do not train.
  assert agent.replay_size == 300


class _AltitudeEnv:
  """Reach 19 000 m in 6 steps: a0 is the desired altitude [m], a1 how many
  steps the move is spread over (h += (a0 - h) / a1); reward 1 at 19 km."""

  steps = 6

  def reset(self):
    self._h, self._t = 15_000.0, 0  # [m]
    return self._obs()

  def _obs(self):
    return np.array([(self._h - 17_500.0) / 3_500.0, self._t / self.steps],
                    dtype=np.float32)

  def step(self, action):
    self._h += (action[0] - self._h) / action[1]
    self._t += 1
    reward = float(np.exp(-abs(self._h - 19_000.0) / 500.0))
    return self._obs(), reward, self._t >= self.steps


def _episode_return(agent, env, mode):
  agent.set_mode(mode)
  obs = env.reset()
  action = agent.begin_episode(obs)
  total = 0.0
  while True:
    obs, reward, done = env.step(action)
    total += reward
    if done:
      break
    action = agent.step(reward, obs)
  agent.end_episode(reward, False)
  return total


@pytest.mark.slow
@pytest.mark.ci
def test_learns_multi_step_altitude_task():
  agent = sac.SACAgent(3, (2,), action_low=LOW, action_high=HIGH, seed=0,
                       hidden_units=64, batch_size=64, min_replay_history=100,
                       actor_learning_rate=1e-3, critic_learning_rate=1e-3,
                       alpha_learning_rate=1e-3, gamma=0.9)
  env = _AltitudeEnv()
  before = _episode_return(agent, env, 'eval')
  for _ in range(200):
    _episode_return(agent, env, 'train')
  after = _episode_return(agent, env, 'eval')
  assert before < 0.5  # Of at most 6.
  assert after > 2.0


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
def test_same_seed_same_actions_and_different_seed_differs():
  a = _run_episodes(_agent(seed=3), _WalkEnv(), 8)
  b = _run_episodes(_agent(seed=3), _WalkEnv(), 8)
  c = _run_episodes(_agent(seed=4), _WalkEnv(), 8)
  np.testing.assert_array_equal(a, b)
  assert not np.allclose(a, c)


def test_checkpoint_round_trip_resumes_identically(tmp_path):
  ckpt = str(tmp_path / 'checkpoints')
  env = _WalkEnv()
  probe = np.random.default_rng(0).uniform(-1, 1, (5, OBS.size))
  original = _agent(seed=1)
  _run_episodes(original, env, 8)  # 32 transitions: updates have started.
  assert original.training_steps > original.min_replay_history
  original.save_checkpoint(ckpt, 0)
  original.set_mode('eval')
  eval_before = [original.begin_episode(o) for o in probe]
  original.set_mode('train')
  continued = _run_episodes(original, env, 3)

  restored = _agent(seed=99)  # Everything must come from the checkpoint.
  assert restored.reload_latest_checkpoint(ckpt) == 0
  assert restored.replay_size == 32
  assert restored.training_steps == 8 * 4
  restored.set_mode('eval')
  eval_after = [restored.begin_episode(o) for o in probe]
  restored.set_mode('train')
  np.testing.assert_array_equal(eval_before, eval_after)
  # Same replay, PRNG key, optimizer and temperature: identical training.
  np.testing.assert_array_equal(continued, _run_episodes(restored, env, 3))
  assert restored.training_steps == original.training_steps
  assert restored.temperature == original.temperature
  for x, y in zip(jax.tree.leaves(original.network_params),
                  jax.tree.leaves(restored.network_params)):
    np.testing.assert_array_equal(x, y)


def test_checkpoint_files_atomic_names_and_cleanup(tmp_path):
  ckpt = str(tmp_path)
  agent = _agent(seed=0, checkpoint_duration=1)
  assert agent.reload_latest_checkpoint(str(tmp_path / 'missing')) == -1
  assert agent.reload_latest_checkpoint(ckpt) == -1
  _run_episodes(agent, _WalkEnv(), 1)
  for iteration in range(4):
    agent.save_checkpoint(ckpt, iteration)
  # A write killed mid-way leaves only a temporary file, never a
  # checkpoint_*.msgpack; it is ignored on reload and removed on the next save.
  with open(os.path.join(ckpt, '.tmp-checkpoint_00009.msgpack-x'), 'wb') as f:
    f.write(b'partial')
  assert sorted(os.listdir(ckpt)) == [
      '.tmp-checkpoint_00009.msgpack-x', 'checkpoint_00002.msgpack',
      'checkpoint_00003.msgpack']
  assert _agent(seed=0).reload_latest_checkpoint(ckpt) == 3
  agent.save_checkpoint(ckpt, 4)
  assert sorted(os.listdir(ckpt)) == ['checkpoint_00003.msgpack',
                                      'checkpoint_00004.msgpack']
  with pytest.raises(FileNotFoundError):
    agent.load_checkpoint(ckpt, 7)
  with pytest.raises(ValueError, match='config'):
    _agent(seed=0, hidden_units=16).load_checkpoint(ckpt, 4)
  safe_io.write_tree(os.path.join(ckpt, 'checkpoint_00005.msgpack'),
                     {'not': 'sac'}, file_format='something else')
  with pytest.raises(ValueError, match='not a SAC checkpoint'):
    agent.load_checkpoint(ckpt, 5)


def _corrupted(tree, change):
  tree = dict(tree)
  change(tree)
  return tree


def _set_kernel_nan(tree):
  params = {k: dict(v) for k, v in tree['network_params']['params'].items()}
  kernel = np.array(params['_actor_final_layer']['kernel'])
  kernel.flat[:3] = np.nan
  params['_actor_final_layer']['kernel'] = kernel
  tree['network_params'] = {'params': params}


def _set_replay_reward_nan(tree):
  replay = dict(tree['replay'])
  reward = np.array(replay['$store$_reward'])
  reward[1] = np.nan
  replay['$store$_reward'] = reward
  tree['replay'] = replay


@pytest.mark.parametrize('change, message', [
    (_set_kernel_nan, 'network_params: leaf params/_actor_final_layer/kernel '
                      'has 3 non-finite values'),
    (_set_replay_reward_nan, r'replay \$store\$_reward has 1 non-finite value'),
    (lambda t: t.update(training_steps=-5),
     'training_steps must be >= 0, got -5'),
    (lambda t: t.update(log_alpha=np.array([0.5 + 1j], np.complex64)),
     'log_alpha has dtype complex64'),
    (lambda t: t.update(log_alpha=np.full(1000, np.nan, np.float32)),
     r'log_alpha has shape \(1000,\), expected \(1,\)'),
    (lambda t: t.update(config={**t['config'], 'hidden_units': 40000}),
     'config.hidden_units must be an integer >= 1 and <= 4096'),
])
def test_checkpoint_values_are_checked_on_load(tmp_path, change, message):
  """NaN weights or replay rewards, bad counters: refused, file and entry named.

  The agent keeps its state.
  """
  ckpt = str(tmp_path)
  agent = _agent(seed=0)
  _run_episodes(agent, _WalkEnv(), 2)
  agent.save_checkpoint(ckpt, 0)
  path = run_files.checkpoint_file(ckpt, 0)
  tree = safe_io.read_tree(path, file_format=sac_core.CHECKPOINT_FORMAT)
  safe_io.write_tree(path, _corrupted(tree, change),
                     file_format=sac_core.CHECKPOINT_FORMAT)
  fresh = _agent(seed=3)
  before = jax.tree.leaves(fresh.network_params)
  with pytest.raises(ValueError, match=message) as raised:
    fresh.reload_latest_checkpoint(ckpt)
  assert path in str(raised.value)
  assert fresh.training_steps == 0 and fresh.replay_size == 0
  for x, y in zip(before, jax.tree.leaves(fresh.network_params)):
    np.testing.assert_array_equal(x, y)


def test_diverged_agent_writes_no_checkpoint_or_policy(tmp_path):
  ckpt = str(tmp_path)
  agent = _agent(seed=0)
  agent.save_checkpoint(ckpt, 0)
  params = agent.network_params['params']
  params['_critic1']['Dense_0']['kernel'] = params['_critic1']['Dense_0'][
      'kernel'].at[0, 0].set(np.inf)
  with pytest.raises(sac_core.TrainingDiverged,
                     match=r'non-finite network_params \(1 values\)'):
    agent.save_checkpoint(ckpt, 1)
  with pytest.raises(sac_core.TrainingDiverged):
    agent.acting_bundle(1)
  assert run_files.iterations(ckpt) == [0]


def test_actions_always_inside_box():
  agent = _agent(seed=5, min_replay_history=8)
  rng = np.random.default_rng(1)
  actions = []
  # Train mode: uniform warm-up actions, then samples of the policy.
  actions.append(agent.begin_episode(rng.normal(size=4)))
  for _ in range(24):
    actions.append(agent.step(0.0, rng.normal(size=4)))
  agent.end_episode(0.0, False)
  assert agent.training_steps > agent.min_replay_history
  # Eval mode: the mean action, also for inputs that saturate the tanh.
  agent.set_mode(base_agent.AgentMode.EVAL)
  for scale in (1.0, 1e3):
    actions.append(agent.begin_episode(scale * rng.normal(size=4)))
    for _ in range(8):
      actions.append(agent.step(0.0, scale * rng.normal(size=4)))
  # A mean action saturated at either edge maps exactly onto the box edge.
  params = agent.network_params['params']
  for sign, edge in ((1.0, HIGH), (-1.0, LOW)):
    params['_actor_final_layer']['bias'] = params['_actor_final_layer'][
        'bias'].at[:3].set(sign * 1e3)
    actions.append(agent.begin_episode(OBS))
    np.testing.assert_array_equal(actions[-1], edge.astype(np.float32))
  actions = np.array(actions)
  assert actions.dtype == np.float32 and actions.shape[1] == 3
  assert np.all(actions >= LOW.astype(np.float32))
  assert np.all(actions <= HIGH.astype(np.float32))
  # Diverged (NaN) parameters never reach the env as a NaN action.
  params['_actor_final_layer']['bias'] = params['_actor_final_layer'][
      'bias'].at[0].set(np.nan)
  with pytest.raises(FloatingPointError, match='non-finite action'):
    agent.begin_episode(OBS)


def test_registry_and_gin_file():
  latex_agents.register()
  latex_agents.register()  # Idempotent.
  assert agent_registry.agent_constructor('sac') is sac.SACAgent
  assert sac.SACAgent.supports_box_actions
  assert 'sac' in latex_agents.BOX_AGENTS
  # No default gin file: SAC's defaults are the code's.
  assert agent_registry.get_default_gin_config('sac') is None
  try:
    gin.clear_config()
    # BLE's own gin + constructor path (as its train/eval use them).
    run_helpers.bind_gin_variables('sac', gin_bindings=[
        'ble_latex.agents.sac.SACAgent.replay_capacity = 1000'])
    agent = run_helpers.create_agent('sac', 3, observation_shape=(7,))
    assert isinstance(agent, sac.SACAgent)
    assert agent.get_name() == 'sac'
    assert agent._hidden_units == 256  # pylint: disable=protected-access
    assert agent._replay_capacity == 1000  # pylint: disable=protected-access
    assert agent.target_entropy == 0.0
    assert agent.min_replay_history == 1000
    action = agent.begin_episode(np.zeros(7))  # Default box: the core's.
    assert np.all((LOW <= action) & (action <= HIGH))
  finally:
    gin.clear_config()


def test_bad_inputs_raise_clear_errors_and_leave_state_untouched():
  agent = _agent(seed=0)
  nan_obs = OBS.copy()
  nan_obs[2] = np.nan
  rng_before = np.asarray(agent._rng).copy()  # pylint: disable=protected-access
  with pytest.raises(ValueError, match=r'observation.*NaN/inf.*\[2\]'):
    agent.begin_episode(nan_obs)
  with pytest.raises(ValueError, match='observation has shape'):
    agent.begin_episode(np.zeros(5))
  np.testing.assert_array_equal(rng_before, agent._rng)  # pylint: disable=protected-access
  assert agent.training_steps == 0
  agent.begin_episode(OBS)
  steps, size = agent.training_steps, agent.replay_size
  with pytest.raises(ValueError, match='observation'):
    agent.step(0.0, np.full(4, np.inf))
  with pytest.raises(ValueError, match='reward'):
    agent.step(float('nan'), OBS)
  with pytest.raises(ValueError, match='reward'):
    agent.end_episode(float('inf'), True)
  assert (agent.training_steps, agent.replay_size) == (steps, size)
  with pytest.raises(ValueError, match='low < high'):
    sac.SACAgent(3, (4,), action_low=HIGH, action_high=LOW)
  with pytest.raises(ValueError, match='shape'):
    sac.SACAgent(3, (4,), action_low=[0.0, 0.0], action_high=[1.0, 1.0])


# --- VectorReplayBuffer equals Dopamine's OutOfGraphReplayBuffer -----------

_CAPACITY = 50
_REPLAY_ARGS = dict(observation_shape=(5,), replay_capacity=_CAPACITY,
                    batch_size=16, update_horizon=1, gamma=0.99,
                    observation_dtype=np.float32, action_shape=(3,),
                    action_dtype=np.float32)
# How an episode ends: (terminal, episode_end) of its last add; 'open' runs
# on into the next episode.
_ENDS = {'terminal': (True, True), 'terminal_flag_only': (True, False),
         'time_limit': (False, True), 'open': (False, False)}
_EPISODES = st.lists(
    st.tuples(st.integers(1, 12), st.sampled_from(sorted(_ENDS))),
    min_size=1, max_size=8)


def _replay_pair(stack_size=1):
  """A VectorReplayBuffer and a stock Dopamine buffer with equal arguments."""
  return (sac.VectorReplayBuffer(stack_size=stack_size, **_REPLAY_ARGS),
          circular_replay_buffer.OutOfGraphReplayBuffer(
              stack_size=stack_size, **_REPLAY_ARGS))


def _feed_both(fast, stock, episodes, n_adds, seed, check):
  """Adds the same n_adds random transitions to both, cycling `episodes`.

  Calls `check()` after every add, so not-full, just-full and wrapped states
  are all compared.
  """
  rng = np.random.default_rng(seed)
  adds = 0
  while True:
    for length, end in episodes:
      for t in range(length):
        last = t == length - 1
        terminal, episode_end = _ENDS[end] if last else (False, False)
        obs = rng.normal(size=5).astype(np.float32)
        action = rng.uniform(-1.0, 1.0, 3).astype(np.float32)
        reward = np.float32(rng.normal())
        for replay in (fast, stock):
          replay.add(obs, action, reward, terminal, episode_end=episode_end)
        adds += 1
        check()
        if adds == n_adds:
          return


def _assert_same_as_dopamine(fast, stock, rng):
  """valid_transition_mask and sample_transition_batch equal Dopamine's."""
  probe = np.arange(-2, _CAPACITY + 2)
  expected = np.array([stock.is_valid_transition(int(i)) for i in probe])
  mask = fast.valid_transition_mask(probe)
  assert mask.dtype == bool and mask.shape == probe.shape
  np.testing.assert_array_equal(mask, expected)
  valid = probe[expected]
  if valid.size == 0:
    return
  # Every valid index once, plus seeded repeats, in a random order.
  idx = rng.permutation(np.concatenate([valid, rng.choice(valid, 16)]))
  elements = stock.get_transition_elements(len(idx))
  got = fast.sample_transition_batch(batch_size=len(idx), indices=idx)
  want = stock.sample_transition_batch(batch_size=len(idx), indices=idx)
  assert len(got) == len(want) == len(elements)
  for element, g, w in zip(elements, got, want):
    assert g.dtype == w.dtype, element.name
    assert g.shape == w.shape == element.shape, element.name
    np.testing.assert_array_equal(g, w, err_msg=element.name)


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
@settings(max_examples=25, deadline=None)
@given(episodes=_EPISODES,
       n_adds=st.integers(_CAPACITY + 2, 3 * _CAPACITY),
       seed=st.integers(0, 2**16))
def test_vector_replay_buffer_equals_dopamine(episodes, n_adds, seed):
  fast, stock = _replay_pair()
  rng = np.random.default_rng(seed)
  _feed_both(fast, stock, episodes, n_adds, seed,
             lambda: _assert_same_as_dopamine(fast, stock, rng))
  assert fast.is_full() and fast.add_count > _CAPACITY  # Wrapped.


def test_vector_replay_buffer_stack_size_2_falls_back_to_dopamine():
  fast, stock = _replay_pair(stack_size=2)
  episodes = [(3, 'time_limit'), (1, 'terminal'), (7, 'open'),
              (5, 'terminal'), (2, 'time_limit'), (9, 'terminal_flag_only')]
  rng = np.random.default_rng(0)
  _feed_both(fast, stock, episodes, 2 * _CAPACITY, 0,
             lambda: _assert_same_as_dopamine(fast, stock, rng))
  assert fast.is_full()


# --- SACAgent._sample_indices and _maybe_sync_weights ----------------------


def test_sample_indices_valid_deterministic_and_cover_valid_set():
  capacity = 40
  # No updates: only the replay contents matter here.
  agent = _agent(seed=0, replay_capacity=capacity, min_replay_history=10**6)
  replay = agent._replay  # pylint: disable=protected-access
  sample = agent._sample_indices  # pylint: disable=protected-access

  def check():
    valid = {i for i in range(capacity) if replay.is_valid_transition(i)}
    assert 0 < len(valid) < capacity - 2  # Episode ends exclude some.
    key = jax.random.PRNGKey(7)
    idx = sample(key)
    assert idx.shape == (SMALL['batch_size'],)
    assert np.issubdtype(idx.dtype, np.integer)
    assert all(replay.is_valid_transition(int(i)) for i in idx)
    np.testing.assert_array_equal(idx, sample(key))
    np.testing.assert_array_equal(idx, sample(jax.random.PRNGKey(7)))
    assert not np.array_equal(idx, sample(jax.random.PRNGKey(8)))
    # Uniform over the valid set: 60 x 16 draws reach every valid index.
    seen = set()
    for k in range(60):
      seen.update(sample(jax.random.PRNGKey(k)).tolist())
    assert seen == valid

  def terminal_episodes(n):  # 2 transitions each, ending in a terminal.
    for _ in range(n):
      agent.begin_episode(OBS)
      agent.step(0.0, -OBS)
      agent.end_episode(1.0, True)

  _run_episodes(agent, _WalkEnv(), 4)  # Time-limit ends.
  terminal_episodes(3)
  assert agent.replay_size == 22 and not replay.is_full()
  check()
  _run_episodes(agent, _WalkEnv(), 5)
  terminal_episodes(1)
  # Wrapped; the oldest transitions (cursor + 1, ...) are valid ones.
  assert agent.replay_size == 44 and replay.is_full()
  assert replay.is_valid_transition(replay.cursor() + 1)
  check()
  assert agent.training_steps == 44


def test_maybe_sync_weights_is_soft_update():
  tau = 0.25
  agent = _agent(seed=0, target_smoothing_coefficient=tau)
  rng = np.random.default_rng(0)

  def known(low, high):
    return jax.tree.map(
        lambda x: jnp.asarray(rng.uniform(low, high, x.shape), x.dtype),
        agent.network_params)

  online, target = known(1.0, 2.0), known(3.0, 4.0)
  agent.network_params, agent.target_params = online, target
  agent._maybe_sync_weights()  # pylint: disable=protected-access
  leaves = jax.tree.leaves
  assert (jax.tree.structure(agent.target_params) ==
          jax.tree.structure(online))
  assert len(leaves(online)) > 2
  expected = []
  for o, t, new in zip(leaves(online), leaves(target),
                       leaves(agent.target_params)):
    want = tau * np.asarray(o, np.float64) + (1 - tau) * np.asarray(
        t, np.float64)
    assert new.dtype == o.dtype and new.shape == o.shape
    np.testing.assert_allclose(new, want, rtol=1e-6)
    expected.append(want)
  for o, now in zip(leaves(online), leaves(agent.network_params)):
    np.testing.assert_array_equal(o, now)  # Online weights untouched.
  agent._maybe_sync_weights()  # pylint: disable=protected-access
  for o, e, new in zip(leaves(online), expected, leaves(agent.target_params)):
    np.testing.assert_allclose(
        new, tau * np.asarray(o, np.float64) + (1 - tau) * e, rtol=1e-6)


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


# -- Checkpoint files: only data, named when bad (the latex env's shapes). ---


def _eval_actions(agent, n=4):
  agent.set_mode('eval')
  obs = np.random.default_rng(3).uniform(-1, 1, (n, 71)).astype(np.float32)
  actions = [agent.begin_episode(o) for o in obs]
  agent.set_mode('train')
  return np.array(actions)


def test_checkpoint_iterations_ignore_unnumbered_names(tmp_path):
  for name in ('checkpoint_00003.msgpack', 'checkpoint_00010.msgpack',
               'checkpoint_backup.msgpack', 'checkpoint_00011 (copy).msgpack',
               'checkpoint_00012.pkl', '.tmp-checkpoint_00013.msgpack-1'):
    (tmp_path / name).write_bytes(b'')
  assert run_files.iterations(str(tmp_path)) == [3, 10]
  assert run_files.iterations(str(tmp_path),
                              run_files.LEGACY_CHECKPOINT_PATTERN) == [12]


def test_crafted_pickle_checkpoint_runs_no_code(tmp_path):
  marker = tmp_path / 'pwned'
  ckpt = tmp_path / 'checkpoints'
  ckpt.mkdir()
  _crafted_pickle(ckpt / 'checkpoint_00000.pkl', marker)
  with pytest.raises(safe_io.UntrustedFileError, match='trust_legacy_pickle'):
    _sac().reload_latest_checkpoint(str(ckpt))
  with pytest.raises(safe_io.UntrustedFileError):
    _sac().load_checkpoint(str(ckpt), 0)
  # Even with the opt-in, only data classes are resolved.
  with pytest.raises(ValueError, match='refusing to load'):
    _sac(trust_legacy_pickle=True).load_checkpoint(str(ckpt), 0)
  # A pickle under a msgpack name is recognised and refused.
  os.rename(ckpt / 'checkpoint_00000.pkl', ckpt / 'checkpoint_00000.msgpack')
  with pytest.raises(safe_io.UntrustedFileError, match='pickle'):
    _sac().load_checkpoint(str(ckpt), 0)
  assert not marker.exists()


def test_truncated_checkpoint_is_an_error_naming_it(tmp_path):
  agent = _sac()
  _train_a_little(agent)
  agent.save_checkpoint(str(tmp_path), 0)
  path = run_files.checkpoint_file(str(tmp_path), 0)
  data = open(path, 'rb').read()
  with open(path, 'wb') as f:
    f.write(data[:len(data) // 2])
  fresh = _sac(seed=5)
  before = _eval_actions(fresh)
  with pytest.raises(ValueError, match='truncated') as e:
    fresh.reload_latest_checkpoint(str(tmp_path))
  assert path in str(e.value)
  np.testing.assert_array_equal(_eval_actions(fresh), before)  # Unchanged.


def test_checkpoint_with_wrong_shapes_leaves_agent_unchanged(tmp_path):
  agent = _sac()
  _train_a_little(agent)
  bundle = agent.bundle_and_checkpoint(str(tmp_path), 0)
  bundle['optimizer_state'] = bundle['optimizer_state'][:-1]
  safe_io.write_tree(run_files.checkpoint_file(str(tmp_path), 0), bundle,
                     file_format=sac_core.CHECKPOINT_FORMAT)
  fresh = _sac(seed=5)
  before = _eval_actions(fresh)
  with pytest.raises(ValueError, match='optimizer_state'):
    fresh.load_checkpoint(str(tmp_path), 0)
  np.testing.assert_array_equal(_eval_actions(fresh), before)


def _legacy_bundle(agent):
  """What ble_latex 0.1 pickled: optax named tuples, tuples, a set."""
  bundle = agent.bundle_and_checkpoint('', 0)
  to_numpy = lambda t: jax.tree.map(np.asarray, jax.device_get(t))
  bundle.update(
      format=sac_core.LEGACY_CHECKPOINT_FORMAT,
      optimizer_state=to_numpy(agent.optimizer_state),
      alpha_optimizer_state=to_numpy(agent.alpha_optimizer_state))
  bundle['config']['observation_shape'] = tuple(
      bundle['config']['observation_shape'])
  bundle['replay']['episode_end_indices'] = set(
      int(i) for i in bundle['replay']['episode_end_indices'])
  return bundle


def test_legacy_pickles_load_only_with_the_opt_in(tmp_path):
  agent = _sac()
  _train_a_little(agent)
  with open(run_files.legacy_checkpoint_file(str(tmp_path), 3), 'wb') as f:
    pickle.dump(_legacy_bundle(agent), f)
  with pytest.raises(safe_io.UntrustedFileError):
    _sac(seed=4).reload_latest_checkpoint(str(tmp_path))
  restored = _sac(seed=4, trust_legacy_pickle=True)
  assert restored.reload_latest_checkpoint(str(tmp_path)) == 3
  assert restored.replay_size == agent.replay_size
  np.testing.assert_array_equal(_eval_actions(restored), _eval_actions(agent))
  # Converting the legacy checkpoint's policy gives a data-only file.
  out = tmp_path / 'policy.msgpack'
  pretrained.export_policy(run_files.legacy_checkpoint_file(str(tmp_path), 3),
                           str(out), trust_legacy_pickle=True)
  loaded = sac.SACPretrainedAgent(
      3, (71,), action_low=_LOW, action_high=_HIGH, hidden_units=16,
      policy_path=str(out))
  np.testing.assert_array_equal(_eval_actions(loaded), _eval_actions(agent))


@pytest.mark.parametrize('name,value', [
    ('gamma', -5.0), ('gamma', 1.5), ('gamma', float('nan')),
    ('actor_learning_rate', 0.0), ('critic_learning_rate', -1e-3),
    ('alpha_learning_rate', float('inf')), ('batch_size', 0),
    ('target_smoothing_coefficient', 0.0), ('reward_scale_factor', -1.0),
    ('update_period', 0), ('hidden_units', 2.5), ('target_entropy', float('nan')),
])
def test_bad_sac_hyperparameters_name_the_binding(name, value):
  with pytest.raises(ValueError, match=f'SACAgent.{name} must be'):
    _sac(**{name: value})


# --- One home of the hyperparameters; the replay's counters on load --------


def test_both_trainers_default_to_the_one_hyperparameter_record():
  agent_defaults = inspect.signature(sac.SACAgent.__init__).parameters
  trainer_defaults = {f.name: f.default for f in
                      dataclasses.fields(sac_trainer.TrainerConfig)}
  for name in sac_core.SAC_HYPERPARAMETERS:
    value = getattr(sac_core.SAC_DEFAULTS, name)
    assert agent_defaults[name].default == value, name
    assert trainer_defaults[name] == value, name


@pytest.mark.parametrize('value', [2**70, 10**400, 4097])
def test_agent_sizes_beyond_bounds_are_one_line_config_errors(value):
  with pytest.raises(errors.ConfigError,
                     match='SACAgent.hidden_units must be an integer') as e:
    _agent(hidden_units=value)
  # One line; gin appends where it was called (commands drop that).
  assert str(e.value).split('\n')[0].endswith(f'got {value!r}')


@pytest.mark.parametrize('field, value, message', [
    ('add_count', np.array(999), r'add_count 999 in a buffer of capacity'),
    pytest.param('invalid_range', np.array([5, 6]),
                 r'replay invalid_range is \[5, 6\]', marks=pytest.mark.slow),
    pytest.param('episode_end_indices', np.array([500]),
                 r'replay episode_end_indices must be rows of the 21 filled',
                 marks=pytest.mark.slow),
])
def test_checkpoint_replay_counters_must_fit_its_arrays(tmp_path, field, value,
                                                        message):
  """add_count 999 over 21 stored rows was accepted (issue 48 item 5)."""
  agent = _sac()
  _train_a_little(agent)  # 21 transitions.
  agent.save_checkpoint(str(tmp_path), 0)
  tree = safe_io.read_tree(run_files.checkpoint_file(str(tmp_path), 0),
                           file_format=sac_core.CHECKPOINT_FORMAT)
  crafted_dir = tmp_path / 'crafted'
  path = run_files.checkpoint_file(str(crafted_dir), 0)
  os.makedirs(crafted_dir)
  safe_io.write_tree(path, {**tree, 'replay': {**tree['replay'], field: value}},
                     file_format=sac_core.CHECKPOINT_FORMAT)
  fresh = _sac()
  with pytest.raises(errors.BadFileError, match=message) as refused:
    fresh.load_checkpoint(str(crafted_dir), 0)
  assert path in str(refused.value) and '\n' not in str(refused.value)
  assert fresh.replay_size == 0  # Unchanged.
  fresh.load_checkpoint(str(tmp_path), 0)  # The file as written loads.
  assert fresh.replay_size == 21
