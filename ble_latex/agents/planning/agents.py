# coding=utf-8
"""The planners as BLE agents (latex_mpc, latex_mpc_oracle, latex_mpc_grad).

Thin BLE `Agent`s over the pure planning of `planning` (the search),
`plan_objective` (the objective and winds), `beam` (the beam search) and
`plan_config` (the settings, their limits and the gin configurables
`LatexMpcAgent.*`, `LatexMpcOracleAgent.*`, `LatexMpcGradAgent.*`). An agent
reads the core state of the env it flies (`attach_env`, called by
`run.runner.create_agent`), plans every `replan_every` strides and flies
the plan's actions in between. This module imports BLE's `Agent` (and
TensorFlow behind it); the pure modules import neither.
"""

import time
from typing import Any, Dict, List, Optional, Sequence, Tuple

from balloon_learning_environment.agents import agent
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import errors
from ble_latex.agents.planning import config as plan_config
from ble_latex.agents.planning import planner as planning
from ble_latex.envs import jax_env
from ble_latex.envs import winds


def core_of(env: Any) -> Tuple[Any, winds.Wind]:
  """The core balloon an env flies, and its JAX wind.

  Accepts BLE's `LatexBalloon-v0` (its arena's driver) or the Gymnasium
  `LatexBalloonGymnasiumEnv` (anything with `state` and `params`).

  Raises:
    errors.ConfigError: An env without a JAX core state, or one that flies
      a BLE wind field through host callbacks (a planner needs JAX winds).
  """
  env = getattr(env, 'unwrapped', env)
  arena = getattr(env, 'arena', None)
  driver = getattr(arena, 'driver', None) if arena is not None else None
  driver = driver if driver is not None else env
  if not (hasattr(driver, 'state') and hasattr(driver, 'params')):
    raise errors.ConfigError(
        f'the planners fly LatexBalloon-v0 (a JAX core state); {env!r} has '
        'none')
  if getattr(driver, 'host_wind_field', None) is not None:
    raise errors.ConfigError(
        'the planners need JAX winds (the generative field, or ERA5 in the '
        'env params); this env flies a BLE wind field through host callbacks')
  return driver, jax_env.LatexBalloonJaxEnv().wind_for(driver.params)


class PlannerAgent(agent.Agent):
  """An MPC agent over the core state of the env it is attached to.

  `run.runner.create_agent` calls `attach_env(env)`; the agent then reads
  the env's `EnvState` at every decision (FORECAST and GRADIENT read it
  without the noise, `blind`), plans every `replan_every` strides and flies
  the plan's actions in between. The observation is not used.

  Args:
    num_actions: Size of the action (must be 3: a0, a1, a2).
    observation_shape: The observation's shape (unused).
    action_low: The action Box's lower bounds; actions are clipped to it.
    action_high: The action Box's upper bounds.
    seed: The agent seed (with the flight and stride, `planning.plan_key`).
    **config: `plan_config.PlannerConfig` fields, over gin's bindings of the
      class's `planner` (`plan_config.PLANNERS`); checked.

  Attributes:
    planner: The planner's name (a key of `plan_config.PLANNERS`).
    config: The checked `plan_config.PlannerConfig` it plans with.

  Raises:
    errors.ConfigError: `num_actions` other than 3, or a bad config value.
  """

  supports_box_actions = True
  needs_env = True
  planner: str = ''  # Set by each planner's class.

  def __init__(self, num_actions: int, observation_shape: Sequence[int], *,
               action_low: Sequence[float], action_high: Sequence[float],
               seed: int = 0, **config: Any):
    super().__init__(num_actions, observation_shape)
    if num_actions != 3:
      raise errors.ConfigError(
          f'the planners act in the (a0, a1, a2) Box; got {num_actions} '
          'actions')
    self._low = np.asarray(action_low, np.float64)
    self._high = np.asarray(action_high, np.float64)
    # gin's bindings of the planner, overridden by `config`; checked.
    self.config = plan_config.PLANNERS[self.planner](**config)
    self._seed = int(seed)
    self._driver = None
    self._wind = None
    self._plan: Optional[planning.Plan] = None
    self._since = 0
    self.decision_seconds: List[float] = []  # Wall time of each plan. # [s]

  def attach_env(self, env: Any) -> None:
    """Flies `env`'s core from now on (see `core_of`)."""
    self._driver, self._wind = core_of(env)

  def _act(self) -> np.ndarray:
    if self._driver is None:
      raise RuntimeError('PlannerAgent.attach_env(env) was not called')
    if self._plan is None or self._since >= self.config.replan_every:
      start = time.perf_counter()
      state = jax.tree.map(lambda a: a[None], self._driver.state)
      previous = (planning.initial_plans(self.config, state)
                  if self._plan is None
                  else jax.tree.map(lambda a: a[None], self._plan))
      new = planning.plan_batch(self.config, self._driver.params, state,
                                jnp.int32(self._seed), previous, self._wind)
      self._plan = jax.tree.map(lambda a: a[0], jax.block_until_ready(new))
      self.decision_seconds.append(time.perf_counter() - start)
      self._since = 0
    action = planning.next_action(self.config, self._plan, self._since)
    self._since += 1
    return np.clip(action, self._low, self._high)

  def begin_episode(self, observation: np.ndarray) -> np.ndarray:
    """Drops the last plan and plans from the env's new flight.

    Args:
      observation: Unused (the agent reads the env's core state).

    Returns:
      The first action (a0 [m], a1, a2), clipped into the Box.

    Raises:
      RuntimeError: `attach_env` was not called.
    """
    self._plan, self._since = None, 0
    return self._act()

  def step(self, reward: float, observation: np.ndarray) -> np.ndarray:
    """The next action of the plan (replanning every `replan_every`).

    Args:
      reward: Unused.
      observation: Unused (the agent reads the env's core state).

    Returns:
      The action (a0 [m], a1, a2), clipped into the Box.

    Raises:
      RuntimeError: `attach_env` was not called.
    """
    return self._act()

  def end_episode(self, reward: float, terminal: bool = True) -> None:
    """Drops the current plan.

    Args:
      reward: Unused.
      terminal: Unused.
    """
    self._plan = None


class LatexMpcAgent(PlannerAgent):
  """Beam-search MPC on the forecast (agent latex_mpc); never reads the noise.

  Settings: gin `LatexMpcAgent.*` (`plan_config.PLANNERS['latex_mpc']`).
  """
  planner = 'latex_mpc'


class LatexMpcOracleAgent(PlannerAgent):
  """Beam search over the whole episode on the true wind (agent
  latex_mpc_oracle): an upper bound. It also knows the flight's drawn burst
  volume and, under stochastic physics, the disturbance's path (the env's
  own draws, `plan_objective.fly(exact=True)`): the env flies its plan
  exactly.

  Settings: gin `LatexMpcOracleAgent.*`
  (`plan_config.PLANNERS['latex_mpc_oracle']`).
  """
  planner = 'latex_mpc_oracle'


class LatexMpcGradAgent(PlannerAgent):
  """First-order MPC on the forecast (agent latex_mpc_grad).

  Settings: gin `LatexMpcGradAgent.*`
  (`plan_config.PLANNERS['latex_mpc_grad']`).
  """
  planner = 'latex_mpc_grad'


AGENTS: Dict[str, Any] = {'latex_mpc': LatexMpcAgent,
                          'latex_mpc_oracle': LatexMpcOracleAgent,
                          'latex_mpc_grad': LatexMpcGradAgent}
