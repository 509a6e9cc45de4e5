# coding=utf-8
"""Soft Actor-Critic for Box actions, as a BLE `Agent` (wraps Dopamine's SAC).

The paper (Saunders et al. 2023, "RL problem") trains SAC (Haarnoja et al.
2018/2019): actor and twin critics as 2 x 256 MLPs, squashed-Gaussian policy,
automatic entropy temperature with target entropy 0, and a replay buffer.

What is reused from Dopamine 4.0.9 (`dopamine.jax.agents.sac.sac_agent`):
the SAC update of `sac_agent.train` (twin-critic TD loss with the clipped
double-Q target, reparameterised actor loss, temperature loss), computed by
`update` on the whole batch at once (Dopamine averages B per-transition
gradients: the same number at ~4x the cost; tests check `update` against
`sac_agent.train`), the jitted
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

Note that Dopamine's update samples the next action of the TD target from the
Polyak-averaged (target) actor rather than the online actor; we keep that.

The critics can be changed (`critic`, `ble_latex.agents.networks`):
Dopamine's MLPs (default), LayerNorm MLPs, or CrossQ's batch-norm critics
without target networks; the actor is Dopamine's in every case.
"""

import functools
import os
import re
from typing import Any, Dict, Mapping, Optional, Sequence, Union

from absl import logging
from balloon_learning_environment.agents import agent
from dopamine.jax.agents.sac import sac_agent
from dopamine.replay_memory import circular_replay_buffer
import gin
import jax
import jax.numpy as jnp
import numpy as np
import optax

from ble_latex.agents import networks
from ble_latex import safe_io

CHECKPOINT_FORMAT = 'ble_latex.sac/2'  # msgpack (`safe_io`).
LEGACY_CHECKPOINT_FORMAT = 'ble_latex.sac/1'  # Pickles of ble_latex <= 0.1.
CHECKPOINT_PATTERN = re.compile(r'^checkpoint_(\d+)\.msgpack$')
LEGACY_CHECKPOINT_PATTERN = re.compile(r'^checkpoint_(\d+)\.pkl$')
_STORE_PREFIX = circular_replay_buffer.STORE_FILENAME_PREFIX
# Largest networks a gin binding or a checkpoint / policy file may ask for:
# a file's config is checked against these before anything is built from it.
MAX_NUM_LAYERS = 16
MAX_HIDDEN_UNITS = 4096
MAX_OBSERVATION_SIZE = 4096  # Features of a file's observation_shape.
MAX_NUM_ACTIONS = 64
# What `file_config` checks and `check_config` compares: the config entries
# that fix the network's shapes and the action box. Policies need no more.
ACTING_CONFIG_KEYS = ('observation_shape', 'num_actions', 'action_low',
                      'action_high', 'num_layers', 'hidden_units', 'critic')


class TrainingDiverged(FloatingPointError):
  """Training produced NaN / inf (parameters, losses, actions, rewards)."""


@functools.partial(jax.jit, static_argnums=0)
def _mean_action(network_def: networks.LatexSACNetwork, params: Any,
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
  """Host (NumPy) copy of a pytree of arrays, for checkpoints."""
  return jax.tree.map(np.asarray, jax.device_get(tree))


def _to_device(tree: Any) -> Any:
  return jax.tree.map(jnp.asarray, tree)


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


def _update_losses(network_def: networks.LatexSACNetwork, params: Any,
                   log_alpha: jnp.ndarray, target_params: Any, key: jnp.ndarray,
                   states: jnp.ndarray, actions: jnp.ndarray,
                   next_states: jnp.ndarray, rewards: jnp.ndarray,
                   terminals: jnp.ndarray, cumulative_gamma: float,
                   target_entropy: float, reward_scale_factor: float):
  """Dopamine's SAC loss (`sac_agent.train`'s `loss_fn`), over a whole batch.

  Dopamine differentiates the loss of each transition separately (a vmapped
  `value_and_grad`) and averages the B gradients; this takes the gradient of
  the batch mean once, which is the same number without B per-example
  gradient copies. Everything else is Dopamine's: per-transition keys split
  from `key`, the target critic evaluated at the target actor's mean action
  with the sampled action's log-probability (Haarnoja et al. 2018, eq. 5),
  the actor loss through critics that are not updated by it (eq. 9), and the
  temperature loss (eq. 18); weights 0.5 / 1 / 1.

  CrossQ critics (`networks.CRITICS`; Bhatt et al. 2024) have no target
  network: the online actor gives the next action the same way, and the
  critics see the B current and B next state-action pairs as one batch of
  2B in training mode, so both are normalised with the same batch
  statistics; the next-state values are not differentiated. The actor loss
  reads the critics with their running statistics. The updated running
  statistics come back in the aux dict as `batch_stats`.
  """
  batch = states.shape[0]
  keys = jax.vmap(lambda k: jax.random.split(k, 2))(
      jax.random.split(key, batch))
  actor_keys, target_keys = keys[:, 1], keys[:, 0]
  critic = lambda p, s, a: network_def.apply(p, s, a,
                                             method=network_def.critic)
  alpha = jnp.exp(log_alpha)
  extra = {}
  if networks.uses_target_network(network_def):
    q1, q2 = jax.vmap(critic, in_axes=(None, 0, 0))(params, states, actions)
    target_out = jax.vmap(lambda s, k: network_def.apply(
        target_params, s, k, True))(next_states, target_keys)
    target_q1, target_q2 = target_out.critic
    next_log_prob = target_out.actor.log_probability
  else:
    next_actor = jax.vmap(lambda s, k: network_def.apply(
        params, s, k, method=network_def.actor))(next_states, target_keys)
    joint, updated = network_def.apply(
        params, jnp.concatenate([states, next_states]),
        jnp.concatenate([actions,
                         jax.lax.stop_gradient(next_actor.mean_action)]),
        True, method=network_def.critic, mutable=['batch_stats'])
    q1, target_q1 = jnp.split(joint.q_value1, 2)
    q2, target_q2 = jnp.split(joint.q_value2, 2)
    next_log_prob = next_actor.log_probability
    extra['batch_stats'] = updated['batch_stats']
  q1, q2 = q1.reshape(batch), q2.reshape(batch)
  target_q1, target_q2 = target_q1.reshape(batch), target_q2.reshape(batch)
  target = reward_scale_factor * rewards + cumulative_gamma * (
      jnp.minimum(target_q1, target_q2) - alpha * next_log_prob) * (
          1.0 - terminals)
  target = jax.lax.stop_gradient(target)
  critic_loss = jnp.mean((q1 - target) ** 2 + (q2 - target) ** 2)
  mean_action, sampled_action, log_prob = jax.vmap(
      lambda s, k: network_def.apply(params, s, k, method=network_def.actor))(
          states, actor_keys)
  frozen = jax.lax.stop_gradient(params)
  no_grad_q1, no_grad_q2 = jax.vmap(critic, in_axes=(None, 0, 0))(
      frozen, states, sampled_action)
  no_grad_q = jnp.minimum(no_grad_q1, no_grad_q2).reshape(batch)
  policy_loss = jnp.mean(jnp.exp(jax.lax.stop_gradient(log_alpha)) * log_prob
                         - no_grad_q)
  alpha_loss = jnp.mean(
      log_alpha * jax.lax.stop_gradient(-log_prob - target_entropy)[:, None])
  combined = 0.5 * critic_loss + policy_loss + alpha_loss
  return combined, {
      'critic_loss': critic_loss, 'policy_loss': policy_loss,
      'alpha_loss': alpha_loss, 'critic_value_1': jnp.mean(q1),
      'critic_value_2': jnp.mean(q2), 'target_value_1': jnp.mean(target_q1),
      'target_value_2': jnp.mean(target_q2),
      'mean_action': jnp.mean(mean_action, axis=0), **extra}


@functools.partial(jax.jit, static_argnums=(0, 1, 2))
def update(network_def: networks.LatexSACNetwork,
           optimizer: optax.GradientTransformation,
           alpha_optimizer: optax.GradientTransformation,
           optimizer_state: Any, alpha_optimizer_state: Any,
           network_params: Any, target_params: Any, log_alpha: jnp.ndarray,
           key: jnp.ndarray, states: jnp.ndarray, actions: jnp.ndarray,
           next_states: jnp.ndarray, rewards: jnp.ndarray,
           terminals: jnp.ndarray, cumulative_gamma: float,
           target_entropy: float, reward_scale_factor: float
           ) -> Dict[str, Any]:
  """One SAC update: Dopamine's `sac_agent.train`, batched (same arguments).

  The one SAC update of the project: `SACAgent` and the jitted trainer
  (`sac_trainer`) both call it. `tests/test_sac_agent.py` checks it against
  Dopamine's `sac_agent.train` on the same inputs.

  Returns:
    Dopamine's dict: new `network_params`, `log_alpha`, `optimizer_state`,
    `alpha_optimizer_state` and the `Losses/*`, `Values/*` scalars.
  """
  batch = states.shape[0]
  states = states.reshape(batch, -1)
  next_states = next_states.reshape(batch, -1)
  actions = actions.reshape(batch, -1)
  grad_fn = jax.value_and_grad(_update_losses, argnums=(1, 2), has_aux=True)
  (_, aux), (network_gradient, alpha_gradient) = grad_fn(
      network_def, network_params, log_alpha, target_params, key, states,
      actions, next_states, rewards.reshape(batch),
      terminals.reshape(batch).astype(jnp.float32), cumulative_gamma,
      target_entropy, reward_scale_factor)
  updates, optimizer_state = optimizer.update(
      network_gradient, optimizer_state, params=network_params)
  network_params = optax.apply_updates(network_params, updates)
  if 'batch_stats' in aux:  # CrossQ: running statistics, not gradients.
    network_params = {**network_params, 'batch_stats': aux['batch_stats']}
  alpha_updates, alpha_optimizer_state = alpha_optimizer.update(
      alpha_gradient, alpha_optimizer_state, params=log_alpha)
  log_alpha = optax.apply_updates(log_alpha, alpha_updates)
  returns = {
      'network_params': network_params, 'log_alpha': log_alpha,
      'optimizer_state': optimizer_state,
      'alpha_optimizer_state': alpha_optimizer_state,
      'Losses/Critic': aux['critic_loss'], 'Losses/Actor': aux['policy_loss'],
      'Losses/Alpha': aux['alpha_loss'],
      'Values/CriticValues1': aux['critic_value_1'],
      'Values/CriticValues2': aux['critic_value_2'],
      'Values/TargetValues1': aux['target_value_1'],
      'Values/TargetValues2': aux['target_value_2'],
      'Values/Alpha': jnp.exp(log_alpha)}
  for i, a in enumerate(aux['mean_action']):
    returns[f'Values/MeanActions{i}'] = a
  return returns


def make_optimizers(params: Any, actor_learning_rate: float,
                    critic_learning_rate: float, alpha_learning_rate: float
                    ) -> tuple:
  """(network optimizer, temperature optimizer): Adam per actor / critics."""
  network = optax.multi_transform(
      {'actor': optax.adam(actor_learning_rate),
       'critic': optax.adam(critic_learning_rate)}, _param_labels(params))
  return network, optax.adam(alpha_learning_rate)


def check_hyperparameters(owner: str, **values: Any) -> None:
  """Raises ValueError naming the `<owner>.<name>` binding that is invalid.

  Args:
    owner: The gin configurable the values are bound to (`SACAgent`).
    **values: Hyperparameters by name; names not given are not checked.
  """

  def number(name, lo=None, hi=None, lo_open=False, integer=False,
             allow_none=False):
    if name not in values:
      return
    value = values[name]
    if value is None and allow_none:
      return
    ok = (isinstance(value, (int, float, np.integer, np.floating)) and
          not isinstance(value, bool) and np.isfinite(value) and
          (not integer or float(value).is_integer()))
    if ok and lo is not None:
      ok = value > lo if lo_open else value >= lo
    if ok and hi is not None:
      ok = value <= hi
    if not ok:
      bounds = ''
      if lo is not None:
        bounds += f' {">" if lo_open else ">="} {lo}'
      if hi is not None:
        bounds += f'{" and" if lo is not None else ""} <= {hi}'
      kind = 'an integer' if integer else 'a finite number'
      raise ValueError(f'{owner}.{name} must be {kind}{bounds}, got '
                       f'{value!r}')

  number('gamma', 0.0, 1.0)
  for name in ('actor_learning_rate', 'critic_learning_rate',
               'alpha_learning_rate'):
    number(name, 0.0, lo_open=True)
  number('batch_size', 1, integer=True)
  number('replay_capacity', 2, integer=True)
  number('min_replay_history', 0, integer=True)
  number('update_period', 1, integer=True)
  number('target_smoothing_coefficient', 0.0, 1.0, lo_open=True)
  number('target_entropy')
  number('reward_scale_factor', 0.0, lo_open=True)
  number('num_layers', 1, MAX_NUM_LAYERS, integer=True)
  number('hidden_units', 1, MAX_HIDDEN_UNITS, integer=True)
  number('checkpoint_duration', 0, integer=True, allow_none=True)
  number('summary_writing_frequency', 1, integer=True)


def checkpoint_path(checkpoint_dir: str, iteration_number: int) -> str:
  """The checkpoint file of `iteration_number` (BLE's numbering)."""
  return os.path.join(checkpoint_dir,
                      f'checkpoint_{iteration_number:05d}.msgpack')


def legacy_checkpoint_path(checkpoint_dir: str, iteration_number: int) -> str:
  """The pickle checkpoint an older ble_latex wrote for `iteration_number`."""
  return os.path.join(checkpoint_dir, f'checkpoint_{iteration_number:05d}.pkl')


def checkpoint_iterations(checkpoint_dir: str,
                          pattern: re.Pattern = CHECKPOINT_PATTERN) -> list:
  """Iterations of the numbered checkpoints in a folder, ascending.

  Only names that match `pattern` exactly count: stray files such as
  `checkpoint_backup.pkl` or `checkpoint_00002 (copy).msgpack` are ignored
  (BLE's `get_latest_checkpoint` gives -1 when it meets one).

  Args:
    checkpoint_dir: Folder to scan (missing: no checkpoints).
    pattern: Regex with the iteration as group 1.

  Returns:
    Sorted iteration numbers.
  """
  if not os.path.isdir(checkpoint_dir):
    return []
  found = (pattern.match(name) for name in os.listdir(checkpoint_dir))
  return sorted(int(m.group(1)) for m in found if m)


def _restore_like(template: Any, stored: Any, what: str) -> Any:
  """A tree shaped like `template` from stored data, checked leaf by leaf.

  Args:
    template: The agent's current tree (e.g. freshly initialised parameters).
    stored: A tree of the same structure (dicts), or the list of its leaves
      in `jax.tree_util` order (optimizer states, whose named tuples a data
      file does not hold).
    what: Name for error messages.

  Returns:
    `stored`'s values on the device, in `template`'s structure and dtypes.

  Raises:
    ValueError: On a different structure, leaf count, leaf shape or kind of
      dtype (real floats where the template has floats, integers where it
      has integers), or a NaN / inf; the message names the leaf.
  """
  return _to_device(check_like(template, stored, what))


def check_like(template: Any, stored: Any, what: str) -> Any:
  """`_restore_like`'s checks, on the host: stored leaves as NumPy arrays.

  Args:
    template: A tree of arrays or `jax.ShapeDtypeStruct`s (nothing is
      allocated from it).
    stored: As `_restore_like`.
    what: Name for error messages.

  Returns:
    `stored`'s leaves in `template`'s structure, as NumPy arrays in the
    template's dtypes.

  Raises:
    ValueError: As `_restore_like`.
  """
  treedef = jax.tree_util.tree_structure(template)
  paths_and_refs = jax.tree_util.tree_flatten_with_path(template)[0]
  expected = [ref for _, ref in paths_and_refs]
  if isinstance(stored, list):
    leaves = stored
  else:
    if jax.tree_util.tree_structure(stored) != treedef:
      names = lambda t: {safe_io.leaf_name(p) for p, _ in
                         jax.tree_util.tree_flatten_with_path(t)[0]}
      missing = sorted(names(template) - names(stored))
      extra = sorted(names(stored) - names(template))
      shown = lambda x: f'{x[:4]}' + (f' and {len(x) - 4} more'
                                      if len(x) > 4 else '')
      raise ValueError(f'{what}: leaves differ from the expected network\'s: '
                       f'missing {shown(missing)}, unexpected {shown(extra)}')
    leaves = jax.tree_util.tree_leaves(stored)
  if not isinstance(leaves, list) or len(leaves) != len(expected):
    raise ValueError(f'{what}: expected {len(expected)} arrays, found '
                     f'{len(leaves) if isinstance(leaves, list) else leaves!r}')
  restored = []
  for i, (leaf, (path, ref)) in enumerate(zip(leaves, paths_and_refs)):
    # A tree of one array (log_alpha) is named by `what` alone.
    label = (f'{what}: leaf {safe_io.leaf_name(path)}' if path else what)
    if np.shape(leaf) != tuple(ref.shape):
      raise ValueError(f'{what}: array {i} ({safe_io.leaf_name(path)}) has '
                       f'shape {np.shape(leaf)}, expected {tuple(ref.shape)}'
                       if path else f'{what} has shape {np.shape(leaf)}, '
                       f'expected {tuple(ref.shape)}')
    dtype = np.dtype(ref.dtype)
    leaf = safe_io.checked_array(
        leaf, label, kind='int' if dtype.kind in 'iu' else 'float')
    restored.append(leaf.astype(dtype, copy=False))
  return jax.tree_util.tree_unflatten(treedef, restored)


def file_config(config: Any, what: str) -> Dict[str, Any]:
  """A checkpoint's or policy's `config`, checked before anything is built.

  The one reading of a file's config: types and bounds of the entries that
  fix the network (`ACTING_CONFIG_KEYS`; sizes at most `MAX_NUM_LAYERS`,
  `MAX_HIDDEN_UNITS`, `MAX_OBSERVATION_SIZE`, `MAX_NUM_ACTIONS`) and of
  `replay_capacity` where present. Files from before critics were
  configurable hold Dopamine's MLPs: a missing `critic` reads as 'mlp'.

  Args:
    config: The `config` entry of the file.
    what: The file, for the message.

  Returns:
    A normalised copy (lists, Python numbers, `critic` filled in).

  Raises:
    ValueError: Naming `what` and the entry.
  """
  if not isinstance(config, Mapping):
    raise ValueError(f'{what}: config is not a mapping: {config!r}')
  config = dict(config)
  config.setdefault('critic', 'mlp')  # Files from before critics were set.
  missing = [k for k in ACTING_CONFIG_KEYS if k not in config]
  if missing:
    raise ValueError(f'{what}: config misses {missing}')
  check_hyperparameters(f'{what}: config', num_layers=config['num_layers'],
                        hidden_units=config['hidden_units'],
                        **({'replay_capacity': config['replay_capacity']}
                           if 'replay_capacity' in config else {}))
  for key in ('num_layers', 'hidden_units', 'replay_capacity'):
    if key in config:
      config[key] = int(config[key])
  networks.check_critic(f'{what}: config', config['critic'])
  num_actions = safe_io.checked_count(
      config['num_actions'], f'{what}: config.num_actions', low=1,
      high=MAX_NUM_ACTIONS)
  shape = safe_io.checked_array(config['observation_shape'],
                                f'{what}: config.observation_shape',
                                kind='int')
  if shape.ndim != 1 or not shape.size or np.any(shape < 1) or (
      np.prod(shape.astype(np.float64)) > MAX_OBSERVATION_SIZE):
    raise ValueError(f'{what}: config.observation_shape must be a list of '
                     f'integers >= 1 with at most {MAX_OBSERVATION_SIZE} '
                     f'features, got {config["observation_shape"]!r}')
  config['num_actions'] = num_actions
  config['observation_shape'] = [int(d) for d in shape]
  for key in ('action_low', 'action_high'):
    config[key] = safe_io.checked_array(
        config[key], f'{what}: config.{key}', shape=(num_actions,)).astype(
            np.float64).tolist()
  return config


@functools.lru_cache(maxsize=16)
def _network_shapes(num_actions: int, observation_shape: tuple,
                    num_layers: int, hidden_units: int, critic: str) -> Any:
  network_def = networks.make_network(num_actions, num_layers, hidden_units,
                                      critic)
  state = jax.ShapeDtypeStruct(observation_shape, jnp.float32)
  return jax.eval_shape(
      lambda s: network_def.init(jax.random.PRNGKey(0), s,
                                 jax.random.PRNGKey(0)), state)


def network_shapes(config: Mapping[str, Any]) -> Any:
  """The network parameters' shapes and dtypes a `file_config` implies.

  Computed abstractly (`jax.eval_shape`): nothing is allocated or compiled.
  """
  return _network_shapes(
      config['num_actions'], tuple(config['observation_shape']),
      config['num_layers'], config['hidden_units'], config['critic'])


def nonfinite_count(tree: Any) -> jnp.ndarray:
  """NaN / inf values in a tree's floating-point leaves (traceable)."""
  counts = [jnp.sum(~jnp.isfinite(x)) for x in jax.tree_util.tree_leaves(tree)
            if jnp.issubdtype(jnp.asarray(x).dtype, jnp.inexact)]
  return sum(counts, jnp.zeros((), jnp.int32))


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
    check_hyperparameters(
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
    self.network_optimizer, self.alpha_optimizer = make_optimizers(
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
      out = update(
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
      raise TrainingDiverged(
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
        target_params=_to_numpy(self.target_params),
        optimizer_state=[np.asarray(x) for x in leaves(_to_numpy(
            self.optimizer_state))],
        alpha_optimizer_state=[np.asarray(x) for x in leaves(_to_numpy(
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
      TrainingDiverged: If the parameters or log(alpha) hold NaN / inf
        (nothing is written from them).
    """
    self._check_finite(network_params=self.network_params,
                       log_alpha=self.log_alpha)
    return {
        'format': CHECKPOINT_FORMAT,
        'iteration': int(iteration_number),
        'config': self._config(),
        'training_steps': int(self.training_steps),
        'network_params': _to_numpy(self.network_params),
        'log_alpha': np.asarray(self.log_alpha),
    }

  def _check_finite(self, **trees: Any) -> None:
    """Raises TrainingDiverged naming the trees that hold NaN / inf."""
    bad = {name: int(nonfinite_count(tree)) for name, tree in trees.items()}
    bad = {name: n for name, n in bad.items() if n}
    if bad:
      raise TrainingDiverged(
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
    theirs = file_config(config, what)
    keys = list(mine) if keys is None else list(keys)
    differ = [k for k in keys if theirs.get(k) != mine[k]]
    if differ:
      raise ValueError(
          f'{what}: its config has '
          f'{", ".join(f"{k}={theirs.get(k)!r}" for k in differ)}; this '
          f'agent has {", ".join(f"{k}={mine[k]!r}" for k in differ)}')

  def restore_network(self, network_params: Any, what: str) -> Any:
    """Network parameters from a file, checked against this agent's shapes."""
    return _restore_like(self.network_params, network_params,
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
        CHECKPOINT_FORMAT, LEGACY_CHECKPOINT_FORMAT):
      raise ValueError('not a ble_latex SAC checkpoint (format '
                       f'{CHECKPOINT_FORMAT!r} expected)')
    legacy = bundle['format'] == LEGACY_CHECKPOINT_FORMAT
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
    target_params = _restore_like(self.target_params, bundle['target_params'],
                                  f'{what}: target_params')
    optimizer_state = _restore_like(
        self.optimizer_state, opt_leaves(bundle['optimizer_state']),
        f'{what}: optimizer_state')
    alpha_optimizer_state = _restore_like(
        self.alpha_optimizer_state, opt_leaves(bundle['alpha_optimizer_state']),
        f'{what}: alpha_optimizer_state')
    log_alpha = _restore_like(self.log_alpha, bundle['log_alpha'],
                              f'{what}: log_alpha')
    rng = safe_io.checked_array(bundle['rng'], f'{what}: rng', kind='int',
                                shape=(2,)).astype(np.uint32)
    state = np.array(safe_io.checked_array(
        bundle['state'], f'{what}: state', shape=np.shape(self.state)))
    old_replay = self._replay
    self._restore_replay(bundle['replay'])  # Raises before replacing.
    del old_replay
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
    safe_io.write_tree(checkpoint_path(checkpoint_dir, iteration_number),
                       bundle, file_format=CHECKPOINT_FORMAT)
    if self._checkpoint_duration is not None:
      for old in checkpoint_iterations(checkpoint_dir):
        if old < iteration_number - self._checkpoint_duration:
          os.remove(checkpoint_path(checkpoint_dir, old))

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
    path = checkpoint_path(checkpoint_dir, iteration_number)
    legacy = legacy_checkpoint_path(checkpoint_dir, iteration_number)
    if not os.path.exists(path) and os.path.exists(legacy):
      path = legacy
      bundle = safe_io.read_legacy_pickle(
          legacy, trust=self._trust_legacy_pickle, what='SAC checkpoint')
    else:
      bundle = safe_io.read_tree(path, file_format=CHECKPOINT_FORMAT,
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
    iterations = checkpoint_iterations(checkpoint_dir)
    legacy = checkpoint_iterations(checkpoint_dir, LEGACY_CHECKPOINT_PATTERN)
    if legacy and (not iterations or legacy[-1] > iterations[-1]):
      if not self._trust_legacy_pickle:
        raise safe_io.UntrustedFileError(
            f'{checkpoint_dir} holds legacy pickle checkpoints (newest '
            f'{os.path.basename(legacy_checkpoint_path(checkpoint_dir, legacy[-1]))}'
            '); pickles can run code. If you made them, resume with '
            "--gin_bindings='ble_latex.agents.sac.SACAgent.trust_legacy_pickle = True' "
            '(docs/trusted-files.md).')
      iterations = legacy
    if not iterations:
      return -1
    self.load_checkpoint(checkpoint_dir, iterations[-1])
    return iterations[-1]
