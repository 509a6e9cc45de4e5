"""benchmarks/reward_shape.py's command line (the study itself is not run
here), its library (`run.seed_runs`' rewards and summary, `run.real_cells`)
and the edge fractions it reads (`ble_latex.run.metrics`)."""

import json

import pytest

from ble_latex.run import episode_log
from ble_latex.run import metrics
from ble_latex.run import real_cells
from ble_latex.run import seed_runs
from ble_latex.run import wind_file

from tests import helpers

ROOT = helpers.ROOT


@pytest.fixture
def script(benchmark_script):
  return benchmark_script('reward_shape.py')


def _record(distances_km, window):
  path = [{'x_km': 0.0, 'y_km': 0.0}]  # The start point does not count.
  path += [{'x_km': d * 0.6, 'y_km': d * 0.8} for d in distances_km]
  return {'flight_path': path, 'window_steps': window}


def test_edge_fractions_count_strides_of_the_window():
  record = _record([10.0, 39.9, 40.0, 40.1, 45.0, 50.0, 50.1, 80.0], 10)
  fractions = metrics.edge_fractions(record)
  assert fractions['core'] == pytest.approx(3 / 10)  # 10, 39.9, 40.
  assert fractions['edge'] == pytest.approx(3 / 10)  # 40.1, 45, 50.
  assert fractions['edge_share'] == pytest.approx(0.5)
  never = metrics.edge_fractions(_record([60.0, 70.0], 216))
  assert never['edge'] == never['core'] == 0.0


def test_rewards_and_their_bindings():
  assert seed_runs.reward_bindings('perciatelli', 25.0) == []
  assert seed_runs.reward_bindings('tanh', 25.0) == [
      'latex_reward.reward_tanh_scale_km = 25.0']
  with pytest.raises(ValueError, match="'flat' is not one of perciatelli"):
    seed_runs.reward_bindings('flat', 25.0)


@pytest.mark.parametrize('args, message', [
    (['--rewards=flat'], "--rewards: 'flat' is not one of perciatelli, tanh"),
    (['--rounds=2'], '--snapshot_period=5 > --rounds=2'),
    (['--tanh_scale_km=-1'], '--tanh_scale_km must be a finite number > 0'),
])
def test_bad_flags_are_one_line(script, tmp_path, capsys, args, message):
  rc = script.main([f'--base_dir={tmp_path}',
                    f'--output={tmp_path / "r.json"}', *args])
  err = capsys.readouterr().err.strip().splitlines()
  assert rc == 2 and len(err) == 1 and message in err[0], err
  assert not (tmp_path / 'r.json').exists()


def test_a_resume_with_other_settings_is_refused(script, tmp_path, capsys):
  output = tmp_path / 'r.json'
  output.write_text(json.dumps({'settings': {'rounds': 60}, 'rewards': {}}))
  rc = script.main([f'--base_dir={tmp_path}', f'--output={output}',
                    '--rounds=61'])
  err = capsys.readouterr().err.strip().splitlines()
  assert rc == 1 and len(err) == 1, err
  assert 'made with other settings (' in err[0] and 'rounds: 60 -> 61' in err[0]


def test_real_sources_fly_where_the_real_winds_table_flies():
  """Each source's station settings are its cells' in the committed
  real-winds record (a sounding at its site, a grid's per-seed stations)."""
  import json  # pylint: disable=g-import-not-at-top
  record = json.loads(
      (episode_log.RECORDS_DIR / 'real_winds.json').read_text())
  keys = ('station_mode', 'station_lat_lon', 'station_bindings')
  for name in ('hilo', 'boise', 'gfs_namerica', 'gfs_global'):
    cell = real_cells.source_cell(name, 'latex_small', '/not/read')
    assert cell['suite'] == 'latex_small'
    table = record['cells'][f'{name}/sac_pretrained/{cell["station_mode"]}']
    recorded = wind_file.canonical(table['settings'])
    assert {k: cell.get(k) for k in keys} == {
        k: recorded.get(k) for k in keys}, name


def test_a_done_cell_flies_only_the_real_sources_it_lacks():
  names = ['hilo', 'boise']
  row = {'real_winds': {'hilo': {'episodes': 100, 'suite': 'latex_small'},
                        'boise': {'episodes': 20, 'suite': 'latex_small'}}}
  assert real_cells.missing_sources(row, names, 100, 'latex_small') == [
      'boise']
  assert real_cells.missing_sources(row, names, 100, 'latex_tiny') == names
  assert real_cells.missing_sources({}, names, 100, 'latex_small') == names


def test_the_summary_spreads_each_real_source_over_seeds():
  rows = {str(s): {'held_out_tw50_window': 0.5, 'edge_fraction': 0.1,
                   'core_fraction': 0.4,
                   'real_winds': {'hilo': {'tw50_window': t,
                                           'edge_fraction': 0.2,
                                           'core_fraction': 0.3}}}
          for s, t in ((0, 0.6), (1, 0.8))}
  summary = seed_runs.reward_summary(rows)
  assert summary['seeds_done'] == 2
  assert summary['real_hilo_seeds_done'] == 2
  assert summary['real_hilo_tw50_window_mean'] == pytest.approx(0.7)
  assert summary['real_hilo_tw50_window_std'] == pytest.approx(0.1414, 1e-3)


@pytest.mark.parametrize('args, message', [
    (['--real_sources=mars'], "--real_sources: unknown ['mars']"),
    (['--real_sources=hilo', '--realdata_dir=/nonexistent'],
     '/nonexistent/soundings/PHTO-Hilo_2023-11-01T00Z_uwyo.csv: no such file'),
])
def test_bad_real_sources_are_one_line(script, tmp_path, capsys, args,
                                       message):
  rc = script.main([f'--base_dir={tmp_path}',
                    f'--output={tmp_path / "r.json"}', *args])
  err = capsys.readouterr().err.strip().splitlines()
  assert rc == 2 and len(err) == 1 and message in err[0], err


def test_a_second_study_on_one_record_is_refused(script, tmp_path, capsys):
  from ble_latex import safe_io  # pylint: disable=g-import-not-at-top
  output = tmp_path / 'r.json'
  output.write_text(json.dumps({'settings': {}, 'rewards': {}}))
  with safe_io.locked_file(str(output), what='reward_shape record'):
    rc = script.main([f'--base_dir={tmp_path}', f'--output={output}'])
  err = capsys.readouterr().err.strip().splitlines()
  assert rc == 1 and len(err) == 1 and 'in use' in err[0], err
  assert json.loads(output.read_text()) == {'settings': {}, 'rewards': {}}


@pytest.mark.slow
def test_a_policy_flies_a_real_source_as_the_real_winds_table_does(
    tmp_path):
  """`real_cells.fly_policy` with the shipped policy = `fly_cell`'s
  `sac_pretrained` (real_winds.py's)."""
  import shutil  # pylint: disable=g-import-not-at-top
  from ble_latex.agents.sac import pretrained  # pylint: disable=g-import-not-at-top
  from ble_latex.run import suites  # pylint: disable=g-import-not-at-top
  folder = tmp_path / 'soundings'
  folder.mkdir()
  path = str(folder / 'PHTO-Hilo_2023-11-01T00Z_uwyo.csv')
  shutil.copy(helpers.REAL_WINDS /
              'PHTO-Hilo_2023-11-01T00Z_uwyo.csv', path)
  cell = real_cells.source_cell('hilo', 'latex_small', path)
  flown = real_cells.fly_policy(
      pretrained.shipped_policy(False), cell, path, 2, max_steps=12)
  seeds = list(suites.get_eval_suite('latex_small').seeds)[:2]
  records, _, _, _ = real_cells.fly_cell(
      {**cell, 'agent': 'sac_pretrained', 'max_steps': 12}, path, seeds)
  assert flown['episodes'] == len(records) == 2
  assert flown['tw50_window'] == pytest.approx(
      sum(r['tw50_window'] for r in records) / 2)
  assert 'time-invariant' in flown['wind_source']


def test_edge_summary_averages_flights_and_skips_never_inside():
  summary = metrics.edge_summary([_record([45.0, 10.0], 2),
                                  _record([60.0, 70.0], 2)])
  assert summary['edge_fraction'] == pytest.approx(0.25)
  assert summary['core_fraction'] == pytest.approx(0.25)
  assert summary['edge_share_of_inside'] == pytest.approx(0.5)  # First only.


# -- Items 6, 11, 12: benchmarks/reward_shape.py. ---------------------------
@pytest.mark.parametrize('argv, needle', [
    (['--tanh_scale_km=1e-40'], '--tanh_scale_km'),
    (['--seeds=99999999999999999999'], '[0, 4294967295]'),
    (['--seeds=0,-1'], '[0, 4294967295]'),
])
def test_reward_shape_refuses_flags_up_front(argv, needle, tmp_path, capsys,
                                             benchmark_script):
  script = benchmark_script('reward_shape.py')
  out = tmp_path / 'r.json'
  assert script.main([f'--base_dir={tmp_path / "b"}', f'--output={out}',
                      *argv]) == 2
  assert needle in helpers.one_line(capsys, 'benchmarks/reward_shape.py')
  assert not (tmp_path / 'b').exists() and not out.exists()


@pytest.mark.parametrize('text, needle', [
    ('{"settings": {}, "rew', 'truncated'),
    ('{"settings": {}, "rewards": {"perciatelli": []}}', 'rewards.perciatelli'),
    ('{"settings": {}, "rewards": {"tanh": {"seeds": [1]}}}', 'rewards.tanh'),
])
def test_reward_shape_bad_record_is_one_line(text, needle, tmp_path, capsys,
                                             benchmark_script):
  script = benchmark_script('reward_shape.py')
  out = tmp_path / 'r.json'
  out.write_text(text)
  assert script.main([f'--base_dir={tmp_path / "b"}', f'--output={out}',
                      '--seeds=0']) == 1
  assert needle in helpers.one_line(capsys, 'benchmarks/reward_shape.py')
  assert out.read_text() == text


def test_reward_shape_edges_of_a_bad_eval_file_is_one_line(
    tmp_path, capsys, benchmark_script):
  script = benchmark_script('reward_shape.py')
  for i, content in enumerate(([{'seed': 0}], {'a': 1}, '[{"seed"')):
    path = tmp_path / f'e{i}.json'
    path.write_text(content if isinstance(content, str) else
                    json.dumps(content))
    assert script.main([f'--edges_of={path}']) == 1
    assert str(path) in helpers.one_line(capsys, 'benchmarks/reward_shape.py')
