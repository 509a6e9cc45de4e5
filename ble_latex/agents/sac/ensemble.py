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
member and no lookahead it is that member's `sac_pretrained` action. No stochastic draws
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

With `lookahead_strides` = H > 0 each proposal is first flown H strides
ahead in the wind a forecast planner plans in (`plan_objective.planning_wind`:
the forecast plus the Gaussian-process correction by the measured winds the
env's state remembers) and scored by the rewards on the way and the
members' value where it ends, a short model rollout bootstrapped by the
learned value (MuZero's and TD-MPC's backup; `lookahead_choice`):

  score_k = sum_{t<H} gamma^t r_t + gamma^H (1/K) sum_j V_j(o_j(s_H)),
  V_j(o) = min(Q1_j, Q2_j)(o, mu_j(o)).

The agent only acts (eval mode); it does not train.
"""

import functools
from typing import (Any, Callable, Mapping, NamedTuple, Optional, Sequence,
                    Tuple, Union)

from balloon_learning_environment.agents import agent
import gin
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import errors
from ble_latex.agents.planning import agents as planners
from ble_latex.agents.planning import config as plan_config
from ble_latex.agents.planning import objective as plan_objective
from ble_latex.agents.planning import value as plan_value
from ble_latex.agents.sac import agent as sac
from ble_latex.agents.sac import core as sac_core
from ble_latex.agents.sac import pretrained
from ble_latex.agents.sac import trainer as sac_trainer
from ble_latex.envs import env_params
from ble_latex.envs import env_types
from ble_latex.envs import jax_env
from ble_latex.envs import jax_features
from ble_latex.envs import observed_winds
from ble_latex.envs import winds
from ble_latex.flight import dynamics
from ble_latex.flight import estimator
from ble_latex.flight import params as params_lib
from ble_latex.flight import state as state_lib

Array = jax.Array
# The env gin file the shipped members observed under (`configs.gin_file`).
SHIPPED_GIN_FILE = 'latex_wind_memory.gin'
MAX_MEMBERS = 16  # Each member adds its actor and K critic evaluations.
# Strides: at most the forecast planner's horizon (its forecast-only wind).
MAX_LOOKAHEAD = plan_config.PlannerConfig.horizon


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
  """The observation settings of a policy config or env, as a view (a
  setting missing from `settings` is off, 0: settings from before it)."""
  return tuple((k, int(settings.get(k, 0)))
               for k in env_params.OBSERVATION_FIELDS)


def env_view_for(member_views: Sequence[View]) -> View:
  """The view an env must observe to hold every member's: the first of
  those that remember the most winds (a memory sizes the state)."""
  return max(member_views, key=lambda v: dict(v)['wind_memory'])


def views_of(member_views: Sequence[View], env_view: View
             ) -> Tuple[Tuple[View, ...], Tuple[int, ...]]:
  """The distinct views (the env's first) and each member's index in them.

  Raises:
    errors.ConfigError: No member observes as the env, a member
      remembers another number of winds than the env's state holds, or
      observes other options (`env_params.OBSERVATION_SWITCHES`).
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
    switched = [k for k in env_params.OBSERVATION_SWITCHES
                if dict(view)[k] != dict(env_view)[k]]
    if switched:  # The appended features are the env's for every view.
      raise errors.ConfigError(
          f'a member observes {dict(view)} and the env '
          f'latex_observation.{switched[0]} = {dict(env_view)[switched[0]]}:'
          ' every member must observe the env\'s observation options')
  views = (env_view,) + tuple(sorted(set(member_views) - {env_view}))
  return views, tuple(views.index(v) for v in member_views)


def view_columns(state: env_types.EnvState, params: env_types.EnvParams,
                 wind: winds.Wind, views: Sequence[View]
                 ) -> Tuple[Array, Array]:
  """One balloon's wind column under each view: (u, v), each [G, L]. # [m/s]

  A view without a memory reads the state without it (the forecast column,
  `observed_winds.column`); one with a memory reads the state's, which
  `views_of` has checked to be of its size.
  """
  levels = jnp.asarray(jax_features.PRESSURE_LEVELS, state.flight.x_m.dtype)
  us, vs = [], []
  for view in views:
    settings = dict(view)
    seen = state if settings['wind_memory'] else state.replace(
        wind_memory=None)
    u, v = observed_winds.column(seen, params.replace(**settings), wind,
                                 levels)
    us.append(u)
    vs.append(v)
  return jnp.stack(us), jnp.stack(vs)


def observe_columns(state: env_types.EnvState, params: env_types.EnvParams,
                    columns: Tuple[Array, Array]) -> Array:
  """The 71 features of `state` read with each view's column: [G, F]."""
  return jax.vmap(lambda u, v: jax_env.observation_of_column(
      state, params, u, v))(*columns)


def observe(state: env_types.EnvState, params: env_types.EnvParams,
            wind: winds.Wind, views: Sequence[View]) -> Array:
  """One balloon's 71 features under each view: [G, F] (traceable): the
  env's own observation (`jax_env.observation`) under each view's
  settings."""
  return observe_columns(state, params,
                         view_columns(state, params, wind, views))


@functools.partial(jax.jit, static_argnums=0)
def _choice(network_def: Any, members: Any, obs: Array) -> Array:
  return critic_choice(network_def, members, obs)


class Lookahead(NamedTuple):
  """How far each proposal is flown ahead before it is scored.

  Attributes:
    strides: H imagined strides; 0: the critics score the proposals where
      the balloon is (`critic_choice`).
    follow: Strides after the first fly member k's own mean action on its
      view of the imagined state; else proposal k is held.
    discount: gamma, the members' discount (policy files do not record it:
      the trainers' default, `sac_core.SACHyperparameters.gamma`).
  """
  strides: int = 0
  follow: bool = False
  discount: float = sac_core.SACHyperparameters.gamma


NO_LOOKAHEAD = Lookahead()
# The lookaheads compared for the shipped members, (strides, follow),
# declared 2026-11-29 10:12 UTC, after validation flights of a slower
# version (imagined states observed with their own columns) and before any
# held-out flight: each flown on validation, the best validated (<= 5 % out
# of resources) alone then flown held out (`benchmarks/policy_select.py
# --mode=lookahead`). (3, True) validated best: `SACEnsembleAgent`'s default.
DECLARED_LOOKAHEADS = ((1, False), (2, True), (3, False), (3, True), (4, True))
# Only the planner's mode and its one-point correction (unused with a memory).
_FORECAST = plan_config.PlannerConfig()


def imagine(params: env_types.EnvParams, wind_fn: Callable[..., Any],
            state: env_types.EnvState, action: Array
            ) -> Tuple[env_types.EnvState, Array]:
  """One imagined stride of `lookahead_choice`: (state after it, reward).

  The env's stride (`jax_env.LatexBalloonJaxEnv.step_env`) in the planning
  wind: the flight as a controller may know it (`estimator.planning_view`:
  the disturbances' estimates held, the burst volume's low quantile; as the
  planners, `plan_objective.fly`), its measured wind the planning wind where it ends,
  its altitude history pushed (`jax_env.stride_state`), its memory of
  measured winds kept (an imagined wind is not a measurement); the reward
  is the env's (`jax_env.stride_reward`), 0 where the flight had already
  ended.

  Args:
    params: The env parameters.
    wind_fn: The planning wind (x [m], y [m], P [Pa], t [s]) -> (u, v).
      # [m/s]
    state: The imagined state (`plan_objective.blind`).
    action: In the normalised box [-1, 1]^3.
  """
  before = state.flight
  box = jnp.clip(jax_env.to_box(action).astype(before.altitude_m.dtype),
                 jax_env.ACTION_LOW, jax_env.ACTION_HIGH)
  # What a controller may know (`estimator.planning_view`).
  flight_params, seen = estimator.planning_view(
      env_types.flight_params_of(params, state), before)
  flight = dynamics.step(flight_params, state.atmosphere, seen, box, wind_fn,
                         params.stride_s)
  u, v = wind_fn(flight.x_m, flight.y_m, flight.pressure_pa, flight.time_s)
  after = jax_env.stride_state(state, flight, box).replace(
      wind_u=u.astype(state.wind_u.dtype),
      wind_v=v.astype(state.wind_v.dtype))
  return after, jnp.where(before.status == state_lib.FlightStatus.OK,
                          jax_env.stride_reward(params, before, flight), 0.0)


def lookahead_scores(network_def: Any, members: Any, group: Tuple[int, ...],
                     views: Sequence[View], lookahead: Lookahead,
                     wind: winds.Wind, params: env_types.EnvParams,
                     state: env_types.EnvState) -> Tuple[Array, Array]:
  """The proposals and their lookahead scores (module docstring).

  It reads no future truth: the state's noise is zeroed
  (`plan_objective.blind`) before anything is imagined. Nothing is added
  after an imagined flight ends (its value counts 0). The imagined states
  are observed with the wind columns of the state the decision is made
  from (each view's `view_columns`, read against the imagined position,
  altitude and measured wind): a column costs 12 to 36 times a stride's
  features, and over a few strides the balloon moves tens of km while the
  column's levels stay.

  Args:
    network_def: The members' network.
    members: Their parameters, stacked on a leading axis of K.
    group: Member k observes `views[group[k]]` (`views_of`).
    views: The distinct views, the env's first.
    lookahead: H >= 1 strides, follow, discount.
    wind: The env's wind.
    params: The env parameters (the env's view).
    state: One balloon's env state.

  Returns:
    (proposals [K, num_actions] in [-1, 1], scores [K]).
  """
  index = jnp.asarray(group)
  gamma = lookahead.discount
  columns = view_columns(state, params, wind, views)  # Each [G, L].
  obs = observe_columns(state, params, columns)[index]  # [K, F]
  actions = proposals(network_def, members, obs, per_member=True)
  blind = plan_objective.blind(state)
  wind_fn = plan_objective.planning_wind(_FORECAST, wind, blind,
                                         memory=blind.wind_memory)

  def score(k, action):
    def stride(carry, t):
      s, total, a = carry
      s, r = imagine(params, wind_fn, s, a)
      if lookahead.follow:  # Member k's own mean action on its view of s.
        a = network_def.apply(
            jax.tree.map(lambda x: x[k], members),
            jax_env.observation_of_column(s, params, columns[0][index[k]],
                                          columns[1][index[k]]),
            jax.random.PRNGKey(0), method=network_def.actor).mean_action
      return (s, total + gamma ** t * r, a), None

    (end, total, _), _ = jax.lax.scan(
        stride, (blind, jnp.zeros((), jnp.float32), action),
        jnp.arange(lookahead.strides, dtype=jnp.float32))
    value = jnp.mean(jax.vmap(
        lambda p, o: plan_value.state_value(network_def, p, o))(
            members, observe_columns(end, params, columns)[index]))
    return total + jnp.where(end.flight.status == state_lib.FlightStatus.OK,
                             gamma ** lookahead.strides * value, 0.0)

  return actions, jax.vmap(score)(jnp.arange(actions.shape[0]), actions)


def lookahead_choice(*args: Any) -> Array:
  """The proposal of best `lookahead_scores` (its arguments): [A]."""
  actions, scores_k = lookahead_scores(*args)
  return actions[jnp.argmax(scores_k)]


def state_choice(network_def: Any, group: Tuple[int, ...],
                 views: Tuple[View, ...], lookahead: Lookahead,
                 wind: winds.Wind, members: Any, state: env_types.EnvState,
                 params: env_types.EnvParams) -> Array:
  """The ensemble's choice for one balloon's env state (traceable): each
  member on its own view, with `lookahead` if it has strides."""
  if lookahead.strides:
    return lookahead_choice(network_def, members, group, views, lookahead,
                            wind, params, state)
  return critic_choice(network_def, members,
                       observe(state, params, wind, views), group)


@functools.partial(jax.jit, static_argnums=(0, 1, 2, 3, 4))
def choice_from_state(network_def: Any, group: Tuple[int, ...],
                      views: Tuple[View, ...], lookahead: Lookahead,
                      wind: winds.Wind, members: Any,
                      state: env_types.EnvState,
                      params: env_types.EnvParams) -> Array:
  """`state_choice` of one balloon (jitted)."""
  return state_choice(network_def, group, views, lookahead, wind, members,
                      state, params)


@functools.partial(jax.jit, static_argnums=(0, 1, 2, 3, 4))
def choices_from_states(network_def: Any, group: Tuple[int, ...],
                        views: Tuple[View, ...], lookahead: Lookahead,
                        wind: winds.Wind, members: Any,
                        states: env_types.EnvState,
                        params: env_types.EnvParams) -> Array:
  """`state_choice` of [N] balloons, one by one (`lax.map`): [N, A]."""
  return jax.lax.map(lambda s: state_choice(
      network_def, group, views, lookahead, wind, members, s, params), states)


@functools.partial(jax.jit, static_argnums=0)
def choices(network_def: Any, members: Any, observations: Array) -> Array:
  """`critic_choice` of [N] observations, row by row (`lax.map`): [N, A].

  Row by row, as the one-balloon agent computes each (a batched matmul
  sums in another order).
  """
  return jax.lax.map(lambda o: critic_choice(network_def, members, o),
                     observations)


@gin.configurable(module='ble_latex.agents.ensemble',
                denylist=['num_actions', 'observation_shape', 'action_low',
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
               lookahead_strides: int = 3,
               lookahead_follow: bool = True,
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
      lookahead_strides: H, 0 to `MAX_LOOKAHEAD` strides each proposal is
        flown ahead in the forecast before it is scored
        (`lookahead_choice`); 0: scored where the balloon is. The default
        (3, following the members) validated best of the lookaheads
        declared beforehand (`DECLARED_LOOKAHEADS`).
      lookahead_follow: The imagined strides after the first fly each
        member's own action (`Lookahead.follow`).
      **kwargs: Further `SACPretrainedAgent` arguments.

    Raises:
      FileNotFoundError: A member's file is missing.
      ValueError: A bad file, or a member whose acting settings differ
        from the env's or the first member's (one line).
      errors.ConfigError: No paths, too many, a `policy_path`, no
        shipped ensemble for the physics gin binds, or a bad lookahead.
    """
    if (isinstance(lookahead_strides, bool) or
        not isinstance(lookahead_strides, (int, np.integer)) or
        not 0 <= lookahead_strides <= MAX_LOOKAHEAD):
      raise errors.ConfigError(
          f'SACEnsembleAgent.lookahead_strides must be an integer from 0 to '
          f'{MAX_LOOKAHEAD}, got {lookahead_strides!r}')
    if not isinstance(lookahead_follow, (bool, np.bool_)):
      raise errors.ConfigError(
          'SACEnsembleAgent.lookahead_follow must be True or False, got '
          f'{lookahead_follow!r}')
    self.lookahead = Lookahead(int(lookahead_strides), bool(lookahead_follow))
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
    """True when a member observes otherwise than the env (`observe`) or
    the proposals are flown ahead (`lookahead_choice` reads the state)."""
    return len(self.views) > 1 or self.lookahead.strides > 0

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
          'sac_ensemble reads the env\'s core state (members of other views '
          'or a lookahead): call attach_env(env) first (ble-latex-eval does)')
    else:
      action = choice_from_state(self.network_def, self.group, self.views,
                                 self.lookahead, self._wind, self.members,
                                 self._driver.state, self._driver.params)
    action = np.asarray(action, np.float32)
    if not np.all(np.isfinite(action)):
      raise sac_core.TrainingDiverged(
          f'SAC ensemble produced a non-finite action {action.tolist()}: a '
          'member\'s parameters have diverged')
    return action
