# coding=utf-8
"""Soft Actor-Critic in pure JAX: the update, optimizers and file checks.

Shared by the BLE agent (`sac.SACAgent`, which wraps Dopamine's) and the
jitted trainer (`sac_trainer`); imports neither TensorFlow nor Dopamine nor
BLE's agents. `update` is Dopamine 4.0.9's `sac_agent.train` (Haarnoja et
al. 2018/2019) on the whole batch at once, with separate Adam learning rates
for actor, critics and temperature (`make_optimizers`). What is read from a
checkpoint or policy file is checked here before anything is built from it
(`file_config`, `check_like`, `network_shapes`).
"""

import dataclasses
import functools
from typing import Any, ClassVar, Dict, Mapping

import jax
import jax.numpy as jnp
import numpy as np
import optax

from ble_latex import errors
from ble_latex import gin_values
from ble_latex import safe_io
from ble_latex.agents.sac import networks
from ble_latex.envs import env_params

CHECKPOINT_FORMAT = 'ble_latex.sac/2'  # msgpack (`safe_io`).
LEGACY_CHECKPOINT_FORMAT = 'ble_latex.sac/1'  # Pickles of ble_latex <= 0.1.
# Largest networks a gin binding or a checkpoint / policy file may ask for:
# a file's config is checked against these before anything is built from it.
MAX_NUM_LAYERS = 16
MAX_HIDDEN_UNITS = 4096
MAX_OBSERVATION_SIZE = 4096  # Features of a file's observation_shape.
MAX_NUM_ACTIONS = 64
# Sizes that drive memory, bounded before anything is allocated: the jitted
# trainer's replay ring holds ~590 bytes per transition (5.9 GB at the bound),
# the agent's ~300; a batch or a vector of balloons is held several times over
# in the update's activations and gradients.
MAX_REPLAY_CAPACITY = 10_000_000
MAX_BATCH_SIZE = 65_536
MAX_NUM_ENVS = 4096
# Every other integer setting is an int32 count on the device.
MAX_INT32 = 2**31 - 1
# What `file_config` checks and `check_config` compares: the config entries
# that fix the network's shapes and the action box, and what the features
# mean (`env_params.OBSERVATION_FIELDS`: the env's `latex_observation.*` the
# policy observed with). Policies need no more.
ACTING_CONFIG_KEYS = ('observation_shape', 'num_actions', 'action_low',
                      'action_high', 'num_layers', 'hidden_units',
                      'critic') + env_params.OBSERVATION_FIELDS


class TrainingDiverged(FloatingPointError):
  """Training produced NaN / inf (parameters, losses, actions, rewards)."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class SACHyperparameters:
  """SAC's hyperparameters: the one home of their defaults.

  Both SAC trainers read this record: the BLE agent (`sac.SACAgent`, gin
  `SACAgent.*`; its keyword defaults are `SAC_DEFAULTS`'s) and the jitted
  trainer (`sac_trainer.TrainerConfig`, gin `sac_trainer_config.*`, a
  subclass that adds the loop's settings). The gin files bind only what
  differs from it (tests/test_gin_defaults.py). Paper (Saunders et al. 2023,
  "RL problem"): SAC (Haarnoja et al. 2018/2019), actor and twin critics as
  2 x 256 MLPs, squashed Gaussian, automatic temperature with target
  entropy 0; the paper gives no other values, the rest are Haarnoja et al.'s
  (2018, Table 1) SAC defaults. Built, it is checked
  (`check_hyperparameters`; errors name `<GIN_NAME>.<field>`).

  Attributes:
    batch_size: Transitions per SAC update.
    replay_capacity: Replay buffer size in transitions (FIFO beyond it);
      the paper's run, 2500 episodes x 216 steps = 540 000, fits.
    min_replay_history: Transitions of uniform random actions before the
      first update (about 5 episodes of 216 steps).
    gamma: Discount factor.
    actor_learning_rate: Adam learning rate of the actor.
    critic_learning_rate: Adam learning rate of the twin critics.
    alpha_learning_rate: Adam learning rate of log(temperature).
    target_smoothing_coefficient: Polyak factor tau of the target critics.
    target_entropy: Target entropy [nats] of the normalised [-1, 1]^d action
      (the paper's 0).
    reward_scale_factor: Rewards are multiplied by this in the TD target.
    num_layers: Hidden layers of the actor and of each critic.
    hidden_units: Units per hidden layer.
    critic: The twin critics (`networks.CRITICS`): 'mlp' (Dopamine's, the
      paper's), 'layernorm' (LayerNorm after each hidden layer) or 'crossq'
      (batch norm, no target networks; `target_smoothing_coefficient` is
      then unused).
  """
  GIN_NAME: ClassVar[str] = 'SACHyperparameters'
  batch_size: int = 256
  replay_capacity: int = 1_000_000
  min_replay_history: int = 1000
  gamma: float = 0.99
  actor_learning_rate: float = 3e-4
  critic_learning_rate: float = 3e-4
  alpha_learning_rate: float = 3e-4
  target_smoothing_coefficient: float = 0.005
  target_entropy: float = 0.0
  reward_scale_factor: float = 1.0
  num_layers: int = 2
  hidden_units: int = 256
  critic: str = 'mlp'

  def __post_init__(self):
    networks.check_critic(self.GIN_NAME, self.critic)
    check_hyperparameters(self.GIN_NAME, **{
        f.name: getattr(self, f.name) for f in dataclasses.fields(self)})



def param_labels(params: Any) -> Any:
  """Labels each parameter leaf 'critic' or 'actor' for multi_transform."""

  def label(path, _):
    names = [getattr(k, 'key', getattr(k, 'name', '')) for k in path]
    return ('critic' if any(str(n).startswith('_critic') for n in names)
            else 'actor')

  return jax.tree_util.tree_map_with_path(label, params)


def to_numpy(tree: Any) -> Any:
  """Host (NumPy) copy of a pytree of arrays, for checkpoints."""
  return jax.tree.map(np.asarray, jax.device_get(tree))


@jax.jit
def polyak_update(online_params: Any, target_params: Any, tau: float) -> Any:
  """Soft target update tau * online + (1 - tau) * target, one XLA call.

  Args:
    online_params: The online network's parameters.
    target_params: The target network's parameters (same tree).
    tau: Step size of the update, in (0, 1].

  Returns:
    The new target parameters.
  """
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
  (`sac_trainer`) both call it. `tests/agents/sac/test_core.py` checks it against
  Dopamine's `sac_agent.train` on the same inputs.

  Args:
    network_def: The actor-critic network (static).
    optimizer: The network optimizer (`make_optimizers`; static).
    alpha_optimizer: The temperature optimizer (static).
    optimizer_state: The network optimizer's state.
    alpha_optimizer_state: The temperature optimizer's state.
    network_params: The online network's parameters.
    target_params: The target network's parameters (unused by CrossQ
      critics, which have no target network).
    log_alpha: Log of the entropy temperature alpha.
    key: PRNG key of the batch (split per transition).
    states: [B, ...] observations.
    actions: [B, ...] actions taken.
    next_states: [B, ...] next observations.
    rewards: [B] rewards.
    terminals: [B] terminal flags (no bootstrap where set).
    cumulative_gamma: Discount of the next-state value (Dopamine's
      gamma ** update_horizon).
    target_entropy: The temperature loss's target entropy.
    reward_scale_factor: Multiplies the rewards in the critic target.

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
  """(network optimizer, temperature optimizer): Adam per actor / critics.

  Args:
    params: The network parameters (labelled by `param_labels`).
    actor_learning_rate: Adam step size of the actor.
    critic_learning_rate: Adam step size of the critics.
    alpha_learning_rate: Adam step size of log alpha.

  Returns:
    (network optimizer, temperature optimizer), optax transformations.
  """
  network = optax.multi_transform(
      {'actor': optax.adam(actor_learning_rate),
       'critic': optax.adam(critic_learning_rate)}, param_labels(params))
  return network, optax.adam(alpha_learning_rate)


def check_hyperparameters(owner: str, **values: Any) -> None:
  """Raises ConfigError naming the `<owner>.<name>` binding that is invalid.

  Sizes that drive memory (`hidden_units`, `num_layers`, `batch_size`,
  `replay_capacity`, `num_envs`) are bounded (`MAX_*`) before anything is
  allocated, every other integer by int32; numbers must be finite in
  float32; an integer of any size (beyond int64 too) gets the one line.

  Args:
    owner: The gin configurable the values are bound to (`SACAgent`).
    **values: Hyperparameters by name; names not given are not checked.

  Raises:
    errors.ConfigError: Naming `<owner>.<name>`, the requirement and the
      value.
  """

  def number(name, lo=None, hi=None, lo_open=False, integer=False,
             allow_none=False):
    if name not in values:
      return
    value = values[name]
    if value is None and allow_none:
      return
    ok = (isinstance(value, (int, float, np.integer, np.floating)) and
          gin_values.is_number(value) and  # Finite in float32 too.
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
      raise errors.ConfigError(f'{owner}.{name} must be {kind}{bounds}, got '
                               f'{value!r}')

  number('gamma', 0.0, 1.0)
  for name in ('actor_learning_rate', 'critic_learning_rate',
               'alpha_learning_rate'):
    number(name, 0.0, lo_open=True)
  number('batch_size', 1, MAX_BATCH_SIZE, integer=True)
  number('replay_capacity', 2, MAX_REPLAY_CAPACITY, integer=True)
  number('min_replay_history', 0, MAX_INT32, integer=True)
  number('update_period', 1, MAX_INT32, integer=True)
  number('target_smoothing_coefficient', 0.0, 1.0, lo_open=True)
  number('target_entropy')
  number('reward_scale_factor', 0.0, lo_open=True)
  number('num_layers', 1, MAX_NUM_LAYERS, integer=True)
  number('hidden_units', 1, MAX_HIDDEN_UNITS, integer=True)
  number('num_envs', 1, MAX_NUM_ENVS, integer=True)
  number('updates_per_step', 1, MAX_INT32, integer=True)
  number('actor_warmup_updates', 0, MAX_INT32, integer=True)
  number('checkpoint_duration', 0, MAX_INT32, integer=True, allow_none=True)
  number('summary_writing_frequency', 1, MAX_INT32, integer=True)


# The defaults, built once (SACAgent's keyword defaults read them).
SAC_DEFAULTS = SACHyperparameters()
SAC_HYPERPARAMETERS = tuple(
    f.name for f in dataclasses.fields(SACHyperparameters))


def restore_like(template: Any, stored: Any, what: str) -> Any:
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
  return jax.tree.map(jnp.asarray, check_like(template, stored, what))


def check_like(template: Any, stored: Any, what: str) -> Any:
  """`restore_like`'s checks, on the host: stored leaves as NumPy arrays.

  Args:
    template: A tree of arrays or `jax.ShapeDtypeStruct`s (nothing is
      allocated from it).
    stored: As `restore_like`.
    what: Name for error messages.

  Returns:
    `stored`'s leaves in `template`'s structure, as NumPy arrays in the
    template's dtypes.

  Raises:
    ValueError: As `restore_like`.
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
  configurable hold Dopamine's MLPs: a missing `critic` reads as 'mlp'; files
  from before an observation setting existed read it as 0 (the paper's
  observation).

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
  # Files from before an observation setting observed without it.
  for key in env_params.OBSERVATION_FIELDS:
    config.setdefault(key, 0)
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
  for key in env_params.OBSERVATION_FIELDS:
    config[key] = gin_values.check_int(
        f'{what}: config.{key}', config[key], minimum=0,
        maximum=env_params.OBSERVATION_MAXIMA[key])
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


