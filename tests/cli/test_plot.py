# coding=utf-8
"""`ble-latex-plot` (ble_latex.cli.plot): figures from the files given, every
input checked before drawing, bad input one line."""

import json

import gin
import numpy as np
import pytest

from ble_latex.cli import plot
from ble_latex.run import records as records_lib

from tests.plots.test_figures import (  # The figures' inputs.
    _assert_png, _episode, _eval_records, _write_episodes, _write_json)
from tests.wind import test_gridded  # pylint: disable=g-bad-import-order


def test_main_training_and_eval_figures(tmp_path, capsys):
  run_dir = tmp_path / 'run'
  _write_episodes(run_dir / 'episodes.jsonl', n=120, torn_tail=True)
  trained = _write_json(tmp_path / 'eval' / 'tiny' / 'sac.json',
                        _eval_records((3, 5, 7)))
  baseline = _write_json(tmp_path / 'eval' / 'tiny' / 'random.json',
                         _eval_records((7, 5), drift_km=12.0))
  out = tmp_path / 'plots'
  with pytest.warns(records_lib.EpisodeLogWarning):
    status = plot.main([f'--output_dir={out}', f'--run_dir={run_dir}',
                        f'--eval_json={trained}',
                        f'--baseline_eval_json={baseline}',
                        '--max_trajectories=2'])
  assert status == 0
  stdout = capsys.readouterr().out
  for name in (plot.TRAINING_CURVES, plot.TERMINAL_CONDITIONS,
               plot.TRAJECTORIES, plot.TRAJECTORY_3D):
    _assert_png(out / name)
    assert f'wrote {out / name}' in stdout
  assert not (out / plot.WIND_FIELD).exists()
  summary = json.loads((out / plot.SUMMARY).read_text())
  s = summary[str(trained)]
  assert s['episodes'] == 3
  assert s['tw50_mean'] == pytest.approx(0.5)
  assert s['tw50_window_mean'] == pytest.approx(0.25)
  assert s['reward_mean'] == pytest.approx(10.0)
  assert s['out_of_resources_pct'] == pytest.approx(100.0 / 3.0)
  assert summary[str(baseline)]['episodes'] == 2
  assert (f'{trained}: 3 seeds, TW50 (window) 25.0 +- 8.2%, TW50 (flown) '
          '50.0 +- ') in stdout


def test_main_only_given_inputs(tmp_path):
  trained = _write_json(tmp_path / 'a.json', _eval_records())
  out = tmp_path / 'plots'
  assert plot.main([f'--output_dir={out}', f'--eval_json={trained}']) == 0
  assert sorted(p.name for p in out.iterdir()) == sorted(
      [plot.SUMMARY, plot.TRAJECTORIES, plot.TRACK_MAP, plot.FLIGHT_TIME])


def test_main_bad_inputs(tmp_path, capsys):
  out = tmp_path / 'plots'
  invalid = tmp_path / 'invalid.json'
  invalid.write_text('[{"seed": 1,')
  assert plot.main([f'--output_dir={out}', f'--eval_json={invalid}']) == 1
  assert f'{invalid}: not a valid eval JSON' in capsys.readouterr().err
  assert plot.main([f'--output_dir={out}',
                    f'--run_dir={tmp_path / "norun"}']) == 1
  assert 'episodes.jsonl' in capsys.readouterr().err
  assert plot.main([f'--output_dir={out}']) == 2
  assert 'nothing to plot' in capsys.readouterr().err
  assert plot.main(['--run_dir=x']) == 2  # --output_dir is required.
  assert plot.main([f'--output_dir={out}', '--no_such_flag=1']) == 2
  assert plot.main([f'--output_dir={out}', '--wind_seeds=a']) == 2
  trained = _write_json(tmp_path / 'a.json', _eval_records((3, 5)))
  baseline = _write_json(tmp_path / 'b.json', _eval_records((5,)))
  assert plot.main([f'--output_dir={out}', f'--eval_json={trained}',
                    f'--baseline_eval_json={baseline}', '--seed=3']) == 1
  assert 'seed 3 is not in both eval files' in capsys.readouterr().err
  assert not out.exists()  # Nothing drawn on bad input.
  assert plot.main(['--help']) == 0
  assert '--wind_seeds' in capsys.readouterr().out


def test_main_wind_stats_writes_figure_and_json(tmp_path, capsys):
  era5_file = test_gridded.write_era5(tmp_path / 'era5.nc')
  out = tmp_path / 'plots'
  argv = [f'--output_dir={out}', '--wind_stats', f'--era5_path={era5_file}',
          '--wind_stats_fields=2', '--wind_stats_points=4',
          '--wind_stats_samples=20']
  assert plot.main(argv) == 0
  assert sorted(p.name for p in out.iterdir()) == [plot.WIND_STATS_JSON,
                                                   plot.WIND_STATS]
  _assert_png(out / plot.WIND_STATS)
  result = json.loads((out / plot.WIND_STATS_JSON).read_text())
  assert result['sources'] == {'a': 'VAE', 'b': era5_file}
  assert result['pressures_pa'] == [5000.0, 10000.0]
  assert result['samples'] == {'a': 8, 'b': 20}
  assert result['wasserstein_u_mps'] > 0.0
  assert set(result['direction_diversity']['a']) >= {
      'opposing_pair_fraction', 'opposing_any_fraction', 'opposing_by_level'}
  assert capsys.readouterr().err == ''
  # Against a second ERA5 file (itself): distance 0, no JAX.
  assert plot.main(argv + [f'--wind_stats_against={era5_file}',
                           '--wind_stats_pressures_pa=7000,5000']) == 0
  result = json.loads((out / plot.WIND_STATS_JSON).read_text())
  assert result['pressures_pa'] == [5000.0, 7000.0]
  assert result['per_level'][0]['u_mps']['a']['mean'] == pytest.approx(
      result['per_level'][0]['u_mps']['b']['mean'], abs=1.0)


@pytest.mark.parametrize('change, message', [
    (dict(nan=True), 'has NaN/inf winds'),
    (dict(lat=np.array([2.0, 1.0, 0.0])), 'too small for samples up to 200 '
     'km'),
    (dict(levels_hpa=np.array([20.0, 50.0, 175.0])), 'the comparison needs 2 '
     'or more'),
])
def test_main_wind_stats_bad_era5_files(tmp_path, capsys, change, message):
  era5_file = test_gridded.write_era5(tmp_path / 'era5.nc', **change)
  out = tmp_path / 'plots'
  assert plot.main([f'--output_dir={out}', '--wind_stats',
                    f'--era5_path={era5_file}']) == 1
  error = capsys.readouterr().err
  assert error.startswith('ble-latex-plot: error: ') and message in error
  assert error.count('\n') == 1, error
  assert not out.exists()


def test_main_validates_every_input_before_drawing(tmp_path, capsys):
  run_dir = tmp_path / 'run'
  _write_episodes(run_dir / 'episodes.jsonl', n=60)
  good = _write_json(tmp_path / 'good.json', _eval_records())
  bad_records = _eval_records()
  bad_records[2]['flight_path'][3]['altitude_m'] = None
  bad = _write_json(tmp_path / 'bad.json', bad_records)
  out = tmp_path / 'plots'
  for inputs in ([f'--eval_json={bad}'],
                 [f'--eval_json={good}', f'--eval_json={bad}'],
                 [f'--eval_json={good}', f'--baseline_eval_json={bad}']):
    assert plot.main([f'--output_dir={out}', f'--run_dir={run_dir}',
                      *inputs]) == 1
    err = capsys.readouterr().err
    assert (f"{bad}: record 2 (seed 7): flight_path[3]: field 'altitude_m': "
            'expected a finite number, got null') in err
    assert not out.exists(), sorted(out.iterdir())  # No figure, no summary.


def test_main_bad_episode_value_exits_1_naming_file(tmp_path, capsys):
  run_dir = tmp_path / 'run'
  records = [_episode(i) for i in range(8)]
  records[5]['reward'] = None  # Was an uncaught TypeError while drawing.
  (run_dir).mkdir()
  log = run_dir / 'episodes.jsonl'
  log.write_text('\n'.join(json.dumps(r) for r in records) + '\n')
  trained = _write_json(tmp_path / 'a.json', _eval_records())
  out = tmp_path / 'plots'
  assert plot.main([f'--output_dir={out}', f'--eval_json={trained}',
                    f'--run_dir={run_dir}']) == 1
  assert (f"ble-latex-plot: error: {log}: record 6 (episode 5): field "
          "'reward': expected a finite number, got null"
          ) in capsys.readouterr().err
  assert not out.exists()


def test_main_bad_wind_flags_draw_nothing(tmp_path, capsys):
  run_dir = tmp_path / 'run'
  _write_episodes(run_dir / 'episodes.jsonl', n=60)
  out = tmp_path / 'plots'
  assert plot.main([f'--output_dir={out}', f'--run_dir={run_dir}',
                    '--wind_seed=-1']) == 2
  assert '--wind_seed(s) must be >= 0' in capsys.readouterr().err
  assert plot.main([f'--output_dir={out}', f'--run_dir={run_dir}',
                    '--wind_seed=0', '--wind_pressures_pa=14000,-5']) == 2
  assert 'finite positive numbers' in capsys.readouterr().err
  try:
    status = plot.main([f'--output_dir={out}', f'--run_dir={run_dir}',
                        '--wind_seed=0', '--env_name=NoSuchBalloon-v0'])
  finally:
    gin.clear_config()
  assert status == 2
  assert '--env_name=NoSuchBalloon-v0' in capsys.readouterr().err
  assert not out.exists()


def test_main_wind_field_real_env(tmp_path, capsys):
  out = tmp_path / 'plots'
  try:
    status = plot.main([f'--output_dir={out}', '--wind_seeds=0,1',
                        '--wind_pressures_pa=14000,7000', '--wind_grid=7',
                        '--wind_hours=1',
                        '--gin_bindings=latex_episode.episode_steps = 5'])
    assert gin.query_parameter('latex_episode.episode_steps') == 5
  finally:
    gin.clear_config()
  assert status == 0
  _assert_png(out / plot.WIND_FIELD)
  assert f'wrote {out / plot.WIND_FIELD}' in capsys.readouterr().out
