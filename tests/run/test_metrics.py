"""The episode metrics: BLE's TW50 over the steps flown and over the window."""

import json
import subprocess
import sys

from hypothesis import given
from hypothesis import strategies as st
import pytest

from ble_latex.run import metrics

from tests import helpers

ROOT = helpers.ROOT


def _fly(tracker, distances_km):
  for d in distances_km:
    tracker.step(1.0, {'distance_km': d})


def test_early_end_counts_as_outside_for_the_rest_of_the_window():
  tracker = metrics.EpisodeTracker(0, 7, radius_km=50.0, window_steps=216)
  _fly(tracker, [10.0] * 54)  # Within for 54 steps, then out of sand.
  s = tracker.summary(done=True)
  assert s.tw50 == 1.0
  assert s.tw50_window == pytest.approx(54 / 216)
  assert s.window_steps == 216 and s.steps == 54


def test_full_flight_scores_the_same_both_ways():
  tracker = metrics.EpisodeTracker(0, 7, radius_km=50.0, window_steps=4)
  _fly(tracker, [10.0, 60.0, 50.0, 51.0])  # 50 km counts as within.
  s = tracker.summary(done=True)
  assert s.tw50 == s.tw50_window == 0.5


@given(st.integers(1, 500), st.data())
def test_window_fraction_never_exceeds_flown_fraction(window, data):
  steps = data.draw(st.integers(0, window))
  within = data.draw(st.integers(0, steps))
  f = metrics.tw50_fractions(within, steps, window)
  assert 0.0 <= f['tw50_window'] <= f['tw50'] <= 1.0
  assert f['tw50_window'] * window == pytest.approx(within)
  if steps == window:
    assert f['tw50_window'] == f['tw50']


@pytest.mark.parametrize('counts', [(-1, 3, 5), (4, 3, 5), (1, 6, 5),
                                    (0, 0, 0)])
def test_inconsistent_counts_are_rejected(counts):
  with pytest.raises(ValueError, match='within_steps <= steps <= window'):
    metrics.tw50_fractions(*counts)


def test_summary_has_both_and_names_a_record_without_the_window():
  records = [{'seed': 1, 'reward': 1.0, 'tw50': 1.0, 'tw50_window': 0.25,
              'helium_vented_mols': 0.0, 'sand_dropped_kg': 0.0,
              'terminal_reason': 'out_of_sand'},
             {'seed': 2, 'reward': 3.0, 'tw50': 0.5, 'tw50_window': 0.5,
              'helium_vented_mols': 0.0, 'sand_dropped_kg': 0.0,
              'terminal_reason': 'time_limit'}]
  s = metrics.summarize(records)
  assert s['tw50_mean'] == 0.75 and s['tw50_window_mean'] == 0.375
  assert s['out_of_resources_pct'] == 50.0
  del records[1]['tw50_window']
  with pytest.raises(ValueError, match=r"record 1 \(seed 2\) lacks \['tw50_window'\]"):
    metrics.summarize(records)


def test_upgrade_script_derives_what_the_tracker_writes(tmp_path):
  tracker = metrics.EpisodeTracker(3, 11, radius_km=50.0, window_steps=216)
  _fly(tracker, [10.0] * 30 + [80.0] * 20)
  new = tracker.summary(done=True).to_json()
  old = {k: v for k, v in new.items() if k not in ('tw50_window',
                                                   'window_steps')}
  path = tmp_path / 'episodes.jsonl'
  path.write_text(json.dumps(old) + '\n' + json.dumps(new) + '\n')
  subprocess.run([sys.executable, str(ROOT / 'benchmarks' /
                                      'add_tw50_window.py'), str(path)],
                 check=True, capture_output=True)
  upgraded = [json.loads(l) for l in path.read_text().splitlines()]
  assert upgraded == [new, new]
  assert list(upgraded[0]) == list(new)  # Same key order as the writer.


def test_days_aloft_and_seed_rows():
  """`summarize_aloft` and `over_seeds` (benchmarks/physics_results.py's
  rows): days aloft from strides (20 min), the share flying the whole
  window, and one mean ± std row over seed files."""

  def record(seed, steps, reason, window):
    return {'seed': seed, 'reward': 1.0, 'tw50': window, 'tw50_window': window,
            'helium_vented_mols': 1.0, 'sand_dropped_kg': 0.5, 'steps': steps,
            'terminal_reason': reason}

  a = metrics.summarize_aloft([record(1, 504, 'time_limit', 0.5),
                      record(2, 72, 'out_of_sand', 0.1)])
  assert a['days_aloft_mean'] == pytest.approx(4.0)  # (7 + 1) / 2 days.
  assert a['full_window_pct'] == 50.0
  b = metrics.summarize_aloft([record(1, 144, 'out_of_helium', 0.3)])
  rows = metrics.over_seeds({'sac_seed_0': a, 'sac_seed_1': b, 'other': a})
  assert list(rows) == ['sac (2 seeds)']
  row = rows['sac (2 seeds)']
  assert row['tw50_window_mean'] == pytest.approx(0.3)  # a: (0.5 + 0.1) / 2.
  assert row['days_aloft_mean'] == pytest.approx(3.0)  # (4 + 2) / 2 days.
  assert row['days_aloft_std'] == pytest.approx(2 ** 0.5)
  assert row['episodes'] == 3 and row['num_seeds'] == 2
