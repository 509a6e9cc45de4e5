# coding=utf-8
"""A training run directory, as both trainers keep it.

`ble-latex-train --base_dir` holds `run.json` (the settings a resumed run
must agree with), `checkpoints/`, `policies/policy_NNNNN.msgpack` snapshots,
`episodes.jsonl` and `metrics/`; after a choice on validation,
`chosen_policy.msgpack` (those files' paths: `ble_latex.run_files`, their
one home). One process writes it at a time (`locked`).
Used by the agent loop (`train_lib`) and the jitted trainer (`jax_train`).
"""

import contextlib
import json
import os
from typing import Any, Iterator, List, Mapping, Optional, Sequence

from ble_latex import errors
from ble_latex import gin_values
from ble_latex import run_files
from ble_latex import safe_io
from ble_latex.envs import seeds as seeds_lib
from ble_latex.run import episode_log

RUN_INFO = 'run.json'  # What a resumed run must agree with.


def check_training_seed(seed: Any, name: str = 'training seed') -> int:
  """A training seed in [0, 2**32), as int (the check of every trainer).

  `jax.random.PRNGKey` takes seeds modulo 2**32: seed 2**32 + s would train
  the run of seed s, and seeds beyond int64 overflow (the env refuses the
  same, `envs.seeds.MAX_SEED`). Both trainers, `ble-latex-train` and the
  sweep check their seeds here, before any directory is made.

  Raises:
    errors.ConfigError: Naming `name` and the value (one line, exit 2).
  """
  return gin_values.check_int(name, seed, minimum=0,
                              maximum=seeds_lib.MAX_SEED - 1)


def training_seeds(values: Sequence[str], flag: str = '--seeds'
                   ) -> List[int]:
  """A --seeds list of training seeds: distinct ints in [0, 2**32).

  Raises:
    errors.UsageError: One line naming the flag and the bad value.
  """
  try:
    seeds = [int(s) for s in values]
  except ValueError as e:
    raise errors.UsageError(f'{flag} takes integers, got {values}') from e
  if not seeds or len(set(seeds)) != len(seeds):
    raise errors.UsageError(f'{flag} takes distinct integers >= 0, got '
                            f'{values}')
  for seed in seeds:
    training_seed(seed, flag)
  return seeds


def training_seed(seed: int, flag: str = '--seed') -> int:
  """A training seed given as `flag` (`check_training_seed`).

  Raises:
    errors.UsageError: One line naming the flag and the bad value.
  """
  try:
    return check_training_seed(seed, flag)
  except errors.ConfigError as e:
    raise errors.UsageError(str(e)) from e


def snapshot_candidates(base_dir: str, every: int,
                        include_newest: bool) -> List[str]:
  """Snapshots of rounds i with (i + 1) % every == 0 (and the newest).

  Raises:
    FileNotFoundError: The run has no snapshot.
  """
  snapshots = run_files.policy_snapshots(base_dir)
  if not snapshots:
    raise FileNotFoundError(
        f'no exported policies in {base_dir}/policies (train with '
        '--policy_snapshot_period, or `train_sac.py train`)')
  chosen = [path for iteration, path in snapshots
            if (iteration + 1) % every == 0]
  if include_newest and snapshots[-1][1] not in chosen:
    chosen.append(snapshots[-1][1])
  return chosen


@contextlib.contextmanager
def locked(base_dir: str, *, wait_s: float = 0.0) -> Iterator[None]:
  """Holds the run directory's lock (`safe_io.locked_dir`, creating it).

  Once it is held no temporary file in checkpoints/ or policies/ belongs to a
  live writer: those killed writes left are removed.
  """
  with safe_io.locked_dir(base_dir, wait_s=wait_s):
    safe_io.remove_stale_temporaries(run_files.checkpoint_dir(base_dir),
                                     run_files.CHECKPOINT_PREFIX)
    safe_io.remove_stale_temporaries(run_files.policy_dir(base_dir),
                                     run_files.POLICY_PREFIX)
    yield


def check_resume(base_dir: str, run_info: Mapping[str, Any], *,
                 start_iteration: int, episodes_per_iteration: int,
                 log_episodes: bool = True,
                 unsaved_iterations: Optional[int] = 1,
                 defaults: Optional[Mapping[str, Mapping[str, Any]]] = None
                 ) -> None:
  """Refuses a resume that would change settings or lose logged episodes.

  Args:
    base_dir: The run directory.
    run_info: This invocation's `RUN_INFO` settings.
    start_iteration: First iteration to run (newest checkpoint + 1, or 0).
    episodes_per_iteration: Episodes one iteration logs.
    log_episodes: Whether episodes.jsonl is written (else it is not checked).
    unsaved_iterations: Iterations the log may hold past the newest
      checkpoint (dropped and flown again; more means checkpoints are
      missing); None: any number.
    defaults: For settings recorded as a mapping (e.g. the jitted trainer's
      `config`), the values of entries added since a run started: a run
      recorded without them counts with these.

  Raises:
    errors.ResumeError: If `RUN_INFO` is unreadable or records other
      settings, or episodes.jsonl holds fewer episodes than the newest
      checkpoint covers, or more than it and the unsaved iterations cover.
      Nothing is changed.
  """
  info_path = os.path.join(base_dir, RUN_INFO)
  if os.path.exists(info_path):
    try:
      with open(info_path, encoding='utf-8') as f:
        recorded = json.load(f)
    except (OSError, ValueError) as e:
      raise errors.ResumeError(
          f'{info_path} is unreadable ({e}); not resuming') from e
    if not isinstance(recorded, dict):
      raise errors.ResumeError(
          f'{info_path} is not a JSON object; not resuming')
    for key, added in (defaults or {}).items():
      if isinstance(recorded.get(key), dict):
        recorded[key] = {**added, **recorded[key]}
    for key, value in run_info.items():
      if key in recorded and recorded[key] != value:
        raise errors.ResumeError(
            f'{base_dir} was started with {key}={recorded[key]!r}, this run '
            f'asks for {key}={value!r}; use the same settings or a new '
            '--base_dir. Nothing was changed.')
  if not log_episodes:
    return
  log_path = os.path.join(base_dir, episode_log.EPISODE_LOG)
  logged = len(episode_log.read(log_path))
  covered = start_iteration * episodes_per_iteration
  if (unsaved_iterations is not None and
      logged > covered + unsaved_iterations * episodes_per_iteration):
    newest = ('no checkpoint' if not start_iteration else
              f'the newest checkpoint (iteration {start_iteration - 1})')
    raise errors.ResumeError(
        f'{log_path} holds {logged} episodes but {newest} covers only '
        f'{covered}: resuming would drop {logged - covered} logged episodes. '
        f'Are checkpoints missing from {run_files.checkpoint_dir(base_dir)}? '
        'Nothing was changed.')
  if logged < covered:
    raise errors.ResumeError(
        f'{log_path} holds {logged} episodes but the newest checkpoint '
        f'(iteration {start_iteration - 1}) covers {covered}: episodes '
        f'{logged}..{covered - 1} would be missing from the log. Nothing was '
        'changed.')


def write_run_info(base_dir: str, run_info: Mapping[str, Any]) -> None:
  """Records the settings a resumed run must agree with (`check_resume`)."""
  safe_io.atomic_write(os.path.join(base_dir, RUN_INFO),
                       json.dumps(run_info, indent=1) + '\n')
