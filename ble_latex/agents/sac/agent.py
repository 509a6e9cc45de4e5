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
`ble_latex.agents.sac.core`'s (Dopamine's `sac_agent.train`, batched), the
network `ble_latex.agents.sac.networks`' (Dopamine's `SACNetwork` re-written):
both are shared with the jitted trainer, which imports no Dopamine.

What this wrapper changes, and why:
- The policy acts in a normalised box [-1, 1]^d; actions are mapped affinely
  to the env's Box [low, high] only on the way out, by the functional env's
  one mapping (`jax_env.to_box`, which the jitted trainer flies too).
  Dopamine would otherwise feed raw actions (e.g. a0 in [14 000, 21 000] m)
  into the critic MLP, and its entropy (and so the paper's target entropy 0)
  would depend on the units of the action. The target entropy is therefore
  that of the normalised action: H = 0 for a [-1, 1]^d box.
- Separate learning rates for actor, critics and temperature (Dopamine uses
  one gin-bound `create_optimizer` for all three; `sac_core.make_optimizers`).
- Eval mode always returns the deterministic policy mean, also before
  `min_replay_history` (Dopamine returns random actions then), and does not
  consume the agent's PRNG key.
- Replay sampling uses indices drawn from the agent's explicitly split JAX
  PRNG key (Dopamine samples with NumPy's global RNG), so a seed fixes every
  action and every update.
- Checkpoints are one msgpack file per iteration, data only, written
  atomically and checked when read (`ble_latex.agents.sac.checkpoint`).
- Observations and rewards are checked: NaN / inf / wrong shape raises a
  ValueError before any state changes.

The hyperparameters' defaults are `sac_core.SACHyperparameters`' (shared
with the jitted trainer). The critics can be changed (`critic`,
`ble_latex.agents.sac.networks`): Dopamine's MLPs (default), LayerNorm MLPs, or
CrossQ's batch-norm critics without target networks; the actor is
Dopamine's in every case.
"""

import functools
from typing import Any, Dict, Optional, Sequence, Union

from balloon_learning_environment.agents import agent
from dopamine.jax.agents.sac import sac_agent
from dopamine.replay_memory import circular_replay_buffer
import gin
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import errors
from ble_latex.agents.sac import checkpoint as sac_checkpoint
from ble_latex.agents.sac import core as sac_core
from ble_latex.agents.sac import networks
from ble_latex.agents.sac import pretrained
from ble_latex.envs import env_params
from ble_latex.envs import jax_env
from ble_latex.flight import params as params_lib

_D = sac_core.SAC_DEFAULTS  # The keyword defaults below.
# The one [-1, 1]^d -> Box mapping (the functional env's), compiled once.
_to_box = jax.jit(jax_env.to_box)


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
  results equal Dopamine's element for element (tests/agents/sac/test_agent.py);
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


class _AgentHyperparameters(sac_core.SACHyperparameters):
  """The record, its errors naming the agent's gin bindings (`SACAgent.*`)."""
  GIN_NAME = 'SACAgent'


@gin.configurable(module='ble_latex.agents.sac',
                denylist=['num_actions', 'observation_shape', 'action_low',
                          'action_high'])
class SACAgent(sac_checkpoint.SACCheckpoints, agent.Agent,
               sac_agent.SACAgent):
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
      num_layers: int = _D.num_layers,
      hidden_units: int = _D.hidden_units,
      critic: str = _D.critic,
      gamma: float = _D.gamma,
      actor_learning_rate: float = _D.actor_learning_rate,
      critic_learning_rate: float = _D.critic_learning_rate,
      alpha_learning_rate: float = _D.alpha_learning_rate,
      batch_size: int = _D.batch_size,
      replay_capacity: int = _D.replay_capacity,
      min_replay_history: int = _D.min_replay_history,
      update_period: int = 1,
      target_smoothing_coefficient: float = _D.target_smoothing_coefficient,
      target_entropy: float = _D.target_entropy,
      reward_scale_factor: float = _D.reward_scale_factor,
      checkpoint_duration: Optional[int] = 2,
      summary_writing_frequency: int = 500,
      trust_legacy_pickle: bool = False):
    """Creates the agent.

    SAC's hyperparameters (`num_layers`, `hidden_units`, `critic`, `gamma`,
    the three learning rates, `batch_size`, `replay_capacity`,
    `min_replay_history`, `target_smoothing_coefficient`, `target_entropy`,
    `reward_scale_factor`) are `sac_core.SACHyperparameters`' fields: their
    meaning and defaults are there.

    Args:
      num_actions: Dimension of the action vector (3 for LatexBalloon-v0).
      observation_shape: Shape of the observation vector.
      action_low: Lower bounds of the Box action space, shape (num_actions,):
        the latex core's (`jax_env.ACTION_LOW`, the default), the Box
        `jax_env.to_box` maps onto.
      action_high: Upper bounds of the Box action space (`jax_env.ACTION_HIGH`).
      seed: Seed of the agent's JAX PRNG key (network init, exploration,
        replay sampling, policy sampling in the update).
      update_period: Environment steps per SAC update.
      checkpoint_duration: Keep checkpoints of the last this many iterations
        besides the newest (BLE's `clean_up_old_checkpoints`); None keeps all.
        Each checkpoint holds the replay buffer.
      summary_writing_frequency: Training steps between tensorboard scalars.
      trust_legacy_pickle: Also read pickle checkpoints written by ble_latex
        <= 0.1 (`checkpoint_NNNNN.pkl`). Unpickling can run code: set it only
        for files you made (README "Trusted files").

    Raises:
      errors.ConfigError: On an invalid action box or hyperparameter; the
        message names the gin binding (`SACAgent.<name>`).
    """
    observation_shape = tuple(int(d) for d in observation_shape)
    num_actions = int(num_actions)
    if num_actions < 1:
      raise ValueError(f'num_actions must be >= 1, got {num_actions}')
    low = np.asarray(jax_env.ACTION_LOW if action_low is None else action_low,
                     dtype=np.float64)
    high = np.asarray(
        jax_env.ACTION_HIGH if action_high is None else action_high,
        dtype=np.float64)
    if low.shape != (num_actions,) or high.shape != (num_actions,):
      raise ValueError(
          f'action_low/action_high must have shape ({num_actions},), got '
          f'{low.shape} and {high.shape}')
    if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high)) and
            np.all(low < high)):
      raise errors.ConfigError(
          'action box must be finite with low < high, got '
          f'low={low.tolist()}, high={high.tolist()}')
    core_low = np.asarray(jax_env.ACTION_LOW, np.float64)
    core_high = np.asarray(jax_env.ACTION_HIGH, np.float64)
    if low.shape != core_low.shape or not (
        np.array_equal(low, core_low) and np.array_equal(high, core_high)):
      raise errors.ConfigError(
          f'SACAgent flies the latex core\'s action Box low='
          f'{core_low.tolist()}, high={core_high.tolist()} (jax_env.to_box); '
          f'got low={low.tolist()}, high={high.tolist()}')
    sac_core.check_hyperparameters(
        'SACAgent', update_period=update_period,
        checkpoint_duration=checkpoint_duration,
        summary_writing_frequency=summary_writing_frequency)
    hp = _AgentHyperparameters(
        gamma=gamma, actor_learning_rate=actor_learning_rate,
        critic_learning_rate=critic_learning_rate,
        alpha_learning_rate=alpha_learning_rate, batch_size=batch_size,
        replay_capacity=replay_capacity, min_replay_history=min_replay_history,
        target_smoothing_coefficient=target_smoothing_coefficient,
        target_entropy=target_entropy, reward_scale_factor=reward_scale_factor,
        num_layers=num_layers, hidden_units=hidden_units, critic=critic)
    self.hyperparameters = hp
    self._critic = hp.critic
    self._trust_legacy_pickle = bool(trust_legacy_pickle)
    self._action_low = low
    self._action_high = high
    self._seed = int(seed)
    self._num_layers = int(hp.num_layers)
    self._hidden_units = int(hp.hidden_units)
    self._batch_size = int(hp.batch_size)
    self._replay_capacity = int(hp.replay_capacity)
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
    hp = self.hyperparameters
    self.network_optimizer, self.alpha_optimizer = sac_core.make_optimizers(
        self.network_params, hp.actor_learning_rate, hp.critic_learning_rate,
        hp.alpha_learning_rate)
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

  @staticmethod
  def _to_box(normalized: np.ndarray) -> np.ndarray:
    """A [-1, 1]^d action on the core's Box: `jax_env.to_box`, float32."""
    return np.asarray(_to_box(np.asarray(normalized, np.float32)))

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

  def _config(self) -> Dict[str, Any]:
    """What a checkpoint or policy records of this agent's shapes."""
    return {
        'observation_shape': list(self.observation_shape),
        'num_actions': int(self._num_actions),
        'action_low': self._action_low.tolist(),
        'action_high': self._action_high.tolist(),
        'num_layers': self._num_layers,
        'hidden_units': self._hidden_units,
        'critic': self._critic,
        'replay_capacity': self._replay_capacity,
        # What the env's features mean (gin `latex_observation.*`).
        **env_params.observation_of(env_params.observation_settings()),
    }


@gin.configurable(module='ble_latex.agents.sac',
                denylist=['num_actions', 'observation_shape', 'action_low',
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
