"""benchmarks/planner_sweep_summary.py: a sweep's flights as a small record."""

import json

from tests import helpers

PROG = 'benchmarks/planner_sweep_summary.py'


def _flight(seed, reason, sand_path, helium_path):
  """A planners.py flight record whose path spends as given (hourly)."""
  path = [{'t_s': 3600.0 * i, 'x_km': 0.0, 'y_km': 0.0, 'altitude_m': 18e3,
           'ascent_rate_mps': 0.0, 'decision': 'nothing', 'helium_mols': h,
           'sand_kg': s} for i, (s, h) in enumerate(zip(sand_path,
                                                        helium_path))]
  return {'seed': seed, 'reward': 1.0, 'tw50': 0.5, 'tw50_window': 0.25,
          'window_steps': 3, 'steps': len(path), 'helium_vented_mols':
          helium_path[0] - helium_path[-1], 'sand_dropped_kg':
          sand_path[0] - sand_path[-1], 'terminal_reason': reason,
          'final_distance_km': 10.0, 'flight_path': path,
          'wind_source': 'test'}


def _sweep(folder):
  (folder / 'timing').mkdir(parents=True)
  flights = [_flight(1, 'time_limit', [3.0] * 9, [200.0] * 9),
             _flight(2, 'out_of_helium', [3.0, 2.5, 2.0, 2.0, 2.0, 2.0, 2.0,
                                          1.0, 1.0],
                     [200.0, 150.0, 150.0, 150.0, 150.0, 150.0, 150.0,
                      100.0, 100.0])]
  (folder / 'a.json').write_text(json.dumps(flights))
  (folder / 'timing' / 'a.json').write_text(json.dumps({'run_config': {
      'gin_files': ['g.gin'], 'gin_bindings': ['X.y=1']}}))


def test_the_record_holds_each_seed_and_its_opening_spend(
    benchmark_script, tmp_path):
  _sweep(tmp_path / 'r')
  out = tmp_path / 'sweep.json'
  script = benchmark_script('planner_sweep_summary.py')
  assert script.main([f'--records={tmp_path}/r', '--names=a',
                      f'--json={out}', '--early_hours=6']) == 0
  (setting,) = json.loads(out.read_text())['settings']
  assert setting['gin_bindings'] == ['X.y=1']
  assert setting['summary']['out_of_resources_pct'] == 50.0
  per_seed = setting['per_seed']
  assert per_seed['terminal_reason'] == ['time_limit', 'out_of_helium']
  # By 6 h the second flight spent 1 kg and a quarter of its helium; the
  # drop at 7 h is outside the opening.
  assert per_seed['early_sand_kg'] == [0.0, 1.0]
  assert per_seed['early_helium_fraction'] == [0.0, 0.25]


def test_bad_input_is_one_line(benchmark_script, tmp_path, capsys):
  script = benchmark_script('planner_sweep_summary.py')
  assert script.main([f'--records={tmp_path}/none', '--names=a',
                      f'--json={tmp_path}/s.json']) == 2
  assert 'no folder' in helpers.one_line(capsys, PROG)
  _sweep(tmp_path / 'r')
  (tmp_path / 'r' / 'a.json').write_text('[{"seed": 1}]')
  assert script.main([f'--records={tmp_path}/r', '--names=a',
                      f'--json={tmp_path}/s.json']) == 1
  helpers.one_line(capsys, PROG)
  assert not (tmp_path / 's.json').exists()
