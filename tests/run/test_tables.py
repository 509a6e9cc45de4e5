# coding=utf-8
"""run.tables: a table's cells from the committed records (issue 66)."""

import json
import math
import statistics

from hypothesis import given
from hypothesis import strategies as st
import pytest

from ble_latex.run import tables

_FRACTIONS = st.lists(st.floats(0.0, 1.0), min_size=1, max_size=12)


def _row(seeds, windows):
  return {'seeds': list(seeds), 'tw50_window': list(windows)}


def test_mean_std_is_the_population_spread():
  assert tables.mean_std([0.25, 0.75]) == (0.5, 0.25)
  assert tables.mean_std([0.4]) == (0.4, 0.0)


@given(_FRACTIONS)
def test_spreads_agree_with_statistics(values):
  mean, std = tables.mean_std(values)
  assert mean == pytest.approx(statistics.fmean(values), abs=1e-12)
  assert std == pytest.approx(statistics.pstdev(values), abs=1e-9)
  if len(values) < 2:
    assert tables.sample_std(values) == tables.standard_error(values) == 0.0
    return
  sample = statistics.stdev(values)
  assert tables.sample_std(values) == pytest.approx(sample, abs=1e-9)
  assert tables.standard_error(values) == pytest.approx(
      sample / math.sqrt(len(values)), abs=1e-9)


@given(st.lists(st.tuples(st.floats(0.0, 1.0), st.floats(0.0, 1.0)),
                min_size=1, max_size=12))
def test_paired_is_the_per_seed_difference(pairs):
  a = _row(range(len(pairs)), [x for x, _ in pairs])
  b = _row(range(len(pairs)), [y for _, y in pairs])
  diff = [y - x for x, y in pairs]
  p = tables.paired(a, b)
  assert p.mean == pytest.approx(sum(diff) / len(diff), abs=1e-12)
  assert p.se == tables.standard_error(diff)
  assert p.ahead == sum(d > 0 for d in diff)
  assert p.behind == sum(d < 0 for d in diff)
  assert p.ahead + p.behind <= len(pairs)
  # The other way round: the same size, the opposite sign.
  q = tables.paired(b, a)
  assert (q.mean, q.se, q.ahead, q.behind) == pytest.approx(
      (-p.mean, p.se, p.behind, p.ahead), abs=1e-12)
  # Equal rows: no difference, nobody ahead.
  assert tables.paired(a, a) == (0.0, 0.0, 0, 0)


def test_paired_cell_in_percentage_points():
  # Differences +0.1, 0, +0.2: mean +10 pts, SE 0.1 / sqrt(3) = 5.8 pts.
  a = _row([1, 2, 3], [0.4, 0.5, 0.6])
  b = _row([1, 2, 3], [0.5, 0.5, 0.8])
  assert tables.paired_cell(a, b) == '+10.0 ± 5.8 (2 / 0)'
  assert tables.paired_cell(b, a) == '-10.0 ± 5.8 (0 / 2)'


def test_paired_refuses_rows_of_other_seeds():
  with pytest.raises(ValueError, match='^where.json: paired rows fly other '
                     'seeds$'):
    tables.paired(_row([1, 2], [0.1, 0.2]), _row([1, 3], [0.1, 0.2]),
                  'where.json')


def test_per_seed_on_takes_the_shared_seeds():
  row = {'per_seed': _row([1, 2, 3], [0.1, 0.2, 0.3])}
  assert tables.per_seed_on(row, [3, 1]) == _row([3, 1], [0.3, 0.1])
  # A seed it did not fly: its own seeds, no values (paired refuses it).
  missing = tables.per_seed_on(row, [1, 4])
  assert missing == _row([1, 2, 3], [])
  with pytest.raises(ValueError, match='other seeds'):
    tables.paired(_row([1, 4], [0.1, 0.2]), missing)


def test_per_seed_mean_averages_each_seed():
  mean = tables.per_seed_mean([_row([5, 6], [0.2, 0.4]),
                               _row([5, 6], [0.4, 0.8])])
  assert mean['seeds'] == [5, 6]
  assert mean['tw50_window'] == pytest.approx([0.3, 0.6])


def test_percentage_cells():
  assert tables.pct(0.5, 0.25) == '50.0 % ± 25.0'
  assert tables.over_seeds_cell([0.5, 0.6]) == '55.0 % ± 7.1 (50.0 / 60.0)'
  assert tables.over_seeds_cell([0.5]) == '50.0 % ± 0.0 (50.0)'
  assert tables.over_seeds_cell([0.1, 0.3], 0) == '20 % ± 14 (10 / 30)'


def _flight(seed, window, reason, sand=1.0, helium=2.0):
  return {'seed': seed, 'tw50_window': window, 'terminal_reason': reason,
          'sand_dropped_kg': sand, 'helium_vented_mols': helium}


def test_flights_summary_of_a_record(tmp_path):
  record = tmp_path / 'agent.json'
  record.write_text(json.dumps([
      _flight(1, 0.25, 'time_limit', sand=1.0),
      _flight(2, 0.75, 'out_of_sand', sand=3.0),
      _flight(3, 0.5, 'out_of_helium'),
      _flight(4, 0.5, 'left_wind_domain')]), encoding='utf-8')
  s = tables.flights_summary(record)
  assert s['seeds'] == 4
  assert s['per_seed'] == _row([1, 2, 3, 4], [0.25, 0.75, 0.5, 0.5])
  assert s['tw50_window'] == tables.mean_std([0.25, 0.75, 0.5, 0.5])
  assert s['out_of_resources_pct'] == 50.0
  assert s['sand'] == 1.5 and s['helium'] == 2.0
  record.write_text('[]', encoding='utf-8')
  with pytest.raises(ValueError, match='agent.json: no flights'):
    tables.flights_summary(record)


def test_planner_summary_reads_the_record_and_its_timing(tmp_path,
                                                         monkeypatch):
  monkeypatch.setattr(tables, 'PLANNERS', tmp_path)
  (tmp_path / 'suite' / 'timing').mkdir(parents=True)
  (tmp_path / 'suite' / 'mpc.json').write_text(json.dumps(
      [_flight(1, 0.5, 'time_limit')]), encoding='utf-8')
  (tmp_path / 'suite' / 'timing' / 'mpc.json').write_text(json.dumps(
      {'summary': {'s_per_decision_per_balloon': 0.25,
                   's_per_episode_per_balloon': 54.0}}), encoding='utf-8')
  s = tables.planner_summary('suite/mpc')
  assert (s['seeds'], s['s_per_decision'], s['s_per_episode']) == (
      1, 0.25, 54.0)
  assert tables.planner_per_seed('suite/mpc') == _row([1], [0.5])


def test_the_committed_planners_records_read():
  s = tables.planner_summary('latex_small/latex_mpc')
  assert s['seeds'] == len(s['per_seed']['seeds']) > 0
  assert 0.0 <= s['tw50_window'][0] <= 1.0
