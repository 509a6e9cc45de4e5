# coding=utf-8
"""Training sweeps on Ray Tune: gin bindings x training seeds (`ble-latex-sweep`).

Each trial is one run of the jitted SAC trainer (`jax_train.train`, its gin
`sac_trainer_config` defaults plus the trial's bindings) in
SWEEP_DIR/runs/p<point>_seed<s>, with the usual run-directory outputs. At
every policy snapshot the trainer flies the policy on `latex_validation` and
the trial reports to Tune: `tw50_window` (the metric, maximised), `tw50`,
`out_of_resources_pct` and `rounds` (ASHA's time axis). Tune runs the trials
(Ray's scheduling, its progress table, its experiment state in
SWEEP_DIR/tune); optional ASHA stops weak trials early.

The space (`load_space`, JSON or YAML) names gin bindings and how to vary
them:

  num_samples: 4            # random draws of the sampled bindings (default 1)
  bindings:
    sac_trainer_config.updates_per_step: [4, 8]          # a list is a grid
    sac_trainer_config.num_envs: {grid: [8, 16]}
    sac_trainer_config.target_entropy: {choice: [0.0, -1.0]}
    sac_trainer_config.critic_learning_rate: {loguniform: [1e-4, 1e-3]}
    sac_trainer_config.tau: {uniform: [0.002, 0.01]}
    sac_trainer_config.hidden_units: {randint: [64, 257]}

The points of the sweep are the grid's product, each with `num_samples` draws
of the sampled bindings (drawn here, seeded by `search_seed`, with Tune's
own distributions), and every point is trained from every training seed, so
seeds of one point share its values. Values are gin literals (numbers,
booleans, strings).

Killed and re-run with the same command, Tune restores the sweep
(`Tuner.restore`): finished trials stay finished, unfinished and errored ones
start again and their trainer resumes from its own last checkpoint. A sweep
directory is for one sweep: other settings are refused, and one driver at a
time runs it (`lock`); each trial locks its own run directory.

Outputs: SWEEP_DIR/results.csv (one row per trial), results.md (one row per
point: mean +- std over seeds of each seed's best validation TW50 over the
window) and best_config.gin (the best point's bindings, for
`ble-latex-train --trainer=jax --gin_file=...`).
"""

import contextlib
import csv
import dataclasses
import io
import itertools
import json
import math
import os
import statistics
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from ble_latex import errors
from ble_latex import gin_values
from ble_latex import safe_io
from ble_latex.run import distributed
from ble_latex.run import episode_log
from ble_latex.run import selection

Literal = Union[bool, int, float, str]
SAMPLED_KINDS = ('choice', 'uniform', 'loguniform', 'randint')
KINDS = ('grid', *SAMPLED_KINDS)
SWEEP_INFO = 'sweep.json'
METRIC = 'tw50_window'
RESULTS_CSV = 'results.csv'
RESULTS_MD = 'results.md'
BEST_GIN = 'best_config.gin'
# [s] A trial waits this long for its run directory's lock: after a killed
# sweep, the old trial's worker may still be exiting when Tune restarts it.
TRIAL_LOCK_WAIT_S = 60.0
# Most trials (points x training seeds) a sweep may have; counted from the
# space before any point is made.
MAX_TRIALS = 10_000


class SpaceError(ValueError):
  """A space file or --grid value that is not a valid sweep space."""


@dataclasses.dataclass(frozen=True)
class Space:
  """What a sweep varies.

  Attributes:
    grid: Binding name -> values, crossed with each other.
    sampled: Binding name -> (kind, arguments), drawn `num_samples` times.
    num_samples: Draws of the sampled bindings per grid point.
  """
  grid: Mapping[str, Tuple[Literal, ...]]
  sampled: Mapping[str, Tuple[str, Tuple[Literal, ...]]]
  num_samples: int = 1


def trial_count(space: Space, num_seeds: int = 1) -> int:
  """Trials of `space` x `num_seeds`, computed without expanding it."""
  count = math.prod(len(v) for v in space.grid.values())
  return count * (space.num_samples if space.sampled else 1) * num_seeds


def check_size(space: Space, source: str, num_seeds: int = 1) -> None:
  """Raises SpaceError if the sweep would have more than `MAX_TRIALS`."""
  count = trial_count(space, num_seeds)
  if count > MAX_TRIALS:
    seeds = f' x {num_seeds} seeds' if num_seeds != 1 else ''
    raise SpaceError(f'{source}: {count} trials (points{seeds}) exceed the '
                     f'limit of {MAX_TRIALS}; sweep fewer values')


def _literal(value: Any, where: str) -> Literal:
  if isinstance(value, np.generic):
    value = value.item()
  if isinstance(value, float) and not gin_values.is_number(value):
    raise SpaceError(f'{where}: {value!r} is not a finite number (the '
                     'core computes in float32: |x| <= 3.4e38)')
  if (isinstance(value, int) and not isinstance(value, bool) and
      not -2**63 <= value < 2**63):
    raise SpaceError(f'{where}: {value!r} is beyond int64')
  if not isinstance(value, (bool, int, float, str)):
    raise SpaceError(f'{where}: {value!r} is not a gin literal (number, '
                     'boolean or string)')
  return value


def _check_name(name: Any, where: str) -> str:
  parts = name.split('.') if isinstance(name, str) else []
  if len(parts) < 2 or not all(p.isidentifier() for p in parts):
    raise SpaceError(f'{where}: {name!r} is not a gin binding name '
                     '(configurable.parameter)')
  return name


def parse_space(data: Any, source: str) -> Space:
  """Checks a decoded space file (see the module docstring)."""
  if not isinstance(data, dict):
    raise SpaceError(f'{source}: expected a mapping with "bindings", got '
                     f'{type(data).__name__}')
  unknown = set(data) - {'bindings', 'num_samples'}
  if unknown:
    raise SpaceError(f'{source}: unknown keys {sorted(unknown)}; valid: '
                     'bindings, num_samples')
  num_samples = data.get('num_samples', 1)
  if (not isinstance(num_samples, int) or isinstance(num_samples, bool) or
      num_samples < 1):
    raise SpaceError(f'{source}: num_samples must be an integer >= 1, got '
                     f'{num_samples!r}')
  bindings = data.get('bindings')
  if not isinstance(bindings, dict) or not bindings:
    raise SpaceError(f'{source}: "bindings" must be a non-empty mapping of '
                     'gin binding names to values')
  grid, sampled = {}, {}
  for name, spec in bindings.items():
    where = f'{source}: bindings.{name}'
    _check_name(name, where)
    if isinstance(spec, list):
      spec = {'grid': spec}
    if not isinstance(spec, dict) or len(spec) != 1:
      raise SpaceError(f'{where}: expected a list of values or one of '
                       f'{{{", ".join(KINDS)}: ...}}, got {spec!r}')
    (kind, args), = spec.items()
    if kind not in KINDS:
      raise SpaceError(f'{where}: unknown kind {kind!r}; valid: '
                       f'{", ".join(KINDS)}')
    if not isinstance(args, list) or not args:
      raise SpaceError(f'{where}: {kind} takes a non-empty list, got '
                       f'{args!r}')
    args = tuple(_literal(a, where) for a in args)
    if kind == 'grid':
      grid[name] = args
    elif kind == 'choice':
      sampled[name] = (kind, args)
    else:
      if len(args) != 2 or not all(
          isinstance(a, (int, float)) and not isinstance(a, bool)
          for a in args) or not args[0] < args[1]:
        raise SpaceError(f'{where}: {kind} takes [low, high] numbers with '
                         f'low < high, got {list(args)!r}')
      if kind == 'loguniform' and args[0] <= 0:
        raise SpaceError(f'{where}: loguniform needs low > 0')
      if kind == 'randint' and not all(isinstance(a, int) for a in args):
        raise SpaceError(f'{where}: randint takes integers [low, high)')
      sampled[name] = (kind, args)
  space = Space(grid=grid, sampled=sampled, num_samples=num_samples)
  check_size(space, source)
  return space


def load_space(path: str) -> Space:
  """Reads a JSON (`.json`) or YAML (`.yaml`, `.yml`) space file.

  YAML is read with `yaml.safe_load` (data only: no tags that build
  objects).

  Raises:
    SpaceError: Missing, unreadable or invalid file (named).
  """
  try:
    with open(path, encoding='utf-8') as f:
      text = f.read()
  except (OSError, UnicodeDecodeError) as e:
    raise SpaceError(f'space file {path}: cannot read it ({e})') from e
  try:
    if path.endswith(('.yaml', '.yml')):
      import yaml  # pylint: disable=g-import-not-at-top  # Ray's dependency.
      data = yaml.safe_load(text)
    elif path.endswith('.json'):
      data = json.loads(text)
    else:
      raise SpaceError(f'space file {path}: expected .json, .yaml or .yml')
  except (ValueError, ImportError) as e:
    if isinstance(e, SpaceError):
      raise
    raise SpaceError(f'space file {path}: not valid '
                     f'{"YAML" if path.endswith("l") else "JSON"} ({e})'
                     ) from e
  except Exception as e:  # yaml.YAMLError has no common base with ValueError.
    raise SpaceError(f'space file {path}: not valid YAML ({e})') from e
  return parse_space(data, f'space file {path}')


def parse_grid_flag(value: str) -> Tuple[str, Tuple[Literal, ...]]:
  """`NAME=V1,V2,...` (a --grid flag) -> (name, values).

  Values are read as JSON where they parse (numbers, true/false, "strings"),
  else as bare strings.
  """
  name, sep, values = value.partition('=')
  name = name.strip()
  if not sep or not values.strip():
    raise SpaceError(f'--grid {value!r}: expected NAME=V1,V2,...')
  _check_name(name, f'--grid {value!r}')
  parsed = []
  for v in values.split(','):
    v = v.strip()
    try:
      parsed.append(json.loads(v))
    except ValueError:
      parsed.append(v)
  return name, tuple(_literal(v, f'--grid {value!r}') for v in parsed)


def merge(space: Optional[Space], grid: Sequence[Tuple[str, Tuple[Literal, ...]]],
          num_samples: Optional[int]) -> Space:
  """A space file's space with --grid bindings and --num_samples added."""
  space = space or Space(grid={}, sampled={})
  combined = dict(space.grid)
  for name, values in grid:
    if name in combined or name in space.sampled:
      raise SpaceError(f'--grid {name}: already in the space file')
    combined[name] = values
  if not combined and not space.sampled:
    raise SpaceError('nothing to sweep: give --space or --grid')
  merged = Space(grid=combined, sampled=space.sampled,
                 num_samples=num_samples or space.num_samples)
  check_size(merged, 'the sweep (--space, --grid, --num_samples)')
  return merged


def points(space: Space, search_seed: int = 0, num_seeds: int = 1
           ) -> List[Dict[str, Literal]]:
  """The sweep's points: grid product x `num_samples` draws (deterministic).

  Args:
    space: The space.
    search_seed: Seed of the draws of the sampled bindings.
    num_seeds: Training seeds each point runs with (for the size check).

  Raises:
    SpaceError: If points x `num_seeds` exceed `MAX_TRIALS` (checked before
      any point is made).
  """
  check_size(space, 'the sweep', num_seeds)
  from ray import tune  # pylint: disable=g-import-not-at-top
  rng = np.random.default_rng(search_seed)
  domains = {'choice': tune.choice, 'uniform': tune.uniform,
             'loguniform': tune.loguniform, 'randint': tune.randint}
  names = list(space.grid)
  result = []
  for values in itertools.product(*(space.grid[n] for n in names)):
    draws = space.num_samples if space.sampled else 1
    for _ in range(draws):
      point = dict(zip(names, values))
      for name, (kind, args) in space.sampled.items():
        domain = (domains[kind](list(args)) if kind == 'choice'
                  else domains[kind](*args))
        point[name] = _literal(domain.sample(random_state=rng), name)
      result.append(point)
  return result


def gin_value(value: Literal) -> str:
  """A literal as gin source (strings quoted)."""
  return repr(value)


def binding_lines(point: Mapping[str, Literal]) -> List[str]:
  """The gin binding lines (`name = value`) of one sweep point."""
  return [f'{name} = {gin_value(v)}' for name, v in point.items()]


def trial_name(index: int, seed: int) -> str:
  """A trial's name and run folder: `p<point>_seed<seed>`, e.g. `p003_seed1`."""
  return f'p{index:03d}_seed{seed}'


@dataclasses.dataclass(frozen=True, kw_only=True)
class SweepSettings:
  """One sweep (stored in SWEEP_DIR/sweep.json; a resume must match)."""
  sweep_dir: str
  points: Tuple[Dict[str, Literal], ...]
  seeds: Tuple[int, ...]
  num_iterations: int
  policy_snapshot_period: int
  validation_episodes: int
  gin_files: Tuple[str, ...] = ()
  gin_bindings: Tuple[str, ...] = ()
  asha_grace_period: Optional[int] = None  # None: no early stopping.
  cpus_per_trial: float = 1.0

  def run_dir(self, index: int, seed: int) -> str:
    """The run directory of a trial: `SWEEP_DIR/runs/p<point>_seed<seed>`."""
    return os.path.join(self.sweep_dir, 'runs', trial_name(index, seed))

  def to_json(self) -> Dict[str, Any]:
    """The settings as a JSON-ready dict (what `sweep.json` records)."""
    d = dataclasses.asdict(self)
    d['points'] = list(d['points'])
    d['seeds'] = list(d['seeds'])
    d['gin_files'] = list(d['gin_files'])
    d['gin_bindings'] = list(d['gin_bindings'])
    return d


def bind_trial_gin(settings: SweepSettings, index: int) -> None:
  """Binds gin for trial point `index` (clears what was bound before)."""
  # pylint: disable=g-import-not-at-top
  import gin
  from ble_latex.agents.sac import trainer as sac_trainer  # pylint: disable=unused-import
  from ble_latex.run import gin_binding
  # pylint: enable=g-import-not-at-top
  gin.clear_config()
  gin_binding.bind_gin('sac', None, settings.gin_files,
                       [*settings.gin_bindings,
                        *binding_lines(settings.points[index])])


def check_points(settings: SweepSettings) -> None:
  """Binds every point's gin and builds its trainer config, here.

  Raises:
    errors.ConfigError: A binding gin, the trainer or the env refuses
      (gin's message names it), before any trial starts.
  """
  # pylint: disable=g-import-not-at-top
  from ble_latex import quiet
  from ble_latex.envs import env_params
  from ble_latex.run import run_dir
  for seed in settings.seeds:
    run_dir.check_training_seed(seed)
  with quiet.third_party_noise():  # Binding imports TF, dopamine, BLE.
    from ble_latex.agents.sac import trainer as sac_trainer
    # pylint: enable=g-import-not-at-top
    for index in range(len(settings.points)):
      try:
        bind_trial_gin(settings, index)
        sac_trainer.TrainerConfig()
        env_params.params_from_gin()
      except errors.ConfigError:
        raise
      except ValueError as e:
        raise errors.ConfigError(str(e)) from e


def _trial(config: Dict[str, Any], *, settings: Dict[str, Any]) -> None:
  """Tune trainable: one training run, reporting each validation."""
  # pylint: disable=g-import-not-at-top
  import ble_latex  # pylint: disable=unused-import  # Fixes first.
  from ray import tune
  from ble_latex import quiet
  from ble_latex.run import suites
  with quiet.third_party_noise():
    from ble_latex.run import jax_train
  # pylint: enable=g-import-not-at-top
  sweep = SweepSettings(**{
      k: tuple(v) if isinstance(v, list) else v for k, v in settings.items()})
  index, seed = config['point']['index'], config['seed']
  bind_trial_gin(sweep, index)
  reported = []

  def report(record: Dict[str, Any]) -> None:
    reported.append(record)
    tune.report(tune_metrics(record))

  first = suites.VALIDATION_SEED_OFFSET
  period = sweep.policy_snapshot_period
  jax_train.train(
      base_dir=sweep.run_dir(index, seed), num_iterations=sweep.num_iterations,
      seed=seed, collectors=('episodes', 'tensorboard'),
      policy_snapshot_period=period, checkpoint_period=period,
      validation_seeds=range(first, first + sweep.validation_episodes),
      on_validation=report, lock_wait_s=TRIAL_LOCK_WAIT_S)
  if not reported:  # Finished before a kill that Tune did not see.
    done = validation_records(sweep.run_dir(index, seed))
    if done:
      tune.report(tune_metrics(done[-1]))


def tune_metrics(record: Mapping[str, Any]) -> Dict[str, float]:
  """What a trial reports to Tune from a `validation.jsonl` record."""
  return {METRIC: float(record['tw50_window_mean']),
          'tw50': float(record['tw50_mean']),
          'out_of_resources_pct': float(record['out_of_resources_pct']),
          'rounds': int(record['iteration']) + 1,
          'training_episodes': int(record['training_episodes']),
          'train_elapsed_s': float(record['elapsed_s'])}


def validation_records(run_dir: str) -> List[Dict[str, Any]]:
  """A trial's validation.jsonl records ([] before its first snapshot)."""
  return episode_log.read(os.path.join(run_dir, episode_log.VALIDATION_LOG))


def lock(settings: SweepSettings) -> contextlib.AbstractContextManager:
  """Context manager: this process is the sweep directory's one driver.

  Locks SWEEP_DIR itself (`safe_io.locked_dir`), not the trials' run
  directories below it, which the trials lock.

  Raises:
    safe_io.InUseError: On entering, if another driver holds it.
  """
  return safe_io.locked_dir(settings.sweep_dir, what='sweep directory')


def check_resume(settings: SweepSettings) -> None:
  """Records the sweep in SWEEP_DIR/sweep.json, or checks it is the same one.

  Call it holding `lock(settings)`.

  Raises:
    ValueError: The directory holds another sweep.
  """
  path = os.path.join(settings.sweep_dir, SWEEP_INFO)
  info = json.dumps(settings.to_json(), indent=1, sort_keys=True) + '\n'
  if os.path.exists(path):
    with open(path, encoding='utf-8') as f:
      stored = f.read()
    try:
      same = json.loads(stored) == json.loads(info)
    except ValueError:
      same = False
    if not same:
      raise ValueError(
          f'{path} describes another sweep (points, seeds or settings '
          'differ); use a new --sweep_dir, or re-run the original command to '
          'resume. Nothing was changed.')
    return
  safe_io.atomic_write(path, info)


def run(settings: SweepSettings, max_concurrent_trials: Optional[int] = None,
        verbose: int = 1) -> List[Dict[str, Any]]:
  """Runs (or resumes) the sweep on the connected Ray; returns the table rows.

  Args:
    settings: The sweep (its `sweep_dir` absolute).
    max_concurrent_trials: Cap on trials at once (default: Ray's resources).
    verbose: Tune's progress output (0 silent, 1 status table).

  Returns:
    `table_rows` of the finished sweep (also written as CSV, markdown and the
    best gin file into the sweep dir).

  Raises:
    safe_io.InUseError: If another driver runs this sweep directory (`lock`,
      held until the outputs are written).
  """
  distributed.require_ray()
  if not os.path.isabs(settings.sweep_dir):
    raise ValueError('settings.sweep_dir must be absolute (Tune storage)')
  with lock(settings):  # Creates the sweep dir.
    return _run_locked(settings, max_concurrent_trials, verbose)


def _run_locked(settings: SweepSettings,
                max_concurrent_trials: Optional[int],
                verbose: int) -> List[Dict[str, Any]]:
  """`run`, holding the sweep directory's lock."""
  # pylint: disable=g-import-not-at-top
  from ray import tune
  from ray.tune import schedulers
  # pylint: enable=g-import-not-at-top
  check_resume(settings)
  trainable = tune.with_resources(
      tune.with_parameters(_trial, settings=settings.to_json()),
      {'cpu': settings.cpus_per_trial})
  experiment = os.path.join(settings.sweep_dir, 'tune')
  if tune.Tuner.can_restore(experiment):
    tuner = tune.Tuner.restore(experiment, trainable, resume_unfinished=True,
                               resume_errored=True)
  else:
    scheduler = None
    if settings.asha_grace_period is not None:
      scheduler = schedulers.ASHAScheduler(
          time_attr='rounds', metric=METRIC, mode='max',
          max_t=settings.num_iterations,
          grace_period=settings.asha_grace_period)
    param_space = {
        'point': tune.grid_search([
            {'index': i, 'bindings': dict(p)}
            for i, p in enumerate(settings.points)]),
        'seed': tune.grid_search(list(settings.seeds)),
    }
    name = lambda trial: trial_name(trial.config['point']['index'],
                                    trial.config['seed'])
    tuner = tune.Tuner(
        trainable, param_space=param_space,
        tune_config=tune.TuneConfig(
            scheduler=scheduler, max_concurrent_trials=max_concurrent_trials,
            trial_name_creator=name, trial_dirname_creator=name),
        run_config=tune.RunConfig(name='tune', storage_path=settings.sweep_dir,
                                  verbose=verbose))
  grid = tuner.fit()
  errors = {}
  for result in grid:
    if result.error is not None:
      point = result.config['point']['index']
      errors[(point, result.config['seed'])] = str(result.error).splitlines()[0]
  rows = table_rows(settings, errors)
  write_outputs(settings, rows)
  return rows


def table_rows(settings: SweepSettings,
               errors: Mapping[Tuple[int, int], str]) -> List[Dict[str, Any]]:
  """One row per trial, from each run's own `validation.jsonl`."""
  rows = []
  for index, point in enumerate(settings.points):
    for seed in settings.seeds:
      run_dir = settings.run_dir(index, seed)
      records = validation_records(run_dir)
      best = selection.best(records, tie=lambda r: -r['iteration'])
      rounds = records[-1]['iteration'] + 1 if records else 0
      if (index, seed) in errors:
        status = 'error: ' + errors[(index, seed)]
      elif rounds >= settings.num_iterations:
        status = 'done'
      else:
        status = 'stopped early' if records else 'no validation'
      rows.append({
          'trial': trial_name(index, seed), 'point': index, 'seed': seed,
          **point,
          'rounds': rounds,
          'best_tw50_window': best['tw50_window_mean'] if best else None,
          'best_round': best['iteration'] + 1 if best else None,
          'best_out_of_resources_pct': (best['out_of_resources_pct']
                                        if best else None),
          'last_tw50_window': (records[-1]['tw50_window_mean']
                               if records else None),
          'status': status,
          'run_dir': os.path.relpath(run_dir, settings.sweep_dir)})
  return rows


def point_summaries(settings: SweepSettings, rows: Sequence[Mapping[str, Any]]
                    ) -> List[Dict[str, Any]]:
  """Per point: mean +- std over seeds of the best validation TW50 (window)."""
  summaries = []
  for index, point in enumerate(settings.points):
    scores = [r['best_tw50_window'] for r in rows
              if r['point'] == index and r['best_tw50_window'] is not None]
    oor = [r['best_out_of_resources_pct'] for r in rows
           if r['point'] == index and r['best_out_of_resources_pct'] is not None]
    summaries.append({
        'point': index, 'bindings': dict(point), 'seeds': len(scores),
        'mean': statistics.fmean(scores) if scores else None,
        'std': statistics.pstdev(scores) if len(scores) > 1 else 0.0,
        'out_of_resources_pct': statistics.fmean(oor) if oor else None})
  return summaries


def write_outputs(settings: SweepSettings,
                  rows: Sequence[Mapping[str, Any]]) -> None:
  """results.csv, results.md and best_config.gin, each written atomically."""
  names = list(dict.fromkeys(n for p in settings.points for n in p))
  columns = ['trial', 'point', 'seed', *names, 'rounds', 'best_tw50_window',
             'best_round', 'best_out_of_resources_pct', 'last_tw50_window',
             'status', 'run_dir']
  out = io.StringIO()
  writer = csv.DictWriter(out, fieldnames=columns, lineterminator='\n')
  writer.writeheader()
  for row in rows:
    writer.writerow({c: row.get(c, '') for c in columns})
  safe_io.atomic_write(os.path.join(settings.sweep_dir, RESULTS_CSV),
                       out.getvalue())
  summaries = point_summaries(settings, rows)
  ranked = sorted((s for s in summaries if s['mean'] is not None),
                  key=lambda s: (-s['mean'], s['point']))
  fmt = lambda x: '—' if x is None else f'{100 * x:.1f}'
  lines = [
      f'Sweep {settings.sweep_dir}: {len(settings.points)} point(s) x '
      f'training seed(s) {", ".join(map(str, settings.seeds))}; '
      f'{settings.num_iterations} rounds per trial, validation on '
      f'{settings.validation_episodes} '
      'latex_validation seeds every '
      f'{settings.policy_snapshot_period} rounds.',
      '',
      '| point | ' + ' | '.join(names) +
      ' | seeds | best TW50 window % (mean ± std) | OOR % at best |',
      '|' + '---|' * (len(names) + 4)]
  for s in ranked + [s for s in summaries if s['mean'] is None]:
    values = ' | '.join(gin_value(s['bindings'].get(n, '')) for n in names)
    score = ('—' if s['mean'] is None
             else f'{fmt(s["mean"])} ± {fmt(s["std"])}')
    oor = ('—' if s['out_of_resources_pct'] is None
           else f'{s["out_of_resources_pct"]:.1f}')
    lines.append(f'| {s["point"]} | {values} | {s["seeds"]} | {score} | '
                 f'{oor} |')
  safe_io.atomic_write(os.path.join(settings.sweep_dir, RESULTS_MD),
                       '\n'.join(lines) + '\n')
  if not ranked:
    return
  best = ranked[0]
  gin_lines = [
      f'# ble-latex-sweep {settings.sweep_dir}: point {best["point"]}, the '
      f'best of {len(settings.points)}',
      f'# by mean validation TW50 over the window ({fmt(best["mean"])} ± '
      f'{fmt(best["std"])} % over {best["seeds"]} seed(s)).',
      '# ble-latex-train --trainer=jax --gin_file=THIS_FILE ...',
      'import ble_latex.agents.sac.trainer',
      *[f"include '{os.path.abspath(p)}'" for p in settings.gin_files],
      *settings.gin_bindings,
      *binding_lines(best['bindings'])]
  safe_io.atomic_write(os.path.join(settings.sweep_dir, BEST_GIN),
                       '\n'.join(gin_lines) + '\n')
