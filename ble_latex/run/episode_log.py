# coding=utf-8
"""RUN/episodes.jsonl: one JSON line per training episode (light, no BLE/TF).

Written by `metrics.EpisodeLogCollector`, read by the plots. A resumed run
truncates it back to its checkpoint (`truncate`), so each episode appears
exactly once.
"""

import json
import os
from typing import Any, Dict, List
import warnings

from ble_latex import safe_io

EPISODE_LOG = 'episodes.jsonl'
# The jitted trainer's validated policy snapshots (records.VALIDATION_SCHEMA).
VALIDATION_LOG = 'validation.jsonl'


class EpisodeLogWarning(UserWarning):
  """A torn last line of episodes.jsonl (a killed run) was skipped."""


def read(path: str) -> List[Dict[str, Any]]:
  """Reads episodes.jsonl ([] if absent); a torn last line is skipped.

  A run killed while writing may leave its last line half written: it is
  skipped with an `EpisodeLogWarning`. Any other invalid line raises
  ValueError naming the file and line.
  """
  if not os.path.exists(path):
    return []
  with open(path, encoding='utf-8') as f:
    numbered = [(i + 1, line) for i, line in enumerate(f.read().split('\n'))
                if line.strip()]
  records = []
  for k, (line_no, line) in enumerate(numbered):
    try:
      records.append(json.loads(line))
    except json.JSONDecodeError as e:
      if k == len(numbered) - 1:
        warnings.warn(f'{path}: skipping torn last line {line_no} ({e}); was '
                      'the run killed while writing?', EpisodeLogWarning)
        break
      raise ValueError(f'{path}: line {line_no} is not valid JSON: {e}') from e
  return records


def truncate(path: str, num_episodes: int) -> None:
  """Keeps the first `num_episodes` records (atomically, `safe_io`)."""
  records = read(path)[:num_episodes]
  safe_io.atomic_write(path, ''.join(json.dumps(r) + '\n' for r in records))
