# coding=utf-8
"""The agents that fly launch candidates, as pure JAX controllers.

A launch planner scores thousands of candidate launches, each flown for a
whole episode: the controller must act inside one jitted `lax.scan` over the
strides, for all balloons at once. `run/batch_eval.py`'s `CorePolicy` acts
from the host once per stride (the seeker there is one Python copy of the
agent per balloon), so it does not fit; a `Controller` here is the same
agent's policy as pure functions of one balloon (vmapped by the scorer):

- `init(obs, state)`: the controller's carry at the launch;
- `plan(carry, obs, state, params, wind)`: called at the start of every
  `period` strides (a planner's replan; the others return the carry);
- `act(carry, obs, state, i)`: the action (a0 [m], a1, a2) in the core's Box
  at stride `i` of the period, and the next carry.

`controller_for(agent)` gives an agent's controller, reading the agent's own
settings (gin bindings included):

- `baselines.GeometricStationSeeker` (`latex_station_seeker`): its rule on
  the observation, decoded as `jax_features.NamedLatexFeatures` decodes it
  (the same actions as the agent's, `tests/launch/test_launch.py`);
- `sac.SACAgent` in eval mode (`sac`, `sac_pretrained`): its mean action
  tanh(mu(s)) mapped onto the Box by `jax_env.to_box`;
- `ensemble.SACEnsembleAgent` (`sac_ensemble`): its members' critics'
  choice (`ensemble.critic_choice`), mapped the same way;
- `planners.PlannerAgent` (`latex_mpc`, ...): `planning.plan` every
  `replan_every` strides, the plan's actions (`plan_objective.plan_actions`)
  in between.
"""

import functools
import math
from typing import Any, Tuple

from balloon_learning_environment.agents import agent as base_agent
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import errors
from ble_latex.agents import baselines
from ble_latex.agents.planning import agents as planners
from ble_latex.agents.planning import objective as plan_objective
from ble_latex.agents.planning import planner as planning
from ble_latex.agents.sac import agent as sac
from ble_latex.agents.sac import ensemble
from ble_latex.envs import env_params
from ble_latex.envs import env_types
from ble_latex.envs import jax_env
from ble_latex.envs import jax_features
from ble_latex.envs import winds

Array = jax.Array


class Controller:
  """An agent's policy for one balloon, pure JAX (see the module).

  Attributes:
    name: The agent's name (for records).
    period: Strides between `plan` calls (1: every stride).
  """

  name = 'controller'
  period = 1

  def init(self, obs: Array, state: env_types.EnvState) -> Any:
    """The carry at the launch."""
    del obs, state
    return jnp.zeros(())

  def plan(self, carry: Any, obs: Array, state: env_types.EnvState,
           params: env_types.EnvParams, wind: winds.Wind) -> Any:
    """The carry at the start of a period (default: unchanged)."""
    del obs, state, params, wind
    return carry

  def act(self, carry: Any, obs: Array, state: env_types.EnvState,
          i: Array) -> Tuple[Array, Any]:
    """(action (a0 [m], a1, a2) in the Box, next carry) at stride `i`."""
    raise NotImplementedError


class SeekerController(Controller):
  """`GeometricStationSeeker`'s rule (Du et al. 2019) in JAX.

  Go to the level whose forecast wind has the largest component towards the
  station (speed * cos(bearing error)); switch levels only for a gain of
  `min_gain_mps`; float within `float_within_m` of the chosen level. The
  carry is the chosen level's altitude (NaN: none yet). # [m]
  """

  name = 'latex_station_seeker'

  def __init__(self, agent: baselines.GeometricStationSeeker):
    # pylint: disable=protected-access
    self._levels = np.asarray(agent._level_altitudes, np.float32)  # [m]
    self._low = np.asarray(agent._low, np.float32)
    self._high = np.asarray(agent._high, np.float32)
    self._time_factor = float(agent._time_factor)
    self._float_within_m = float(agent._float_within_m)  # [m]
    self._min_gain_mps = float(agent._min_gain_mps)  # [m/s]
    # pylint: enable=protected-access

  # Equal settings are one static jit argument (the scorer compiles once).
  def _key(self):
    return (self._levels.tobytes(), self._low.tobytes(), self._high.tobytes(),
            self._time_factor, self._float_within_m, self._min_gain_mps)

  def __eq__(self, other):
    return type(other) is type(self) and self._key() == other._key()

  def __hash__(self):
    return hash(self._key())

  def init(self, obs, state):
    del obs, state
    return jnp.full((), jnp.nan, jnp.float32)

  def act(self, carry, obs, state, i):
    del state, i
    n = jax_features.N_LEVELS
    # NamedLatexFeatures' decoding: 1 - exp(-|v| / c), bearing / pi, and
    # (h - 17.5 km) / 3.5 km.
    squashed = jnp.clip(obs[:n], 0.0, 1.0 - 1e-6)
    speeds = -jax_features.SPEED_SQUASH_MPS * jnp.log1p(-squashed)  # [m/s]
    bearings = obs[n:2 * n] * math.pi  # [rad]
    altitude = (jax_features.ALTITUDE_CENTER_M +
                jax_features.ALTITUDE_SCALE_M * obs[2 * n])  # [m]
    levels = jnp.asarray(self._levels)
    reachable = (levels >= self._low[0]) & (levels <= self._high[0])
    towards = jnp.where(reachable, speeds * jnp.cos(bearings), -jnp.inf)
    best = jnp.argmax(towards)
    here = jnp.argmin(jnp.abs(levels - altitude))
    switch = jnp.isnan(carry) | (towards[best] >
                                 towards[here] + self._min_gain_mps)
    target = jnp.where(switch, levels[best], carry)
    a0 = jnp.clip(target, self._low[0], self._high[0])
    a2 = jnp.where(jnp.abs(a0 - altitude) <= self._float_within_m, 1.0, -1.0)
    return jnp.stack([a0, jnp.full_like(a0, self._time_factor), a2]), target


class SacController(Controller):
  """SAC's deterministic eval action: `to_box(tanh(mu(obs)))`."""

  name = 'sac'

  def __init__(self, agent: sac.SACAgent):
    self._network_def = agent.network_def
    self._network_params = agent.network_params

  def normalized(self, obs: Array) -> Array:
    """The action in the normalised box [-1, 1]^3."""
    # The actor also draws a sample; its key does not change the mean.
    return self._network_def.apply(
        self._network_params, obs, jax.random.PRNGKey(0),
        method=self._network_def.actor).mean_action

  def act(self, carry, obs, state, i):
    del state, i
    return jax_env.to_box(self.normalized(obs)), carry


class EnsembleController(SacController):
  """`sac_ensemble`: `to_box(ensemble.critic_choice(obs))`.

  Members that observe otherwise than the env, or a lookahead, choose in
  `plan` (each stride) from the state (`ensemble.state_choice`); the carry
  holds the choice.
  """

  name = 'sac_ensemble'

  def __init__(self, agent: ensemble.SACEnsembleAgent):
    super().__init__(agent)
    self._members = agent.members
    self._views = agent.views
    self._group = agent.group
    self._lookahead = agent.lookahead
    self._reads_state = agent.needs_env

  def normalized(self, obs: Array) -> Array:
    return ensemble.critic_choice(self._network_def, self._members, obs)

  def init(self, obs, state):
    del state
    return jnp.zeros_like(self.normalized(obs))

  def plan(self, carry, obs, state, params, wind):
    if not self._reads_state:
      return carry
    return ensemble.state_choice(self._network_def, self._group, self._views,
                                 self._lookahead, wind, self._members, state,
                                 params)

  def act(self, carry, obs, state, i):
    if not self._reads_state:
      return super().act(carry, obs, state, i)
    return jax_env.to_box(carry), carry


class PlannerController(Controller):
  """A planner: `planning.plan` every `replan_every` strides."""

  name = 'latex_mpc'

  def __init__(self, agent: planners.PlannerAgent):
    self._config = agent.config
    self.period = int(agent.config.replan_every)
    # pylint: disable=protected-access
    self._seed = int(agent._seed)
    self._low = np.asarray(agent._low, np.float32)
    self._high = np.asarray(agent._high, np.float32)
    # pylint: enable=protected-access

  def init(self, obs, state):
    del obs
    return planning.initial_plan(self._config, state)

  def plan(self, carry, obs, state, params, wind):
    del obs
    return planning.plan(self._config, params, state,
                         planning.plan_key(self._seed, state), carry, wind)

  def act(self, carry, obs, state, i):
    del obs, state
    actions = plan_objective.plan_actions(self._config, carry.targets_m,
                                          carry.floats)
    return jnp.clip(actions[i], self._low, self._high), carry


@functools.singledispatch
def controller_for(agent: Any) -> Controller:
  """The pure JAX controller of an agent (see the module).

  Args:
    agent: A BLE agent of `LatexBalloon-v0`.

  Returns:
    Its `Controller`.

  Raises:
    errors.ConfigError: an agent without one (one line).
  """
  raise errors.ConfigError(
      f'{type(agent).__name__} has no JAX controller for launch planning; '
      'fly latex_station_seeker, sac, sac_pretrained, sac_ensemble or a '
      'latex_mpc planner')


@controller_for.register
def _seeker(agent: baselines.GeometricStationSeeker) -> Controller:
  return SeekerController(agent)


@controller_for.register
def _sac(agent: sac.SACAgent) -> Controller:
  agent.set_mode(base_agent.AgentMode.EVAL)
  return SacController(agent)


@controller_for.register
def _ensemble(agent: ensemble.SACEnsembleAgent) -> Controller:
  return EnsembleController(agent)


@controller_for.register
def _planner(agent: planners.PlannerAgent) -> Controller:
  return PlannerController(agent)


def controller_named(name: str, seed: int = 0) -> Controller:
  """The controller of the registered agent `name` (gin bindings applied).

  The agent is built for `LatexBalloon-v0`'s Box without an env (the
  planners' env is the scorer's world).

  Raises:
    errors.ConfigError: an unknown agent, or one without a controller.
  """
  # pylint: disable=g-import-not-at-top
  from balloon_learning_environment.agents import agent_registry
  from ble_latex import agents
  # pylint: enable=g-import-not-at-top
  agents.register()
  if name not in agent_registry.REGISTRY:
    raise errors.ConfigError(
        f'unknown agent {name!r}; valid: '
        f'{", ".join(sorted(agents.BOX_AGENTS))}')
  constructor = agent_registry.agent_constructor(name)
  if not getattr(constructor, 'supports_box_actions', False):
    raise errors.ConfigError(f'agent {name!r} does not act in the Box of '
                             'LatexBalloon-v0')
  agent = constructor(len(jax_env.ACTION_LOW),
                      observation_shape=(env_params.num_features(
                          env_params.observation_settings()),),
                      action_low=np.asarray(jax_env.ACTION_LOW),
                      action_high=np.asarray(jax_env.ACTION_HIGH), seed=seed)
  controller = controller_for(agent)
  controller.name = name
  return controller
