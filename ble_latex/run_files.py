# coding=utf-8
"""Where a training run's files are: the one home of their paths and names.

A run directory (`ble-latex-train --base_dir`, `benchmarks/train_dagger.py
--base_dir`) holds

- `checkpoints/checkpoint_NNNNN.msgpack`: the SAC trainers' checkpoints (the
  BLE agent's, `agents.sac.checkpoint`, and the jitted trainer's,
  `run.jax_train`), numbered by iteration (0-based, 5 digits or more);
  `checkpoint_NNNNN.pkl` the pickles of ble_latex <= 0.1, read only when
  trusted;
- `checkpoints/dagger_NNNNN.msgpack`: DAgger's, numbered by round;
- `policies/policy_NNNNN.msgpack`: the policy snapshots of the SAC trainers;
- `chosen_policy.msgpack`: the snapshot chosen on validation
  (`run.seed_runs.write_chosen_policy`).

What else a run directory holds (`run.json`, the lock, the episode log) is
`run.run_dir`'s. Light on purpose (only the standard library): the agents
(below `run/`) and the drivers read the same names here.
"""

import os
import re
from typing import List, Optional, Pattern, Tuple

CHECKPOINT_DIR = 'checkpoints'
POLICY_DIR = 'policies'
CHOSEN_POLICY = 'chosen_policy.msgpack'
CHECKPOINT_PREFIX = 'checkpoint_'  # Also of their temporary files.
POLICY_PREFIX = 'policy_'
CHECKPOINT_PATTERN = re.compile(r'^checkpoint_(\d+)\.msgpack$')
LEGACY_CHECKPOINT_PATTERN = re.compile(r'^checkpoint_(\d+)\.pkl$')
DAGGER_CHECKPOINT_PATTERN = re.compile(r'^dagger_(\d{5,})\.msgpack$')
POLICY_SNAPSHOT_PATTERN = re.compile(r'^policy_(\d{5,})\.msgpack$')


def checkpoint_dir(base_dir: str) -> str:
  """The folder of a run's checkpoints."""
  return os.path.join(base_dir, CHECKPOINT_DIR)


def checkpoint_file(folder: str, iteration: int) -> str:
  """`folder/checkpoint_NNNNN.msgpack`: the SAC checkpoint of `iteration`
  in a folder of checkpoints (BLE's numbering, 0-based)."""
  return os.path.join(folder, f'{CHECKPOINT_PREFIX}{iteration:05d}.msgpack')


def legacy_checkpoint_file(folder: str, iteration: int) -> str:
  """`folder/checkpoint_NNNNN.pkl`: the pickle an older ble_latex wrote."""
  return os.path.join(folder, f'{CHECKPOINT_PREFIX}{iteration:05d}.pkl')


def checkpoint_path(base_dir: str, iteration: int) -> str:
  """Where a SAC trainer checkpoints `iteration` (0-based) in a run."""
  return checkpoint_file(checkpoint_dir(base_dir), iteration)


def iterations(folder: str,
               pattern: Pattern[str] = CHECKPOINT_PATTERN) -> List[int]:
  """Numbers of the files in `folder` that match `pattern`, ascending.

  Only names that match exactly count: stray files such as
  `checkpoint_backup.pkl` or `checkpoint_00002 (copy).msgpack` are ignored
  (BLE's `get_latest_checkpoint` gives -1 when it meets one).

  Args:
    folder: Folder to scan (missing: none).
    pattern: Regex with the number as group 1 (default: SAC checkpoints).
  """
  if not os.path.isdir(folder):
    return []
  found = (pattern.match(name) for name in os.listdir(folder))
  return sorted(int(m.group(1)) for m in found if m)


def dagger_checkpoint_path(base_dir: str, round_index: int) -> str:
  """Where DAgger checkpoints round `round_index` in a run."""
  return os.path.join(checkpoint_dir(base_dir),
                      f'dagger_{round_index:05d}.msgpack')


def newest_dagger_checkpoint(base_dir: str) -> Optional[Tuple[int, str]]:
  """(round, path) of a run's newest DAgger checkpoint, or None."""
  done = iterations(checkpoint_dir(base_dir), DAGGER_CHECKPOINT_PATTERN)
  return (done[-1], dagger_checkpoint_path(base_dir, done[-1])) if done else (
      None)


def policy_dir(base_dir: str) -> str:
  """The folder of a run's policy snapshots."""
  return os.path.join(base_dir, POLICY_DIR)


def policy_snapshot_path(base_dir: str, iteration: int) -> str:
  """Where a trainer exports the policy of `iteration` (0-based)."""
  return os.path.join(policy_dir(base_dir),
                      f'{POLICY_PREFIX}{iteration:05d}.msgpack')


def policy_snapshots(base_dir: str) -> List[Tuple[int, str]]:
  """(iteration, path) of each of a run's policy snapshots, by iteration."""
  folder = policy_dir(base_dir)
  found = ((POLICY_SNAPSHOT_PATTERN.match(name), name)
           for name in (os.listdir(folder) if os.path.isdir(folder) else []))
  return sorted((int(m.group(1)), os.path.join(folder, name))
                for m, name in found if m)


def chosen_policy_path(base_dir: str) -> str:
  """Where the snapshot chosen on validation is copied."""
  return os.path.join(base_dir, CHOSEN_POLICY)
