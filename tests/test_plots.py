# coding=utf-8
"""Tests for ble_latex.plots (figures) and ble_latex.plot (`ble-latex-plot`)."""

import json
import math
import pathlib
from typing import Any, Dict, List

import gin
import numpy as np
import pytest

from ble_latex import plot
from ble_latex import plots

_PNG_MAGIC = b'\x89PNG\r\n\x1a\n'
_REASONS = ('out_of_sand', 'time_limit', 'time_limit', 'out_of_helium')


def _episode(i: int) -> Dict[str, Any]:
  return {'episode': i, 'seed': 1000 + i, 'reward': 0.9 * i - 20.0,
          'tw50': (i % 10) / 10.0, 'steps': 216,
          'helium_vented_mols': 1.0 * (i % 7), 'sand_dropped_kg': 0.1 * (i % 5),
          'terminal_reason': _REASONS[i % 4], 'final_distance_km': 30.0 + i,
          'wall_time_s': 2.5}


def _write_episodes(path: pathlib.Path, n: int = 120,
                    torn_tail: bool = False) -> pathlib.Path:
  lines = [json.dumps(_episode(i)) for i in range(n)]
  text = '\n'.join(lines) + '\n'
  if torn_tail:
    text += json.dumps(_episode(n))[:25]  # A run killed mid-write.
  path.parent.mkdir(parents=True, exist_ok=True)
  path.write_text(text)
  return path


def _eval_records(seeds=(3, 5, 7), drift_km: float = 6.0
                  ) -> List[Dict[str, Any]]:
  records = []
  for seed in seeds:
    flight = [{'t_s': 1200.0 * k,
               'x_km': 20.0 * math.cos(seed + 0.4 * k) + drift_km * k,
               'y_km': 20.0 * math.sin(seed + 0.4 * k),
               'altitude_m': 16_000.0 + 300.0 * k, 'ascent_rate_mps': 0.25,
               'decision': 'float', 'helium_mols': 168.0, 'sand_kg': 2.0}
              for k in range(10)]
    records.append({'seed': seed, 'reward': 5.0 + seed, 'tw50': seed / 10.0,
                    'steps': 9, 'helium_vented_mols': 1.5,
                    'sand_dropped_kg': 0.25,
                    'terminal_reason': ('out_of_sand' if seed == 3 else
                                        'time_limit'),
                    'final_distance_km': 60.0, 'flight_path': flight})
  return records


def _write_json(path: pathlib.Path, obj: Any) -> pathlib.Path:
  path.parent.mkdir(parents=True, exist_ok=True)
  path.write_text(json.dumps(obj))
  return path


def _assert_png(path) -> None:
  data = pathlib.Path(path).read_bytes()
  assert data[:8] == _PNG_MAGIC, path
  assert len(data) > 10_000, (path, len(data))


# --- helpers ---------------------------------------------------------------


def test_rolling_mean_hand_example():
  values = [1.0, 2.0, 3.0, 4.0, 5.0]
  np.testing.assert_allclose(plots.rolling_mean(values, 2),
                             [1.0, 1.5, 2.5, 3.5, 4.5])
  np.testing.assert_allclose(plots.rolling_mean(values, 3),
                             [1.0, 1.5, 2.0, 3.0, 4.0])
  np.testing.assert_allclose(plots.rolling_mean(values, 1), values)
  np.testing.assert_allclose(plots.rolling_mean(values, 50),
                             [1.0, 1.5, 2.0, 2.5, 3.0])
  assert plots.rolling_mean([], 50).shape == (0,)
  with pytest.raises(ValueError, match='window'):
    plots.rolling_mean(values, 0)


def test_cumulative_terminal_counts():
  episodes = [{'terminal_reason': r} for r in
              ('out_of_sand', 'time_limit', 'weird', 'time_limit')]
  counts = plots.cumulative_terminal_counts(episodes)
  assert list(counts) == ['time_limit', 'out_of_sand', 'weird']
  np.testing.assert_array_equal(counts['time_limit'], [0, 1, 1, 2])
  np.testing.assert_array_equal(counts['out_of_sand'], [1, 1, 1, 1])
  np.testing.assert_array_equal(counts['weird'], [0, 0, 1, 1])


def test_common_seed():
  a, b = _eval_records((3, 5, 7)), _eval_records((7, 5))
  assert plots.common_seed(a, b) == 5
  assert plots.common_seed(a, b, seed=7) == 7
  with pytest.raises(ValueError, match='seed 3'):
    plots.common_seed(a, b, seed=3)
  with pytest.raises(ValueError, match='share no seed'):
    plots.common_seed(a, _eval_records((1,)))


def test_wind_direction_deg():
  np.testing.assert_allclose(
      plots.wind_direction_deg(np.array([1.0, 0.0, -1.0, 0.0]),
                               np.array([0.0, 1.0, 0.0, -1.0])),
      [0.0, 90.0, 180.0, -90.0])


# --- loaders ---------------------------------------------------------------


def test_load_episodes_skips_torn_last_line(tmp_path):
  path = _write_episodes(tmp_path / 'run' / 'episodes.jsonl', n=120,
                         torn_tail=True)
  with pytest.warns(plots.EpisodeLogWarning, match='torn last line 121'):
    episodes = plots.load_episodes(str(path))
  assert [e['episode'] for e in episodes] == list(range(120))


def test_load_episodes_bad_files(tmp_path):
  with pytest.raises(FileNotFoundError, match='missing.jsonl'):
    plots.load_episodes(str(tmp_path / 'missing.jsonl'))
  lines = [json.dumps(_episode(i)) for i in range(3)]
  corrupt = tmp_path / 'corrupt.jsonl'
  corrupt.write_text('\n'.join([lines[0], '{oops', lines[2]]) + '\n')
  with pytest.raises(ValueError, match=r'corrupt\.jsonl: line 2'):
    plots.load_episodes(str(corrupt))
  duplicate = tmp_path / 'duplicate.jsonl'
  duplicate.write_text('\n'.join([lines[0], lines[1], lines[1]]))
  with pytest.raises(ValueError, match='duplicate.jsonl: record 3: episode 1'):
    plots.load_episodes(str(duplicate))
  no_key = tmp_path / 'no_key.jsonl'
  no_key.write_text(json.dumps({'episode': 0, 'reward': 1.0}) + '\n')
  with pytest.raises(ValueError, match=r"no_key.jsonl: record 1: .*'tw50'"):
    plots.load_episodes(str(no_key))
  empty = tmp_path / 'empty.jsonl'
  empty.write_text('\n')
  with pytest.raises(ValueError, match='empty.jsonl: no episodes'):
    plots.load_episodes(str(empty))


def test_load_eval_bad_files(tmp_path):
  good = _write_json(tmp_path / 'good.json', _eval_records())
  assert [r['seed'] for r in plots.load_eval(str(good))] == [3, 5, 7]
  invalid = tmp_path / 'invalid.json'
  invalid.write_text(good.read_text()[:-40])
  with pytest.raises(ValueError, match='invalid.json: not a valid eval JSON'):
    plots.load_eval(str(invalid))
  with pytest.raises(ValueError, match='dict.json: expected a non-empty'):
    plots.load_eval(str(_write_json(tmp_path / 'dict.json', {'seed': 1})))
  bad_point = _eval_records()
  del bad_point[1]['flight_path'][4]['y_km']
  with pytest.raises(ValueError, match=r'record 1 \(seed 5\) flight_path\[4\]'):
    plots.load_eval(str(_write_json(tmp_path / 'bad_point.json', bad_point)))
  with pytest.raises(FileNotFoundError, match='nope.json'):
    plots.load_eval(str(tmp_path / 'nope.json'))


# --- figures ---------------------------------------------------------------


def test_training_figures(tmp_path):
  episodes = [_episode(i) for i in range(120)]
  _assert_png(plots.plot_training_curves(episodes,
                                         str(tmp_path / 'curves.png')))
  _assert_png(plots.plot_terminal_conditions(episodes,
                                             str(tmp_path / 'term.png')))
  with pytest.raises(ValueError, match='no episodes'):
    plots.plot_training_curves([], str(tmp_path / 'empty.png'))


def test_trajectory_figures(tmp_path):
  trained, untrained = _eval_records(drift_km=0.0), _eval_records()
  _assert_png(plots.plot_trajectories(trained, str(tmp_path / 'traj.png'),
                                      max_trajectories=2))
  _assert_png(plots.plot_trajectory_3d(trained[0], untrained[0],
                                       str(tmp_path / 'sub' / 'traj3d.png')))
  no_path = dict(trained[0], flight_path=[])
  with pytest.raises(ValueError, match='seed 3: no flight_path'):
    plots.plot_trajectories([no_path], str(tmp_path / 'none.png'))


def test_wind_figure_from_synthetic_field(tmp_path):
  axis = np.linspace(-300.0, 300.0, 7)
  xx, yy = np.meshgrid(axis, axis)
  u = np.stack([np.cos(xx / 200.0) * 10.0, -yy / 30.0])
  v = np.stack([np.sin(yy / 200.0) * 10.0, xx / 30.0])
  row = plots.WindPanelRow(
      title='synthetic', x_km=axis, y_km=axis,
      pressures_pa=np.array([14000.0, 7000.0]),
      altitudes_km=np.array([14.1, 18.5]), u_mps=u, v_mps=v,
      balloon_xy_km=(-80.0, 20.0))
  _assert_png(plots.plot_wind_fields([row, row], str(tmp_path / 'wind.png')))
  with pytest.raises(ValueError, match='u_mps has shape'):
    plots.WindPanelRow(title='bad', x_km=axis, y_km=axis,
                       pressures_pa=np.array([1.0]),
                       altitudes_km=np.array([1.0]), u_mps=u, v_mps=v)
  with pytest.raises(ValueError, match='non-finite'):
    plots.WindPanelRow(title='nan', x_km=axis, y_km=axis,
                       pressures_pa=np.array([14000.0, 7000.0]),
                       altitudes_km=np.array([14.1, 18.5]),
                       u_mps=np.full_like(u, np.nan), v_mps=v)


# --- the command -------------------------------------------------------------


def test_main_training_and_eval_figures(tmp_path, capsys):
  run_dir = tmp_path / 'run'
  _write_episodes(run_dir / 'episodes.jsonl', n=120, torn_tail=True)
  trained = _write_json(tmp_path / 'eval' / 'tiny' / 'sac.json',
                        _eval_records((3, 5, 7)))
  baseline = _write_json(tmp_path / 'eval' / 'tiny' / 'random.json',
                         _eval_records((7, 5), drift_km=12.0))
  out = tmp_path / 'plots'
  with pytest.warns(plots.EpisodeLogWarning):
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
  assert s['reward_mean'] == pytest.approx(10.0)
  assert s['out_of_resources_pct'] == pytest.approx(100.0 / 3.0)
  assert summary[str(baseline)]['episodes'] == 2
  assert f'{trained}: 3 seeds, TW50 50.0 +- ' in stdout


def test_main_only_given_inputs(tmp_path):
  trained = _write_json(tmp_path / 'a.json', _eval_records())
  out = tmp_path / 'plots'
  assert plot.main([f'--output_dir={out}', f'--eval_json={trained}']) == 0
  assert sorted(p.name for p in out.iterdir()) == [plot.SUMMARY,
                                                   plot.TRAJECTORIES]


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


def test_main_wind_field_real_env(tmp_path, capsys):
  out = tmp_path / 'plots'
  try:
    status = plot.main([f'--output_dir={out}', '--wind_seeds=0,1',
                        '--wind_pressures_pa=14000,7000', '--wind_grid=7',
                        '--wind_hours=1',
                        '--gin_bindings=LatexBalloonEnv.episode_steps = 5'])
    assert gin.query_parameter('LatexBalloonEnv.episode_steps') == 5
  finally:
    gin.clear_config()
  assert status == 0
  _assert_png(out / plot.WIND_FIELD)
  assert f'wrote {out / plot.WIND_FIELD}' in capsys.readouterr().out
