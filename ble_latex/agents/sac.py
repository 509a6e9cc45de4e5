# coding=utf-8
"""Soft Actor-Critic for Box actions, as a BLE `Agent` (wraps Dopamine's SAC).

The paper (Saunders et al. 2023, "RL problem") trains SAC (Haarnoja et al.
2018/2019): actor and twin critics as 2 x 256 MLPs, squashed-Gaussian policy,
automatic entropy temperature with target entropy 0, and a replay buffer.

What is reused from Dopamine 4.0.9 (`dopamine.jax.agents.sac.sac_agent`):
the jitted SAC update `sac_agent.train` (twin-critic TD loss with the clipped
double-Q target, reparameterised actor loss, temperature loss), the jitted
stochastic action sampler `sac_agent.select_action`, the network
`continuous_networks.SACNetwork` (tanh-squashed diagonal Gaussian actor, two
critics), the soft target update, the train-step schedule (`_train_step`),
and the out-of-graph `OutOfGraphReplayBuffer` with its episode-end handling
(transitions cut by a time limit are never bootstrapped across episodes).

What this wrapper changes, and why:
- The policy acts in a normalised box [-1, 1]^d; actions are mapped affinely
  to the env's Box [low, high] only on the way out. Dopamine would otherwise
  feed raw actions (e.g. a0 in [14 000, 21 000] m) into the critic MLP, and
  its entropy (and so the paper's target entropy 0) would depend on the units
  of the action. The target entropy is therefore that of the normalised
  action: H = 0 for a [-1, 1]^d box.
- Separate learning rates for actor, critics and temperature (Dopamine uses
  one gin-bound `create_optimizer` for all three) via `optax.multi_transform`.
- Eval mode always returns the deterministic policy mean, also before
  `min_replay_history` (Dopamine returns random actions then), and does not
  consume the agent's PRNG key.
- Replay sampling uses indices drawn from the agent's explicitly split JAX
  PRNG key (Dopamine samples with NumPy's global RNG), so a seed fixes every
  action and every update.
- Checkpoints are one pickle per iteration (BLE's `checkpoint_NNNNN.pkl`
  names) holding network, target and optimizer states, temperature and its
  optimizer state, the PRNG key, the train-step counter and the filled part
  of the replay buffer; written atomically (temporary file, fsync, rename).
  Dopamine writes the replay buffer as a dozen separate, non-atomic files and
  does not save the PRNG key.
- Observations and rewards are checked: NaN / inf / wrong shape raises a
  ValueError before any state changes.

Note that Dopamine's update samples the next action of the TD target from the
Polyak-averaged (target) actor rather than the online actor; we keep that.
"""

import functools
import os
import pickle
import secrets
from typing import Any, Dict, Mapping, Optional, Sequence, Union

from absl import logging
from balloon_learning_environment.agents import agent
from balloon_learning_environment.agents import dopamine_utils
from dopamine.jax import continuous_networks
from dopamine.jax.agents.sac import sac_agent
from dopamine.replay_memory import circular_replay_buffer
import gin
import jax
import jax.numpy as jnp
import numpy as np
import optax

CHECKPOINT_FORMAT = 'ble_latex.sac/1'
_TMP_PREFIX = '.tmp-'
_STORE_PREFIX = circular_replay_buffer.STORE_FILENAME_PREFIX


@functools.partial(jax.jit, static_argnums=0)
def _mean_action(network_def: continuous_networks.SACNetwork, params: Any,
                 state: jnp.ndarray) -> jnp.ndarray:
  """Deterministic policy action tanh(mu(s)) in the normalised box."""
  # The actor also draws a sample; its key is irrelevant to the mean.
  output = network_def.apply(params, state, jax.random.PRNGKey(0),
                             method=network_def.actor)
  return output.mean_action


def _param_labels(params: Any) -> Any:
  """Labels each parameter leaf 'critic' or 'actor' for multi_transform."""

  def label(path, _):
    names = [getattr(k, 'key', getattr(k, 'name', '')) for k in path]
    return ('critic' if any(str(n).startswith('_critic') for n in names)
            else 'actor')

  return jax.tree_util.tree_map_with_path(label, params)


def _to_numpy(tree: Any) -> Any:
  """Host (NumPy) copy of a pytree of arrays, for pickling."""
  return jax.tree.map(np.asarray, jax.device_get(tree))


def _to_device(tree: Any) -> Any:
  return jax.tree.map(jnp.asarray, tree)


def _atomic_pickle(path: str, obj: Any) -> None:
  """Pickles `obj` to `path` so that `path` is either old or complete.

  Writes to a temporary file in the same folder (a name BLE's checkpoint glob
  `checkpoint_*.pkl` never matches), fsyncs it, then renames it over `path`.

  Args:
    path: Destination file.
    obj: Object to pickle.
  """
  folder = os.path.dirname(path) or '.'
  tmp_path = os.path.join(folder, f'{_TMP_PREFIX}{os.path.basename(path)}-'
                          f'{os.getpid()}-{secrets.token_hex(4)}')
  # Mode 0o666 minus the umask, like a plain open() (mkstemp would use 0o600).
  fd = os.open(tmp_path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
  try:
    with os.fdopen(fd, 'wb') as f:
      pickle.dump(obj, f, protocol=pickle.HIGHEST_PROTOCOL)
      f.flush()
      os.fsync(f.fileno())
    os.replace(tmp_path, path)
  except BaseException:
    if os.path.exists(tmp_path):
      os.remove(tmp_path)
    raise
  try:  # Make the rename itself durable.
    dir_fd = os.open(folder, os.O_RDONLY)
    try:
      os.fsync(dir_fd)
    finally:
      os.close(dir_fd)
  except OSError:
    pass


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


@jax.jit
def _polyak_update(online_params: Any, target_params: Any,
                   tau: float) -> Any:
  """Soft target update tau * online + (1 - tau) * target, one XLA call."""
  return optax.incremental_update(online_params, target_params, tau)


def checkpoint_path(checkpoint_dir: str, iteration_number: int) -> str:
  """BLE's checkpoint file name (dopamine_utils) for `iteration_number`."""
  return os.path.join(checkpoint_dir, f'checkpoint_{iteration_number:05d}.pkl')


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
      summary_writing_frequency: int = 500):
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

    Raises:
      ValueError: On an invalid action box or hyperparameter.
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
    if batch_size < 1 or replay_capacity < 2 or min_replay_history < 0:
      raise ValueError('need batch_size >= 1, replay_capacity >= 2, '
                       'min_replay_history >= 0')
    if not 0.0 < target_smoothing_coefficient <= 1.0:
      raise ValueError('target_smoothing_coefficient must be in (0, 1], got '
                       f'{target_smoothing_coefficient}')
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
        network=continuous_networks.SACNetwork,
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
    self.network_optimizer = optax.multi_transform(
        {'actor': optax.adam(self._actor_learning_rate),
         'critic': optax.adam(self._critic_learning_rate)},
        _param_labels(self.network_params))
    self.optimizer_state = self.network_optimizer.init(self.network_params)
    self.target_params = self.network_params
    self.log_alpha = jnp.zeros(1)  # Temperature alpha = exp(log_alpha) = 1.
    self.alpha_optimizer = optax.adam(self._alpha_learning_rate)
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

  def _maybe_sync_weights(self) -> None:
    """Dopamine's soft target update, as one jitted call (was 18 eager ops)."""
    self.target_params = _polyak_update(
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
      raise FloatingPointError(
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
        'observation_shape': tuple(self.observation_shape),
        'num_actions': int(self._num_actions),
        'action_low': self._action_low.tolist(),
        'action_high': self._action_high.tolist(),
        'num_layers': self._num_layers,
        'hidden_units': self._hidden_units,
        'replay_capacity': self._replay_capacity,
    }

  def _replay_bundle(self) -> Dict[str, Any]:
    """The replay buffer's state; stored arrays cut to their filled part."""
    filled = min(int(self._replay.add_count), self._replay_capacity)
    bundle = {}
    for name, value in self._replay._return_checkpointable_elements().items():  # pylint: disable=protected-access
      if name.startswith(_STORE_PREFIX):
        bundle[name] = np.array(value[:filled])
      else:
        bundle[name] = pickle.loads(pickle.dumps(value))
    bundle['_next_experience_is_episode_start'] = (
        self._replay._next_experience_is_episode_start)  # pylint: disable=protected-access
    return bundle

  def _restore_replay(self, bundle: Mapping[str, Any]) -> None:
    # A fresh buffer of the same capacity, so nothing of the current one stays.
    self._replay = replay = self._build_replay_buffer()
    for name, value in bundle.items():
      if name.startswith(_STORE_PREFIX):
        array = replay._store[name[len(_STORE_PREFIX):]]  # pylint: disable=protected-access
        array[:len(value)] = value
      elif name == '_next_experience_is_episode_start':
        replay._next_experience_is_episode_start = value  # pylint: disable=protected-access
      else:
        setattr(replay, name, value)

  def bundle_and_checkpoint(self, checkpoint_dir: str,
                            iteration_number: int) -> Dict[str, Any]:
    """The agent's full training state as a picklable dict (Dopamine API).

    Args:
      checkpoint_dir: Unused (everything is in the returned dict).
      iteration_number: Iteration the bundle belongs to.

    Returns:
      Dict with the format tag, config, train-step counter, PRNG key, online
      and target parameters, optimizer states, log(alpha) and the replay.
    """
    del checkpoint_dir
    bundle = self.acting_bundle(iteration_number)
    bundle.update(
        rng=np.asarray(self._rng),
        state=np.array(self.state),
        target_params=_to_numpy(self.target_params),
        optimizer_state=_to_numpy(self.optimizer_state),
        alpha_optimizer_state=_to_numpy(self.alpha_optimizer_state),
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
    """
    return {
        'format': CHECKPOINT_FORMAT,
        'iteration': int(iteration_number),
        'config': self._config(),
        'training_steps': int(self.training_steps),
        'network_params': _to_numpy(self.network_params),
        'log_alpha': np.asarray(self.log_alpha),
    }

  def unbundle(self, checkpoint_dir: str, iteration_number: int,
               bundle_dictionary: Mapping[str, Any]) -> bool:
    """Restores the state written by `bundle_and_checkpoint` (Dopamine API).

    Args:
      checkpoint_dir: Unused.
      iteration_number: Unused (the bundle carries its own).
      bundle_dictionary: A dict from `bundle_and_checkpoint`.

    Returns:
      True.

    Raises:
      ValueError: If the bundle is not an ble_latex SAC checkpoint or was
        written by an agent with a different shape / action box / network.
    """
    del checkpoint_dir, iteration_number
    bundle = bundle_dictionary
    if not isinstance(bundle, Mapping) or bundle.get(
        'format') != CHECKPOINT_FORMAT:
      raise ValueError('not a ble_latex SAC checkpoint (format '
                       f'{CHECKPOINT_FORMAT!r} expected)')
    if bundle['config'] != self._config():
      raise ValueError('checkpoint was written by an agent with config '
                       f'{bundle["config"]}, this agent has {self._config()}')
    self.training_steps = int(bundle['training_steps'])
    self._rng = jnp.asarray(bundle['rng'], dtype=jnp.uint32)
    self.state = np.array(bundle['state'])
    self.network_params = _to_device(bundle['network_params'])
    self.target_params = _to_device(bundle['target_params'])
    self.optimizer_state = _to_device(bundle['optimizer_state'])
    self.log_alpha = jnp.asarray(bundle['log_alpha'])
    self.alpha_optimizer_state = _to_device(bundle['alpha_optimizer_state'])
    self._restore_replay(bundle['replay'])
    self._episode_started = False
    return True

  def save_checkpoint(self, checkpoint_dir: str, iteration_number: int) -> None:
    """Writes checkpoint_dir/checkpoint_NNNNN.pkl atomically.

    Call it between episodes (BLE does, after each iteration): the state of
    an unfinished episode is not saved. Older checkpoints beyond
    `checkpoint_duration` iterations are removed afterwards.

    Args:
      checkpoint_dir: Folder of the checkpoints (created if missing).
      iteration_number: Iteration just completed.
    """
    os.makedirs(checkpoint_dir, exist_ok=True)
    for name in os.listdir(checkpoint_dir):  # Leftovers of a killed write.
      if name.startswith(_TMP_PREFIX + 'checkpoint_'):
        os.remove(os.path.join(checkpoint_dir, name))
    bundle = self.bundle_and_checkpoint(checkpoint_dir, iteration_number)
    _atomic_pickle(checkpoint_path(checkpoint_dir, iteration_number), bundle)
    if self._checkpoint_duration is not None:
      dopamine_utils.clean_up_old_checkpoints(
          checkpoint_dir, iteration_number,
          checkpoint_duration=self._checkpoint_duration)

  def load_checkpoint(self, checkpoint_dir: str, iteration_number: int) -> None:
    """Restores the checkpoint of `iteration_number`.

    Args:
      checkpoint_dir: Folder of the checkpoints.
      iteration_number: Iteration to restore.

    Raises:
      FileNotFoundError: If there is no such checkpoint.
      ValueError: If the file is not a compatible SAC checkpoint.
    """
    path = checkpoint_path(checkpoint_dir, iteration_number)
    if not os.path.isfile(path):
      raise FileNotFoundError(f'no SAC checkpoint {path}')
    try:
      with open(path, 'rb') as f:
        bundle = pickle.load(f)
    except (pickle.UnpicklingError, EOFError, AttributeError) as e:
      raise ValueError(f'unreadable SAC checkpoint {path}: {e}') from e
    self.unbundle(checkpoint_dir, iteration_number, bundle)
    logging.info('Restored SAC checkpoint %s (training step %d, replay %d).',
                 path, self.training_steps, self.replay_size)

  def reload_latest_checkpoint(self, checkpoint_dir: str) -> int:
    """Loads the newest checkpoint in `checkpoint_dir`, if any.

    Args:
      checkpoint_dir: Folder of the checkpoints.

    Returns:
      The iteration number of the loaded checkpoint (BLE's `Agent` semantics:
      training resumes at that number + 1), or -1 if there is none.
    """
    latest = dopamine_utils.get_latest_checkpoint(checkpoint_dir)
    if latest < 0:
      return -1
    self.load_checkpoint(checkpoint_dir, latest)
    return latest
