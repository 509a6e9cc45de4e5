# coding=utf-8
"""SAC networks in Flax: Dopamine's `SACNetwork`, with a choice of critic.

`LatexSACNetwork` has exactly the variables (module names, parameter names
and shapes) and outputs of Dopamine 4.0.9's
`dopamine.jax.continuous_networks.SACNetwork` (Apache 2.0; re-written here so
that the jitted trainer needs neither Dopamine nor TensorFlow, which that
module imports), so policies and checkpoints written with Dopamine's network
load unchanged; tests/agents/sac/test_networks.py checks both against each other.

The actor (`_actor_layers_i`, `_actor_final_layer`): an MLP of `num_layers`
ReLU layers giving the mean mu and log standard deviation log(sigma) of a
diagonal Gaussian over u; the action is a = m * tanh(u) + c with c and m the
centre and half-width of `action_limits`, the mean action
m * tanh(mu) + c, and the log-probability of a sampled action that of the
transformed density (Haarnoja et al. 2018, appendix C):
log N(u; mu, sigma) - sum_i log(m_i (1 - tanh(u_i)^2)), the tanh term
written as 2 (log 2 - u - softplus(-2u)) for stability, as TFP's `Tanh`
bijector which Dopamine uses.

The critic is one of `CRITICS` (gin `SACAgent.critic`,
`sac_trainer_config.critic`):

- 'mlp': twin MLPs (`_critic1`, `_critic2`), Dopamine's `SACCriticNetwork`,
  the paper's network (Saunders et al. 2023, "RL problem": 2 x 256 ReLU
  layers); the default.
- 'layernorm': the same MLPs with a LayerNorm after each hidden Dense layer,
  before the ReLU (as in RLPD, Ball et al. 2023, and SimBa, Lee et al. 2024),
  which keeps the Q-values bounded at high update-to-data ratios. Soft
  target networks as usual.
- 'crossq': CrossQ (Bhatt et al., ICLR 2024): batch normalisation of the
  critic's input and after each hidden layer, no target networks; the
  current and next state-action pairs go through the critics in one batch
  so that both are normalised with the same statistics (`sac_core.update`).
  The running statistics live in the `batch_stats` collection of the
  network's variables, beside `params`.
"""

import math
from typing import Any, NamedTuple, Optional, Tuple

from flax import linen as nn
import jax
import jax.numpy as jnp
import numpy as np

CRITICS = ('mlp', 'layernorm', 'crossq')
# Momentum of the running batch-norm statistics (CrossQ's 0.99).
BATCH_NORM_MOMENTUM = 0.99
_LOG_2 = math.log(2.0)
_HALF_LOG_2PI = 0.5 * math.log(2.0 * math.pi)


class SacActorOutput(NamedTuple):
  """The actor's output (Dopamine's field names)."""
  mean_action: jax.Array
  sampled_action: jax.Array
  log_probability: jax.Array


class SacCriticOutput(NamedTuple):
  """The twin critics' Q-values (Dopamine's field names)."""
  q_value1: jax.Array
  q_value2: jax.Array


class SacOutput(NamedTuple):
  """Actor and critic outputs of `LatexSACNetwork.__call__`."""
  actor: SacActorOutput
  critic: SacCriticOutput


def check_critic(owner: str, critic: Any) -> None:
  """Raises ValueError naming the binding `<owner>.critic` if `critic` is bad."""
  if critic not in CRITICS:
    raise ValueError(f'{owner}.critic must be one of {list(CRITICS)}, got '
                     f'{critic!r}')


def uses_target_network(network_def: 'LatexSACNetwork') -> bool:
  """False for CrossQ critics, which bootstrap from the online critics."""
  return network_def.critic_type != 'crossq'


class Critic(nn.Module):
  """A Q-network, plain or normalised, on single or batched input.

  With `norm=None` its variables are Dopamine's `SACCriticNetwork`'s.

  Attributes:
    num_layers: Hidden layers.
    hidden_units: Units per hidden layer.
    norm: None, 'layernorm' or 'batchnorm'.
  """
  num_layers: int = 2
  hidden_units: int = 256
  norm: Optional[str] = None

  @nn.compact
  def __call__(self, state: jax.Array, action: jax.Array,
               train: bool = False) -> jax.Array:
    """Q(state, action): [..., 1] for action [..., k] and state [..., d].

    Args:
      state: Observation(s).
      action: Action(s) in the normalised box.
      train: Batch norm only: normalise with this batch's statistics and
        update the running ones (apply with `mutable=['batch_stats']`);
        otherwise use the running statistics.
    """
    kernel_init = jax.nn.initializers.glorot_uniform()
    batch_norm = lambda x: nn.BatchNorm(
        use_running_average=not train, momentum=BATCH_NORM_MOMENTUM)(x)
    # One example's state may come stacked ([d, 1], Dopamine's agent): the
    # action's leading axes are the batch axes.
    state = state.reshape(action.shape[:-1] + (-1,))
    x = jnp.concatenate([state.astype(jnp.float32),
                         action.astype(jnp.float32)], axis=-1)
    if self.norm == 'batchnorm':
      x = batch_norm(x)
    for _ in range(self.num_layers):
      x = nn.Dense(self.hidden_units, kernel_init=kernel_init)(x)
      if self.norm == 'layernorm':
        x = nn.LayerNorm()(x)
      x = nn.relu(x)
      if self.norm == 'batchnorm':
        x = batch_norm(x)
    return nn.Dense(1, kernel_init=kernel_init)(x)


class LatexSACNetwork(nn.Module):
  """SAC's squashed-Gaussian actor and twin critics chosen by `critic_type`.

  The fields and methods (`actor`, `critic`, `__call__`) are those of
  Dopamine's `SACNetwork`, whose `SACAgent` builds and applies this one.

  Attributes:
    action_shape: Shape of an action.
    num_layers: Hidden layers of the actor and of each critic.
    hidden_units: Units per hidden layer.
    action_limits: (low, high) of the action, flat tuples; None: unbounded
      (no tanh).
    critic_type: One of `CRITICS`.
  """
  action_shape: Tuple[int, ...]
  num_layers: int = 2
  hidden_units: int = 256
  action_limits: Optional[Tuple[Tuple[float, ...], Tuple[float, ...]]] = None
  critic_type: str = 'mlp'

  def setup(self):
    kernel_init = jax.nn.initializers.glorot_uniform()
    self._actor_layers = [
        nn.Dense(self.hidden_units, kernel_init=kernel_init)
        for _ in range(self.num_layers)]
    self._actor_final_layer = nn.Dense(
        2 * int(np.prod(self.action_shape)), kernel_init=kernel_init)
    # Names start with '_critic': `sac_core.param_labels` gives them the
    # critic optimizer. The MLP critics keep Dopamine's names.
    if self.critic_type == 'mlp':
      self._critic1 = Critic(self.num_layers, self.hidden_units)
      self._critic2 = Critic(self.num_layers, self.hidden_units)
    else:
      norm = 'batchnorm' if self.critic_type == 'crossq' else 'layernorm'
      self._critic_norm1 = Critic(self.num_layers, self.hidden_units, norm)
      self._critic_norm2 = Critic(self.num_layers, self.hidden_units, norm)

  def __call__(self, state: jax.Array, key: jax.Array,
               mean_action: bool = True) -> SacOutput:
    """Actor, and critics at its mean (or sampled) action; initialises all."""
    actor = self.actor(state, key)
    action = actor.mean_action if mean_action else actor.sampled_action
    return SacOutput(actor, self.critic(state, action))

  def actor(self, state: jax.Array, key: jax.Array) -> SacActorOutput:
    """The policy at one observation.

    Args:
      state: One observation (flattened).
      key: PRNG key of the sampled action.

    Returns:
      Mean action, sampled action (both of `action_shape`) and the sampled
      action's log-probability [nats], a scalar.
    """
    x = state.astype(jnp.float32).reshape(-1)
    for layer in self._actor_layers:
      x = nn.relu(layer(x))
    loc, log_scale = jnp.split(self._actor_final_layer(x), 2)
    scale = jnp.exp(log_scale)
    noise = jax.random.normal(key, loc.shape, jnp.float32)
    u = scale * noise + loc
    # log(exp(.)), not log_scale: bit for bit Dopamine's (TFP's) number.
    log_prob = (jnp.sum(-0.5 * jnp.square(noise) - _HALF_LOG_2PI)
                - jnp.sum(jnp.log(scale)))
    if self.action_limits is None:
      mode, sample = loc, u
    else:
      low, high = (jnp.asarray(x, jnp.float32) for x in self.action_limits)
      centre, half_width = (low + high) / 2.0, (high - low) / 2.0
      mode = half_width * jnp.tanh(loc) + centre
      sample = half_width * jnp.tanh(u) + centre
      log_det = 2.0 * (_LOG_2 - u - jax.nn.softplus(-2.0 * u))
      log_prob = log_prob - (jnp.sum(jnp.log(half_width)) + jnp.sum(log_det))
    return SacActorOutput(mode.reshape(self.action_shape),
                          sample.reshape(self.action_shape), log_prob)

  def critic(self, state: jax.Array, action: jax.Array,
             train: bool = False) -> SacCriticOutput:
    """The twin Q-values.

    Args:
      state: Observation(s).
      action: Action(s) in the normalised box.
      train: Batch-norm critics only (`Critic`).
    """
    if self.critic_type == 'mlp':
      return SacCriticOutput(self._critic1(state, action),
                             self._critic2(state, action))
    return SacCriticOutput(self._critic_norm1(state, action, train),
                           self._critic_norm2(state, action, train))


def make_network(num_actions: int, num_layers: int, hidden_units: int,
                 critic: str = 'mlp') -> LatexSACNetwork:
  """The SAC network acting in the normalised box [-1, 1]^num_actions."""
  check_critic('make_network', critic)
  limits = ((-1.0,) * num_actions, (1.0,) * num_actions)
  return LatexSACNetwork((num_actions,), num_layers, hidden_units, limits,
                         critic_type=critic)
