# coding=utf-8
"""The latex training loop (BLE's `train_lib.run_training_loop`, for Box actions).

Checkpoints after each iteration; a restarted run resumes after the last
checkpoint. Used by `ble-latex-train` and the demo.
"""

import json
import os
import re
from typing import Any, Dict, Sequence

from absl import logging
from balloon_learning_environment.agents import agent as base_agent
import gin
import gym

from ble_latex.agents import pretrained
from ble_latex.agents import sac
from ble_latex.run import episode_log
from ble_latex.run import metrics
from ble_latex.run import runner
from ble_latex.run import suites
from ble_latex import errors
from ble_latex import safe_io


POLICY_SNAPSHOT_PATTERN = re.compile(r'^policy_(\d{5,})\.msgpack$')
RUN_INFO = 'run.json'  # What a resumed run must agree with.
# BLE's own agents checkpoint with Dopamine's `checkpoint_NNNNN.pkl` files.
_BLE_CHECKPOINT_PATTERN = re.compile(r'^checkpoint_(\d+)\.pkl$')


ResumeError = errors.ResumeError  # The old name.


def policy_snapshot_path(base_dir: str, iteration: int) -> str:
  """Where `train` exports the policy of `iteration` (0-based)."""
  return os.path.join(base_dir, 'policies', f'policy_{iteration:05d}.msgpack')


def remove_stale_temporaries(base_dir: str) -> None:
  """Removes the temporary files killed writes left in checkpoints/, policies/.

  Call it holding the run directory's lock (`safe_io.locked_dir`): then no
  temporary file there belongs to a live writer.
  """
  safe_io.remove_stale_temporaries(os.path.join(base_dir, 'checkpoints'),
                                   'checkpoint_')
  safe_io.remove_stale_temporaries(os.path.join(base_dir, 'policies'),
                                   'policy_')


def _reload_latest(agent: base_agent.Agent, checkpoint_dir: str) -> int:
  """Loads the newest numbered checkpoint; returns its iteration or -1.

  SAC agents find theirs themselves (`sac.SACAgent.reload_latest_checkpoint`).
  For BLE's agents, whose `reload_latest_checkpoint` gives -1 as soon as any
  `checkpoint_*.pkl` name lacks a number, the numbered files are found here
  and loaded with the agent's own `load_checkpoint`.
  """
  if isinstance(agent, sac.SACAgent):
    return agent.reload_latest_checkpoint(checkpoint_dir)
  iterations = sac.checkpoint_iterations(checkpoint_dir,
                                         _BLE_CHECKPOINT_PATTERN)
  if not iterations:
    return -1
  agent.load_checkpoint(checkpoint_dir, iterations[-1])
  return iterations[-1]


def _check_resume(base_dir: str, run_info: Dict[str, Any],
                  start_iteration: int, log_episodes: bool) -> None:
  """Refuses to resume where resuming would lose or skip logged episodes.

  Args:
    base_dir: The run directory.
    run_info: This invocation's `RUN_INFO` settings.
    start_iteration: First iteration to run (last checkpoint + 1, or 0).
    log_episodes: Whether the episodes.jsonl collector is on.

  Raises:
    ResumeError: If `RUN_INFO` records other settings (e.g. another
      `episodes_per_iteration`), or episodes.jsonl holds more episodes than
      the newest checkpoint and the one unfinished iteration after it cover,
      or fewer than the checkpoint covers.
  """
  info_path = os.path.join(base_dir, RUN_INFO)
  if os.path.exists(info_path):
    try:
      with open(info_path, encoding='utf-8') as f:
        recorded = json.load(f)
    except (OSError, ValueError) as e:
      raise ResumeError(f'{info_path} is unreadable ({e}); not resuming') from e
    if not isinstance(recorded, dict):
      raise ResumeError(f'{info_path} is not a JSON object; not resuming')
    for key, value in run_info.items():
      if key in recorded and recorded[key] != value:
        raise ResumeError(
            f'{base_dir} was started with {key}={recorded[key]!r}, this run '
            f'asks for {key}={value!r}: resuming would leave a gap in its '
            f'episode log. Use the same value or a new --base_dir.')
  if not log_episodes:
    return
  log_path = os.path.join(base_dir, episode_log.EPISODE_LOG)
  logged = len(episode_log.read(log_path))
  per_iteration = run_info['episodes_per_iteration']
  covered = start_iteration * per_iteration
  if logged > covered + per_iteration:
    newest = ('no checkpoint' if not start_iteration else
              f'the newest checkpoint (iteration {start_iteration - 1})')
    raise ResumeError(
        f'{log_path} holds {logged} episodes but {newest} covers only '
        f'{covered}: resuming would drop {logged - covered} logged episodes. '
        f'Are checkpoints missing from {base_dir}/checkpoints? Nothing was '
        'changed.')
  if logged < covered:
    raise ResumeError(
        f'{log_path} holds {logged} episodes but the newest checkpoint '
        f'(iteration {start_iteration - 1}) covers {covered}: episodes '
        f'{logged}..{covered - 1} would be missing from the log. Nothing was '
        'changed.')


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
      `base_dir/policies/policy_NNNNN.msgpack` (~1 MB; checkpoints hold the
      replay buffer and only the newest few are kept), so a policy can be
      chosen afterwards on a validation suite (`benchmarks/train_sac.py`).

  Raises:
    ValueError: On an unknown collector, a non-positive count, or policy
      snapshots asked of an agent that is not SAC.
    ResumeError: If `base_dir` holds a run that cannot be resumed without
      losing logged episodes or with these settings (nothing is changed).
    safe_io.InUseError: If another process (or another run in this one)
      trains in `base_dir` (`safe_io.locked_dir`, held for the whole run).
  """
  metrics.check_collectors(collectors)
  if num_iterations < 1 or episodes_per_iteration < 1 or max_episode_length < 1:
    raise ValueError('num_iterations, episodes_per_iteration and '
                     'max_episode_length must be >= 1')
  if policy_snapshot_period < 0:
    raise ValueError('policy_snapshot_period must be >= 0, got '
                     f'{policy_snapshot_period}')
  with safe_io.locked_dir(base_dir):  # Creates it.
    remove_stale_temporaries(base_dir)
    env = gym.make(env_name).unwrapped
    agent = runner.create_agent(agent_name, env, seed=seed)
    if policy_snapshot_period and not isinstance(agent, sac.SACAgent):
      raise ValueError(
          f'policy snapshots need a SAC agent, not {agent_name!r}')
    checkpoint_dir = os.path.join(base_dir, 'checkpoints')
    start_iteration = _reload_latest(agent, checkpoint_dir) + 1
    run_info = {'agent': agent_name, 'env_name': env_name, 'seed': seed,
                'episodes_per_iteration': episodes_per_iteration,
                'max_episode_length': max_episode_length}
    _check_resume(base_dir, run_info, start_iteration,
                  log_episodes='episodes' in collectors)
    safe_io.atomic_write(os.path.join(base_dir, RUN_INFO),
                         json.dumps(run_info, indent=1) + '\n')
    start_episode = start_iteration * episodes_per_iteration
    if start_iteration:
      logging.info('Resuming after checkpoint %d (episode %d).',
                   start_iteration - 1, start_episode)
    action_dim = (env.action_space.n if hasattr(env.action_space, 'n') else
                  env.action_space.shape[0])
    dispatcher = metrics.dispatcher(
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
            os.path.basename(sac.checkpoint_path(checkpoint_dir, iteration)),
            note=f'{agent_name} after '
            f'{(iteration + 1) * episodes_per_iteration} training episodes')
        pretrained.write_policy(policy,
                                policy_snapshot_path(base_dir, iteration))
    dispatcher.end_training()
    safe_io.atomic_write(os.path.join(base_dir, 'operative_config.gin'),
                         gin.operative_config_str())
