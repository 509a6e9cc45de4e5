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


def train(*, agent_name: str, env_name: str, base_dir: str,
          num_iterations: int, episodes_per_iteration: int,
          max_episode_length: int, collectors: Sequence[str],
          seed: int = 0) -> None:
  """Runs (or resumes) a training run; gin must already be bound."""
  for name in collectors:
    if name not in metrics.AVAILABLE_COLLECTORS:
      raise ValueError(f'Unknown collector {name!r}; available: '
                       f'{sorted(metrics.AVAILABLE_COLLECTORS)}')
  if num_iterations < 1 or episodes_per_iteration < 1 or max_episode_length < 1:
    raise ValueError('num_iterations, episodes_per_iteration and '
                     'max_episode_length must be >= 1')
  os.makedirs(base_dir, exist_ok=True)
  env = gym.make(env_name).unwrapped
  agent = runner.create_agent(agent_name, env, seed=seed)
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
  dispatcher.end_training()
  with open(os.path.join(base_dir, 'operative_config.gin'), 'w') as f:
    f.write(gin.operative_config_str())
