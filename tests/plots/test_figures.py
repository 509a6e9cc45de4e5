# coding=utf-8
"""Tests for ble_latex.plots.figures (figures); the command, ble-latex-plot, in
tests/cli/test_plot.py."""

import dataclasses
import json
import math
import pathlib
import types
from typing import Any, Dict, List

import numpy as np
import pytest

from ble_latex.cli import plot
from ble_latex.plots import figures as plots
from ble_latex.run import episode_log
from ble_latex.run import records as records_lib

_PNG_MAGIC = b'\x89PNG\r\n\x1a\n'
_REASONS = ('out_of_sand', 'time_limit', 'time_limit', 'out_of_helium')


def _episode(i: int) -> Dict[str, Any]:
  return {'episode': i, 'seed': 1000 + i, 'reward': 0.9 * i - 20.0,
          'tw50': (i % 10) / 10.0, 'tw50_window': (i % 10) / 10.0,
          'window_steps': 216, 'steps': 216,
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
                    'tw50_window': seed / 20.0, 'window_steps': 18,
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
  with pytest.warns(records_lib.EpisodeLogWarning, match='torn last line 121'):
    episodes = records_lib.load_episodes(str(path))
  assert [e['episode'] for e in episodes] == list(range(120))


def test_load_episodes_bad_files(tmp_path):
  with pytest.raises(FileNotFoundError, match='missing.jsonl'):
    records_lib.load_episodes(str(tmp_path / 'missing.jsonl'))
  lines = [json.dumps(_episode(i)) for i in range(3)]
  corrupt = tmp_path / 'corrupt.jsonl'
  corrupt.write_text('\n'.join([lines[0], '{oops', lines[2]]) + '\n')
  with pytest.raises(ValueError, match=r'corrupt\.jsonl: line 2'):
    records_lib.load_episodes(str(corrupt))
  duplicate = tmp_path / 'duplicate.jsonl'
  duplicate.write_text('\n'.join([lines[0], lines[1], lines[1]]))
  with pytest.raises(ValueError,
                     match=r'duplicate.jsonl: record 3 \(episode 1\): '
                     'episode 1 does not follow episode 1'):
    records_lib.load_episodes(str(duplicate))
  no_key = tmp_path / 'no_key.jsonl'
  no_key.write_text(json.dumps({'episode': 0, 'reward': 1.0}) + '\n')
  with pytest.raises(ValueError, match=r'no_key.jsonl: record 1 \(episode 0\): '
                     r"missing field\(s\) .*'tw50'"):
    records_lib.load_episodes(str(no_key))
  empty = tmp_path / 'empty.jsonl'
  empty.write_text('\n')
  with pytest.raises(ValueError, match='empty.jsonl: no episodes'):
    records_lib.load_episodes(str(empty))


_DEEP = '[' * 100_000 + ']' * 100_000  # RecursionError inside json.


@pytest.mark.parametrize('deep', [
    _DEEP, '[' * 33 + ']' * 33,
    '{"episode": 1, "x": ' + '{"a": ' * 40 + '1' + '}' * 40 + '}'])
def test_deeply_nested_json_is_refused_naming_file_and_line(tmp_path, deep):
  lines = [json.dumps(_episode(0)), deep, json.dumps(_episode(1))]
  path = tmp_path / 'deep.jsonl'
  path.write_text('\n'.join(lines) + '\n')
  with pytest.raises(ValueError, match=(
      r'deep\.jsonl: line 2 nests JSON arrays/objects more than 32 levels')):
    records_lib.load_episodes(str(path))
  eval_path = tmp_path / 'deep.json'
  eval_path.write_text(deep)
  with pytest.raises(ValueError, match=r'deep\.json nests JSON arrays'):
    records_lib.load_eval(str(eval_path))


def test_plot_deeply_nested_json_line_is_one_line(tmp_path, capsys):
  run_dir = tmp_path / 'run'
  path = _write_episodes(run_dir / 'episodes.jsonl', n=3)
  path.write_text(path.read_text() + _DEEP + '\n' + json.dumps(_episode(3)))
  out = tmp_path / 'plots'
  assert plot.main([f'--output_dir={out}', f'--run_dir={run_dir}']) == 1
  err = capsys.readouterr().err
  assert err == (f'ble-latex-plot: error: {path}: line 4 nests JSON '
                 'arrays/objects more than 32 levels deep; not a file this '
                 'package wrote\n'), err
  assert not out.exists()


def test_load_eval_bad_files(tmp_path):
  good = _write_json(tmp_path / 'good.json', _eval_records())
  assert [r['seed'] for r in records_lib.load_eval(str(good))] == [3, 5, 7]
  invalid = tmp_path / 'invalid.json'
  invalid.write_text(good.read_text()[:-40])
  with pytest.raises(ValueError, match='invalid.json: not a valid eval JSON'):
    records_lib.load_eval(str(invalid))
  with pytest.raises(ValueError, match='dict.json: expected a non-empty'):
    records_lib.load_eval(str(_write_json(tmp_path / 'dict.json', {'seed': 1})))
  bad_point = _eval_records()
  del bad_point[1]['flight_path'][4]['y_km']
  with pytest.raises(ValueError, match=r"bad_point.json: record 1 \(seed 5\): "
                     r"flight_path\[4\]: missing field\(s\) 'y_km'"):
    records_lib.load_eval(str(_write_json(tmp_path / 'bad_point.json', bad_point)))
  with pytest.raises(FileNotFoundError, match='nope.json'):
    records_lib.load_eval(str(tmp_path / 'nope.json'))


def _set(record: Dict[str, Any], key: str, value: Any) -> Dict[str, Any]:
  record[key] = value
  return record


def _drop(record: Dict[str, Any], key: str) -> Dict[str, Any]:
  del record[key]
  return record


def _set_point(record: Dict[str, Any], j: int, key: str,
               value: Any) -> Dict[str, Any]:
  record['flight_path'][j][key] = value
  return record


# (test id, change to the third record, what the error says after the file).
_BAD_EPISODES = [
    ('reward_null', lambda r: _set(r, 'reward', None),
     "record 3 (episode 2): field 'reward': expected a finite number, got "
     'null'),
    ('tw50_string', lambda r: _set(r, 'tw50', 'x'),
     "record 3 (episode 2): field 'tw50': expected a finite number in [0, 1], "
     'got "x"'),
    ('tw50_above_one', lambda r: _set(r, 'tw50', 1.5),
     "record 3 (episode 2): field 'tw50': expected a finite number in [0, 1], "
     'got 1.5'),
    ('reward_nan', lambda r: _set(r, 'reward', float('nan')),
     "record 3 (episode 2): field 'reward': expected a finite number, got NaN"),
    ('reward_inf', lambda r: _set(r, 'reward', float('-inf')),
     "record 3 (episode 2): field 'reward': expected a finite number, got "
     '-Infinity'),
    ('reward_huge_int', lambda r: _set(r, 'reward', 10**400),
     "record 3 (episode 2): field 'reward': expected a finite number"),
    ('reward_bool', lambda r: _set(r, 'reward', True),
     "record 3 (episode 2): field 'reward': expected a finite number, got "
     'true'),
    ('steps_float', lambda r: _set(r, 'steps', 2.5),
     "record 3 (episode 2): field 'steps': expected a non-negative integer, "
     'got 2.5'),
    ('seed_bool', lambda r: _set(r, 'seed', False),
     "record 3 (episode 2): field 'seed': expected an integer, got false"),
    ('episode_negative', lambda r: _set(r, 'episode', -1),
     "record 3: field 'episode': expected a non-negative integer, got -1"),
    ('episode_string', lambda r: _set(r, 'episode', '2'),
     "record 3: field 'episode': expected a non-negative integer, got \"2\""),
    ('unknown_reason', lambda r: _set(r, 'terminal_reason', 'abducted'),
     "record 3 (episode 2): field 'terminal_reason': expected one of "
     "'time_limit', "),
    ('missing_sand', lambda r: _drop(r, 'sand_dropped_kg'),
     "record 3 (episode 2): missing field(s) 'sand_dropped_kg'"),
    ('not_an_object', lambda r: [r['episode']],
     'record 3: expected a JSON object, got an array [2]'),
    ('null_line', lambda r: None,
     'record 3: expected a JSON object, got null'),
]


@pytest.mark.parametrize('change,message',
                         [c[1:] for c in _BAD_EPISODES],
                         ids=[c[0] for c in _BAD_EPISODES])
def test_load_episodes_names_file_record_and_field(tmp_path, change, message):
  records = [_episode(i) for i in range(5)]
  records[2] = change(records[2])
  path = tmp_path / 'bad.jsonl'
  # json.dumps writes NaN/Infinity tokens, as Python's json writers do.
  path.write_text('\n'.join(json.dumps(r) for r in records) + '\n')
  with pytest.raises(ValueError) as e:
    records_lib.load_episodes(str(path))
  assert str(e.value).startswith(f'{path}: {message}'), str(e.value)


_BAD_EVALS = [
    ('missing_flight_path', lambda r: _drop(r, 'flight_path'),
     "record 1 (seed 5): missing field(s) 'flight_path'"),
    ('empty_flight_path', lambda r: _set(r, 'flight_path', []),
     "record 1 (seed 5): field 'flight_path': expected a non-empty list of "
     'flight points, got []'),
    ('flight_path_object', lambda r: _set(r, 'flight_path', {'t_s': 0}),
     "record 1 (seed 5): field 'flight_path': expected a non-empty list"),
    ('point_altitude_null', lambda r: _set_point(r, 4, 'altitude_m', None),
     "record 1 (seed 5): flight_path[4]: field 'altitude_m': expected a finite "
     'number, got null'),
    ('point_x_nan', lambda r: _set_point(r, 0, 'x_km', float('nan')),
     "record 1 (seed 5): flight_path[0]: field 'x_km': expected a finite "
     'number, got NaN'),
    ('point_t_string', lambda r: _set_point(r, 9, 't_s', '1200'),
     "record 1 (seed 5): flight_path[9]: field 't_s': expected a finite "
     'number, got "1200"'),
    ('point_bad_decision', lambda r: _set_point(r, 2, 'decision', 'hover'),
     "record 1 (seed 5): flight_path[2]: field 'decision': expected one of "
     "'nothing', 'float', 'vent', 'ballast', got \"hover\""),
    ('point_not_object', lambda r: _set(r, 'flight_path', [None]),
     'record 1 (seed 5): flight_path[0]: expected a JSON object, got null'),
    ('reward_null', lambda r: _set(r, 'reward', None),
     "record 1 (seed 5): field 'reward': expected a finite number, got null"),
    ('helium_bool', lambda r: _set(r, 'helium_vented_mols', True),
     "record 1 (seed 5): field 'helium_vented_mols': expected a finite "
     'number, got true'),
    ('seed_string', lambda r: _set(r, 'seed', '5'),
     "record 1: field 'seed': expected an integer, got \"5\""),
    ('unknown_reason', lambda r: _set(r, 'terminal_reason', None),
     "record 1 (seed 5): field 'terminal_reason': expected one of "),
    ('duplicate_seed', lambda r: _set(r, 'seed', 3),
     'record 1 (seed 3): seed 3 already in record 0'),
    ('record_string', lambda r: 'seed 5',
     'record 1: expected a JSON object, got a string "seed 5"'),
]


@pytest.mark.parametrize('change,message',
                         [c[1:] for c in _BAD_EVALS],
                         ids=[c[0] for c in _BAD_EVALS])
def test_load_eval_names_file_record_and_field(tmp_path, change, message):
  records = _eval_records((3, 5, 7))
  records[1] = change(records[1])
  path = _write_json(tmp_path / 'bad.json', records)
  with pytest.raises(ValueError) as e:
    records_lib.load_eval(str(path))
  assert str(e.value).startswith(f'{path}: {message}'), str(e.value)


@pytest.mark.parametrize('top,message', [
    ({'seed': 1}, 'got an object {"seed": 1}'),
    ([], 'got an array []'),
    (None, 'got null'),
    ('records', 'got a string "records"'),
])
def test_load_eval_top_level_must_be_a_list(tmp_path, top, message):
  path = _write_json(tmp_path / 'top.json', top)
  with pytest.raises(ValueError) as e:
    records_lib.load_eval(str(path))
  assert str(e.value) == (f'{path}: expected a non-empty JSON list of per-seed '
                          f'records, {message}')


def test_loaders_name_file_on_bad_encoding(tmp_path):
  latin = tmp_path / 'latin.jsonl'
  latin.write_bytes(b'{"x": "\xe9"}\n')
  with pytest.raises(ValueError, match='latin.jsonl: not a UTF-8'):
    records_lib.load_episodes(str(latin))
  latin_eval = tmp_path / 'latin.json'
  latin_eval.write_bytes(b'[{"x": "\xe9"}]')
  with pytest.raises(ValueError, match='latin.json: not a valid eval JSON'):
    records_lib.load_eval(str(latin_eval))


def test_schemas_match_what_is_written():
  # pylint: disable-next=g-import-not-at-top
  from ble_latex.flight import state as state_lib
  from ble_latex.run import metrics
  from ble_latex.run import runner
  assert set(plots.TERMINAL_COLORS) == set(records_lib.TERMINAL_REASONS)
  assert set(records_lib.DECISIONS) == {
      d.name.lower() for d in state_lib.DecisionCode}
  fields = {f.name for f in dataclasses.fields(metrics.EpisodeSummary)}
  assert set(records_lib.EPISODE_SCHEMA) == fields
  assert set(records_lib.EVAL_SCHEMA) == (
      fields - {'episode', 'wall_time_s'}) | {'flight_path'}
  # The run shipped in benchmarks/ passes.
  shipped = (episode_log.RECORDS_DIR / 'sac_paper_run' /
             episode_log.EPISODE_LOG)
  assert len(records_lib.load_episodes(str(shipped))) == 2260
  # What the gym env's flight points and station hold is what is read back.
  import gym  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import task  # pylint: disable=g-import-not-at-top
  env = gym.make('LatexBalloon-v0').unwrapped
  env.reset(seed=1_000_000)
  point = runner.flight_point(env)
  assert set(point) == set(records_lib.FLIGHT_POINT_SCHEMA)
  records_lib.validate_record(point, records_lib.FLIGHT_POINT_SCHEMA, 'point')
  assert env.radius.kilometers == task.STATION_RADIUS_KM
  assert plots.STATION_RADIUS_KM == task.STATION_RADIUS_KM
  assert plots.ALTITUDE_BAND_KM == (14.0, 21.0)


# --- figures ---------------------------------------------------------------


def _visible_axes(fig):
  return [ax for ax in fig.axes if ax.get_visible() and ax.get_label() !=
          '<colorbar>']


def test_training_figures(tmp_path):
  episodes = [_episode(i) for i in range(120)]
  fig = plots.plot_training_curves(episodes, str(tmp_path / 'curves.png'),
                                   window=10)
  _assert_png(tmp_path / 'curves.png')
  reward_ax, tw50_ax = fig.axes
  assert reward_ax.get_ylabel() == 'episode reward'
  assert tw50_ax.get_ylabel() == 'TW50 [%]'
  assert tw50_ax.get_xlabel() == 'episode'
  # Reward: per episode and rolling mean; TW50: flown mean, per episode, mean.
  assert len(reward_ax.get_lines()) == 3 and len(tw50_ax.get_lines()) == 4
  per_episode = reward_ax.get_lines()[0]
  np.testing.assert_allclose(per_episode.get_xdata(), np.arange(120))
  np.testing.assert_allclose(per_episode.get_ydata(),
                             [e['reward'] for e in episodes])
  tw50 = [line for line in tw50_ax.get_lines()
          if line.get_label() == 'per episode'][0]
  np.testing.assert_allclose(tw50.get_ydata(),
                             [100 * e['tw50_window'] for e in episodes])
  paper = [line for line in tw50_ax.get_lines()
           if line.get_label().startswith('paper')][0]
  assert paper.get_ydata()[0] == pytest.approx(100 * plots.PAPER_TW50)
  no_paper = plots.plot_training_curves(
      episodes, str(tmp_path / 'c2.png'), paper_reference=False)
  assert len(no_paper.axes[0].get_lines()) == 2

  fig = plots.plot_terminal_conditions(episodes, str(tmp_path / 'term.png'))
  _assert_png(tmp_path / 'term.png')
  (ax,) = fig.axes
  assert ax.get_ylabel() == 'cumulative episodes'
  finals = {line.get_label().rsplit(' (', 1)[0].replace(' ', '_'):
            line.get_ydata()[-1] for line in ax.get_lines()}
  assert finals == {r: 30 * _REASONS.count(r) for r in _REASONS}
  with pytest.raises(ValueError, match='no episodes'):
    plots.plot_training_curves([], str(tmp_path / 'empty.png'))


def test_trajectory_figures(tmp_path):
  trained, untrained = _eval_records(drift_km=0.0), _eval_records()
  fig = plots.plot_trajectories(trained, str(tmp_path / 'traj.png'),
                                max_trajectories=2)
  _assert_png(tmp_path / 'traj.png')
  panels = _visible_axes(fig)
  assert len(panels) == 2  # --max_trajectories of 3 seeds.
  for ax, record in zip(panels, trained):
    assert ax.get_title().startswith(f'seed {record["seed"]}:')
    assert (ax.get_xlabel(), ax.get_ylabel()) == ('x [km]', 'y [km]')
    (circle,) = ax.patches
    assert circle.get_radius() == plots.STATION_RADIUS_KM
    (path,) = ax.collections  # The flight, coloured by time.
    assert len(path.get_segments()) == len(record['flight_path']) - 1
    start = [line for line in ax.get_lines() if line.get_label() == 'start']
    assert tuple(start[0].get_xydata()[0]) == pytest.approx(
        (record['flight_path'][0]['x_km'], record['flight_path'][0]['y_km']))
    low, high = ax.get_xlim()
    assert low <= -plots.STATION_RADIUS_KM and high >= plots.STATION_RADIUS_KM

  fig = plots.plot_trajectory_3d(trained[0], untrained[0],
                                 str(tmp_path / 'sub' / 'traj3d.png'),
                                 labels=('sac', 'random'))
  _assert_png(tmp_path / 'sub' / 'traj3d.png')
  (ax,) = fig.axes
  assert ax.get_zlabel() == 'altitude [km]'
  flights = {line.get_label().split(':')[0]: line for line in ax.get_lines()
             if line.get_label().startswith(('sac:', 'random:'))}
  assert set(flights) == {'sac', 'random'}
  x, _, z = flights['random'].get_data_3d()
  np.testing.assert_allclose(
      z, [p['altitude_m'] / 1000 for p in untrained[0]['flight_path']])
  np.testing.assert_allclose(
      x, [p['x_km'] for p in untrained[0]['flight_path']])
  low, high = ax.get_zlim()
  assert low <= plots.ALTITUDE_BAND_KM[0] and high >= plots.ALTITUDE_BAND_KM[1]
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
  fig = plots.plot_wind_fields([row, row], str(tmp_path / 'wind.png'))
  _assert_png(tmp_path / 'wind.png')
  panels = _visible_axes(fig)
  assert len(panels) == 4  # 2 rows x 2 pressure levels.
  assert panels[0].get_title().startswith('14000 Pa')
  assert panels[1].get_title().startswith('7000 Pa')
  for ax, level in zip(panels, (0, 1, 0, 1)):
    (arrows,) = [c for c in ax.collections if hasattr(c, 'U')]
    np.testing.assert_allclose(arrows.U, u[level].ravel())
    np.testing.assert_allclose(arrows.V, v[level].ravel())
    balloon = [line for line in ax.get_lines() if line.get_marker() == '*']
    assert tuple(balloon[0].get_xydata()[0]) == (-80.0, 20.0)
  with pytest.raises(ValueError, match='u_mps has shape'):
    plots.WindPanelRow(title='bad', x_km=axis, y_km=axis,
                       pressures_pa=np.array([1.0]),
                       altitudes_km=np.array([1.0]), u_mps=u, v_mps=v)
  with pytest.raises(ValueError, match='non-finite'):
    plots.WindPanelRow(title='nan', x_km=axis, y_km=axis,
                       pressures_pa=np.array([14000.0, 7000.0]),
                       altitudes_km=np.array([14.1, 18.5]),
                       u_mps=np.full_like(u, np.nan), v_mps=v)


def test_wind_stats_figure(tmp_path):
  pressures = np.array([5000.0, 7000.0, 10000.0])
  rng = np.random.default_rng(0)
  a = types.SimpleNamespace(label='a', pressures_pa=pressures,
                            u=rng.normal(size=(40, 3)),
                            v=rng.normal(size=(40, 3)))
  b = types.SimpleNamespace(label='b' * 60, pressures_pa=pressures,
                            u=a.u + 2.0, v=a.v)
  diversity = {'opposing_pair_fraction': 0.25, 'opposing_any_fraction': 0.5,
               'opposing_by_level': [0.1, 0.2, 0.3]}
  stats = {'per_level': [{'wasserstein_u_mps': 2.0, 'wasserstein_v_mps': 0.0}
                         ] * 3,
           'wasserstein_u_mps': 2.0, 'wasserstein_v_mps': 0.0,
           'direction_diversity': {'a': diversity, 'b': diversity}}
  fig = plots.plot_wind_stats(a, b, stats, str(tmp_path / 'stats.png'))
  _assert_png(tmp_path / 'stats.png')
  panels = _visible_axes(fig)
  assert [ax.get_title() for ax in panels] == [
      'u per level', 'v per level', 'distance between the sources',
      'direction diversity (> 90 deg)']
  assert [t.get_text() for t in panels[0].get_yticklabels()] == [
      '5000', '7000', '10000']
  np.testing.assert_allclose(panels[2].get_lines()[0].get_xdata(), [2.0] * 3)
  np.testing.assert_allclose(panels[3].get_lines()[0].get_xdata(),
                             [0.1, 0.2, 0.3])


def test_seed_curves_mean_and_band(tmp_path):
  runs = {}
  for seed in range(3):
    episodes = [dict(_episode(i), tw50_window=0.1 * seed, reward=float(seed))
                for i in range(60 + 10 * seed)]
    runs[f'seed_{seed}'] = episodes
    _write_episodes(tmp_path / f'seed_{seed}' / 'episodes.jsonl', 0)
    (tmp_path / f'seed_{seed}' / 'episodes.jsonl').write_text(
        ''.join(json.dumps(e) + '\n' for e in episodes))
  curves = plots.seed_curves(runs, 'tw50_window', window=10)
  assert curves.shape == (3, 60)  # The episodes all runs have.
  np.testing.assert_allclose(curves[:, -1], [0.0, 0.1, 0.2])
  with pytest.raises(ValueError, match='each with episodes'):
    plots.seed_curves({'a': []}, 'reward')
  out = tmp_path / 'out'
  code = plot.main(['--output_dir', str(out), '--rolling_window=10',
                    *[f'--seed_run_dirs={tmp_path / s}' for s in runs]])
  assert code == 0
  _assert_png(out / plot.SEED_CURVES)
  assert plot.main(['--output_dir', str(out),
                    f'--seed_run_dirs={tmp_path / "seed_0"}']) == 2


def _validation(iteration, tw50_window, n=32):
  return {'iteration': iteration, 'training_episodes': (iteration + 1) * n,
          'updates': 8 * iteration, 'elapsed_s': 10.0 * iteration,
          'seeds': [2000000, 2000099], 'episodes': 100,
          'tw50_window_mean': tw50_window, 'tw50_mean': tw50_window,
          'out_of_resources_pct': 0.0}


def test_seed_curves_draw_validated_snapshots(tmp_path, capsys):
  runs, validation = {}, {}
  for seed in range(2):
    runs[f'seed_{seed}'] = [dict(_episode(i), tw50_window=0.1, reward=1.0)
                            for i in range(40)]
    # seed_1 has one snapshot more: mean and band over the common ones.
    validation[f'seed_{seed}'] = [_validation(it, 0.2 + 0.1 * seed + 0.01 * k)
                                  for k, it in enumerate(range(4, 20 + 5 * seed,
                                                               5))]
  fig = plots.plot_seed_curves(runs, str(tmp_path / 'a.png'), window=10,
                               validation=validation)
  assert len(fig.axes) == 3
  val = fig.axes[2]
  assert 'validation TW50 window' in val.get_ylabel()
  assert '100 seeds' in val.get_ylabel()
  lines = {l.get_label(): l for l in val.get_lines()}
  np.testing.assert_allclose(lines['seed_1'].get_xdata(), [160, 320, 480, 640,
                                                           800])
  np.testing.assert_allclose(lines['seed_1'].get_ydata(),
                             [30.0, 31.0, 32.0, 33.0, 34.0])
  mean = lines['mean of 2 runs']
  np.testing.assert_allclose(mean.get_xdata(), [160, 320, 480, 640])
  np.testing.assert_allclose(mean.get_ydata(), [25.0, 26.0, 27.0, 28.0])
  with pytest.raises(ValueError, match='each run'):
    plots.plot_seed_curves(runs, str(tmp_path / 'b.png'),
                           validation={'seed_0': validation['seed_0']})
  # The command draws them when every run has validation.jsonl, and names a
  # bad one.
  for name in runs:
    run = tmp_path / name
    run.mkdir()
    (run / 'episodes.jsonl').write_text(
        ''.join(json.dumps(e) + '\n' for e in runs[name]))
    (run / 'validation.jsonl').write_text(
        ''.join(json.dumps(r) + '\n' for r in validation[name]))
  out = tmp_path / 'out'
  args = ['--output_dir', str(out), '--rolling_window=10',
          *[f'--seed_run_dirs={tmp_path / s}' for s in runs]]
  assert plot.main(args) == 0
  _assert_png(out / plot.SEED_CURVES)
  bad = dict(validation['seed_1'][0], tw50_window_mean=1.5)
  (tmp_path / 'seed_1' / 'validation.jsonl').write_text(
      json.dumps(bad) + '\n' + json.dumps(validation['seed_1'][1]) + '\n')
  assert plot.main(args) == 1
  assert ("seed_1/validation.jsonl: record 1 (iteration 4): field "
          "'tw50_window_mean'") in capsys.readouterr().err


def test_load_validation_bad_files(tmp_path):
  with pytest.raises(FileNotFoundError, match='validation log not found'):
    records_lib.load_validation(str(tmp_path / 'missing.jsonl'))
  empty = tmp_path / 'empty.jsonl'
  empty.write_text('')
  with pytest.raises(ValueError, match='no validated snapshots'):
    records_lib.load_validation(str(empty))
  twice = tmp_path / 'twice.jsonl'
  twice.write_text(json.dumps(_validation(4, 0.1)) + '\n' +
                   json.dumps(_validation(4, 0.2)) + '\n')
  with pytest.raises(ValueError, match='record 2 .iteration 4.: iteration 4 '
                     'does not follow'):
    records_lib.load_validation(str(twice))
  missing = tmp_path / 'missing_field.jsonl'
  record = _validation(4, 0.1)
  del record['updates']
  missing.write_text(json.dumps(record) + '\n')
  with pytest.raises(ValueError, match="missing field.*'updates'"):
    records_lib.load_validation(str(missing))
  corrupt = tmp_path / 'corrupt.jsonl'
  corrupt.write_text('{"iteration": 4\n' + json.dumps(_validation(9, 0.1)) +
                     '\n')
  with pytest.raises(ValueError, match='corrupt.jsonl'):
    records_lib.load_validation(str(corrupt))
