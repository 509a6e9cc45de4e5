"""Tests of ble_latex's SAC agent (ble_latex/agents/sac/agent.py)."""

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

import ble_latex  # noqa: F401  pylint: disable=unused-import
from ble_latex import agents as latex_agents
from ble_latex import errors
from ble_latex.agents.sac import agent as sac

from tests.agents.sac import agent_cases as cases
from tests.agents.sac.test_pretrained import _sac  # pylint: disable=g-bad-import-order


def _bandit_reward(action):
  """-||u - t||^2 on the normalised action: best at TARGET, 0 there."""
  u = 2.0 * (action - cases.LOW) / (cases.HIGH - cases.LOW) - 1.0
  t = 2.0 * (cases.TARGET - cases.LOW) / (cases.HIGH - cases.LOW) - 1.0
  return -float(np.sum((u - t) ** 2))


def _eval_bandit(agent):
  agent.set_mode(base_agent.AgentMode.EVAL)
  action = agent.begin_episode(cases.OBS)
  reward = _bandit_reward(action)
  agent.end_episode(reward, True)
  agent.set_mode(base_agent.AgentMode.TRAIN)
  return reward


@pytest.mark.slow
@pytest.mark.ci
def test_learns_one_step_task_deterministic_eval_improves():
  agent = cases.agent(seed=0, batch_size=32, min_replay_history=32,
                 actor_learning_rate=1e-3, critic_learning_rate=1e-3,
                 alpha_learning_rate=1e-3)
  before = _eval_bandit(agent)
  for _ in range(300):  # One SAC update per 1-step episode.
    action = agent.begin_episode(cases.OBS)
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
  agent = sac.SACAgent(3, (2,), action_low=cases.LOW,
                       action_high=cases.HIGH, seed=0,
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
  a = cases.run_episodes(cases.agent(seed=3), cases.WalkEnv(), 8)
  b = cases.run_episodes(cases.agent(seed=3), cases.WalkEnv(), 8)
  c = cases.run_episodes(cases.agent(seed=4), cases.WalkEnv(), 8)
  np.testing.assert_array_equal(a, b)
  assert not np.allclose(a, c)


def test_actions_always_inside_box():
  agent = cases.agent(seed=5, min_replay_history=8)
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
  for sign, edge in ((1.0, cases.HIGH), (-1.0, cases.LOW)):
    params['_actor_final_layer']['bias'] = params['_actor_final_layer'][
        'bias'].at[:3].set(sign * 1e3)
    actions.append(agent.begin_episode(cases.OBS))
    np.testing.assert_array_equal(actions[-1], edge.astype(np.float32))
  actions = np.array(actions)
  assert actions.dtype == np.float32 and actions.shape[1] == 3
  assert np.all(actions >= cases.LOW.astype(np.float32))
  assert np.all(actions <= cases.HIGH.astype(np.float32))
  # Diverged (NaN) parameters never reach the env as a NaN action.
  params['_actor_final_layer']['bias'] = params['_actor_final_layer'][
      'bias'].at[0].set(np.nan)
  with pytest.raises(FloatingPointError, match='non-finite action'):
    agent.begin_episode(cases.OBS)


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
    assert np.all((cases.LOW <= action) & (action <= cases.HIGH))
  finally:
    gin.clear_config()


def test_bad_inputs_raise_clear_errors_and_leave_state_untouched():
  agent = cases.agent(seed=0)
  nan_obs = cases.OBS.copy()
  nan_obs[2] = np.nan
  rng_before = np.asarray(agent._rng).copy()  # pylint: disable=protected-access
  with pytest.raises(ValueError, match=r'observation.*NaN/inf.*\[2\]'):
    agent.begin_episode(nan_obs)
  with pytest.raises(ValueError, match='observation has shape'):
    agent.begin_episode(np.zeros(5))
  np.testing.assert_array_equal(rng_before, agent._rng)  # pylint: disable=protected-access
  assert agent.training_steps == 0
  agent.begin_episode(cases.OBS)
  steps, size = agent.training_steps, agent.replay_size
  with pytest.raises(ValueError, match='observation'):
    agent.step(0.0, np.full(4, np.inf))
  with pytest.raises(ValueError, match='reward'):
    agent.step(float('nan'), cases.OBS)
  with pytest.raises(ValueError, match='reward'):
    agent.end_episode(float('inf'), True)
  assert (agent.training_steps, agent.replay_size) == (steps, size)
  with pytest.raises(ValueError, match='low < high'):
    sac.SACAgent(3, (4,), action_low=cases.HIGH, action_high=cases.LOW)
  with pytest.raises(ValueError, match='shape'):
    sac.SACAgent(3, (4,), action_low=[0.0, 0.0], action_high=[1.0, 1.0])


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


def test_sample_indices_valid_deterministic_and_cover_valid_set():
  capacity = 40
  # No updates: only the replay contents matter here.
  agent = cases.agent(seed=0, replay_capacity=capacity,
                      min_replay_history=10**6)
  replay = agent._replay  # pylint: disable=protected-access
  sample = agent._sample_indices  # pylint: disable=protected-access

  def check():
    valid = {i for i in range(capacity) if replay.is_valid_transition(i)}
    assert 0 < len(valid) < capacity - 2  # Episode ends exclude some.
    key = jax.random.PRNGKey(7)
    idx = sample(key)
    assert idx.shape == (cases.SMALL['batch_size'],)
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
      agent.begin_episode(cases.OBS)
      agent.step(0.0, -cases.OBS)
      agent.end_episode(1.0, True)

  cases.run_episodes(agent, cases.WalkEnv(), 4)  # Time-limit ends.
  terminal_episodes(3)
  assert agent.replay_size == 22 and not replay.is_full()
  check()
  cases.run_episodes(agent, cases.WalkEnv(), 5)
  terminal_episodes(1)
  # Wrapped; the oldest transitions (cursor + 1, ...) are valid ones.
  assert agent.replay_size == 44 and replay.is_full()
  assert replay.is_valid_transition(replay.cursor() + 1)
  check()
  assert agent.training_steps == 44


def test_maybe_sync_weights_is_soft_update():
  tau = 0.25
  agent = cases.agent(seed=0, target_smoothing_coefficient=tau)
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


@pytest.mark.parametrize('value', [2**70, 10**400, 4097])
def test_agent_sizes_beyond_bounds_are_one_line_config_errors(value):
  with pytest.raises(errors.ConfigError,
                     match='SACAgent.hidden_units must be an integer') as e:
    cases.agent(hidden_units=value)
  # One line; gin appends where it was called (commands drop that).
  assert str(e.value).split('\n')[0].endswith(f'got {value!r}')
