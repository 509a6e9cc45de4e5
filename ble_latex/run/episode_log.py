# coding=utf-8
"""RUN/episodes.jsonl: one JSON line per training episode (light, no BLE/TF).

Written by `collectors.EpisodeLogCollector`, read by the plots. A resumed run
truncates it back to its checkpoint (`truncate`), so each episode appears
exactly once. A log is a run's, not a record: what is committed of it is its
`summarize`d blocks, in the records folder (`RECORDS_DIR`).
"""

import json
import os
import pathlib
from typing import Any, Dict, List, Sequence
import warnings

from ble_latex import errors
from ble_latex import safe_io

EPISODE_LOG = 'episodes.jsonl'
# A run's committed summary of EPISODE_LOG (`summarize`).
EPISODE_SUMMARY = 'episodes_summary.json'
# The committed records of a checkout (benchmarks/records/, by topic): what
# the docs' tables and figures read and the benchmark scripts write by default.
RECORDS_DIR = pathlib.Path(__file__).resolve().parents[2] / 'benchmarks' / 'records'
# The jitted trainer's validated policy snapshots (records.VALIDATION_SCHEMA).
VALIDATION_LOG = 'validation.jsonl'
# Deepest nesting of JSON arrays/objects read (ours nest at most 4 levels).
MAX_JSON_DEPTH = 32


class EpisodeLogWarning(UserWarning):
  """A torn last line of episodes.jsonl (a killed run) was skipped."""


def read(path: str) -> List[Dict[str, Any]]:
  """Reads episodes.jsonl ([] if absent); a torn last line is skipped.

  A run killed while writing may leave its last line half written: it is
  skipped with an `EpisodeLogWarning`. Any other invalid line, or one nested
  too deeply to parse (`parse_json_line`), raises `errors.BadFileError` (a
  ValueError) naming the file and line.
  """
  if not os.path.exists(path):
    return []
  with open(path, encoding='utf-8') as f:
    numbered = [(i + 1, line) for i, line in enumerate(f.read().split('\n'))
                if line.strip()]
  records = []
  for k, (line_no, line) in enumerate(numbered):
    try:
      records.append(parse_json_line(line, f'{path}: line {line_no}'))
    except json.JSONDecodeError as e:
      if k == len(numbered) - 1:
        warnings.warn(f'{path}: skipping torn last line {line_no} ({e}); was '
                      'the run killed while writing?', EpisodeLogWarning)
        break
      raise errors.BadFileError(
          f'{path}: line {line_no} is not valid JSON: {e}') from e
  return records


def parse_json_line(text: str, where: str) -> Any:
  """`json.loads(text)`, refusing arrays/objects nested too deeply.

  Our records nest a few levels (an eval file: list, record, flight path,
  point); a value nested beyond `MAX_JSON_DEPTH` levels is refused before
  anything recurses into it (json itself raises RecursionError at Python's
  recursion limit; printing or checking such a value would too).

  Args:
    text: JSON text.
    where: The file (and line) it comes from, for the error.

  Returns:
    The decoded value.

  Raises:
    json.JSONDecodeError: `text` is not valid JSON.
    errors.BadFileError: nesting deeper than `MAX_JSON_DEPTH`.
  """
  too_deep = errors.BadFileError(
      f'{where} nests JSON arrays/objects more than {MAX_JSON_DEPTH} levels '
      'deep; not a file this package wrote')
  try:
    value = json.loads(text)
  except RecursionError:
    raise too_deep from None
  pending = [(value, 0)]
  while pending:  # Iterative: no recursion into a deep value.
    item, depth = pending.pop()
    if isinstance(item, (list, dict)):
      if depth >= MAX_JSON_DEPTH:
        raise too_deep
      children = item.values() if isinstance(item, dict) else item
      pending.extend((child, depth + 1) for child in children)
  return value


def truncate(path: str, num_episodes: int) -> None:
  """Keeps the first `num_episodes` records (atomically, `safe_io`)."""
  records = read(path)[:num_episodes]
  safe_io.atomic_write(path, ''.join(json.dumps(r) + '\n' for r in records))


def summarize(records: Sequence[Dict[str, Any]], every: int = 100
              ) -> List[Dict[str, Any]]:
  """Means over consecutive blocks of `every` episodes of an episode log.

  Args:
    records: episodes.jsonl records (`read`), in episode order.
    every: Episodes per block (>= 1); the last block may hold fewer.

  Returns:
    One dict per block: `first_episode`, `last_episode`, `episodes`, the mean
    of each numeric field (`reward`, `tw50`, `tw50_window`, ... ; fields
    absent from some records are averaged over those holding them) and
    `terminal_reasons` (reason -> count).
  """
  if every < 1:
    raise ValueError(f'summarize: every must be >= 1, got {every}')
  blocks = []
  for start in range(0, len(records), every):
    block = records[start:start + every]
    row: Dict[str, Any] = {'first_episode': block[0].get('episode', start),
                           'last_episode': block[-1].get(
                               'episode', start + len(block) - 1),
                           'episodes': len(block)}
    keys = [k for k in block[0] if k not in ('episode', 'seed')]
    for key in keys:
      values = [r[key] for r in block if isinstance(r.get(key), (int, float))
                and not isinstance(r.get(key), bool)]
      if values:
        row[key] = sum(values) / len(values)
    reasons: Dict[str, int] = {}
    for r in block:
      if 'terminal_reason' in r:
        reasons[r['terminal_reason']] = reasons.get(r['terminal_reason'], 0) + 1
    row['terminal_reasons'] = dict(sorted(reasons.items()))
    blocks.append(row)
  return blocks
