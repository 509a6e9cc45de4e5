# coding=utf-8
r"""An ensemble of SAC policies whose critics choose the action (`sac_ensemble`).

Issue 47: K SAC policies trained from different seeds (the same recipe, the
same observation) each propose their deterministic action
a_k = tanh(mu_k(o)); every member's twin critics score every proposal,
and the proposal with the largest mean over the members of
min(Q1_j, Q2_j)(o, a_k) is flown:

  a* = argmax_{a_k} (1/K) sum_j min(Q1_j, Q2_j)(o, a_k).

This is policy improvement by the learned critics at decision time over
an ensemble's proposals (the critics of an ensemble pick among its actors,
as in Lee et al., "SUNRISE", ICML 2021, which adds an exploration bonus
while training; Anschel et al. 2017 average target values). With one
member it is that member's `sac_pretrained` action. No stochastic draws
are scored: on 100 `latex_validation` seeds, adding 8 draws per member as
proposals ran 10 % of the flights out of resources
(`benchmarks/policy_select.py`).

The members must share every acting setting (`sac_core.ACTING_CONFIG_KEYS`:
network sizes, critic, the env's `latex_observation.*`); their parameters
are stacked (`sac_trainer.stack`) and vmapped. The shipped ensemble
(`pretrained.SHIPPED_ENSEMBLE`) observes the drifted wind column, so it
flies under gin_configs/latex_wind_lookahead.gin:

  ble-latex-eval --agent=sac_ensemble --suite=latex_small \
      --gin_file=gin_configs/latex_wind_lookahead.gin
  ble-latex-eval --agent=sac_ensemble --gin_file=... \
      --gin_bindings="SACEnsembleAgent.policy_paths=['a.msgpack', 'b.msgpack']"

The agent only acts (eval mode); it does not train.
"""

import functools
from typing import Any, Callable, Optional, Sequence, Union

from balloon_learning_environment.agents import agent
import gin
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import errors
from ble_latex.agents import pretrained
from ble_latex.agents import sac
from ble_latex.agents import sac_core
from ble_latex.agents import sac_trainer
from ble_latex.flight import params as params_lib

Array = jax.Array
# The env gin file the shipped members observed under (`configs.gin_file`).
SHIPPED_GIN_FILE = 'latex_wind_lookahead.gin'
MAX_MEMBERS = 16  # Each member adds its actor and K critic evaluations.


def proposals(network_def: Any, members: Any, obs: Array) -> Array:
  """Each member's deterministic action tanh(mu_k(o)): [K, num_actions].

  Args:
    network_def: The members' network (`networks.LatexSACNetwork`).
    members: Their parameters, stacked on a leading axis of K.
    obs: One observation [F].
  """
  # The actor also draws a sample; its key does not change the mean.
  return jax.vmap(lambda p: network_def.apply(
      p, obs, jax.random.PRNGKey(0), method=network_def.actor).mean_action)(
          members)


def scores(network_def: Any, members: Any, obs: Array, actions: Array,
           combine: Callable[..., Array] = jnp.mean) -> Array:
  """Mean over the members of min(Q1, Q2)(o, a) for each action: [C].

  Args:
    network_def: The members' network.
    members: Their parameters, stacked on a leading axis of K.
    obs: One observation [F].
    actions: Candidate actions in the normalised box [C, num_actions].
    combine: How the members' values combine (`jnp.mean`; `jnp.min` is
      measured in `benchmarks/policy_select.py --score=min`).
  """
  def member_q(p):
    out = jax.vmap(lambda a: network_def.apply(
        p, obs, a, method=network_def.critic))(actions)
    return jnp.minimum(out.q_value1, out.q_value2).reshape(actions.shape[0])
  return combine(jax.vmap(member_q)(members), axis=0)


def critic_choice(network_def: Any, members: Any, obs: Array) -> Array:
  """The proposal the members' critics score highest (normalised box).

  Args:
    network_def: The members' network.
    members: Their parameters, stacked on a leading axis of K.
    obs: One observation [F].

  Returns:
    [num_actions] in [-1, 1].
  """
  actions = proposals(network_def, members, obs)
  return actions[jnp.argmax(scores(network_def, members, obs, actions))]


@functools.partial(jax.jit, static_argnums=0)
def _choice(network_def: Any, members: Any, obs: Array) -> Array:
  return critic_choice(network_def, members, obs)


@functools.partial(jax.jit, static_argnums=0)
def choices(network_def: Any, members: Any, observations: Array) -> Array:
  """`critic_choice` of [N] observations, row by row (`lax.map`): [N, A].

  Row by row, as the one-balloon agent computes each (a batched matmul
  sums in another order).
  """
  return jax.lax.map(lambda o: critic_choice(network_def, members, o),
                     observations)


@gin.configurable(denylist=['num_actions', 'observation_shape', 'action_low',
                            'action_high'])
class SACEnsembleAgent(sac.SACPretrainedAgent):
  """K SAC policies; their critics choose among their actions (eval only)."""

  def __init__(self, num_actions: int, observation_shape: Sequence[int], *,
               action_low: Optional[Sequence[float]] = None,
               action_high: Optional[Sequence[float]] = None,
               seed: int = 0,
               policy_paths: Optional[Sequence[str]] = None,
               **kwargs: Any):
    """Loads and checks every member.

    Args:
      num_actions: Dimension of the action vector.
      observation_shape: Shape of the observation vector.
      action_low: Lower bounds of the Box action space.
      action_high: Upper bounds of the Box action space.
      seed: Unused (the agent acts deterministically).
      policy_paths: SAC policy files (`.msgpack`), 1 to `MAX_MEMBERS`.
        None: `pretrained.SHIPPED_ENSEMBLE` (paper physics only).
      **kwargs: Further `SACPretrainedAgent` arguments.

    Raises:
      FileNotFoundError: A member's file is missing.
      ValueError: A bad file, or a member whose acting settings differ
        from the env's or the first member's (one line).
      errors.ConfigError: No paths, too many, a `policy_path`, or no
        shipped ensemble for the physics gin binds.
    """
    shipped = policy_paths is None
    if shipped:
      policy_paths = pretrained.shipped_ensemble(
          params_lib.flight_params_from_gin().realistic)
    if isinstance(policy_paths, str):
      policy_paths = [policy_paths]
    paths = [str(p) for p in policy_paths]
    if not 1 <= len(paths) <= MAX_MEMBERS:
      raise errors.ConfigError(
          f'SACEnsembleAgent.policy_paths needs 1 to {MAX_MEMBERS} policy '
          f'files, got {len(paths)}')
    if 'policy_path' in kwargs:
      raise errors.ConfigError(
          'sac_ensemble takes policy_paths (a list of files), not '
          'policy_path')
    try:
      super().__init__(num_actions, observation_shape, action_low=action_low,
                       action_high=action_high, seed=seed,
                       policy_path=paths[0], **kwargs)
    except ValueError as e:
      if not shipped:
        raise
      first_line = str(e).split('\n', 1)[0]  # Without gin's call notes.
      raise ValueError(f'{first_line}: the shipped ensemble flies under '
                       f'gin_configs/{SHIPPED_GIN_FILE}') from e
    members = [self.network_params]
    for path in paths[1:]:
      policy = pretrained.load_policy(path)
      self.check_config(policy['config'], f'SAC policy {path}',
                        keys=sac_core.ACTING_CONFIG_KEYS)
      members.append(self.restore_network(policy['network_params'],
                                          f'SAC policy {path}'))
    self.policy_paths = tuple(paths)
    self.members = sac_trainer.stack(members)
    self.eval_mode = True

  def get_name(self) -> str:
    return 'sac_ensemble'

  def set_mode(self, mode: Union[agent.AgentMode, str]) -> None:
    """EVAL only: the ensemble acts and does not train."""
    if not hasattr(self, 'members'):  # `SACAgent.__init__`'s own call.
      super().set_mode(mode)
      return
    if agent.AgentMode(mode) != agent.AgentMode.EVAL:
      raise errors.ConfigError(
          'sac_ensemble only acts (eval mode); train its members with '
          '`ble-latex-train --agent=sac` and list their policy files')
    self.eval_mode = True

  def _choose_normalized_action(self) -> np.ndarray:
    action = np.asarray(_choice(self.network_def, self.members, self.state),
                        np.float32)
    if not np.all(np.isfinite(action)):
      raise sac_core.TrainingDiverged(
          f'SAC ensemble produced a non-finite action {action.tolist()}: a '
          'member\'s parameters have diverged')
    return action
