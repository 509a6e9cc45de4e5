# coding=utf-8
"""SAC networks: Dopamine's `SACNetwork` with a choice of critic.

The actor is always Dopamine's (a squashed Gaussian MLP), so a policy file
holds the same actor whatever critic trained it. The critic is one of
`CRITICS` (gin `SACAgent.critic`, `sac_trainer_config.critic`):

- 'mlp': Dopamine's twin `SACCriticNetwork` MLPs, the paper's network
  (Saunders et al. 2023, "RL problem": 2 x 256 ReLU layers); the default.
- 'layernorm': the same MLPs with a LayerNorm after each hidden Dense layer,
  before the ReLU (as in RLPD, Ball et al. 2023, and SimBa, Lee et al. 2024),
  which keeps the Q-values bounded at high update-to-data ratios. Soft
  target networks as usual.
- 'crossq': CrossQ (Bhatt et al., ICLR 2024): batch normalisation of the
  critic's input and after each hidden layer, no target networks; the
  current and next state-action pairs go through the critics in one batch
  so that both are normalised with the same statistics (`sac.update`).
  The running statistics live in the `batch_stats` collection of the
  network's variables, beside `params`.
"""

from typing import Any

from dopamine.jax import continuous_networks
from flax import linen as nn
import jax
import jax.numpy as jnp
import numpy as np

CRITICS = ('mlp', 'layernorm', 'crossq')
# Momentum of the running batch-norm statistics (CrossQ's 0.99).
BATCH_NORM_MOMENTUM = 0.99


def check_critic(owner: str, critic: Any) -> None:
  """Raises ValueError naming the binding `<owner>.critic` if `critic` is bad."""
  if critic not in CRITICS:
    raise ValueError(f'{owner}.critic must be one of {list(CRITICS)}, got '
                     f'{critic!r}')


def uses_target_network(network_def: 'LatexSACNetwork') -> bool:
  """False for CrossQ critics, which bootstrap from the online critics."""
  return network_def.critic_type != 'crossq'


class NormalizedCritic(nn.Module):
  """A Q-network with LayerNorm or batch-norm layers, on single or batched input.

  Attributes:
    num_layers: Hidden layers.
    hidden_units: Units per hidden layer.
    norm: 'layernorm' or 'batchnorm'.
  """
  num_layers: int = 2
  hidden_units: int = 256
  norm: str = 'layernorm'

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


class LatexSACNetwork(continuous_networks.SACNetwork):
  """Dopamine's `SACNetwork` whose twin critics are chosen by `critic_type`.

  With 'mlp' the variables are exactly Dopamine's (same names), so policies
  and checkpoints written before critics were configurable load.

  Attributes:
    critic_type: One of `CRITICS`.
  """
  critic_type: str = 'mlp'

  def setup(self):
    super().setup()  # The actor; Dopamine's critics stay unused (no params).
    if self.critic_type != 'mlp':
      norm = 'batchnorm' if self.critic_type == 'crossq' else 'layernorm'
      # Names start with '_critic': `sac._param_labels` gives them the critic
      # optimizer.
      self._critic_norm1 = NormalizedCritic(self.num_layers,
                                            self.hidden_units, norm)
      self._critic_norm2 = NormalizedCritic(self.num_layers,
                                            self.hidden_units, norm)

  def critic(self, state: jax.Array, action: jax.Array,
             train: bool = False) -> continuous_networks.SacCriticOutput:
    """The twin Q-values (Dopamine's `critic`, used by its `__call__`).

    Args:
      state: Observation(s).
      action: Action(s) in the normalised box.
      train: Batch-norm critics only (`NormalizedCritic`).
    """
    if self.critic_type == 'mlp':
      return super().critic(state, action)
    return continuous_networks.SacCriticOutput(
        self._critic_norm1(state, action, train),
        self._critic_norm2(state, action, train))


def make_network(num_actions: int, num_layers: int, hidden_units: int,
                 critic: str = 'mlp') -> LatexSACNetwork:
  """The SAC network acting in the normalised box [-1, 1]^num_actions."""
  check_critic('make_network', critic)
  unit = np.ones(num_actions, dtype=np.float32)
  limits = tuple(tuple(x.reshape(-1)) for x in (-unit, unit))
  return LatexSACNetwork((num_actions,), num_layers, hidden_units, limits,
                         critic_type=critic)
