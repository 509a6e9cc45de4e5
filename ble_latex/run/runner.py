# coding=utf-8
"""Runs agents in the latex envs: one episode and agent construction.

Shared by `ble-latex-train` and `ble-latex-eval`. Follows BLE's `train_lib`
episode loop (begin_episode / step / end_episode, collectors notified per
step), generalised to Box action spaces, with per-episode seeds.
"""

from typing import Any, Dict, List, Optional, Tuple

from balloon_learning_environment.agents import agent as base_agent
from balloon_learning_environment.agents import agent_registry
from balloon_learning_environment.metrics import collector_dispatcher
from balloon_learning_environment.utils import run_helpers
import gym
import numpy as np

from ble_latex import agents as latex_agents
from ble_latex import errors
from ble_latex import quiet
from ble_latex.run import metrics


def create_agent(name: str, env: gym.Env, seed: int = 0) -> base_agent.Agent:
  """Builds a registered agent for `env` (Box or Discrete actions)."""
  latex_agents.register()
  with quiet.dopamine_parameters_at_debug():
    return _create_agent(name, env, seed)


def _create_agent(name: str, env: gym.Env, seed: int) -> base_agent.Agent:
  observation_shape = env.observation_space.shape
  space = env.action_space
  constructor = agent_registry.agent_constructor(name)
  if isinstance(space, gym.spaces.Discrete):
    if getattr(constructor, 'supports_box_actions', False):  # Box only.
      raise errors.ConfigError(
          f'Agent {name!r} acts in the Box ([-1, 1] altitude actions); use '
          'it with --env_name=LatexBalloon-v0, not a discrete-action env')
    return run_helpers.create_agent(name, space.n,
                                    observation_shape=observation_shape)
  if not getattr(constructor, 'supports_box_actions', False):
    raise errors.ConfigError(
        f'Agent {name!r} only supports discrete actions; use it with '
        "--env_name=LatexBalloonDiscrete-v0, or a Box agent "
        f'({sorted(latex_agents.BOX_AGENTS)}) with LatexBalloon-v0.')
  agent = constructor(space.shape[0], observation_shape=observation_shape,
                      action_low=space.low, action_high=space.high, seed=seed)
  if getattr(agent, 'needs_env', False):  # The planners read the core state.
    agent.attach_env(env)
  return agent


def flight_point(env: gym.Env) -> Dict[str, Any]:
  """One point of an eval record's flight path: the balloon's state now.

  Args:
    env: A gym env of ble_latex (its arena holds the balloon state).

  Returns:
    `t_s`, `x_km`, `y_km`, `altitude_m`, `ascent_rate_mps`, `decision`,
    `helium_mols`, `sand_kg` (`records.FLIGHT_POINT_SCHEMA`).
  """
  s = env.unwrapped.arena.get_balloon_state()
  return {
      't_s': s.time_elapsed.total_seconds(),
      'x_km': s.x.kilometers,
      'y_km': s.y.kilometers,
      'altitude_m': s.altitude_m,
      'ascent_rate_mps': s.ascent_rate_mps,
      'decision': s.last_decision.name.lower(),
      'helium_mols': s.helium_mols,
      'sand_kg': s.sand_kg,
  }


def run_episode(
    env: gym.Env,
    agent: base_agent.Agent,
    *,
    episode: int,
    seed: int,
    max_steps: int,
    dispatcher: Optional[collector_dispatcher.CollectorDispatcher] = None,
    record_flight: bool = False
) -> Tuple[metrics.EpisodeSummary, List[Dict[str, Any]]]:
  """Runs one episode from `seed`; returns its summary and flight path."""
  if dispatcher is not None:
    dispatcher.begin_episode()
  tracker = metrics.EpisodeTracker(
      episode, seed, env.unwrapped.radius.kilometers,
      window_steps=min(env.unwrapped.episode_steps, max_steps))
  obs = env.reset(seed=seed)
  flight = [flight_point(env)] if record_flight else []
  action = agent.begin_episode(obs)
  done, reward, info = False, 0.0, {}
  for i in range(max_steps):
    obs, reward, done, info = env.step(action)
    tracker.step(reward, info)
    if record_flight:
      flight.append(flight_point(env))
    if done or i == max_steps - 1:
      break  # The last transition goes to end_episode below.
    if dispatcher is not None:
      dispatcher.step(metrics.LatexStatistics(
          step=i, action=np.asarray(action).tolist(), reward=reward,
          terminal=done, info=info))
    action = agent.step(reward, obs)
  # A time limit is a truncation, not a terminal state (no bootstrapping cut).
  terminal = done and not info.get('TimeLimit.truncated', False)
  agent.end_episode(reward, terminal)
  summary = tracker.summary(done)
  if dispatcher is not None:
    dispatcher.end_episode(metrics.LatexStatistics(
        step=tracker.steps, action=np.asarray(action).tolist(), reward=reward,
        terminal=terminal, info=info, summary=summary))
  return summary, flight
