# coding=utf-8
r"""The jitted SAC trainer's driver: `sac_trainer` rounds in run directories.

  ble-latex-train --trainer=jax --base_dir=/tmp/latex/jax \
      --num_iterations=40 --seeds=0,1,2,3,4

Episode e of a training seed flies env seed `suites.train_seed(e)`, as
`ble-latex-train` does. Several training seeds (`train_seeds`, `--seeds`) run
one after another, or with `vmap=True` (`--vmap_seeds`) as one
`sac_trainer.train_round_seeds` call per round; each keeps its own run
directory (`run_dir`), with what `ble-latex-train` writes:
`episodes.jsonl` (with env seeds and both TW50s), tensorboard scalars,
`checkpoints/` (msgpack, `safe_io`; the whole `TrainState` including the
replay and the PRNG key, so a killed run resumes after its last checkpoint
with no episode lost or repeated), `policies/policy_NNNNN.msgpack` snapshots
that `ble-latex-eval --gin_bindings='SACPretrainedAgent.policy_path="..."'`
and `sac_pretrained` load, `validation.jsonl`, `run.json` and
`operative_config.gin`.
"""

import contextlib
import dataclasses
import json
import os
import time
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple

from absl import logging
import gin
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import errors
from ble_latex import run_files
from ble_latex import safe_io
from ble_latex.agents.sac import pretrained
from ble_latex.agents.sac import core as sac_core
from ble_latex.agents.sac import trainer as sac_trainer
from ble_latex.envs import env_params as env_params_lib
from ble_latex.envs import env_types
from ble_latex.envs import jax_env
from ble_latex.flight import state as state_lib
from ble_latex.run import episode_log
from ble_latex.run import metrics
from ble_latex.run import run_dir
from ble_latex.run import suites

CHECKPOINT_FORMAT = 'ble_latex.sac_trainer/1'  # msgpack (`safe_io`).


def validation_summary(result: Dict[str, jax.Array], window_steps: int
                       ) -> Dict[str, float]:
  """Mean TW50 (window and flown), % out of resources of a validation.

  Args:
    result: What `sac_trainer.validate` returns.
    window_steps: Steps of the TW50 window.
  """
  r = jax.device_get(result)
  fractions = [metrics.tw50_fractions(int(w), int(s), window_steps)
               for w, s in zip(r['within_steps'], r['steps'])]
  out_of_resources = [
      state_lib.FlightStatus(int(x)) in state_lib.OUT_OF_RESOURCES
      for x in r['status']]
  return {'episodes': len(fractions),
          'tw50_window_mean': float(np.mean([f['tw50_window']
                                             for f in fractions])),
          'tw50_mean': float(np.mean([f['tw50'] for f in fractions])),
          'out_of_resources_pct': 100.0 * float(np.mean(out_of_resources))}


def episode_records(out: sac_trainer.RoundOutput, seeds: Sequence[int],
                    first_episode: int, window_steps: int,
                    wall_time_s: float
                    ) -> List[Tuple[metrics.EpisodeSummary, Dict[str, Any]]]:
  """The round's (`EpisodeSummary`, last info) pairs, in balloon order.

  Args:
    out: One seed's round output (per-balloon reward, steps, info).
    seeds: The env seed of each balloon's episode (`round_seeds`).
    first_episode: The number of the round's first episode.
    window_steps: Steps of the TW50 window.
    wall_time_s: The round's wall time, shared equally among its episodes.
      # [s]

  Returns:
    One (summary, info dict) pair per balloon.

  Raises:
    ValueError: Step counts that are negative or inconsistent
      (`metrics.tw50_fractions`).
  """
  out = jax.device_get(out)
  records = []
  for i, seed in enumerate(seeds):
    info = jax_env.info_dict({k: v[i] for k, v in out.info.items()})
    summary = metrics.EpisodeSummary(
        episode=first_episode + i, seed=int(seed),
        reward=float(out.reward[i]),
        **metrics.tw50_fractions(int(out.within_steps[i]), int(out.steps[i]),
                                 window_steps),
        window_steps=window_steps, steps=int(out.steps[i]),
        helium_vented_mols=info['helium_vented_mols'],
        sand_dropped_kg=info['sand_dropped_kg'],
        terminal_reason=metrics.terminal_reason(info, done=True),
        final_distance_km=info['distance_km'],
        wall_time_s=wall_time_s / len(seeds))
    records.append((summary, info))
  return records


def check_round(out: sac_trainer.RoundOutput, iteration: int,
                base_dir: str) -> None:
  """Raises `sac_core.TrainingDiverged` if the round produced NaN / inf.

  Called before anything of the round is written: the newest checkpoint in
  `base_dir` stays the last good one.

  Args:
    out: One seed's round output (its `nonfinite` counts).
    iteration: The round.
    base_dir: The seed's run directory.
  """
  counts = jax.device_get(out.nonfinite)
  bad = [name for name in sac_trainer.NONFINITE if int(counts[name])]
  if not bad:
    return
  done = run_files.iterations(run_files.checkpoint_dir(base_dir))
  kept = (f'last good checkpoint: '
          f'{run_files.checkpoint_path(base_dir, done[-1])} kept' if done
          else f'no checkpoint was written in {base_dir}')
  raise sac_core.TrainingDiverged(
      f'training diverged at round {iteration}: non-finite '
      f'{", ".join(bad)}; {kept}')


def save_checkpoint(base_dir: str, iteration: int,
                    state: sac_trainer.TrainState, elapsed_s: float = 0.0,
                    keep: int = 2) -> None:
  """The whole state (replay cut to its filled part), atomically.

  Args:
    base_dir: Run directory.
    iteration: The round just finished.
    state: The trainer's state.
    elapsed_s: Training wall time so far, resumes included. # [s]
    keep: Checkpoints kept (the newest ones).
  """
  host = jax.device_get(state)
  filled = int(host.replay.size)
  replay = {k: np.asarray(getattr(host.replay, k))[:filled]
            for k in ('obs', 'action', 'reward', 'next_obs', 'terminal')}
  replay.update(size=int(host.replay.size), cursor=int(host.replay.cursor))
  leaves = lambda t: [np.asarray(x) for x in jax.tree_util.tree_leaves(t)]
  tree = {'iteration': int(iteration),
          'network_params': leaves(host.network_params),
          'target_params': leaves(host.target_params),
          'optimizer_state': leaves(host.optimizer_state),
          'log_alpha': np.asarray(host.log_alpha),
          'alpha_optimizer_state': leaves(host.alpha_optimizer_state),
          'replay': replay, 'key': np.asarray(host.key),
          'updates': int(host.updates), 'env_steps': int(host.env_steps),
          'elapsed_s': float(elapsed_s)}
  path = run_files.checkpoint_path(base_dir, iteration)
  os.makedirs(os.path.dirname(path), exist_ok=True)
  safe_io.write_tree(path, tree, file_format=CHECKPOINT_FORMAT)
  folder = os.path.dirname(path)
  for old in run_files.iterations(folder)[:-keep]:
    os.remove(run_files.checkpoint_path(base_dir, old))


def load_checkpoint(path: str, template: sac_trainer.TrainState
                    ) -> Tuple[sac_trainer.TrainState, float]:
  """A checkpoint's state (checked against `template`) and elapsed [s].

  Args:
    path: The checkpoint file.
    template: A train state whose tree, shapes and dtypes the checkpoint
      must match.

  Returns:
    (train state, training wall time so far [s]; 0 in a checkpoint
    without one).

  Raises:
    errors.BadFileError: The file is unreadable, or an entry is missing, of
      another shape or dtype, non-finite or out of range (named with the
      file).
  """
  tree = safe_io.read_tree(path, file_format=CHECKPOINT_FORMAT,
                           what='SAC trainer checkpoint')
  with safe_io.checking():
    return _restore_checkpoint(tree, path, template)


def _restore_checkpoint(tree: Dict[str, Any], path: str,
                        template: sac_trainer.TrainState
                        ) -> Tuple[sac_trainer.TrainState, float]:
  """`load_checkpoint` of a read tree."""
  what = f'{path}'
  restore = lambda name, t: sac_core.restore_like(t, tree[name],
                                                  f'{what}: {name}')
  missing = [k for k in ('iteration', 'network_params', 'target_params',
                         'optimizer_state', 'log_alpha',
                         'alpha_optimizer_state', 'replay', 'key', 'updates',
                         'env_steps') if k not in tree]
  if missing:
    raise ValueError(f'{what} misses {missing}')
  r = tree['replay']
  if not isinstance(r, dict):
    raise ValueError(f'{what}: replay is not a mapping')
  capacity = template.replay.reward.shape[0]
  size = safe_io.checked_count(r.get('size'), f'{what}: replay size',
                               high=capacity)
  cursor = safe_io.checked_count(r.get('cursor'), f'{what}: replay cursor',
                                 high=capacity - 1)
  sac_trainer.check_replay_counters(size, cursor, capacity, what)
  counters = {k: safe_io.checked_count(tree[k], f'{what}: {k}',
                                       high=np.iinfo(np.int32).max)
              for k in ('iteration', 'updates', 'env_steps')}
  arrays = {}
  for name in ('obs', 'action', 'reward', 'next_obs', 'terminal'):
    ref = getattr(template.replay, name)
    value = safe_io.checked_array(r.get(name), f'{what}: replay {name}',
                                  shape=(size,) + ref.shape[1:])
    arrays[name] = jnp.asarray(ref).at[:size].set(value.astype(ref.dtype))
  replay = sac_trainer.Replay(size=jnp.asarray(size, jnp.int32),
                              cursor=jnp.asarray(cursor, jnp.int32), **arrays)
  elapsed = safe_io.checked_array(tree.get('elapsed_s', 0.0),
                                  f'{what}: elapsed_s', shape=())
  return sac_trainer.TrainState(
      network_params=restore('network_params', template.network_params),
      target_params=restore('target_params', template.target_params),
      optimizer_state=restore('optimizer_state', template.optimizer_state),
      log_alpha=restore('log_alpha', template.log_alpha),
      alpha_optimizer_state=restore('alpha_optimizer_state',
                                    template.alpha_optimizer_state),
      replay=replay, key=restore('key', template.key),
      updates=jnp.asarray(counters['updates'], jnp.int32),
      env_steps=jnp.asarray(counters['env_steps'], jnp.int32)), float(elapsed)


def _config_defaults() -> Dict[str, Any]:
  return {f.name: f.default
          for f in dataclasses.fields(sac_trainer.TrainerConfig)}


def recorded_config(config: Mapping[str, Any]) -> Dict[str, Any]:
  """A `run.json` config with the settings added since it was written.

  Settings added since a run started count with their defaults (e.g.
  `critic`: 'mlp').
  """
  return {**_config_defaults(), **config}


def round_seeds(iteration: int, num_envs: int) -> List[int]:
  """Env seeds of a round's episodes: episode e flies `train_seed(e)`.

  Args:
    iteration: The round (0-based).
    num_envs: Episodes per round (balloons).

  Returns:
    The seeds of episodes iteration * num_envs + i, i < num_envs.
  """
  return [suites.train_seed(iteration * num_envs + i)
          for i in range(num_envs)]


def warm_start(learner: sac_trainer.Learner, state: sac_trainer.TrainState,
               path: str, observation: Mapping[str, int]
               ) -> sac_trainer.TrainState:
  """A new run's state from the policy file `path`
  (`sac_trainer_config.init_policy`, `sac_trainer.warm_start`).

  Raises:
    errors.ConfigError: The file observed another wind column than this
      run's env (`observation`: `env_params.observation_of` it, gin
      `latex_observation.*`).
    ValueError: A bad file, or networks not shaped as this learner's.
  """
  what = f'sac_trainer_config.init_policy = {path!r}'
  policy = pretrained.load_policy(path)
  for key, mine in observation.items():
    theirs = policy['config'][key]
    if theirs != mine:
      raise errors.ConfigError(
          f'{what}: the policy observed with latex_observation.{key} = '
          f'{theirs}, this run observes with {mine}')
  logging.info('Starting from the networks of %s.', path)
  return sac_trainer.warm_start(learner, state, policy, what)


class _RunDir:
  """The host side of one training seed: its run directory and logs.

  Opening one checks a resume (same settings, no episode lost), restores the
  newest checkpoint and cuts `validation.jsonl` back to it; `record` then
  writes what a round leaves: episodes, tensorboard scalars, the validation
  record, checkpoint and policy snapshot.
  """

  def __init__(self, *, base_dir: str, seed: int,
               learner: sac_trainer.Learner, num_iterations: int,
               collectors: Sequence[str], window: int,
               observation: Mapping[str, int],
               validation_seeds: Sequence[int]):
    config = learner.config
    self.base_dir, self.seed, self.learner = base_dir, seed, learner
    _, self.state = sac_trainer.make_learner(
        config, jax.random.PRNGKey(seed),
        num_features=env_params_lib.num_features(dict(observation)))
    done_iterations = run_files.iterations(
        run_files.checkpoint_dir(base_dir))
    self.start = done_iterations[-1] + 1 if done_iterations else 0
    run_info = {'trainer': 'jax', 'seed': seed,
                'config': dataclasses.asdict(config), 'episode_steps': window,
                'wind_source': env_params_lib.wind_source(), **observation}
    # Rounds after the newest checkpoint (up to `checkpoint_period`) are
    # flown again: any number of them may be logged.
    run_dir.check_resume(
        base_dir, run_info, start_iteration=self.start,
        episodes_per_iteration=config.num_envs,
        log_episodes='episodes' in collectors, unsaved_iterations=None,
        defaults={'config': _config_defaults()})
    self.elapsed = 0.0
    if self.start:
      self.state, self.elapsed = load_checkpoint(
          run_files.checkpoint_path(base_dir, self.start - 1), self.state)
      logging.info('%s: resuming after round %d.', base_dir, self.start - 1)
    elif config.init_policy:
      self.state = warm_start(learner, self.state, config.init_policy,
                              observation)
    self.validation_path = os.path.join(base_dir, episode_log.VALIDATION_LOG)
    validated = [r for r in episode_log.read(self.validation_path)
                 if r['iteration'] < self.start]
    safe_io.atomic_write(self.validation_path,
                         ''.join(json.dumps(r) + '\n' for r in validated))
    run_dir.write_run_info(base_dir, run_info)
    self.validation_seeds = list(validation_seeds)
    self._validation_seeds = jnp.asarray(self.validation_seeds, jnp.int32)
    n = config.num_envs
    # BLE's collectors import TensorFlow: only once a run starts.
    from ble_latex.run import collectors as collectors_lib  # pylint: disable=g-import-not-at-top
    self.dispatcher = collectors_lib.dispatcher(
        base_dir, len(jax_env.ACTION_LOW), collectors, self.start * n,
        num_iterations * n, f'train sac (jax, seed {seed})')
    self.writer = self.dispatcher.get_summary_writer()
    self.dispatcher.pre_training()

  def record(self, *, iteration: int, state: sac_trainer.TrainState,
             out: sac_trainer.RoundOutput, wall: float,
             env: jax_env.LatexBalloonJaxEnv,
             params: env_types.EnvParams,
             validation_params: env_types.EnvParams,
             checkpoint: bool,
             policy_snapshot_period: int) -> Optional[Dict[str, Any]]:
    """Logs a finished round of this seed; returns its validation record.

    Args:
      iteration: The round.
      state: This seed's state after the round (its replay may be None
        without `checkpoint`).
      out: This seed's round output.
      wall: The round's wall time (for vmapped seeds, that of all). # [s]
      env: The functional env.
      params: Env parameters.
      validation_params: The validation's env parameters.
      checkpoint: Whether to write a checkpoint after this round.
      policy_snapshot_period: Rounds between policy snapshots (0: never).
    """
    self.elapsed += wall
    n, window = self.learner.config.num_envs, int(params.episode_steps)
    for summary, info in episode_records(out, round_seeds(iteration, n),
                                         iteration * n, window,
                                         wall):
      self.dispatcher.begin_episode()
      self.dispatcher.end_episode(metrics.LatexStatistics(
          step=summary.steps, action=[], reward=summary.reward,
          terminal=summary.terminal_reason != 'time_limit', info=info,
          summary=summary))
    if self.writer is not None:
      for k, v in jax.device_get(out.losses).items():
        self.writer.scalar(k, float(v), int(state.updates))
      self.writer.scalar('Train/RoundSeconds', wall, iteration)
      self.writer.flush()
    snapshot = bool(policy_snapshot_period and
                    (iteration + 1) % policy_snapshot_period == 0)
    record = None
    if snapshot and self.validation_seeds:
      began = time.monotonic()
      result = validation_summary(
          sac_trainer.validate(self.learner, env, state.network_params,
                   self._validation_seeds, window, validation_params), window)
      self.elapsed += time.monotonic() - began
      record = {'iteration': iteration,
                'training_episodes': (iteration + 1) * n,
                'updates': int(state.updates), 'elapsed_s': self.elapsed,
                'seeds': [int(self.validation_seeds[0]),
                          int(self.validation_seeds[-1])], **result}
      with open(self.validation_path, 'a', encoding='utf-8') as f:
        f.write(json.dumps(record) + '\n')
      if self.writer is not None:
        for k in ('tw50_window_mean', 'tw50_mean', 'out_of_resources_pct'):
          self.writer.scalar(f'Validation/{k}', record[k], (iteration + 1) * n)
        self.writer.flush()
    if checkpoint:
      save_checkpoint(self.base_dir, iteration, state, self.elapsed)
    if snapshot:
      policy = pretrained.policy_from_bundle(
          sac_trainer.acting_bundle(
              self.learner, state, iteration,
              observation=env_params_lib.observation_of(params)),
          f'{self.base_dir} round {iteration}',
          note=f'sac (jax trainer, seed {self.seed}) after '
          f'{(iteration + 1) * n} training episodes')
      pretrained.write_policy(
          policy, run_files.policy_snapshot_path(self.base_dir, iteration))
    return record

  def close(self) -> None:
    self.dispatcher.end_training()
    safe_io.atomic_write(os.path.join(self.base_dir, 'operative_config.gin'),
                         gin.operative_config_str())


def train(*, base_dir: str, num_iterations: int, seed: int = 0,
          config: Optional[sac_trainer.TrainerConfig] = None,
          collectors: Sequence[str] = ('progress', 'episodes', 'tensorboard'),
          policy_snapshot_period: int = 1, checkpoint_period: int = 1,
          validation_seeds: Sequence[int] = (),
          env_params: Optional[env_types.EnvParams] = None,
          validation_params: Optional[env_types.EnvParams] = None,
          on_validation: Optional[Callable[[Dict[str, Any]], None]] = None,
          lock_wait_s: float = 0.0) -> sac_trainer.TrainState:
  """Runs (or resumes) one jitted training run; gin must already be bound.

  Args:
    base_dir: Run directory.
    num_iterations: Rounds in total (a resumed run counts the finished ones);
      each flies `config.num_envs` episodes.
    seed: Training seed (network init, exploration, replay sampling).
    config: Trainer settings (default: gin's `sac_trainer_config.*`).
    collectors: Names from `collectors.AVAILABLE_COLLECTORS`.
    policy_snapshot_period: Every this many rounds export the policy to
      `base_dir/policies/` (0: never).
    checkpoint_period: Every this many rounds (and after the last) write a
      checkpoint; a resumed run re-flies the rounds after it.
    validation_seeds: If given, each policy snapshot is also flown
      deterministically from these env seeds in one batched call
      (`sac_trainer.validate`); the results go to `base_dir/validation.jsonl`
      (with the training wall time so far) and tensorboard (`Validation/*`).
    env_params: Env parameters (default: `env_params.params_from_gin()`).
    validation_params: The validation's env parameters (default: the
      training's), e.g. ERA5 flights starting in the validation dates
      (`gridded.DATE_SPLITS`); the same static structure as `env_params`.
    on_validation: Called with each `validation.jsonl` record once its round
      is done (policy snapshot written; the checkpoint too when the periods
      coincide), e.g. to report it to
      Ray Tune (`ble_latex.run.sweep_lib`).
    lock_wait_s: How long to wait for another writer of `base_dir` to end
      before giving up (a sweep's trial waits out the worker of a killed
      sweep); 0: refuse at once. # [s]

  Returns:
    The final `TrainState`.

  Raises:
    safe_io.InUseError: If another process (or another run in this one)
      trains in `base_dir` (`run_dir.locked`, held for the whole run).
      Stale temporary files of killed writes in checkpoints/ and policies/
      are removed once the lock is held.
  """
  return train_seeds(
      runs=[(seed, base_dir)], num_iterations=num_iterations, config=config,
      collectors=collectors, policy_snapshot_period=policy_snapshot_period,
      checkpoint_period=checkpoint_period, validation_seeds=validation_seeds,
      env_params=env_params, validation_params=validation_params,
      on_validation=on_validation, lock_wait_s=lock_wait_s)[0]


def train_seeds(*, runs: Sequence[Tuple[int, str]], num_iterations: int,
                config: Optional[sac_trainer.TrainerConfig] = None,
                collectors: Sequence[str] = ('progress', 'episodes',
                                             'tensorboard'),
                policy_snapshot_period: int = 1, checkpoint_period: int = 1,
                validation_seeds: Sequence[int] = (),
                env_params: Optional[env_types.EnvParams] = None,
                validation_params: Optional[env_types.EnvParams] = None,
                on_validation: Optional[Callable[[Dict[str, Any]], None]] = None,
                vmap: bool = False, lock_wait_s: float = 0.0
                ) -> List[sac_trainer.TrainState]:
  """Runs (or resumes) several training seeds, each in its own directory.

  With `vmap` the seeds' rounds run as one vmapped XLA call
  (`sac_trainer.train_round_seeds`); a seed whose run is behind the others
  (resumed from an older checkpoint) first catches up alone. Otherwise the
  seeds run one after another. Either way each directory gets what `train`
  writes; with `vmap` a round's wall time (`Train/RoundSeconds`,
  `elapsed_s`) is that of all seeds together.

  Args:
    runs: (training seed, run directory) pairs, seeds distinct.
    num_iterations: Rounds per seed in total.
    config: Trainer settings (default: gin's `sac_trainer_config.*`).
    collectors: As `train`.
    policy_snapshot_period: As `train`.
    checkpoint_period: As `train`.
    validation_seeds: As `train`.
    env_params: As `train`.
    validation_params: As `train`.
    on_validation: As `train`, called with each seed's records.
    vmap: Train the seeds together with `jax.vmap`.
    lock_wait_s: As `train`.

  Returns:
    The final `TrainState` of each run, in the order of `runs` (each with
    its replay: K seeds hold K replays in memory, vmapped or not).

  Raises:
    safe_io.InUseError: As `train`, for any of the directories (all are
      locked before any training starts, and held until all are done).
  """
  config = config or sac_trainer.TrainerConfig()
  from ble_latex.run import collectors as collectors_lib  # pylint: disable=g-import-not-at-top
  collectors_lib.check_collectors(collectors)
  if num_iterations < 1 or checkpoint_period < 1 or policy_snapshot_period < 0:
    raise ValueError('num_iterations and checkpoint_period must be >= 1, '
                     'policy_snapshot_period >= 0')
  seeds_of_runs = [run_dir.check_training_seed(seed) for seed, _ in runs]
  if not runs or len(set(seeds_of_runs)) != len(seeds_of_runs):
    raise ValueError(f'runs need distinct training seeds, got {seeds_of_runs}')
  with contextlib.ExitStack() as locks:  # One writer per run directory.
    for _, base_dir in runs:
      locks.enter_context(run_dir.locked(base_dir, wait_s=lock_wait_s))
    env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
    params = (env_params_lib.check_params(env_params) if env_params is not None
              else env.default_params)
    window = int(params.episode_steps)
    validation_params = (params if validation_params is None else
                         env_params_lib.check_params(validation_params))
    learner = sac_trainer.learner_for(config)
    n = config.num_envs

    def env_seeds(iteration):
      return jnp.asarray(round_seeds(iteration, n), jnp.int32)

    def checkpoint_due(iteration):
      return ((iteration + 1) % checkpoint_period == 0 or
              iteration == num_iterations - 1)

    def record(run, iteration, state, out, wall):
      result = run.record(
          iteration=iteration, state=state, out=out, wall=wall, env=env,
          params=params, validation_params=validation_params,
          checkpoint=checkpoint_due(iteration),
          policy_snapshot_period=policy_snapshot_period)
      if result is not None and on_validation is not None:
        on_validation(result)

    def alone(run, stop):
      state = run.state
      for iteration in range(run.start, stop):
        began = time.monotonic()
        state, out = sac_trainer.train_round(
            learner, env, state, env_seeds(iteration), window, params)
        jax.block_until_ready(state.key)
        check_round(out, iteration, run.base_dir)  # Before it is written.
        record(run, iteration, state, out, time.monotonic() - began)
      run.state = state
      return state

    together = vmap and len(runs) > 1
    opened = []
    for seed, base_dir in runs:
      opened.append(_RunDir(
          base_dir=base_dir, seed=seed, learner=learner,
          num_iterations=num_iterations, collectors=collectors, window=window,
          observation=env_params_lib.observation_of(params),
          validation_seeds=validation_seeds))
      if not together:
        alone(opened[-1], num_iterations)
        opened[-1].close()
    if not together:
      return [run.state for run in opened]
    common = min(max(run.start for run in opened), num_iterations)
    states = sac_trainer.stack([alone(run, common) for run in opened])
    for run in opened:
      run.state = None  # Only the stacked copy stays (each holds a replay).
    k = len(opened)
    for iteration in range(common, num_iterations):
      began = time.monotonic()
      states, outs = sac_trainer.train_round_seeds(
          learner, env, states, env_seeds(iteration), window, params)
      jax.block_until_ready(states.key)
      wall = time.monotonic() - began
      # Slicing the replays out costs a copy each: only for checkpoints.
      sliced = sac_trainer.unstack(states if checkpoint_due(iteration)
                                   else states.replace(replay=None), k)
      outs = sac_trainer.unstack(outs, k)
      for run, out in zip(opened, outs):  # Every seed before any is written.
        check_round(out, iteration, run.base_dir)
      for run, state, out in zip(opened, sliced, outs):
        record(run, iteration, state, out, wall)
    for run in opened:
      run.close()
    return sac_trainer.unstack(states, k)
