# coding=utf-8
"""The record schema: episodes.jsonl lines, eval records and flight points.

One home for what a record holds. `metrics.EpisodeSummary` writes the episode
record (RUN/episodes.jsonl, one JSON object per line), `eval_lib.evaluate`
the per-seed eval record (the summary without `episode`/`wall_time_s`, plus
`flight_path`), `runner.flight_point` each point of that path; tests check
that each writer's fields are this module's. The loaders read the files back
and check every record, raising ValueError naming the file, record and field
(docs/training.md and docs/plots.md). Nothing here imports BLE.
"""

import dataclasses
import json
import math
import os
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence

from ble_latex.flight import state as state_lib
from ble_latex.run import episode_log

# The values of an episode's `terminal_reason`, in plot order: the env's time
# limit, the runner's episode-length cap, then each non-OK flight status by
# name (`jax_env.info_dict` writes `FlightStatus.name.lower()`).
TERMINAL_REASONS = ('time_limit', 'max_episode_length') + tuple(
    s.name.lower() for s in state_lib.FlightStatus
    if s != state_lib.FlightStatus.OK)
# The terminal reasons that count as out of resources (`state.OUT_OF_RESOURCES`).
OUT_OF_RESOURCES_REASONS = frozenset(
    s.name.lower() for s in state_lib.OUT_OF_RESOURCES)
# A flight point's `decision` (the controller's decisions, by name).
DECISIONS = tuple(d.name.lower() for d in state_lib.DecisionCode)

EpisodeLogWarning = episode_log.EpisodeLogWarning


def _is_int(value: Any) -> bool:
  return isinstance(value, int) and not isinstance(value, bool)


def _is_finite_number(value: Any) -> bool:
  if isinstance(value, bool) or not isinstance(value, (int, float)):
    return False
  try:
    return math.isfinite(value)
  except OverflowError:  # An int too large for a float.
    return False


@dataclasses.dataclass(frozen=True)
class FieldType:
  """What a record field must hold.

  Attributes:
    description: The expectation, as error messages word it ("a finite
      number").
    accepts: True for a valid value (already parsed from JSON).
    items: For a list of records: the schema of each item (then `accepts`
      checks the list itself).
    optional_items: For a list of records: the fields an item may hold,
      checked when present.
  """
  description: str
  accepts: Callable[[Any], bool]
  items: Optional[Mapping[str, 'FieldType']] = None
  optional_items: Optional[Mapping[str, 'FieldType']] = None


NUMBER = FieldType('a finite number', _is_finite_number)
FRACTION = FieldType('a finite number in [0, 1]',
                     lambda v: _is_finite_number(v) and 0 <= v <= 1)
INTEGER = FieldType('an integer', _is_int)
COUNT = FieldType('a non-negative integer', lambda v: _is_int(v) and v >= 0)


def one_of(values: Sequence[str]) -> FieldType:
  """A string from `values`."""
  allowed = frozenset(values)
  return FieldType(f'one of {", ".join(repr(v) for v in values)}',
                   lambda v: isinstance(v, str) and v in allowed)


def list_of(schema: Mapping[str, FieldType], what: str,
            optional: Optional[Mapping[str, FieldType]] = None) -> FieldType:
  """A non-empty list whose items are records of `schema` (and `optional`)."""
  return FieldType(f'a non-empty list of {what}',
                   lambda v: isinstance(v, list) and bool(v), items=schema,
                   optional_items=optional)


def number_within(bound: float) -> FieldType:
  """A finite number in [-bound, bound]."""
  return FieldType(f'a finite number in [-{bound:g}, {bound:g}]',
                   lambda v: _is_finite_number(v) and abs(v) <= bound)


TEXT = FieldType('a string', lambda v: isinstance(v, str))
LATITUDE = number_within(90.0)
LONGITUDE = number_within(360.0)


TERMINAL_REASON = one_of(TERMINAL_REASONS)
# One point of an eval record's flight path (runner.flight_point).
FLIGHT_POINT_SCHEMA: Mapping[str, FieldType] = {
    't_s': NUMBER,
    'x_km': NUMBER,
    'y_km': NUMBER,
    'altitude_m': NUMBER,
    'ascent_rate_mps': NUMBER,
    'decision': one_of(DECISIONS),
    'helium_mols': NUMBER,
    'sand_kg': NUMBER,
}
# What a flight point may also hold (`tracks.locate`): its place and time.
FLIGHT_POINT_OPTIONAL: Mapping[str, FieldType] = {
    'lat': LATITUDE,  # [deg N]
    'lon': LONGITUDE,  # [deg E], -180..180 as written
    'utc': TEXT,  # ISO 8601
}


def batch_flight_point(flight: Mapping[str, Any], i: int) -> Dict[str, Any]:
  """Balloon `i`'s flight point (`FLIGHT_POINT_SCHEMA`) from batched arrays.

  Args:
    flight: The core's flight arrays of a batch (`time_s` [s], `x_m`, `y_m`,
      `altitude_m` [m], `ascent_rate_mps` [m/s], `last_decision`,
      `helium_mols` [mol], `sand_kg` [kg]), each [N].
    i: The balloon.
  """
  return {
      't_s': float(flight['time_s'][i]),
      'x_km': float(flight['x_m'][i]) / 1000.0,
      'y_km': float(flight['y_m'][i]) / 1000.0,
      'altitude_m': float(flight['altitude_m'][i]),
      'ascent_rate_mps': float(flight['ascent_rate_mps'][i]),
      'decision': state_lib.DecisionCode(
          int(flight['last_decision'][i])).name.lower(),
      'helium_mols': float(flight['helium_mols'][i]),
      'sand_kg': float(flight['sand_kg'][i]),
  }
# One line of RUN/episodes.jsonl (metrics.EpisodeSummary).
EPISODE_SCHEMA: Mapping[str, FieldType] = {
    'episode': COUNT,
    'seed': INTEGER,
    'reward': NUMBER,
    'tw50': FRACTION,
    'tw50_window': FRACTION,
    'window_steps': COUNT,
    'steps': COUNT,
    'helium_vented_mols': NUMBER,
    'sand_dropped_kg': NUMBER,
    'terminal_reason': TERMINAL_REASON,
    'final_distance_km': NUMBER,
    'wall_time_s': NUMBER,
}
# One per-seed record of a `ble-latex-eval` file (eval_lib.evaluate).
# It is the episode summary without `episode` and `wall_time_s`, plus the path.
EVAL_SCHEMA: Mapping[str, FieldType] = {
    **{k: v for k, v in EPISODE_SCHEMA.items()
       if k not in ('episode', 'wall_time_s')},
    'flight_path': list_of(FLIGHT_POINT_SCHEMA, 'flight points',
                           FLIGHT_POINT_OPTIONAL),
}
# What an eval record may also hold (`cli/eval.py`, `tracks.locate`).
EVAL_OPTIONAL: Mapping[str, FieldType] = {
    'wind_source': TEXT,
    'station_lat': LATITUDE,  # [deg N]
    'station_lon': LONGITUDE,  # [deg E]
    'station_source': TEXT,
    'start_utc': TEXT,  # ISO 8601
}
# One line of RUN/validation.jsonl (the jitted trainer's policy snapshots
# flown on latex_validation seeds, `jax_train.train`).
VALIDATION_SCHEMA: Mapping[str, FieldType] = {
    'iteration': COUNT,
    'training_episodes': COUNT,
    'updates': COUNT,
    'elapsed_s': NUMBER,
    'episodes': COUNT,
    'tw50_window_mean': FRACTION,
    'tw50_mean': FRACTION,
    'out_of_resources_pct': NUMBER,
}


def _json_type(value: Any) -> str:
  """The JSON name of a parsed value's type."""
  if value is None:
    return 'null'
  if isinstance(value, bool):
    return 'a boolean'
  if isinstance(value, (int, float)):
    return 'a number'
  if isinstance(value, str):
    return 'a string'
  if isinstance(value, list):
    return 'an array'
  if isinstance(value, dict):
    return 'an object'
  return type(value).__name__


def _show(value: Any, limit: int = 60) -> str:
  """A value as it appears in the JSON file, shortened to `limit` chars."""
  try:
    text = json.dumps(value)
  except (TypeError, ValueError):
    text = repr(value)
  return text if len(text) <= limit else text[:limit - 3] + '...'


def _describe(value: Any, limit: int = 60) -> str:
  """'an array [1, 2]', 'a string "x"', 'null': type and value."""
  if value is None:
    return 'null'
  return f'{_json_type(value)} {_show(value, limit)}'


def validate_record(record: Any, schema: Mapping[str, FieldType],
                    where: str,
                    optional: Optional[Mapping[str, FieldType]] = None
                    ) -> None:
  """Checks one record against a schema (extra fields are allowed).

  Args:
    record: A parsed JSON value that should be an object.
    schema: field -> `FieldType`; every field is required.
    where: Names the record in errors ("FILE: record 3 (seed 5)").
    optional: field -> `FieldType` of fields checked when present.

  Raises:
    ValueError: '{where}: ...' naming the field if `record` is not an object,
      misses a field or holds a value the field's type does not accept;
      list fields name the bad item ('{where}: flight_path[4]: ...').
  """
  if not isinstance(record, dict):
    raise ValueError(f'{where}: expected a JSON object, got '
                     f'{_describe(record)}')
  missing = [k for k in schema if k not in record]
  if missing:
    raise ValueError(f'{where}: missing field(s) '
                     f'{", ".join(repr(k) for k in missing)}')
  present = {**schema, **{k: v for k, v in (optional or {}).items()
                          if k in record}}
  for name, field in present.items():
    value = record[name]
    if not field.accepts(value):
      raise ValueError(f'{where}: field {name!r}: expected '
                       f'{field.description}, got {_show(value)}')
    if field.items is not None:
      for j, item in enumerate(value):
        validate_record(item, field.items, f'{where}: {name}[{j}]',
                        field.optional_items)


def _record_label(record: Any, index: int, key: str,
                  key_type: FieldType) -> str:
  """'record {index}', plus '({key} {value})' when that field is valid."""
  label = f'record {index}'
  if isinstance(record, dict) and key_type.accepts(record.get(key)):
    label += f' ({key} {record[key]})'
  return label


def _validate_log(records: Sequence[Any], path: str,
                  schema: Mapping[str, FieldType], key: str,
                  nothing: str) -> None:
  """Checks the lines of a .jsonl log: `schema`, `key` strictly increasing."""
  if not records:
    raise ValueError(f'{path}: {nothing}')
  for i, record in enumerate(records):
    where = f'{path}: {_record_label(record, i + 1, key, COUNT)}'
    validate_record(record, schema, where)
    if i and record[key] <= records[i - 1][key]:
      raise ValueError(
          f'{where}: {key} {record[key]} does not follow {key} '
          f'{records[i - 1][key]} (duplicate or out of order)')


def validate_episodes(records: Sequence[Any], path: str) -> None:
  """Checks episodes.jsonl records: EPISODE_SCHEMA, increasing episodes.

  Args:
    records: The parsed lines, in file order.
    path: The file, named in errors.

  Raises:
    ValueError: '{path}: record N (episode E): ...' (N counts from 1) naming
      the field, for the first bad record; or if there is no record.
  """
  _validate_log(records, path, EPISODE_SCHEMA, 'episode', 'no episodes')


def validate_validation(records: Sequence[Any], path: str) -> None:
  """Checks validation.jsonl records: VALIDATION_SCHEMA, increasing rounds.

  Args:
    records: The parsed lines, in file order.
    path: The file, named in errors.

  Raises:
    ValueError: '{path}: record N (iteration I): ...' (N counts from 1)
      naming the field, for the first bad record; or if there is no record.
  """
  _validate_log(records, path, VALIDATION_SCHEMA, 'iteration',
                'no validated snapshots')


def validate_eval(records: Any, path: str) -> None:
  """Checks an eval file's content: a non-empty list of EVAL_SCHEMA records.

  Args:
    records: The parsed file.
    path: The file, named in errors.

  Raises:
    ValueError: '{path}: record N (seed S): ...' (N counts from 0, the list
      index) naming the field and flight point, for the first bad record;
      '{path}: ...' if the top level is not a non-empty list or two records
      have the same seed.
  """
  if not isinstance(records, list) or not records:
    raise ValueError(f'{path}: expected a non-empty JSON list of per-seed '
                     f'records, got {_describe(records, 40)}')
  first_index = {}
  for i, record in enumerate(records):
    where = f'{path}: {_record_label(record, i, "seed", INTEGER)}'
    validate_record(record, EVAL_SCHEMA, where, EVAL_OPTIONAL)
    seed = record['seed']
    if seed in first_index:
      raise ValueError(f'{where}: seed {seed} already in record '
                       f'{first_index[seed]}')
    first_index[seed] = i


# ---------------------------------------------------------------------------
# Loading (and validating) the inputs.
# ---------------------------------------------------------------------------


def _load_log(path: str, what: str,
              validate: Callable[[Sequence[Any], str], None]
              ) -> List[Dict[str, Any]]:
  """Reads a .jsonl log (`episode_log.read`) and checks it with `validate`."""
  if not os.path.isfile(path):
    raise FileNotFoundError(f'{what} not found: {path}')
  try:
    records = episode_log.read(path)
  except UnicodeDecodeError as e:
    raise ValueError(f'{path}: not a UTF-8 text file: {e}') from e
  validate(records, path)
  return records


def load_episodes(path: str) -> List[Dict[str, Any]]:
  """Reads and validates a training run's episodes.jsonl.

  Args:
    path: RUN/episodes.jsonl, one JSON object per training episode.

  Returns:
    The episode records, in file order.

  Raises:
    FileNotFoundError: if `path` does not exist.
    ValueError: naming the file and the line or record if a line other than
      the last is not valid JSON or UTF-8, or `validate_episodes` fails (a
      record is not an object of EPISODE_SCHEMA, the episode numbers do not
      increase, there is no episode). A torn last line (a run killed while
      writing) is skipped with an `EpisodeLogWarning` instead.
  """
  return _load_log(path, 'episode log', validate_episodes)


def load_validation(path: str) -> List[Dict[str, Any]]:
  """Reads and validates a jitted-trainer run's validation.jsonl.

  Args:
    path: RUN/validation.jsonl, one JSON object per validated snapshot.

  Returns:
    The records, in file order.

  Raises:
    FileNotFoundError: if `path` does not exist.
    ValueError: naming the file and the record if a line other than the last
      is not valid JSON or UTF-8, or `validate_validation` fails. A torn last
      line is skipped with an `EpisodeLogWarning`, as in episodes.jsonl.
  """
  return _load_log(path, 'validation log', validate_validation)


def load_eval(path: str) -> List[Dict[str, Any]]:
  """Reads and validates a `ble-latex-eval` result file.

  Args:
    path: OUT/SUITE/AGENT.json, a JSON list with one object per seed.

  Returns:
    The per-seed records.

  Raises:
    FileNotFoundError: if `path` does not exist.
    ValueError: naming the file if it is not valid JSON (or UTF-8), and the
      record, field and flight point if `validate_eval` fails.
  """
  if not os.path.isfile(path):
    raise FileNotFoundError(f'eval file not found: {path}')
  with open(path, encoding='utf-8') as f:
    try:
      records = episode_log.parse_json_line(f.read(), path)
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
      raise ValueError(f'{path}: not a valid eval JSON file: {e}') from e
  validate_eval(records, path)
  return records
