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

The members must share every acting setting but the observation
(`sac_core.ACTING_CONFIG_KEYS`: network sizes, critic); their parameters
are stacked (`sac_trainer.stack`) and vmapped. Members may observe the
wind column differently (`latex_observation.*`, `observed_winds.column`):
each member proposes and scores from its own view of the balloon,
computed from the env's core state (`observe`; the agent reads it as the
planners do, `attach_env`). The env must observe as one of the members,
and a member with a wind memory must remember as many winds as the env
(the state holds them). The shipped ensemble
(`pretrained.SHIPPED_ENSEMBLE`) holds members of the drifted column and of
the column corrected by the last 16 measured winds, so it flies under
gin_configs/latex_wind_memory.gin (the env's state keeps the memory):

  ble-latex-eval --agent=sac_ensemble --suite=latex_small \
      --gin_file=gin_configs/latex_wind_memory.gin
  ble-latex-eval --agent=sac_ensemble --gin_file=... \
      --gin_bindings="SACEnsembleAgent.policy_paths=['a.msgpack', 'b.msgpack']"

The agent only acts (eval mode); it does not train.
"""

import functools
from typing import Any, Callable, Mapping, Optional, Sequence, Tuple, Union

from balloon_learning_environment.agents import agent
import gin
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import errors
from ble_latex.agents import planners
from ble_latex.agents import pretrained
from ble_latex.agents import sac
from ble_latex.agents import sac_core
from ble_latex.agents import sac_trainer
from ble_latex.envs import env_params
from ble_latex.envs import env_types
from ble_latex.envs import jax_env
from ble_latex.envs import winds
from ble_latex.flight import params as params_lib

Array = jax.Array
# The env gin file the shipped members observed under (`configs.gin_file`).
SHIPPED_GIN_FILE = 'latex_wind_memory.gin'
MAX_MEMBERS = 16  # Each member adds its actor and K critic evaluations.


def proposals(network_def: Any, members: Any, obs: Array,
              per_member: bool = False) -> Array:
  """Each member's deterministic action tanh(mu_k(o)): [K, num_actions].

  Args:
    network_def: The members' network (`networks.LatexSACNetwork`).
    members: Their parameters, stacked on a leading axis of K.
    obs: One observation; with `per_member`, each member's own [K, ...].
    per_member: Whether `obs` has a leading axis of the K members.
  """
  # The actor also draws a sample; its key does not change the mean.
  return jax.vmap(lambda p, o: network_def.apply(
      p, o, jax.random.PRNGKey(0), method=network_def.actor).mean_action,
                  in_axes=(0, 0 if per_member else None))(members, obs)


def scores(network_def: Any, members: Any, obs: Array, actions: Array,
           combine: Callable[..., Array] = jnp.mean,
           per_member: bool = False) -> Array:
  """Mean over the members of min(Q1, Q2)(o, a) for each action: [C].

  Args:
    network_def: The members' network.
    members: Their parameters, stacked on a leading axis of K.
    obs: One observation; with `per_member`, each member's own [K, ...].
    actions: Candidate actions in the normalised box [C, num_actions].
    combine: How the members' values combine (`jnp.mean`; `jnp.min` is
      measured in `benchmarks/policy_select.py --score=min`).
    per_member: Whether `obs` has a leading axis of the K members.
  """
  def member_q(p, o):
    out = jax.vmap(lambda a: network_def.apply(
        p, o, a, method=network_def.critic))(actions)
    return jnp.minimum(out.q_value1, out.q_value2).reshape(actions.shape[0])
  return combine(jax.vmap(member_q, in_axes=(0, 0 if per_member else None))(
      members, obs), axis=0)


def critic_choice(network_def: Any, members: Any, obs: Array,
                  group: Optional[Sequence[int]] = None) -> Array:
  """The proposal the members' critics score highest (normalised box).

  Args:
    network_def: The members' network.
    members: Their parameters, stacked on a leading axis of K.
    obs: One observation [F]; with `group`, the views [G, F] (`observe`).
    group: None: every member reads `obs`; else member k reads view
      group[k].

  Returns:
    [num_actions] in [-1, 1].
  """
  per_member = group is not None
  if per_member:
    obs = obs[np.asarray(group)]  # [K, F]: each member's own view.
  actions = proposals(network_def, members, obs, per_member)
  return actions[jnp.argmax(scores(network_def, members, obs, actions,
                                   per_member=per_member))]


View = Tuple[Tuple[str, int], ...]  # `env_params.OBSERVATION_FIELDS` values.


def view_of(settings: Mapping[str, Any]) -> View:
  """The observation settings of a policy config or env, as a view."""
  return tuple((k, int(settings[k])) for k in env_params.OBSERVATION_FIELDS)


def env_view_for(member_views: Sequence[View]) -> View:
  """The view an env must observe to hold every member's: the first of
  those that remember the most winds (a memory sizes the state)."""
  return max(member_views, key=lambda v: dict(v)['wind_memory'])


def views_of(member_views: Sequence[View], env_view: View
             ) -> Tuple[Tuple[View, ...], Tuple[int, ...]]:
  """The distinct views (the env's first) and each member's index in them.

  Raises:
    errors.ConfigError: No member observes as the env, or a member
      remembers another number of winds than the env's state holds.
  """
  if env_view not in member_views:
    raise errors.ConfigError(
        f'no member of the ensemble observes as the env ({dict(env_view)}); '
        'bind the env\'s latex_observation.* to one member\'s')
  memory = dict(env_view)['wind_memory']
  for view in member_views:
    if dict(view)['wind_memory'] not in (0, memory):
      raise errors.ConfigError(
          f'a member observes {dict(view)} and the env remembers '
          f'{memory} winds (latex_observation.wind_memory): a member\'s '
          'memory must be 0 or the env\'s')
  views = (env_view,) + tuple(sorted(set(member_views) - {env_view}))
  return views, tuple(views.index(v) for v in member_views)


def observe(state: env_types.EnvState, params: env_types.EnvParams,
            wind: winds.Wind, views: Sequence[View]) -> Array:
  """One balloon's 71 features under each view: [G, F] (traceable).

  A view without a memory reads the state without it (the forecast column,
  `observed_winds.column`); one with a memory reads the state's, which
  `views_of` has checked to be of its size.
  """
  rows = []
  for view in views:
    settings = dict(view)
    seen = state if settings['wind_memory'] else state.replace(
        wind_memory=None)
    rows.append(jax_env.observation(seen, params.replace(**settings), wind))
  return jnp.stack(rows)


@functools.partial(jax.jit, static_argnums=0)
def _choice(network_def: Any, members: Any, obs: Array) -> Array:
  return critic_choice(network_def, members, obs)


@functools.partial(jax.jit, static_argnums=(0, 1, 2, 3))
def choice_from_state(network_def: Any, group: Tuple[int, ...],
                      views: Tuple[View, ...], wind: winds.Wind, members: Any,
                      state: env_types.EnvState,
                      params: env_types.EnvParams) -> Array:
  """`critic_choice` of one balloon, each member on its own view."""
  return critic_choice(network_def, members,
                       observe(state, params, wind, views), group)


@functools.partial(jax.jit, static_argnums=(0, 1, 2, 3))
def choices_from_states(network_def: Any, group: Tuple[int, ...],
                        views: Tuple[View, ...], wind: winds.Wind,
                        members: Any, states: env_types.EnvState,
                        params: env_types.EnvParams) -> Array:
  """`choice_from_state` of [N] balloons, one by one (`lax.map`): [N, A]."""
  return jax.lax.map(lambda s: critic_choice(
      network_def, members, observe(s, params, wind, views), group), states)


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
  """K SAC policies; their critics choose among their actions (eval only).

  Attributes:
    policy_paths: The members' files.
    members: Their parameters, stacked on a leading axis of K.
    views: The distinct observation settings of the members, the env's
      first (`views_of`).
    group: Member k observes `views[group[k]]`.
    needs_env: Some member observes otherwise than the env; the agent then
      reads the core state of the env it is attached to (`attach_env`).
  """

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
    policies = [pretrained.load_policy(path) for path in paths]
    try:
      member_views = [view_of(sac_core.file_config(
          policy['config'], f'SAC policy {path}'))
                      for path, policy in zip(paths, policies)]
      self.views, self.group = views_of(
          member_views, view_of(env_params.observation_settings()))
      # The first member that observes as the env builds the agent (its
      # acting settings, the env's observation included, are checked).
      first = member_views.index(self.views[0])
      super().__init__(num_actions, observation_shape, action_low=action_low,
                       action_high=action_high, seed=seed,
                       policy_path=paths[first], **kwargs)
    except ValueError as e:  # errors.ConfigError is one.
      if not shipped:
        raise
      first_line = str(e).split('\n', 1)[0]  # Without gin's call notes.
      raise type(e)(f'{first_line}: the shipped ensemble flies under '
                    f'gin_configs/{SHIPPED_GIN_FILE}') from e
    others = [k for k in sac_core.ACTING_CONFIG_KEYS
              if k not in env_params.OBSERVATION_FIELDS]
    members = []
    for path, policy in zip(paths, policies):
      self.check_config(policy['config'], f'SAC policy {path}', keys=others)
      members.append(self.restore_network(policy['network_params'],
                                          f'SAC policy {path}'))
    self.policy_paths = tuple(paths)
    self.members = sac_trainer.stack(members)
    self.eval_mode = True
    self._driver = None
    self._wind = None

  @property
  def needs_env(self) -> bool:
    """True when a member observes otherwise than the env (`observe`)."""
    return len(self.views) > 1

  def attach_env(self, env: Any) -> None:
    """Reads `env`'s core state at each decision (`planners.core_of`)."""
    self._driver, self._wind = planners.core_of(env)

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
    if not self.needs_env:
      action = _choice(self.network_def, self.members, self.state)
    elif self._driver is None:
      raise RuntimeError(
          'sac_ensemble: members observe otherwise than the env, so the '
          'agent reads its core state: call attach_env(env) first '
          '(ble-latex-eval does)')
    else:
      action = choice_from_state(self.network_def, self.group, self.views,
                                 self._wind, self.members,
                                 self._driver.state, self._driver.params)
    action = np.asarray(action, np.float32)
    if not np.all(np.isfinite(action)):
      raise sac_core.TrainingDiverged(
          f'SAC ensemble produced a non-finite action {action.tolist()}: a '
          'member\'s parameters have diverged')
    return action
