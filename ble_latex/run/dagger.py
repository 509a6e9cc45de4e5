# coding=utf-8
r"""DAgger's driver: a planner distilled into a policy, run by run directory.

The algorithm (the student, the beta-mixture flights labelled by the teacher,
the aggregate and the fit, the policy export) is `ble_latex.agents.dagger`,
pure JAX over the batched core; its settings are `DaggerConfig` (gin
`dagger_config.*`). Each round's student flies the first `validation_seeds`
seeds of `latex_validation` (`sac_trainer.validate`); the best round by TW50
over the window, among those at most `max_out_of_resources_pct` out of
resources, is kept and exported (`best_policy.msgpack`).

`train` is the driver: the run directory (`run_dir`: run.json and the one
resume check, the lock), one checkpoint per round (student, Adam state,
aggregate, best student, records; `checkpoints/dagger_NNNNN.msgpack`, the
previous one removed) and `summary.json`, the per-round records. A resumed
run continues after its newest checkpoint with the same keys (round r's keys
are folded from the seed and r), and refuses other settings.
"""

import dataclasses
import json
import os
import re
import time
from typing import Any, Callable, Dict, List, NamedTuple, Optional, Tuple

import gin
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import gin_values
from ble_latex import run_files
from ble_latex import safe_io
from ble_latex.agents import dagger
from ble_latex.agents.planning import config as plan_config
from ble_latex.agents.sac import core as sac_core
from ble_latex.agents.sac import trainer as sac_trainer
from ble_latex.envs import env_params
from ble_latex.envs import env_types
from ble_latex.envs import jax_env
from ble_latex.envs import task
from ble_latex.run import jax_train
from ble_latex.run import run_dir
from ble_latex.run import selection
from ble_latex.run import suites

Array = jax.Array
CHECKPOINT_FORMAT = 'ble_latex.dagger/1'  # msgpack (`safe_io`).
SUMMARY = 'summary.json'  # Per-round records (committed with a run).
BEST_POLICY = 'best_policy.msgpack'  # The best student as a SAC policy.
MAX_DATASET = 10_000_000  # Rows of the aggregate: 74 float32 = 3 GB.
_GIN_NAME = 'dagger_config'
# Seeds of the `latex_validation` suite (`suites.get_eval_suite`).
_VALIDATION_SIZE = len(suites.get_eval_suite('latex_validation').seeds)


@gin.configurable(_GIN_NAME)
@dataclasses.dataclass(frozen=True, kw_only=True)
class DaggerConfig:
  """DAgger's settings (gin: `dagger_config.*`), checked when built.

  Attributes:
    seed: Training seed: the student's initialisation, the mixture's and
      minibatches' keys, the teacher's planning seed.
    teacher: The planner that labels (`plan_config.PLANNERS`; its settings
      are its gin configurable's, e.g. `LatexMpcAgent.beam_width`).
    num_balloons: Flights per round.
    episode_steps: Strides per flight (216 = 3 days).
    beta0: Probability that a balloon flies the teacher in round 0. # [.]
    beta_decay: beta_r = beta0 x beta_decay^r. # [.]
    num_layers: Hidden layers of the student (SAC's actor).
    hidden_units: Units per hidden layer.
    learning_rate: Adam's step size.
    batch_size: Rows per minibatch.
    fit_steps: Adam steps per round.
    dataset_capacity: Rows of the aggregate kept (the oldest replaced).
    validation_seeds: First seeds of `latex_validation` flown per round.
    max_out_of_resources_pct: A round counts as best only at most this
      many validation flights out of resources. # [%]
  """
  seed: int = 0
  teacher: str = 'latex_mpc'
  num_balloons: int = 8
  episode_steps: int = task.EPISODE_STEPS
  beta0: float = 1.0
  beta_decay: float = 0.5
  num_layers: int = 2
  hidden_units: int = 256
  learning_rate: float = 1e-3
  batch_size: int = 256
  fit_steps: int = 1_000
  dataset_capacity: int = 500_000
  validation_seeds: int = 10
  max_out_of_resources_pct: float = 5.0

  def __post_init__(self):
    name = lambda field: f'{_GIN_NAME}.{field}'
    run_dir.check_training_seed(self.seed, name('seed'))
    gin_values.require(isinstance(self.teacher, str) and
                       self.teacher in plan_config.PLANNERS, name('teacher'),
                       f'one of {sorted(plan_config.PLANNERS)}', self.teacher)
    for field, maximum in (('num_balloons', sac_core.MAX_NUM_ENVS),
                           ('episode_steps', suites.EPISODE_STEPS),
                           ('num_layers', sac_core.MAX_NUM_LAYERS),
                           ('hidden_units', sac_core.MAX_HIDDEN_UNITS),
                           ('batch_size', sac_core.MAX_BATCH_SIZE),
                           ('fit_steps', 1_000_000),
                           ('dataset_capacity', MAX_DATASET),
                           ('validation_seeds', _VALIDATION_SIZE)):
      gin_values.check_int(name(field), getattr(self, field), minimum=1,
                           maximum=maximum)
    for field in ('beta0', 'beta_decay'):
      gin_values.check_number(name(field), getattr(self, field), minimum=0.0,
                              maximum=1.0)
    gin_values.check_number(name('learning_rate'), self.learning_rate,
                            above=0.0, maximum=1.0)
    gin_values.check_number(name('max_out_of_resources_pct'),
                            self.max_out_of_resources_pct, minimum=0.0,
                            maximum=100.0)

  def beta(self, round_index: int) -> float:
    """The probability of flying the teacher in round `round_index`."""
    return self.beta0 * self.beta_decay ** round_index


# --- The driver: run directory, checkpoints, resume. ------------------------


class _Progress(NamedTuple):
  """What a round leaves for the next one (and a checkpoint holds)."""
  params: Any
  opt_state: Any
  data: dagger.Aggregate
  best_params: Any
  records: List[Dict[str, Any]]
  fit_steps_done: int


def _save(path: str, round_index: int, progress: _Progress) -> None:
  leaves = lambda tree: [np.asarray(x) for x in
                         jax.tree.leaves(jax.device_get(tree))]
  data = progress.data
  safe_io.write_tree(path, {
      'round': round_index, 'params': leaves(progress.params),
      'opt_state': leaves(progress.opt_state),
      'best_params': leaves(progress.best_params),
      'obs': data.obs[:data.size], 'labels': data.labels[:data.size],
      'cursor': data.cursor, 'fit_steps_done': progress.fit_steps_done,
      'records_json': json.dumps(progress.records)},
                     file_format=CHECKPOINT_FORMAT)


def _load(path: str, template: _Progress) -> Tuple[int, _Progress]:
  """A checkpoint's round and progress, checked against `template`."""
  tree = safe_io.read_tree(path, file_format=CHECKPOINT_FORMAT,
                           what='DAgger checkpoint')
  with safe_io.checking(f'DAgger checkpoint {path}'):
    like = lambda t, key: jax.tree.map(
        jnp.asarray, sac_core.check_like(t, list(tree[key]), f'{path}: {key}'))
    capacity = len(template.data.obs)
    size = len(tree['obs'])
    cursor = safe_io.checked_count(tree['cursor'], f'{path}: cursor')
    if size > capacity or cursor >= capacity or (
        size < capacity and cursor != size):
      raise ValueError(f'{path}: aggregate of {size} rows, cursor {cursor} '
                       f'does not fit dataset_capacity {capacity}')
    data = dagger.empty_aggregate(capacity, template.data.obs.shape[1])
    data.obs[:size] = safe_io.checked_array(
        tree['obs'], f'{path}: obs', shape=(size, data.obs.shape[1]))
    data.labels[:size] = safe_io.checked_array(
        tree['labels'], f'{path}: labels', shape=(size, data.labels.shape[1]))
    records = json.loads(tree['records_json'])
    return safe_io.checked_count(tree['round'], f'{path}: round'), _Progress(
        like(template.params, 'params'),
        like(template.opt_state, 'opt_state'),
        data._replace(size=size, cursor=cursor),
        like(template.params, 'best_params'), records,
        safe_io.checked_count(tree['fit_steps_done'],
                              f'{path}: fit_steps_done'))


def best_round(records: List[Dict[str, Any]], max_out_of_resources_pct: float
               ) -> Optional[Dict[str, Any]]:
  """The record of highest validation TW50 (window) within the bound."""
  return selection.best(records, max_oor_pct=max_out_of_resources_pct,
                        result=lambda r: r['validation'],
                        tie=lambda r: -r['round'])


def round_line(record: Dict[str, Any]) -> str:
  """A round's log line (`records_from_log` reads it back)."""
  result = record['validation']
  return (f'round {record["round"]}: beta {record["beta"]:.2f}, '
          f'{record["labelled"]} labels ({record["dataset_size"]} in all), '
          f'fit loss {record["fit_loss"]:.4f}, validation TW50 window '
          f'{result["tw50_window_mean"]:.3f} '
          f'({result["out_of_resources_pct"]:.0f} % out of resources); '
          f'fly {record["fly_s"]:.0f} s, fit {record["fit_s"]:.0f} s')


# `round_line`'s line, read back.
_ROUND_LINE = re.compile(
    r'^round (\d+): beta ([0-9.]+), (\d+) labels \((\d+) in all\), fit loss '
    r'([0-9.]+), validation TW50 window ([0-9.]+) \((\d+) % out of '
    r'resources\); fly (\d+) s, fit (\d+) s$')


def records_from_log(path: str) -> List[Dict[str, Any]]:
  """What a log's round lines (`round_line`) keep of the round records.

  Raises:
    ValueError: The log has no round line.
  """
  records = []
  with open(path, encoding='utf-8') as f:
    for line in f:
      m = _ROUND_LINE.match(line.strip())
      if m:
        records.append({
            'round': int(m[1]), 'beta': float(m[2]), 'labelled': int(m[3]),
            'fit_loss': float(m[5]),
            'validation': {'tw50_window_mean': float(m[6]),
                           'out_of_resources_pct': float(m[7])},
            'fly_s': int(m[8]), 'fit_s': int(m[9])})
  if not records:
    raise ValueError(f'{path}: no round lines')
  return records


def flat_round(record: Dict[str, Any]) -> Dict[str, Any]:
  """A round as benchmarks/records/dagger/results.json keeps it (wall times [s] as
  far as known: a log line gives no validation time)."""
  validation = record['validation']
  out = {'round': record['round'], 'beta': record['beta'],
         'labelled': record['labelled'], 'fit_loss': record['fit_loss'],
         'validation_tw50_window': validation['tw50_window_mean'],
         'validation_out_of_resources_pct': validation['out_of_resources_pct']}
  if 'validate_s' in record:
    out['validation_episodes'] = validation['episodes']
    out['wall_s'] = record['fly_s'] + record['fit_s'] + record['validate_s']
  else:  # A log line gives no validation time.
    out['wall_s_fly_fit'] = record['fly_s'] + record['fit_s']
  return out


def run_settings(config: DaggerConfig, teacher: plan_config.PlannerConfig
                 ) -> Dict[str, Any]:
  """What `run.json` records and a resume must agree with."""
  return {'trainer': 'dagger', 'config': dataclasses.asdict(config),
          'teacher': dataclasses.asdict(teacher)}


def train(*, base_dir: str, num_rounds: int, config: Optional[DaggerConfig] = None,
          teacher: Optional[plan_config.PlannerConfig] = None,
          params: Optional[env_types.EnvParams] = None,
          log: Callable[[str], None] = print) -> Dict[str, Any]:
  """Runs (or resumes) DAgger in `base_dir` until `num_rounds` rounds.

  Args:
    base_dir: The run directory (created; resumed if it holds a run).
    num_rounds: Rounds in all (rounds done are not flown again).
    config: The settings (None: `DaggerConfig()`, gin's bindings).
    teacher: The planner (None: `config.teacher`'s under gin's bindings).
    params: The env parameters (None: `env_params.params_from_gin()`).
    log: Called with a line per round.

  Returns:
    The summary (`SUMMARY`'s content).

  Raises:
    errors.ConfigError: A bad setting (one line).
    errors.ResumeError: `base_dir` holds a run with other settings.
  """
  config = DaggerConfig() if config is None else config
  gin_values.check_int('num_rounds', num_rounds, minimum=1, maximum=100_000)
  teacher = (plan_config.from_gin(config.teacher) if teacher is None else
             teacher.checked())
  plan_config.check_batch(teacher, config.num_balloons, owner='',
                          what=f'{_GIN_NAME}.num_balloons')
  gin_values.require(config.episode_steps % teacher.replan_every == 0,
                     f'{_GIN_NAME}.episode_steps',
                     f'a multiple of the teacher\'s replan_every '
                     f'({teacher.replan_every})', config.episode_steps)
  params = env_params.check_params(
      env_params.params_from_gin() if params is None else params)
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  student = dagger.student_for(config.num_layers, config.hidden_units,
                        config.learning_rate)
  init_key, run_key = jax.random.split(jax.random.PRNGKey(config.seed))
  features = env_params.num_features(params)  # With the options'.
  fresh = dagger.init_params(student, init_key, num_features=features)
  progress = _Progress(fresh, student.optimizer.init(fresh),
                       dagger.empty_aggregate(config.dataset_capacity,
                                              features),
                       fresh, [], 0)
  validation = jnp.asarray(list(suites.get_eval_suite(
      'latex_validation').seeds)[:config.validation_seeds], jnp.int32)
  settings = run_settings(config, teacher)
  os.makedirs(base_dir, exist_ok=True)
  with run_dir.locked(base_dir):
    newest = run_files.newest_dagger_checkpoint(base_dir)
    start = 0 if newest is None else newest[0] + 1
    run_dir.check_resume(base_dir, settings, start_iteration=start,
                         episodes_per_iteration=config.num_balloons,
                         log_episodes=False)
    run_dir.write_run_info(base_dir, settings)
    if newest is not None:
      _, progress = _load(newest[1], progress)
    os.makedirs(run_files.checkpoint_dir(base_dir), exist_ok=True)
    for r in range(start, num_rounds):
      began = time.monotonic()
      mix_key, fit_key = jax.random.split(jax.random.fold_in(run_key, r))
      flights = dagger.fly_round(student, progress.params, teacher, env, params,
                          jax_train.round_seeds(r, config.num_balloons),
                          config.episode_steps, config.beta(r), mix_key,
                          config.seed)
      flown = time.monotonic()
      data = dagger.aggregate(progress.data, flights['obs'], flights['labels'])
      net, opt_state, loss = dagger.fit(
          student, progress.params, progress.opt_state, jnp.asarray(data.obs),
          jnp.asarray(data.labels), jnp.int32(data.size), config.fit_steps,
          config.batch_size, fit_key)
      loss = float(loss)
      if not np.isfinite(loss):
        raise sac_core.TrainingDiverged(
            f'DAgger round {r}: the imitation loss is {loss}')
      fitted = time.monotonic()
      result = jax_train.validation_summary(sac_trainer.validate(
          student.learner, env, net, validation, config.episode_steps,
          params), config.episode_steps)
      record = {
          'round': r, 'beta': config.beta(r),
          'teacher_fraction': flights['teacher_fraction'],
          'labelled': int(len(flights['obs'])), 'dataset_size': data.size,
          'train_tw50_window_mean': float(np.mean(
              flights['within'] / config.episode_steps)),
          'fit_loss': loss, 'validation': result,
          'fly_s': flown - began, 'fit_s': fitted - flown,
          'validate_s': time.monotonic() - fitted,
          'loadavg': list(os.getloadavg())}
      records = progress.records + [record]
      best = best_round(records, config.max_out_of_resources_pct)
      best_params = net if best is record else progress.best_params
      progress = _Progress(net, opt_state, data, best_params, records,
                           progress.fit_steps_done + config.fit_steps)
      if best is record:
        dagger.export_policy(
            student, net, r, progress.fit_steps_done,
            os.path.join(base_dir, BEST_POLICY),
            f'DAgger student of {config.teacher} (seed {config.seed}), round '
            f'{r}: validation TW50 window {result["tw50_window_mean"]:.3f} on '
            f'latex_validation[:{config.validation_seeds}]',
            observation=env_params.observation_of(params))
      path = run_files.dagger_checkpoint_path(base_dir, r)
      _save(path, r, progress)
      if newest is not None and newest[1] != path:
        os.remove(newest[1])
      newest = (r, path)
      summary = {'settings': settings, 'rounds': records, 'best': best}
      safe_io.atomic_write(os.path.join(base_dir, SUMMARY),
                           json.dumps(summary, indent=1) + '\n')
      log(round_line(record))
  with open(os.path.join(base_dir, SUMMARY), encoding='utf-8') as f:
    return json.load(f)
