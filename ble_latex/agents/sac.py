# coding=utf-8
"""Soft Actor-Critic for Box actions, as a BLE `Agent` (wraps Dopamine's SAC).

The paper (Saunders et al. 2023, "RL problem") trains SAC (Haarnoja et al.
2018/2019): actor and twin critics as 2 x 256 MLPs, squashed-Gaussian policy,
automatic entropy temperature with target entropy 0, and a replay buffer.

What is reused from Dopamine 4.0.9 (`dopamine.jax.agents.sac.sac_agent`):
the jitted stochastic action sampler `sac_agent.select_action`, the
train-step schedule (`_train_step`), and the out-of-graph
`OutOfGraphReplayBuffer` with its episode-end handling (transitions cut by a
time limit are never bootstrapped across episodes). The SAC update, the
optimizers, the soft target update and the checks of files are
`ble_latex.agents.sac_core`'s (Dopamine's `sac_agent.train`, batched), the
network `ble_latex.agents.networks`' (Dopamine's `SACNetwork` re-written):
both are shared with the jitted trainer, which imports no Dopamine.

What this wrapper changes, and why:
- The policy acts in a normalised box [-1, 1]^d; actions are mapped affinely
  to the env's Box [low, high] only on the way out. Dopamine would otherwise
  feed raw actions (e.g. a0 in [14 000, 21 000] m) into the critic MLP, and
  its entropy (and so the paper's target entropy 0) would depend on the units
  of the action. The target entropy is therefore that of the normalised
  action: H = 0 for a [-1, 1]^d box.
- Separate learning rates for actor, critics and temperature (Dopamine uses
  one gin-bound `create_optimizer` for all three; `sac_core.make_optimizers`).
- Eval mode always returns the deterministic policy mean, also before
  `min_replay_history` (Dopamine returns random actions then), and does not
  consume the agent's PRNG key.
- Replay sampling uses indices drawn from the agent's explicitly split JAX
  PRNG key (Dopamine samples with NumPy's global RNG), so a seed fixes every
  action and every update.
- Checkpoints are one msgpack file per iteration (`checkpoint_NNNNN.msgpack`,
  `ble_latex.safe_io`: data only, reading one cannot run code) holding
  network, target and optimizer states, temperature and its optimizer state,
  the PRNG key, the train-step counter and the filled part of the replay
  buffer; written atomically (temporary file, fsync, rename). Dopamine
  pickles the bundle and writes the replay buffer as a dozen separate,
  non-atomic files and does not save the PRNG key. Pickled checkpoints of
  older ble_latex versions are read only with `trust_legacy_pickle=True`.
- Observations and rewards are checked: NaN / inf / wrong shape raises a
  ValueError before any state changes.

The critics can be changed (`critic`, `ble_latex.agents.networks`):
Dopamine's MLPs (default), LayerNorm MLPs, or CrossQ's batch-norm critics
without target networks; the actor is Dopamine's in every case.
"""

import functools
import os
from typing import Any, Dict, Mapping, Optional, Sequence, Union

from absl import logging
from balloon_learning_environment.agents import agent
from dopamine.jax.agents.sac import sac_agent
from dopamine.replay_memory import circular_replay_buffer
import gin
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex.agents import networks
from ble_latex.agents import pretrained
from ble_latex.agents import sac_core
from ble_latex.flight import params as params_lib
from ble_latex import safe_io

_STORE_PREFIX = circular_replay_buffer.STORE_FILENAME_PREFIX


@functools.partial(jax.jit, static_argnums=0)
def _mean_action(network_def: networks.LatexSACNetwork, params: Any,
                 state: jnp.ndarray) -> jnp.ndarray:
  """Deterministic policy action tanh(mu(s)) in the normalised box."""
  # The actor also draws a sample; its key is irrelevant to the mean.
  output = network_def.apply(params, state, jax.random.PRNGKey(0),
                             method=network_def.actor)
  return output.mean_action


class _ScalarSummaryWriter:
  """Lets dopamine's SAC log its (1,)-shaped losses with flax's writer.

  Dopamine passes `train_returns[k]` arrays of shape (1,); flax's
  `SummaryWriter.scalar` calls float() on them, which NumPy >= 2.4 only allows
  for 0-d arrays. Everything else is the wrapped writer's.
  """

  def __init__(self, writer: Any):
    self._writer = writer

  def scalar(self, tag: str, value: Any, step: int) -> None:
    self._writer.scalar(tag, float(np.mean(np.asarray(value))), step)

  def __getattr__(self, name: str) -> Any:
    return getattr(self._writer, name)


class VectorReplayBuffer(circular_replay_buffer.OutOfGraphReplayBuffer):
  """Dopamine's uniform replay buffer with array-at-once sampling.

  Storage, `add`, episode-end bookkeeping and checkpoint elements are
  Dopamine's. For the 1-frame, 1-step transitions SAC uses here
  (`stack_size == 1`, `update_horizon == 1`), validity checks and batch
  gathering are done with NumPy fancy indexing instead of Dopamine's
  per-index Python loop (which was ~8 ms of a ~25 ms training step). The
  results equal Dopamine's element for element (tests/test_sac_agent.py);
  any other stack size or horizon falls back to Dopamine's code.
  """

  def _vectorizable(self) -> bool:
    return self._stack_size == 1 and self._update_horizon == 1

  def valid_transition_mask(self, indices: np.ndarray) -> np.ndarray:
    """Vectorised `is_valid_transition` for an array of indices.

    Args:
      indices: Integer array of replay indices.

    Returns:
      Boolean array, True where Dopamine's `is_valid_transition` is True.
    """
    indices = np.asarray(indices, dtype=np.int64)
    if not self._vectorizable():
      return np.array([self.is_valid_transition(int(i)) for i in indices],
                      dtype=bool)
    valid = (indices >= 0) & (indices < self._replay_capacity)
    if not self.is_full():
      valid &= indices < self.cursor() - self._update_horizon
    valid &= ~np.isin(indices, np.asarray(self.invalid_range, dtype=np.int64))
    # A transition cut by a time limit (episode end without a terminal flag)
    # has no next state of its own episode.
    if self.episode_end_indices:
      ends = np.fromiter(self.episode_end_indices, dtype=np.int64,
                         count=len(self.episode_end_indices))
      cut = np.isin(indices, ends)
      safe = np.clip(indices, 0, self._replay_capacity - 1)
      valid &= ~(cut & ~self._store['terminal'][safe].astype(bool))
    return valid

  def sample_transition_batch(self, batch_size=None, indices=None):
    """Dopamine's `sample_transition_batch`, gathered with array indexing."""
    if not self._vectorizable():
      return super().sample_transition_batch(batch_size, indices)
    if batch_size is None:
      batch_size = self._batch_size
    if indices is None:
      indices = self.sample_index_batch(batch_size)
    idx = np.asarray(indices, dtype=np.int64)
    assert len(idx) == batch_size
    nxt = (idx + 1) % self._replay_capacity
    store = self._store
    terminal = store['terminal'][idx].astype(bool)
    batch = []
    for element in self.get_transition_elements(batch_size):
      name = element.name
      if name in ('state', 'next_state'):
        rows = store['observation'][idx if name == 'state' else nxt]
        value = rows[..., np.newaxis]  # The 1-frame stack is the last axis.
      elif name in ('next_action', 'next_reward'):
        value = store[name[len('next_'):]][nxt]
      elif name == 'terminal':
        value = terminal
      elif name == 'indices':
        value = idx
      elif name in store:  # action, reward (1-step discounted sum = reward)
        value = store[name][idx]
      else:  # Filled by a subclass, as in Dopamine.
        value = np.empty(element.shape, dtype=element.type)
      batch.append(np.asarray(value, dtype=element.type).reshape(
          element.shape))
    return tuple(batch)


@gin.configurable(denylist=['num_actions', 'observation_shape', 'action_low',
                            'action_high'])
class SACAgent(agent.Agent, sac_agent.SACAgent):
  """Soft Actor-Critic with a Box action space, for BLE's train/eval loops."""

  supports_box_actions = True

  def __init__(
      self,
      num_actions: int,
      observation_shape: Sequence[int],
      *,
      action_low: Optional[Sequence[float]] = None,
      action_high: Optional[Sequence[float]] = None,
      seed: int = 0,
      num_layers: int = 2,
      hidden_units: int = 256,
      critic: str = 'mlp',
      gamma: float = 0.99,
      actor_learning_rate: float = 3e-4,
      critic_learning_rate: float = 3e-4,
      alpha_learning_rate: float = 3e-4,
      batch_size: int = 256,
      replay_capacity: int = 1_000_000,
      min_replay_history: int = 1000,
      update_period: int = 1,
      target_smoothing_coefficient: float = 0.005,
      target_entropy: float = 0.0,
      reward_scale_factor: float = 1.0,
      checkpoint_duration: Optional[int] = 2,
      summary_writing_frequency: int = 500,
      trust_legacy_pickle: bool = False):
    """Creates the agent.

    Args:
      num_actions: Dimension of the action vector (3 for LatexBalloon-v0).
      observation_shape: Shape of the observation vector.
      action_low: Lower bounds of the Box action space, shape (num_actions,).
        Defaults to -1 in every dimension.
      action_high: Upper bounds of the Box action space, shape (num_actions,).
        Defaults to +1 in every dimension.
      seed: Seed of the agent's JAX PRNG key (network init, exploration,
        replay sampling, policy sampling in the update).
      num_layers: Hidden layers of the actor and of each critic MLP.
      hidden_units: Units per hidden layer.
      critic: The twin critics, one of `networks.CRITICS`: 'mlp' (the
        paper's), 'layernorm' or 'crossq' (batch norm, no target networks).
      gamma: Discount factor.
      actor_learning_rate: Adam learning rate of the actor.
      critic_learning_rate: Adam learning rate of the twin critics.
      alpha_learning_rate: Adam learning rate of log(temperature).
      batch_size: Transitions per SAC update.
      replay_capacity: Replay buffer size in transitions (FIFO beyond it).
      min_replay_history: Transitions collected with uniform random actions
        before updates start.
      update_period: Environment steps per SAC update.
      target_smoothing_coefficient: Polyak factor tau of the target networks.
      target_entropy: Target policy entropy [nats] of the automatic
        temperature, measured on the normalised [-1, 1]^d action.
      reward_scale_factor: Rewards are multiplied by this in the TD target.
      checkpoint_duration: Keep checkpoints of the last this many iterations
        besides the newest (BLE's `clean_up_old_checkpoints`); None keeps all.
        Each checkpoint holds the replay buffer.
      summary_writing_frequency: Training steps between tensorboard scalars.
      trust_legacy_pickle: Also read pickle checkpoints written by ble_latex
        <= 0.1 (`checkpoint_NNNNN.pkl`). Unpickling can run code: set it only
        for files you made (README "Trusted files").

    Raises:
      ValueError: On an invalid action box or hyperparameter; the message
        names the gin binding (`SACAgent.<name>`).
    """
    observation_shape = tuple(int(d) for d in observation_shape)
    num_actions = int(num_actions)
    if num_actions < 1:
      raise ValueError(f'num_actions must be >= 1, got {num_actions}')
    low = (np.full(num_actions, -1.0) if action_low is None
           else np.asarray(action_low, dtype=np.float64))
    high = (np.full(num_actions, 1.0) if action_high is None
            else np.asarray(action_high, dtype=np.float64))
    if low.shape != (num_actions,) or high.shape != (num_actions,):
      raise ValueError(
          f'action_low/action_high must have shape ({num_actions},), got '
          f'{low.shape} and {high.shape}')
    if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high)) and
            np.all(low < high)):
      raise ValueError('action box must be finite with low < high, got '
                       f'low={low.tolist()}, high={high.tolist()}')
    sac_core.check_hyperparameters(
        'SACAgent', gamma=gamma, actor_learning_rate=actor_learning_rate,
        critic_learning_rate=critic_learning_rate,
        alpha_learning_rate=alpha_learning_rate, batch_size=batch_size,
        replay_capacity=replay_capacity, min_replay_history=min_replay_history,
        update_period=update_period,
        target_smoothing_coefficient=target_smoothing_coefficient,
        target_entropy=target_entropy, reward_scale_factor=reward_scale_factor,
        num_layers=num_layers, hidden_units=hidden_units,
        checkpoint_duration=checkpoint_duration,
        summary_writing_frequency=summary_writing_frequency)
    networks.check_critic('SACAgent', critic)
    self._critic = critic
    self._trust_legacy_pickle = bool(trust_legacy_pickle)
    self._action_low = low
    self._action_high = high
    self._seed = int(seed)
    self._num_layers = int(num_layers)
    self._hidden_units = int(hidden_units)
    self._actor_learning_rate = actor_learning_rate
    self._critic_learning_rate = critic_learning_rate
    self._alpha_learning_rate = alpha_learning_rate
    self._batch_size = int(batch_size)
    self._replay_capacity = int(replay_capacity)
    self._checkpoint_duration = checkpoint_duration
    self._episode_started = False
    agent.Agent.__init__(self, num_actions, observation_shape)
    # Dopamine's agent acts in the normalised box [-1, 1]^d.
    unit = np.ones(num_actions, dtype=np.float32)
    sac_agent.SACAgent.__init__(
        self,
        action_shape=(num_actions,),
        action_limits=(-unit, unit),
        observation_shape=observation_shape,
        action_dtype=jnp.float32,
        observation_dtype=jnp.float32,
        reward_scale_factor=reward_scale_factor,
        stack_size=1,
        network=functools.partial(networks.LatexSACNetwork,
                                  critic_type=critic),
        num_layers=self._num_layers,
        hidden_units=self._hidden_units,
        gamma=gamma,
        update_horizon=1,
        min_replay_history=min_replay_history,
        update_period=update_period,
        target_update_type='soft',
        target_smoothing_coefficient=target_smoothing_coefficient,
        target_entropy=float(target_entropy),
        eval_mode=False,
        summary_writer=None,
        summary_writing_frequency=summary_writing_frequency,
        seed=self._seed)

  # --- Construction (Dopamine hooks) ---------------------------------------

  def _build_replay_buffer(self) -> VectorReplayBuffer:
    """Dopamine's uniform replay buffer, sized by this agent's arguments."""
    return VectorReplayBuffer(
        observation_shape=self.observation_shape,
        stack_size=self.stack_size,
        replay_capacity=self._replay_capacity,
        batch_size=self._batch_size,
        update_horizon=self.update_horizon,
        gamma=self.gamma,
        observation_dtype=np.float32,
        action_shape=self.action_shape,
        action_dtype=np.float32)

  def _build_networks_and_optimizer(self) -> None:
    """Initialises SACNetwork, Adam per actor / critics, and log(alpha)."""
    self._rng, init_key = jax.random.split(self._rng)
    self.network_params = self.network_def.init(init_key, self.state, init_key)
    self.network_optimizer, self.alpha_optimizer = sac_core.make_optimizers(
        self.network_params, self._actor_learning_rate,
        self._critic_learning_rate, self._alpha_learning_rate)
    self.optimizer_state = self.network_optimizer.init(self.network_params)
    self.target_params = self.network_params
    self.log_alpha = jnp.zeros(1)  # Temperature alpha = exp(log_alpha) = 1.
    self.alpha_optimizer_state = self.alpha_optimizer.init(self.log_alpha)

  def _sample_from_replay_buffer(self) -> None:
    """Samples a uniform batch with indices from the agent's PRNG key."""
    self._rng, key = jax.random.split(self._rng)
    indices = self._sample_indices(key)
    samples = self._replay.sample_transition_batch(
        batch_size=self._batch_size, indices=indices)
    types = self._replay.get_transition_elements(self._batch_size)
    self.replay_elements = {t.name: s for s, t in zip(samples, types)}

  def _sample_indices(self, key: jnp.ndarray) -> np.ndarray:
    """Valid replay indices, uniform as in Dopamine's `sample_index_batch`."""
    replay = self._replay
    capacity = self._replay_capacity
    if replay.is_full():
      min_id = replay.cursor() - capacity + self.stack_size - 1
    else:
      min_id = self.stack_size - 1
    max_id = replay.cursor() - self.update_horizon
    if max_id <= min_id:
      raise RuntimeError('replay buffer holds too few transitions to sample')
    rng = np.random.default_rng(np.asarray(key, dtype=np.uint32))
    # Rejection sampling in rounds: uniform over the valid indices, as in
    # Dopamine, with the validity test done for a whole round at once.
    indices = np.empty(0, dtype=np.int64)
    for _ in range(20):
      candidates = rng.integers(min_id, max_id, size=self._batch_size)
      candidates %= capacity
      indices = np.concatenate(
          [indices, candidates[replay.valid_transition_mask(candidates)]])
      if len(indices) >= self._batch_size:
        return indices[:self._batch_size]
    raise RuntimeError('could not sample enough valid replay indices')

  def _train_step(self) -> None:
    """Dopamine's `_train_step` schedule, with the batched `update`."""
    if (self._replay.add_count > self.min_replay_history and
        self.training_steps % self.update_period == 0):
      self._sample_from_replay_buffer()
      self._rng, key = jax.random.split(self._rng)
      e = self.replay_elements
      out = sac_core.update(
          self.network_def, self.network_optimizer, self.alpha_optimizer,
          self.optimizer_state, self.alpha_optimizer_state,
          self.network_params, self.target_params, self.log_alpha, key,
          e['state'], e['action'], e['next_state'], e['reward'],
          e['terminal'], self.cumulative_gamma, self.target_entropy,
          self.reward_scale_factor)
      self.network_params = out['network_params']
      self.optimizer_state = out['optimizer_state']
      self.log_alpha = out['log_alpha']
      self.alpha_optimizer_state = out['alpha_optimizer_state']
      if (self.summary_writer is not None and self.training_steps > 0 and
          self.training_steps % self.summary_writing_frequency == 0):
        for name, value in out.items():
          if name.startswith(('Losses', 'Values')):
            self.summary_writer.scalar(name, value, self.training_steps)
        self.summary_writer.flush()
      self._maybe_sync_weights()
    self.training_steps += 1

  def _maybe_sync_weights(self) -> None:
    """Dopamine's soft target update, as one jitted call (was 18 eager ops)."""
    self.target_params = sac_core.polyak_update(
        self.network_params, self.target_params,
        self.target_smoothing_coefficient)

  # --- Input checks and action mapping -------------------------------------

  def _checked_observation(self, observation: np.ndarray) -> np.ndarray:
    obs = np.asarray(observation, dtype=np.float32)
    if obs.shape != tuple(self.observation_shape):
      raise ValueError(f'observation has shape {obs.shape}, expected '
                       f'{tuple(self.observation_shape)}')
    bad = np.flatnonzero(~np.isfinite(obs))
    if bad.size:
      raise ValueError(f'observation has non-finite values (NaN/inf) at '
                       f'indices {bad[:10].tolist()}')
    return obs

  @staticmethod
  def _checked_reward(reward: float) -> float:
    value = float(reward)
    if not np.isfinite(value):
      raise ValueError(f'reward must be finite, got {reward}')
    return value

  def _to_box(self, normalized: np.ndarray) -> np.ndarray:
    """Maps a [-1, 1]^d action affinely onto [low, high] (clipped)."""
    u = np.clip(np.asarray(normalized, dtype=np.float64), -1.0, 1.0)
    box = self._action_low + 0.5 * (u + 1.0) * (
        self._action_high - self._action_low)
    box = np.clip(box, self._action_low, self._action_high)
    # Rounding to float32 must not leave the box.
    box32 = box.astype(np.float32)
    return np.clip(box32, self._action_low.astype(np.float32),
                   self._action_high.astype(np.float32))

  def _choose_normalized_action(self) -> np.ndarray:
    if self.eval_mode:
      action = _mean_action(self.network_def, self.network_params, self.state)
    elif self._replay.add_count > self.min_replay_history:
      self._rng, action = sac_agent.select_action(
          self.network_def, self.network_params, self.state, self._rng, False)
    else:
      self._rng, key = jax.random.split(self._rng)
      action = jax.random.uniform(key, self.action_shape, jnp.float32,
                                  -1.0, 1.0)
    action = np.asarray(action, dtype=np.float32)
    if not np.all(np.isfinite(action)):
      raise sac_core.TrainingDiverged(
          f'SAC policy produced a non-finite action {action.tolist()} at '
          f'training step {self.training_steps}: the network parameters have '
          'diverged (check observation scaling and learning rates)')
    return action

  # --- BLE Agent interface -------------------------------------------------

  def get_name(self) -> str:
    return 'sac'

  def begin_episode(self, observation: np.ndarray) -> np.ndarray:
    """Starts an episode; returns the first action (inside the Box).

    Args:
      observation: First observation of the episode.

    Returns:
      float32 action of shape (num_actions,) inside [action_low, action_high].

    Raises:
      ValueError: If the observation has the wrong shape or NaN/inf values.
    """
    obs = self._checked_observation(observation)
    self._reset_state()
    self._record_observation(obs)
    if not self.eval_mode:
      self._train_step()
    self.action = self._choose_normalized_action()
    self._episode_started = True
    return self._to_box(self.action)

  def step(self, reward: float, observation: np.ndarray) -> np.ndarray:
    """Stores the last transition (train mode), updates, returns an action.

    Args:
      reward: Reward of the last action.
      observation: Observation after the last action.

    Returns:
      float32 action of shape (num_actions,) inside [action_low, action_high].

    Raises:
      ValueError: If the reward is not finite, or the observation has the
        wrong shape or NaN/inf values.
      RuntimeError: If no episode was begun.
    """
    obs = self._checked_observation(observation)
    reward = self._checked_reward(reward)
    if not self._episode_started:
      raise RuntimeError('step() called before begin_episode()')
    self._last_observation = self._observation
    self._record_observation(obs)
    if not self.eval_mode:
      self._store_transition(self._last_observation, self.action, reward,
                             False)
      self._train_step()
    self.action = self._choose_normalized_action()
    return self._to_box(self.action)

  def end_episode(self, reward: float, terminal: bool = True) -> None:
    """Stores the last transition of the episode (train mode).

    Args:
      reward: Reward of the last action.
      terminal: True at a true terminal state (no bootstrapping); False when
        the episode was cut (time limit), so the transition is never used as
        a bootstrapped target across episodes.

    Raises:
      ValueError: If the reward is not finite.
      RuntimeError: If no episode was begun.
    """
    reward = self._checked_reward(reward)
    if not self._episode_started:
      raise RuntimeError('end_episode() called before begin_episode()')
    sac_agent.SACAgent.end_episode(self, reward, bool(terminal))
    self._episode_started = False

  def set_summary_writer(self, summary_writer: Any) -> None:
    """Sets BLE's summary writer (adapted for dopamine's array scalars)."""
    super().set_summary_writer(
        None if summary_writer is None else _ScalarSummaryWriter(
            summary_writer))

  def set_mode(self, mode: Union[agent.AgentMode, str]) -> None:
    """TRAIN: sampled actions, stores transitions, updates. EVAL: mean action."""
    self.eval_mode = agent.AgentMode(mode) == agent.AgentMode.EVAL

  @property
  def replay_size(self) -> int:
    """Transitions added to the replay buffer so far."""
    return int(self._replay.add_count)

  @property
  def temperature(self) -> float:
    """Current entropy temperature alpha."""
    return float(jnp.exp(self.log_alpha)[0])

  # --- Checkpoints ---------------------------------------------------------

  def _config(self) -> Dict[str, Any]:
    return {
        'observation_shape': list(self.observation_shape),
        'num_actions': int(self._num_actions),
        'action_low': self._action_low.tolist(),
        'action_high': self._action_high.tolist(),
        'num_layers': self._num_layers,
        'hidden_units': self._hidden_units,
        'critic': self._critic,
        'replay_capacity': self._replay_capacity,
    }

  def _replay_bundle(self) -> Dict[str, Any]:
    """The replay buffer's state; stored arrays cut to their filled part."""
    filled = min(int(self._replay.add_count), self._replay_capacity)
    bundle = {}
    for name, value in self._replay._return_checkpointable_elements().items():  # pylint: disable=protected-access
      if name.startswith(_STORE_PREFIX):
        bundle[name] = np.array(value[:filled])
      elif name == 'episode_end_indices':
        bundle[name] = np.array(sorted(value), dtype=np.int64)
      elif isinstance(value, np.ndarray):
        bundle[name] = np.array(value)
      else:
        raise TypeError(f'unexpected replay buffer member {name!r} '
                        f'({type(value).__name__})')
    bundle['_next_experience_is_episode_start'] = bool(
        self._replay._next_experience_is_episode_start)  # pylint: disable=protected-access
    return bundle

  def _restore_replay(self, bundle: Mapping[str, Any]) -> None:
    # A fresh buffer of the same capacity, so nothing of the current one stays.
    replay = self._build_replay_buffer()
    expected = set(replay._return_checkpointable_elements()) | {  # pylint: disable=protected-access
        '_next_experience_is_episode_start'}
    if not isinstance(bundle, Mapping) or set(bundle) != expected:
      raise ValueError('replay buffer entries differ: expected '
                       f'{sorted(expected)}, found '
                       f'{sorted(bundle) if isinstance(bundle, Mapping) else bundle!r}')
    for name, value in bundle.items():
      if name.startswith(_STORE_PREFIX):
        array = replay._store[name[len(_STORE_PREFIX):]]  # pylint: disable=protected-access
        value = safe_io.checked_array(
            value, f'replay {name}',
            kind='float' if array.dtype.kind == 'f' else 'int')
        if value.ndim != array.ndim or value.shape[1:] != array.shape[1:] or (
            len(value) > len(array)):
          raise ValueError(f'replay {name} has shape {value.shape}, buffer '
                           f'{array.shape}')
        array[:len(value)] = value
      elif name == '_next_experience_is_episode_start':
        replay._next_experience_is_episode_start = bool(value)  # pylint: disable=protected-access
      elif name == 'episode_end_indices':
        indices = value if isinstance(value, (set, frozenset, list)) else (
            np.asarray(value).reshape(-1))  # Legacy pickles hold a set.
        replay.episode_end_indices = {int(i) for i in indices}
      else:  # add_count, invalid_range: counters.
        value = safe_io.checked_array(value, f'replay {name}', kind='int')
        if np.any(value < 0):
          raise ValueError(f'replay {name} must be >= 0, got {value}')
        setattr(replay, name, np.array(value))
    self._replay = replay

  def bundle_and_checkpoint(self, checkpoint_dir: str,
                            iteration_number: int) -> Dict[str, Any]:
    """The agent's full training state as a data-only dict (Dopamine API).

    Args:
      checkpoint_dir: Unused (everything is in the returned dict).
      iteration_number: Iteration the bundle belongs to.

    Returns:
      Dict with the format tag, config, train-step counter, PRNG key, online
      and target parameters, optimizer states (as lists of arrays), log(alpha)
      and the replay; only dicts, lists, numbers, strings and NumPy arrays
      (`safe_io.write_tree`).
    """
    del checkpoint_dir
    bundle = self.acting_bundle(iteration_number)
    self._check_finite(target_params=self.target_params,
                       optimizer_state=self.optimizer_state,
                       alpha_optimizer_state=self.alpha_optimizer_state)
    leaves = jax.tree_util.tree_leaves
    bundle.update(
        rng=np.asarray(self._rng),
        state=np.array(self.state),
        target_params=sac_core.to_numpy(self.target_params),
        optimizer_state=[np.asarray(x) for x in leaves(sac_core.to_numpy(
            self.optimizer_state))],
        alpha_optimizer_state=[np.asarray(x) for x in leaves(sac_core.to_numpy(
            self.alpha_optimizer_state))],
        replay=self._replay_bundle())
    return bundle

  def acting_bundle(self, iteration_number: int) -> Dict[str, Any]:
    """The part of `bundle_and_checkpoint` that acting needs.

    Format tag, iteration, config, train-step counter, online network
    parameters and log(alpha); no replay buffer, optimizer or target states.

    Args:
      iteration_number: Iteration the bundle belongs to.

    Returns:
      A dict with those entries, as in a checkpoint.

    Raises:
      sac_core.TrainingDiverged: If the parameters or log(alpha) hold NaN / inf
        (nothing is written from them).
    """
    self._check_finite(network_params=self.network_params,
                       log_alpha=self.log_alpha)
    return {
        'format': sac_core.CHECKPOINT_FORMAT,
        'iteration': int(iteration_number),
        'config': self._config(),
        'training_steps': int(self.training_steps),
        'network_params': sac_core.to_numpy(self.network_params),
        'log_alpha': np.asarray(self.log_alpha),
    }

  def _check_finite(self, **trees: Any) -> None:
    """Raises TrainingDiverged naming the trees that hold NaN / inf."""
    bad = {name: int(sac_core.nonfinite_count(tree))
           for name, tree in trees.items()}
    bad = {name: n for name, n in bad.items() if n}
    if bad:
      raise sac_core.TrainingDiverged(
          f'training diverged at training step {self.training_steps}: '
          f'non-finite {", ".join(f"{k} ({n} values)" for k, n in bad.items())}'
          '; no checkpoint or policy is written from it (the newest one on '
          'disk is the last good one)')

  def check_config(self, config: Any, what: str,
                   keys: Optional[Sequence[str]] = None) -> None:
    """Raises ValueError unless `config` (from a file) matches this agent's.

    Args:
      config: The `config` entry of a checkpoint or policy (`file_config`
        checks it first).
      what: The file, for the message.
      keys: The entries that must be equal (default: all of this agent's;
        a policy compares `ACTING_CONFIG_KEYS`).
    """
    mine = self._config()
    theirs = sac_core.file_config(config, what)
    keys = list(mine) if keys is None else list(keys)
    differ = [k for k in keys if theirs.get(k) != mine[k]]
    if differ:
      raise ValueError(
          f'{what}: its config has '
          f'{", ".join(f"{k}={theirs.get(k)!r}" for k in differ)}; this '
          f'agent has {", ".join(f"{k}={mine[k]!r}" for k in differ)}')

  def restore_network(self, network_params: Any, what: str) -> Any:
    """Network parameters from a file, checked against this agent's shapes."""
    return sac_core.restore_like(self.network_params, network_params,
                         f'{what}: network_params')

  def unbundle(self, checkpoint_dir: str, iteration_number: int,
               bundle_dictionary: Mapping[str, Any]) -> bool:
    """Restores the state written by `bundle_and_checkpoint` (Dopamine API).

    Nothing of the agent changes unless the whole bundle is valid.

    Args:
      checkpoint_dir: Unused.
      iteration_number: Unused (the bundle carries its own).
      bundle_dictionary: A dict from `bundle_and_checkpoint` (or a legacy
        pickle's, format `LEGACY_CHECKPOINT_FORMAT`).

    Returns:
      True.

    Raises:
      ValueError: If the bundle is not an ble_latex SAC checkpoint, misses an
        entry, or was written by an agent with a different shape / action box
        / network.
    """
    del checkpoint_dir, iteration_number
    bundle = bundle_dictionary
    what = 'checkpoint'
    if not isinstance(bundle, Mapping) or bundle.get('format') not in (
        sac_core.CHECKPOINT_FORMAT, sac_core.LEGACY_CHECKPOINT_FORMAT):
      raise ValueError('not a ble_latex SAC checkpoint (format '
                       f'{sac_core.CHECKPOINT_FORMAT!r} expected)')
    legacy = bundle['format'] == sac_core.LEGACY_CHECKPOINT_FORMAT
    needed = ('config', 'training_steps', 'rng', 'state', 'network_params',
              'target_params', 'optimizer_state', 'log_alpha',
              'alpha_optimizer_state', 'replay')
    missing = [k for k in needed if k not in bundle]
    if missing:
      raise ValueError(f'{what} misses {missing}')
    self.check_config(bundle['config'], what)
    training_steps = safe_io.checked_count(bundle['training_steps'],
                                           f'{what}: training_steps')
    if 'iteration' in bundle:
      safe_io.checked_count(bundle['iteration'], f'{what}: iteration')

    def opt_leaves(value):
      return jax.tree_util.tree_leaves(value) if legacy else value

    network_params = self.restore_network(bundle['network_params'], what)
    target_params = sac_core.restore_like(
        self.target_params, bundle['target_params'], f'{what}: target_params')
    optimizer_state = sac_core.restore_like(
        self.optimizer_state, opt_leaves(bundle['optimizer_state']),
        f'{what}: optimizer_state')
    alpha_optimizer_state = sac_core.restore_like(
        self.alpha_optimizer_state, opt_leaves(bundle['alpha_optimizer_state']),
        f'{what}: alpha_optimizer_state')
    log_alpha = sac_core.restore_like(self.log_alpha, bundle['log_alpha'],
                              f'{what}: log_alpha')
    rng = safe_io.checked_array(bundle['rng'], f'{what}: rng', kind='int',
                                shape=(2,)).astype(np.uint32)
    state = np.array(safe_io.checked_array(
        bundle['state'], f'{what}: state', shape=np.shape(self.state)))
    self._restore_replay(bundle['replay'])  # Raises before replacing.
    self.training_steps = training_steps
    self._rng = jnp.asarray(rng)
    self.state = state
    self.network_params = network_params
    self.target_params = target_params
    self.optimizer_state = optimizer_state
    self.log_alpha = log_alpha
    self.alpha_optimizer_state = alpha_optimizer_state
    self._episode_started = False
    return True

  def save_checkpoint(self, checkpoint_dir: str, iteration_number: int) -> None:
    """Writes checkpoint_dir/checkpoint_NNNNN.msgpack atomically.

    Call it between episodes (BLE does, after each iteration): the state of
    an unfinished episode is not saved. Numbered checkpoints older than
    `checkpoint_duration` iterations are removed afterwards.

    Args:
      checkpoint_dir: Folder of the checkpoints (created if missing).
      iteration_number: Iteration just completed.
    """
    os.makedirs(checkpoint_dir, exist_ok=True)
    safe_io.remove_stale_temporaries(checkpoint_dir, 'checkpoint_')
    bundle = self.bundle_and_checkpoint(checkpoint_dir, iteration_number)
    safe_io.write_tree(
        sac_core.checkpoint_path(checkpoint_dir, iteration_number), bundle,
        file_format=sac_core.CHECKPOINT_FORMAT)
    if self._checkpoint_duration is not None:
      for old in sac_core.checkpoint_iterations(checkpoint_dir):
        if old < iteration_number - self._checkpoint_duration:
          os.remove(sac_core.checkpoint_path(checkpoint_dir, old))

  def load_checkpoint(self, checkpoint_dir: str, iteration_number: int) -> None:
    """Restores the checkpoint of `iteration_number`.

    Reads `checkpoint_NNNNN.msgpack`; a legacy `checkpoint_NNNNN.pkl` only
    with `trust_legacy_pickle=True`. The agent is unchanged on any error.

    Args:
      checkpoint_dir: Folder of the checkpoints.
      iteration_number: Iteration to restore.

    Raises:
      FileNotFoundError: If there is no such checkpoint.
      safe_io.UntrustedFileError: If only a legacy pickle exists and
        `trust_legacy_pickle` is False.
      ValueError: If the file is truncated, corrupt or not a compatible SAC
        checkpoint (the message names the file).
    """
    path = sac_core.checkpoint_path(checkpoint_dir, iteration_number)
    legacy = sac_core.legacy_checkpoint_path(checkpoint_dir, iteration_number)
    if not os.path.exists(path) and os.path.exists(legacy):
      path = legacy
      bundle = safe_io.read_legacy_pickle(
          legacy, trust=self._trust_legacy_pickle, what='SAC checkpoint')
    else:
      bundle = safe_io.read_tree(path, file_format=sac_core.CHECKPOINT_FORMAT,
                                 what='SAC checkpoint')
    with safe_io.checking(f'SAC checkpoint {path}: '):
      self.unbundle(checkpoint_dir, iteration_number, bundle)
    logging.info('Restored SAC checkpoint %s (training step %d, replay %d).',
                 path, self.training_steps, self.replay_size)

  def reload_latest_checkpoint(self, checkpoint_dir: str) -> int:
    """Loads the newest numbered checkpoint in `checkpoint_dir`, if any.

    Only `checkpoint_NNNNN.msgpack` files count (legacy `.pkl` ones with
    `trust_legacy_pickle=True`); other files in the folder are ignored.

    Args:
      checkpoint_dir: Folder of the checkpoints.

    Returns:
      The iteration number of the loaded checkpoint (BLE's `Agent` semantics:
      training resumes at that number + 1), or -1 if there is none.

    Raises:
      safe_io.UntrustedFileError: If the folder holds only legacy pickle
        checkpoints and `trust_legacy_pickle` is False.
      ValueError: If the newest checkpoint cannot be read (never falls back
        silently to starting over).
    """
    iterations = sac_core.checkpoint_iterations(checkpoint_dir)
    legacy = sac_core.checkpoint_iterations(
        checkpoint_dir, sac_core.LEGACY_CHECKPOINT_PATTERN)
    if legacy and (not iterations or legacy[-1] > iterations[-1]):
      if not self._trust_legacy_pickle:
        newest = sac_core.legacy_checkpoint_path(checkpoint_dir, legacy[-1])
        raise safe_io.UntrustedFileError(
            f'{checkpoint_dir} holds legacy pickle checkpoints (newest '
            f'{os.path.basename(newest)}'
            '); pickles can run code. If you made them, resume with '
            "--gin_bindings='ble_latex.agents.sac.SACAgent.trust_legacy_pickle = True' "
            '(docs/trusted-files.md).')
      iterations = legacy
    if not iterations:
      return -1
    self.load_checkpoint(checkpoint_dir, iterations[-1])
    return iterations[-1]


@gin.configurable(denylist=['num_actions', 'observation_shape', 'action_low',
                            'action_high'])
class SACPretrainedAgent(SACAgent):
  """`SACAgent` with the shipped (or a given) policy loaded (`pretrained`)."""

  def __init__(self, num_actions: int, observation_shape: Sequence[int], *,
               action_low: Optional[Sequence[float]] = None,
               action_high: Optional[Sequence[float]] = None,
               seed: int = 0, policy_path: Optional[str] = None,
               trust_legacy_pickle: bool = False,
               **kwargs: Any):
    """Loads the policy, then builds the agent around it.

    Args:
      num_actions: Dimension of the action vector.
      observation_shape: Shape of the observation vector.
      action_low: Lower bounds of the Box action space.
      action_high: Upper bounds of the Box action space.
      seed: Agent seed (only used if the agent is fine-tuned).
      policy_path: Policy file (`.msgpack`). None: the shipped policy of
        the physics gin binds (`pretrained.shipped_policy`: the realistic
        one under gin_configs/latex_realistic.gin, else the paper's).
      trust_legacy_pickle: Also read a legacy `.pkl` policy or checkpoint.
        Unpickling can run code: only for files you made.
      **kwargs: Further `SACAgent` arguments.

    Raises:
      ValueError: If the policy file is bad or does not fit the env (checked
        before the agent's networks are built).
    """
    if policy_path is None:
      policy_path = pretrained.shipped_policy(
          params_lib.flight_params_from_gin().realistic)
    policy = pretrained.load_policy(policy_path, trust_legacy_pickle)
    config = policy['config']  # Checked by `sac_core.file_config`.
    for key in ('num_layers', 'hidden_units', 'critic'):
      kwargs.setdefault(key, config[key])
    super().__init__(num_actions, observation_shape, action_low=action_low,
                     action_high=action_high, seed=seed,
                     trust_legacy_pickle=trust_legacy_pickle, **kwargs)
    self.check_config(config, f'SAC policy {policy_path}',
                      keys=sac_core.ACTING_CONFIG_KEYS)
    self.network_params = self.restore_network(policy['network_params'],
                                               f'SAC policy {policy_path}')
    # Fine-tuning starts with the target networks equal to the online ones.
    self.target_params = self.network_params
    self.log_alpha = jnp.asarray(policy['log_alpha'], dtype=jnp.float32)
    self.policy_info = {k: policy[k] for k in ('source', 'iteration',
                                               'training_steps', 'note')}

  def get_name(self) -> str:
    return 'sac_pretrained'
