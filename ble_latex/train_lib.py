# coding=utf-8
"""The latex training loop (BLE's `train_lib.run_training_loop`, for Box actions).

Checkpoints after each iteration; a restarted run resumes after the last
checkpoint. Used by `ble-latex-train` and the demo.
"""

import os
from typing import Sequence

from absl import logging
from balloon_learning_environment.agents import agent as base_agent
from balloon_learning_environment.metrics import collector_dispatcher
import gin
import gym

from ble_latex import metrics
from ble_latex import runner
from ble_latex import suites
from ble_latex.agents import pretrained
from ble_latex.agents import sac


def policy_snapshot_path(base_dir: str, iteration: int) -> str:
  """Where `train` exports the policy of `iteration` (0-based)."""
  return os.path.join(base_dir, 'policies', f'policy_{iteration:05d}.pkl')


def train(*, agent_name: str, env_name: str, base_dir: str,
          num_iterations: int, episodes_per_iteration: int,
          max_episode_length: int, collectors: Sequence[str],
          seed: int = 0, policy_snapshot_period: int = 0) -> None:
  """Runs (or resumes) a training run; gin must already be bound.

  Args:
    agent_name: Registered agent name (`runner.create_agent`).
    env_name: Gym id of the env.
    base_dir: Run directory (checkpoints/, episodes.jsonl, metrics/).
    num_iterations: Iterations to train in total (a resumed run counts the
      finished ones).
    episodes_per_iteration: Episodes per iteration; a checkpoint follows each.
    max_episode_length: Steps per episode at most.
    collectors: Names from `metrics.AVAILABLE_COLLECTORS`.
    seed: Agent seed.
    policy_snapshot_period: If > 0 (SAC agents only), every this many
      iterations the acting part of the checkpoint is also exported to
      `base_dir/policies/policy_NNNNN.pkl` (~1 MB; checkpoints hold the
      replay buffer and only the newest few are kept), so a policy can be
      chosen afterwards on a validation suite (`benchmarks/train_sac.py`).

  Raises:
    ValueError: On an unknown collector, a non-positive count, or policy
      snapshots asked of an agent that is not SAC.
  """
  for name in collectors:
    if name not in metrics.AVAILABLE_COLLECTORS:
      raise ValueError(f'Unknown collector {name!r}; available: '
                       f'{sorted(metrics.AVAILABLE_COLLECTORS)}')
  if num_iterations < 1 or episodes_per_iteration < 1 or max_episode_length < 1:
    raise ValueError('num_iterations, episodes_per_iteration and '
                     'max_episode_length must be >= 1')
  if policy_snapshot_period < 0:
    raise ValueError('policy_snapshot_period must be >= 0, got '
                     f'{policy_snapshot_period}')
  os.makedirs(base_dir, exist_ok=True)
  env = gym.make(env_name).unwrapped
  agent = runner.create_agent(agent_name, env, seed=seed)
  if policy_snapshot_period and not isinstance(agent, sac.SACAgent):
    raise ValueError(f'policy snapshots need a SAC agent, not {agent_name!r}')
  checkpoint_dir = os.path.join(base_dir, 'checkpoints')
  start_iteration = agent.reload_latest_checkpoint(checkpoint_dir) + 1
  start_episode = start_iteration * episodes_per_iteration
  if start_iteration:
    logging.info('Resuming after checkpoint %d (episode %d).',
                 start_iteration - 1, start_episode)
  total = num_iterations * episodes_per_iteration

  def make(name):
    ctor = metrics.AVAILABLE_COLLECTORS[name]
    if ctor is metrics.ProgressCollector:
      return lambda d, n, e: ctor(d, n, e, total_episodes=total,
                                  description=f'train {agent_name}')
    return ctor

  action_dim = (env.action_space.n if hasattr(env.action_space, 'n') else
                env.action_space.shape[0])
  dispatcher = collector_dispatcher.CollectorDispatcher(
      base_dir, action_dim, [make(c) for c in collectors], start_episode)
  agent.set_summary_writer(dispatcher.get_summary_writer())
  agent.set_mode(base_agent.AgentMode.TRAIN)
  dispatcher.pre_training()
  for iteration in range(start_iteration, num_iterations):
    for i in range(episodes_per_iteration):
      episode = iteration * episodes_per_iteration + i
      runner.run_episode(env, agent, episode=episode,
                         seed=suites.train_seed(episode),
                         max_steps=max_episode_length, dispatcher=dispatcher)
    agent.save_checkpoint(checkpoint_dir, iteration)
    if policy_snapshot_period and (iteration + 1) % policy_snapshot_period == 0:
      # From the agent in memory: reading the checkpoint back would load the
      # replay buffer (~150 MB late in a 2500-episode run) every iteration.
      policy = pretrained.policy_from_bundle(
          agent.acting_bundle(iteration),
          os.path.basename(sac.checkpoint_path(checkpoint_dir, iteration)),
          note=f'{agent_name} after {(iteration + 1) * episodes_per_iteration} '
          'training episodes')
      pretrained.write_policy(policy, policy_snapshot_path(base_dir, iteration))
  dispatcher.end_training()
  with open(os.path.join(base_dir, 'operative_config.gin'), 'w') as f:
    f.write(gin.operative_config_str())
