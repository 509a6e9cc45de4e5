# coding=utf-8
"""run.selection: the one rule that chooses on validation (issue 66)."""

import json

from hypothesis import given
from hypothesis import strategies as st
import pytest

from ble_latex.run import episode_log
from ble_latex.run import records
from ble_latex.run import selection

SAC_RUNS = episode_log.RECORDS_DIR / 'sac_jax'

_ROWS = st.lists(st.fixed_dictionaries({
    'iteration': st.integers(0, 50),
    'tw50_window_mean': st.sampled_from([0.0, 0.1, 0.25, 0.4]),
    'out_of_resources_pct': st.sampled_from([0.0, 3.0, 5.0, 20.0, 100.0]),
}), max_size=12)


@given(_ROWS, st.sampled_from([None, 0.0, 5.0, 50.0]))
def test_best_is_within_the_cap_and_nothing_within_beats_it(rows, cap):
  chosen = selection.best(rows, max_oor_pct=cap, tie=lambda r: -r['iteration'])
  fit = [r for r in rows if cap is None or r['out_of_resources_pct'] <= cap]
  if not fit:
    assert chosen is None
    return
  assert chosen in fit
  for r in fit:
    assert (r['tw50_window_mean'], -r['iteration']) <= (
        chosen['tw50_window_mean'], -chosen['iteration'])


@given(_ROWS, st.sampled_from([None, 5.0]))
def test_ranked_is_best_first_and_stable(rows, cap):
  order = selection.ranked(rows, max_oor_pct=cap)
  position = {id(r): i for i, r in enumerate(rows)}
  keys = [r['tw50_window_mean'] for r in order]
  assert keys == sorted(keys, reverse=True)
  for a, b in zip(order, order[1:]):  # equal scores keep their order
    if a['tw50_window_mean'] == b['tw50_window_mean']:
      assert position[id(a)] < position[id(b)]
  assert (order[0] if order else None) is selection.best(rows, max_oor_pct=cap)


def test_result_and_tie_read_nested_records():
  rounds = [{'round': 0, 'validation': {'tw50_window_mean': 0.3,
                                        'out_of_resources_pct': 0.0}},
            {'round': 1, 'validation': {'tw50_window_mean': 0.3,
                                        'out_of_resources_pct': 0.0}},
            {'round': 2, 'validation': {'tw50_window_mean': 0.5,
                                        'out_of_resources_pct': 9.0}}]
  earliest = selection.best(rounds, max_oor_pct=5.0,
                            result=lambda r: r['validation'],
                            tie=lambda r: -r['round'])
  assert earliest['round'] == 0


@pytest.mark.parametrize('run', sorted(p.parent.name for p in
                                       SAC_RUNS.glob('*/report.json')))
def test_committed_reports_choose_the_same_snapshots(run):
  """Golden: the rule re-chooses every committed report's snapshots."""
  report = json.loads((SAC_RUNS / run / 'report.json').read_text())
  for row in report['rows']:
    path = SAC_RUNS / run / f'seed_{row["seed"]}' / 'validation.jsonl'
    if not path.is_file():
      pytest.skip(f'{run}: validation log of seed {row["seed"]} not committed')
    log = [r for r in records.load_validation(str(path))
           if (report['max_iteration'] is None or
               r['iteration'] <= report['max_iteration']) and
           (report['max_minutes'] is None or
            r['elapsed_s'] <= 60.0 * report['max_minutes'])]
    chosen = selection.best(log, max_oor_pct=report['max_oor_pct'],
                            tie=lambda r: -r['iteration'])
    assert chosen['iteration'] == row['iteration'], (run, row['seed'])


def test_choose_snapshot_chooses_on_validation_within_caps():
  choose = selection.choose_snapshot

  def r(iteration, tw50, oor, minutes):
    return {'iteration': iteration, 'tw50_window_mean': tw50,
            'out_of_resources_pct': oor, 'elapsed_s': 60.0 * minutes}
  log = [r(4, 0.3, 0.0, 10), r(9, 0.5, 8.0, 20), r(14, 0.45, 2.0, 30),
         r(19, 0.6, 0.0, 50)]
  assert choose(log, 5.0)['iteration'] == 19
  assert choose(log, 5.0, max_minutes=45)['iteration'] == 14
  assert choose(log, 10.0, max_minutes=45)['iteration'] == 9
  assert choose(log, 5.0, max_minutes=5) is None
  assert choose(log, 5.0, max_iteration=18)['iteration'] == 14
  assert choose(log, 5.0, max_iteration=14)['iteration'] == 14
  assert choose(log, 5.0, max_iteration=3) is None
