# coding=utf-8
"""The latex training loop (BLE's `train_lib.run_training_loop`, for Box actions).

Checkpoints after each iteration; a restarted run resumes after the last
checkpoint. Used by `ble-latex-train` and the demo.
"""

import os
from typing import Sequence

from absl import logging
from balloon_learning_environment.agents import agent as base_agent
import gin
import gym

from ble_latex import errors
from ble_latex import run_files
from ble_latex import safe_io
from ble_latex.agents.sac import agent as sac
from ble_latex.agents.sac import pretrained
from ble_latex.envs import env_params
from ble_latex.run import collectors as collectors_lib
from ble_latex.run import run_dir
from ble_latex.run import runner
from ble_latex.run import suites


def _reload_latest(agent: base_agent.Agent, checkpoint_dir: str) -> int:
  """Loads the newest numbered checkpoint; returns its iteration or -1.

  SAC agents find theirs themselves (`sac.SACAgent.reload_latest_checkpoint`).
  For BLE's agents, whose `reload_latest_checkpoint` gives -1 as soon as any
  `checkpoint_*.pkl` name lacks a number, the numbered files are found here
  and loaded with the agent's own `load_checkpoint`.
  """
  if isinstance(agent, sac.SACAgent):
    return agent.reload_latest_checkpoint(checkpoint_dir)
  # BLE's own agents write Dopamine's `checkpoint_NNNNN.pkl` files.
  iterations = run_files.iterations(checkpoint_dir,
                                    run_files.LEGACY_CHECKPOINT_PATTERN)
  if not iterations:
    return -1
  agent.load_checkpoint(checkpoint_dir, iterations[-1])
  return iterations[-1]


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
    collectors: Names from `collectors.AVAILABLE_COLLECTORS`.
    seed: Agent seed.
    policy_snapshot_period: If > 0 (SAC agents only), every this many
      iterations the acting part of the checkpoint is also exported to
      `base_dir/policies/policy_NNNNN.msgpack` (~1 MB; checkpoints hold the
      replay buffer and only the newest few are kept), so a policy can be
      chosen afterwards on a validation suite (`benchmarks/train_sac.py`).

  Raises:
    ValueError: On an unknown collector, a non-positive count, or policy
      snapshots asked of an agent that is not SAC.
    errors.ResumeError: If `base_dir` holds a run that cannot be resumed
      without losing logged episodes or with these settings (nothing is
      changed; `run_dir.check_resume`).
    safe_io.InUseError: If another process (or another run in this one)
      trains in `base_dir` (`safe_io.locked_dir`, held for the whole run).
  """
  run_dir.check_training_seed(seed)
  collectors_lib.check_collectors(collectors)
  if num_iterations < 1 or episodes_per_iteration < 1 or max_episode_length < 1:
    raise errors.ConfigError('num_iterations, episodes_per_iteration and '
                             'max_episode_length must be >= 1')
  if policy_snapshot_period < 0:
    raise errors.ConfigError('policy_snapshot_period must be >= 0, got '
                             f'{policy_snapshot_period}')
  with run_dir.locked(base_dir):  # Creates it.
    env = gym.make(env_name).unwrapped
    agent = runner.create_agent(agent_name, env, seed=seed)
    if policy_snapshot_period and not isinstance(agent, sac.SACAgent):
      raise errors.ConfigError(
          f'policy snapshots need a SAC agent, not {agent_name!r}')
    checkpoint_dir = run_files.checkpoint_dir(base_dir)
    start_iteration = _reload_latest(agent, checkpoint_dir) + 1
    run_info = {'agent': agent_name, 'env_name': env_name, 'seed': seed,
                'episodes_per_iteration': episodes_per_iteration,
                'max_episode_length': max_episode_length,
                # What the winds are (the file, its run and lead times).
                'wind_source': env_params.wind_source()}
    run_dir.check_resume(base_dir, run_info, start_iteration=start_iteration,
                         episodes_per_iteration=episodes_per_iteration,
                         log_episodes='episodes' in collectors)
    run_dir.write_run_info(base_dir, run_info)
    start_episode = start_iteration * episodes_per_iteration
    if start_iteration:
      logging.info('Resuming after checkpoint %d (episode %d).',
                   start_iteration - 1, start_episode)
    action_dim = (env.action_space.n if isinstance(
        env.action_space, gym.spaces.Discrete) else env.action_space.shape[0])
    dispatcher = collectors_lib.dispatcher(
        base_dir, action_dim, collectors, start_episode,
        num_iterations * episodes_per_iteration, f'train {agent_name}')
    agent.set_summary_writer(dispatcher.get_summary_writer())
    agent.set_mode(base_agent.AgentMode.TRAIN)
    dispatcher.pre_training()
    for iteration in range(start_iteration, num_iterations):
      for i in range(episodes_per_iteration):
        episode = iteration * episodes_per_iteration + i
        runner.run_episode(env, agent, episode=episode,
                           seed=suites.train_seed(episode),
                           max_steps=max_episode_length,
                           dispatcher=dispatcher)
      agent.save_checkpoint(checkpoint_dir, iteration)
      if (policy_snapshot_period and
          (iteration + 1) % policy_snapshot_period == 0):
        # From the agent in memory: reading the checkpoint back would load
        # the replay buffer (~150 MB late in a 2500-episode run) every
        # iteration.
        policy = pretrained.policy_from_bundle(
            agent.acting_bundle(iteration),
            os.path.basename(run_files.checkpoint_path(base_dir, iteration)),
            note=f'{agent_name} after '
            f'{(iteration + 1) * episodes_per_iteration} training episodes')
        pretrained.write_policy(
            policy, run_files.policy_snapshot_path(base_dir, iteration))
    dispatcher.end_training()
    safe_io.atomic_write(os.path.join(base_dir, 'operative_config.gin'),
                         gin.operative_config_str())
