# coding=utf-8
"""A table's cells from the committed records: read, summarise, format.

The arithmetic and number formats of README's and the docs' result tables,
in one home: reading a record (`load`), mean and spread (`mean_std`,
`sample_std`, `standard_error`), per-seed paired differences between two
controllers flown on the same seeds (`paired`, `paired_cell`,
`per_seed_on`, `per_seed_mean`), the summary of a record of flights
(`flights_summary`, `planner_summary`) and the percentage cells (`pct`,
`over_seeds_cell`). The docs' hooks (`docs/hooks/tables.py`,
`docs/hooks/learned.py`) say which records, which rows and where each table
goes; what a cell holds is computed here.

A per-seed row is `{'seeds': [...], 'tw50_window': [...]}` (what
`metrics.summarize_aloft` writes as `per_seed` and `flights_summary`
returns as `per_seed`): one TW50 over the window per seed, in seed order.
Fractions are in [0, 1]; cells show them in percent or percentage points.
The out-of-resources terminal reasons are the record schema's
(`records.OUT_OF_RESOURCES_REASONS`).
"""

import json
import math
import pathlib
from typing import Any, Dict, NamedTuple, Sequence, Tuple

from ble_latex.run import episode_log
from ble_latex.run import records as records_lib

# `benchmarks/planners.py`'s records: SUITE/NAME.json (one flight per seed)
# and SUITE/timing/NAME.json (its timing summary).
PLANNERS = episode_log.RECORDS_DIR / 'planners'


def load(path: pathlib.Path) -> Any:
  """The JSON value of the record at `path` (UTF-8)."""
  with open(path, encoding='utf-8') as f:
    return json.load(f)


def mean_std(values: Sequence[float]) -> Tuple[float, float]:
  """(mean, population standard deviation) of `values` (one or more): the
  spread over episodes, as `metrics.summarize`."""
  return sum(values) / len(values), math.sqrt(_squares(values) / len(values))


def _squares(values: Sequence[float]) -> float:
  """Sum of squared deviations of `values` from their mean."""
  mean = sum(values) / len(values)
  return sum((v - mean) ** 2 for v in values)


def sample_std(values: Sequence[float]) -> float:
  """Sample standard deviation (n − 1) of `values`; 0.0 for one value: the
  spread over training seeds."""
  if len(values) < 2:
    return 0.0
  return math.sqrt(_squares(values) / (len(values) - 1))


def standard_error(values: Sequence[float]) -> float:
  """Standard error of the mean of `values`: sample std / sqrt(n); 0.0 for
  one value."""
  return sample_std(values) / math.sqrt(len(values))


def pct(mean: float, std: float) -> str:
  """'M % ± S': a fraction's mean and spread in percent, one decimal."""
  return f'{100 * mean:.1f} % ± {100 * std:.1f}'


def over_seeds_cell(values: Sequence[float], digits: int = 1) -> str:
  """'M % ± S (v1 / v2 / ...)': the mean ± sample std over training seeds
  of fractions, then each seed's value, in percent with `digits` decimals."""
  mean = sum(values) / len(values)
  each = ' / '.join(f'{100 * v:.{digits}f}' for v in values)
  return (f'{100 * mean:.{digits}f} % ± {100 * sample_std(values):.{digits}f}'
          f' ({each})')


class Paired(NamedTuple):
  """b − a per seed (TW50 over the window, a fraction)."""
  mean: float  # mean difference
  se: float  # its standard error (0.0 on one seed)
  ahead: int  # seeds where b flew better
  behind: int  # seeds where b flew worse


def paired(a: Dict[str, Any], b: Dict[str, Any],
           where: Any = 'record') -> Paired:
  """b − a on the same seeds, from two per-seed rows.

  Raises:
    ValueError: `a` and `b` list other seeds (naming `where`).
  """
  if a['seeds'] != b['seeds']:
    raise ValueError(f'{where}: paired rows fly other seeds')
  diff = [y - x for x, y in zip(a['tw50_window'], b['tw50_window'])]
  return Paired(sum(diff) / len(diff), standard_error(diff),
                sum(d > 0 for d in diff), sum(d < 0 for d in diff))


def paired_cell(a: Dict[str, Any], b: Dict[str, Any],
                where: Any = 'record') -> str:
  """'+M ± SE (ahead / behind)': `paired(a, b)` in percentage points."""
  p = paired(a, b, where)
  return f'{100 * p.mean:+.1f} ± {100 * p.se:.1f} ({p.ahead} / {p.behind})'


def per_seed_on(row: Dict[str, Any], seeds: Sequence[int]) -> Dict[str, Any]:
  """The per-seed row of `row['per_seed']` on `seeds` (a subset flown by
  both sides of a pair), or, where `row` misses one of them, its own seeds
  with no values (which `paired` refuses)."""
  by_seed = dict(zip(row['per_seed']['seeds'], row['per_seed']['tw50_window']))
  if any(s not in by_seed for s in seeds):
    return {'seeds': list(row['per_seed']['seeds']), 'tw50_window': []}
  return {'seeds': list(seeds), 'tw50_window': [by_seed[s] for s in seeds]}


def per_seed_mean(rows: Sequence[Dict[str, Any]]) -> Dict[str, Any]:
  """Per seed, the mean TW50 of `rows` (per-seed rows on the first's
  seeds): e.g. an ensemble's members flown alone."""
  return {'seeds': rows[0]['seeds'],
          'tw50_window': [sum(r['tw50_window'][i] for r in rows) / len(rows)
                          for i in range(len(rows[0]['seeds']))]}


def flights_summary(record: pathlib.Path) -> Dict[str, Any]:
  """Mean/std of an eval or planners' record of flights (one per seed).

  Returns:
    `seeds` (how many), `per_seed` (a per-seed row), `tw50_window` (mean,
    population std), `out_of_resources_pct` [%], mean `sand` [kg] and
    `helium` [mol].

  Raises:
    ValueError: The record holds no flights.
  """
  return summarize_flights(load(record), record)


def summarize_flights(flights: Sequence[Dict[str, Any]],
                      source: Any) -> Dict[str, Any]:
  """`flights_summary` of flights already read from `source` (named in the
  ValueError raised when there are none)."""
  if not flights:
    raise ValueError(f'{source}: no flights')
  return {
      'seeds': len(flights),
      'per_seed': {'seeds': [f['seed'] for f in flights],
                   'tw50_window': [f['tw50_window'] for f in flights]},
      'tw50_window': mean_std([f['tw50_window'] for f in flights]),
      'out_of_resources_pct': 100.0 * sum(
          f['terminal_reason'] in records_lib.OUT_OF_RESOURCES_REASONS
          for f in flights) / len(flights),
      'sand': mean_std([f['sand_dropped_kg'] for f in flights])[0],
      'helium': mean_std([f['helium_vented_mols'] for f in flights])[0],
  }


def planner_record(name: str) -> pathlib.Path:
  """The planners' record `name` ('SUITE/NAME', under `PLANNERS`)."""
  return PLANNERS / f'{name}.json'


def planner_summary(name: str) -> Dict[str, Any]:
  """`flights_summary` of the planners' record `name` ('SUITE/NAME') plus
  its timing: `s_per_decision` and `s_per_episode` per balloon [s]."""
  record = planner_record(name)
  seconds = load(record.parent / 'timing' / record.name)['summary']
  return {**flights_summary(record),
          's_per_decision': seconds['s_per_decision_per_balloon'],
          's_per_episode': seconds['s_per_episode_per_balloon']}


def planner_per_seed(name: str) -> Dict[str, Any]:
  """The per-seed row of the planners' record `name` ('SUITE/NAME')."""
  return flights_summary(planner_record(name))['per_seed']

