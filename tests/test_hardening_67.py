"""Issue 67 (hardening, fourth round): each refusal is one line before any
work; each test fails without its fix."""

import json
import os

import gin
import pytest

from ble_latex import errors
from ble_latex import gin_values
from ble_latex.run import real_cells
from tests import helpers


def _one_line(capsys, prog):
  err = capsys.readouterr().err.strip().splitlines()
  assert len(err) == 1, err
  assert err[0].startswith(f'{prog}: '), err
  return err[0]


# -- Item 6: "> 0" holds in float32 (XLA flushes subnormals to 0). ---------
@pytest.mark.parametrize('value', [1e-40, 1e-46, 1e-39])
def test_a_positive_number_that_is_0_in_float32_is_refused(value):
  assert not gin_values.is_positive(value)
  with pytest.raises(errors.ConfigError, match='float32'):
    gin_values.check_number('gin binding x.y', value, above=0.0)
  with pytest.raises(errors.ConfigError, match='float32'):
    gin_values.check_number('gin binding x.y', -value, below=0.0)
  assert gin_values.check_number('x', 1.2e-38, above=0.0) == 1.2e-38


@pytest.mark.parametrize('binding', [
    'latex_reward.reward_tanh_scale_km = 1e-40',
    'latex_reward.reward_halflife_km = 1e-45',
    'latex_episode.station_keeping_radius_km = 1e-40',
])
def test_reward_bindings_that_are_0_in_float32_are_refused(binding):
  from ble_latex.envs import env_params  # pylint: disable=g-import-not-at-top
  gin.clear_config()
  try:
    gin.parse_config(binding)
    with pytest.raises(ValueError, match=binding.split(' ')[0]):
      env_params.params_from_gin()
  finally:
    gin.clear_config()


def test_tanh_scale_0_still_switches_the_reward_off():
  gin_values.check_reward_values({'reward_tanh_scale_km': 0.0})


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
  assert needle in _one_line(capsys, 'benchmarks/reward_shape.py')
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
  assert needle in _one_line(capsys, 'benchmarks/reward_shape.py')
  assert out.read_text() == text


def test_reward_shape_edges_of_a_bad_eval_file_is_one_line(
    tmp_path, capsys, benchmark_script):
  script = benchmark_script('reward_shape.py')
  for i, content in enumerate(([{'seed': 0}], {'a': 1}, '[{"seed"')):
    path = tmp_path / f'e{i}.json'
    path.write_text(content if isinstance(content, str) else
                    json.dumps(content))
    assert script.main([f'--edges_of={path}']) == 1
    assert str(path) in _one_line(capsys, 'benchmarks/reward_shape.py')


# -- Items 9, 14 and the lock: ble-latex-launch. ----------------------------
@pytest.mark.parametrize('argv, needle', [
    (['--grid=100000,100000,100'], 'balloons, more than'),
    (['--grid=2000,2000,1', '--draws=2'], 'balloons, more than'),
])
def test_launch_grid_too_big_is_refused_before_allocation(argv, needle,
                                                           tmp_path, capsys):
  from ble_latex.cli import launch  # pylint: disable=g-import-not-at-top
  assert launch.main([f'--output_dir={tmp_path / "o"}', *argv]) == 2
  assert needle in _one_line(capsys, 'ble-latex-launch')


def test_launch_library_grid_is_bounded_before_meshgrid():
  from ble_latex.launch import scoring  # pylint: disable=g-import-not-at-top
  space = scoring.SearchSpace(east_km=(-1.0, 1.0), north_km=(-1.0, 1.0),
                              hours=(0.0, 1.0))
  with pytest.raises(errors.ConfigError, match='balloons, more than'):
    scoring.grid(space, 100000, 100000, 100)
  with pytest.raises(errors.ConfigError, match='balloons, more than'):
    scoring.uniform(space, 10**8, None)


def test_launch_date_at_the_end_of_time_is_one_line(tmp_path, capsys):
  from tests.wind import test_gridded  # pylint: disable=g-import-not-at-top
  from ble_latex.cli import launch  # pylint: disable=g-import-not-at-top
  path = test_gridded.write_era5(tmp_path / 'era5.nc')
  assert launch.main([f'--output_dir={tmp_path / "o"}', f'--wind_file={path}',
                      '--date=9999-12-31T23:59', '--grid=1,1,1',
                      '--max_steps=1', '--draws=1']) == 2
  assert 'year 9999' in _one_line(capsys, 'ble-latex-launch')


def test_launch_has_one_writer_per_output_dir(tmp_path, capsys):
  from ble_latex import safe_io  # pylint: disable=g-import-not-at-top
  from ble_latex.cli import launch  # pylint: disable=g-import-not-at-top
  out = tmp_path / 'o'
  with safe_io.locked_dir(str(out), what='launch output folder'):
    assert launch.main([f'--output_dir={out}', '--grid=1,1,1',
                        '--max_steps=1', '--draws=1']) == 1
  assert 'in use by' in _one_line(capsys, 'ble-latex-launch')
  assert not (out / 'launches.json').exists()


# -- Items 13, 14: benchmarks/launch_search.py. -----------------------------
@pytest.mark.parametrize('argv, needle', [
    (['--seeds=abc'], '--seeds'),
    (['--seeds=-1'], '--seeds'),
    (['--budgets=0'], '--budgets'),
    (['--budgets=x'], '--budgets'),
    (['--grid=100000,100000,100'], 'balloons, more than'),
    (['--grid=3,3'], '--grid'),
    (['--draws=0'], '--draws'),
])
def test_launch_search_flags_are_checked_up_front(argv, needle, tmp_path,
                                                  capsys, benchmark_script):
  script = benchmark_script('launch_search.py')
  out = tmp_path / 'ls.json'
  assert script.main([f'--output={out}', *argv]) == 2
  assert needle in _one_line(capsys, 'launch_search')
  assert not out.exists()


@pytest.mark.parametrize('text', ['{"settings": {"gri', '[1, 2]',
                                  '{"settings": {}, "cases": []}'])
def test_launch_search_bad_record_is_one_line(text, tmp_path, capsys,
                                              benchmark_script):
  script = benchmark_script('launch_search.py')
  out = tmp_path / 'ls.json'
  out.write_text(text)
  assert script.main([f'--output={out}', '--seeds=0']) == 1
  assert str(out) in _one_line(capsys, 'launch_search')
  assert out.read_text() == text


def test_launch_search_output_folder_checked_first(tmp_path, capsys,
                                                   benchmark_script):
  script = benchmark_script('launch_search.py')
  blocker = tmp_path / 'file'
  blocker.write_text('x')
  assert script.main([f'--output={blocker / "ls.json"}', '--seeds=0']) == 1
  assert '--output' in _one_line(capsys, 'launch_search')


# -- Item 15: policy and checkpoint files are size-bounded before reading. ---
def test_a_huge_policy_is_refused_before_it_is_read(tmp_path):
  from ble_latex.agents.sac import pretrained  # pylint: disable=g-import-not-at-top
  path = tmp_path / 'huge.msgpack'
  with open(path, 'wb') as f:
    f.truncate(2**30)  # Sparse: 1 GiB on no disk.
  with pytest.raises(errors.BadFileError, match='more than the most a SAC'):
    pretrained.load_policy(str(path))


def test_a_huge_checkpoint_is_refused_before_it_is_read(tmp_path, capsys):
  from ble_latex.cli import export_policy  # pylint: disable=g-import-not-at-top
  path = tmp_path / 'checkpoint_00001.msgpack'
  with open(path, 'wb') as f:
    f.truncate(2**43)  # Sparse: 8 TiB, more than any memory here.
  out = tmp_path / 'p.msgpack'
  assert export_policy.main([f'--checkpoint={path}', f'--output={out}']) == 1
  assert 'memory available' in _one_line(capsys, 'ble-latex-export-policy')
  assert not out.exists()


def test_a_fifo_is_not_read_as_a_policy(tmp_path):
  from ble_latex import safe_io  # pylint: disable=g-import-not-at-top
  path = tmp_path / 'fifo.msgpack'
  import os  # pylint: disable=g-import-not-at-top
  os.mkfifo(path)
  with pytest.raises(errors.BadFileError, match='not a regular file'):
    safe_io.read_tree(str(path), file_format='x', what='SAC policy')


def test_the_wind_memory_guard_uses_available_memory(monkeypatch):
  from ble_latex import safe_io  # pylint: disable=g-import-not-at-top
  from ble_latex.wind import gridded_checks  # pylint: disable=g-import-not-at-top
  monkeypatch.setattr(safe_io, 'available_memory_bytes', lambda: 10**6)
  assert gridded_checks.memory_bytes() == 10**6
  with pytest.raises(errors.BadFileError, match='available now'):
    gridded_checks.check_size('f.nc', (10, 10, 10, 1000))


# -- Item 16: the Gymnasium vector env's num_envs is capped. ----------------
@pytest.mark.parametrize('kwargs', [{}, {'asynchronous': True}])
@pytest.mark.parametrize('num_envs', [10**9, 65_537])
def test_make_vec_caps_num_envs_before_allocating(kwargs, num_envs):
  import gymnasium  # pylint: disable=g-import-not-at-top
  import ble_latex  # pylint: disable=g-import-not-at-top,unused-import
  with pytest.raises(ValueError, match=r'num_envs must be an int in \[1, '
                     r'65536\]'):
    gymnasium.make_vec('ble_latex/LatexBalloon-v0', num_envs=num_envs,
                       **kwargs)


# -- Items 18, 23: benchmarks/policy_select.py sizes before compiling. ------
@pytest.mark.parametrize('argv, needle', [
    (['--samples=1000000000'], '--samples must be in [0, '),
    (['--samples=-1'], '--samples must be in [0, '),
    (['--batch=0'], '--batch must be in [1, 65536]'),
    (['--batch=100000'], '--batch must be in [1, 65536]'),
    (['--num_seeds=0'], '--num_seeds'),
])
def test_policy_select_sizes_are_checked_before_compiling(
    argv, needle, tmp_path, capsys, benchmark_script):
  script = benchmark_script('policy_select.py')
  out = tmp_path / 'r.json'
  assert script.main(['policy_select.py', '--policy=shipped',
                      '--mode=critic', *argv, f'--output={out}']) == 2
  assert needle in _one_line(capsys, 'policy_select')
  assert not out.exists()


def test_policy_select_output_folder_checked_first(tmp_path, capsys,
                                                   benchmark_script):
  script = benchmark_script('policy_select.py')
  out = tmp_path / 'missing' / 'r.json'
  assert script.main(['policy_select.py', '--policy=shipped',
                      f'--output={out}']) == 1
  assert '--output' in _one_line(capsys, 'policy_select')


# -- Item 17: wind statistics' sample counts are bounded. -------------------
@pytest.mark.parametrize('flag', ['--wind_stats_samples=2000000000',
                                  '--wind_stats_fields=100000',
                                  ])
def test_wind_stats_sample_counts_are_bounded(flag, tmp_path, capsys):
  from tests.wind import test_gridded  # pylint: disable=g-import-not-at-top
  from ble_latex.cli import plot  # pylint: disable=g-import-not-at-top
  era5_file = test_gridded.write_era5(tmp_path / 'era5.nc')
  out = tmp_path / 'plots'
  assert plot.main([f'--output_dir={out}', '--wind_stats',
                    f'--era5_path={era5_file}', '--wind_stats_points=1000',
                    flag]) == 2
  assert flag.split('=')[0] in _one_line(capsys, 'ble-latex-plot')


# -- Item 22: ble-latex-download-era5's grid spacing is bounded. ------------
@pytest.mark.parametrize('grid', ['1e-30', '0.001', '50'])
def test_download_era5_grid_deg_out_of_range_is_refused(grid, capsys):
  from ble_latex.cli import download_era5  # pylint: disable=g-import-not-at-top
  assert download_era5.main(['--dry_run', f'--grid_deg={grid}']) == 2
  assert 'grid_deg must be in [0.05, ' in capsys.readouterr().err


def test_download_era5_paper_grid_is_accepted(capsys):
  from ble_latex.cli import download_era5  # pylint: disable=g-import-not-at-top
  assert download_era5.main(['--dry_run', '--grid_deg=0.25']) == 0


# -- Items 19, 20: a BOM in a sounding; what a missing wind file is. ---------
_DATA = str(helpers.REAL_WINDS)


def test_a_sounding_csv_with_a_byte_order_mark_reads(tmp_path):
  from ble_latex.wind import sounding  # pylint: disable=g-import-not-at-top
  hilo = os.path.join(_DATA, 'PHTO-Hilo_2023-11-01T00Z_uwyo.csv')
  with open(hilo, 'rb') as f:
    raw = f.read()
  path = tmp_path / 'bom.csv'
  path.write_bytes(b'\xef\xbb\xbf' + raw)
  plain, bom = sounding.read(hilo), sounding.read(str(path))
  assert len(bom.pressure_pa) == len(plain.pressure_pa) > 10


@pytest.mark.parametrize('name, needle', [
    ('gfs.grib2', 'ble-latex-download-gfs'),
    ('PHTO_uwyo.csv', 'University of Wyoming sounding'),
    ('station.txt', 'University of Wyoming sounding'),
])
def test_a_missing_wind_file_hint_names_its_kind(name, needle, tmp_path):
  from ble_latex.wind import gridded  # pylint: disable=g-import-not-at-top
  with pytest.raises(FileNotFoundError) as info:
    gridded.load(str(tmp_path / name))
  assert needle in str(info.value)
  assert 'download-era5' not in str(info.value)


def test_a_fifo_or_symlink_loop_is_not_called_missing(tmp_path):
  from ble_latex.wind import gridded  # pylint: disable=g-import-not-at-top
  from ble_latex.wind import sounding  # pylint: disable=g-import-not-at-top
  fifo = tmp_path / 'winds.nc'
  os.mkfifo(fifo)
  loop = tmp_path / 'loop.nc'
  os.symlink(loop, loop)
  for path, needle in ((fifo, 'is a FIFO'), (loop, 'symbolic link')):
    with pytest.raises(errors.BadFileError, match=needle):
      gridded.load(str(path))
  with pytest.raises(errors.BadFileError, match='is a FIFO'):
    sounding.read(str(fifo))


def test_wind_file_fifo_is_one_line_exit_1(tmp_path, capsys):
  from ble_latex.cli import plot  # pylint: disable=g-import-not-at-top
  fifo = tmp_path / 'winds.nc'
  os.mkfifo(fifo)
  assert plot.main([f'--output_dir={tmp_path / "p"}', '--wind_stats',
                    f'--wind_file={fifo}']) == 1
  assert 'is a FIFO' in _one_line(capsys, 'ble-latex-plot')


# -- Item 21: output names stay inside the output folder. -------------------
@pytest.mark.parametrize('name', ['../../x', '/tmp/abs', '..', 'a/b', ''])
def test_eval_name_override_stays_inside_output_dir(name, tmp_path, capsys):
  from ble_latex.cli import eval as eval_cli  # pylint: disable=g-import-not-at-top
  out = tmp_path / 'a' / 'b' / 'out'
  rc = eval_cli.main([f'--output_dir={out}', f'--name_override={name}',
                      '--agent=latex_station_seeker', '--suite=latex_micro'])
  if name == '':  # absl: an empty override is no override; nothing checked.
    capsys.readouterr()
    return
  assert rc == 2
  assert '--name_override must be a plain file name' in _one_line(
      capsys, 'ble-latex-eval')
  assert not list(tmp_path.rglob('*.json'))


@pytest.mark.parametrize('name', ['../../x', '/tmp/abs'])
def test_planners_name_override_stays_inside_output_dir(
    name, tmp_path, capsys, benchmark_script):
  script = benchmark_script('planners.py')
  out = tmp_path / 'a' / 'out'
  assert script.main([f'--output_dir={out}', f'--name_override={name}',
                      '--suite=latex_small', '--seeds=0']) == 2
  assert '--name_override must be a plain file name' in _one_line(
      capsys, 'benchmarks/planners.py')
  assert not list(tmp_path.rglob('*.json'))


# -- Items 1, 8, 10: benchmarks/real_winds.py's record. ---------------------
_KEY = 'hilo/latex_station_seeker/center'


def _flights(seeds, tw50=0.5):
  return [{'seed': s, 'tw50': tw50, 'tw50_window': tw50, 'window_steps': 3,
           'reward': 1.0, 'steps': 3, 'helium_vented_mols': 0.0,
           'sand_dropped_kg': 0.0, 'terminal_reason': 'time_limit',
           'final_distance_km': 1.0} for s in seeds]


@pytest.fixture(name='real_winds_run')
def _real_winds_run(benchmark_script, tmp_path, monkeypatch):
  import shutil  # pylint: disable=g-import-not-at-top
  from ble_latex.run import suites  # pylint: disable=g-import-not-at-top
  real_winds = benchmark_script('real_winds.py')
  realdata = tmp_path / 'realdata'
  (realdata / 'soundings').mkdir(parents=True)
  shutil.copy(os.path.join(_DATA, 'PHTO-Hilo_2023-11-01T00Z_uwyo.csv'),
              realdata / 'soundings')
  record = tmp_path / 'r.json'
  argv = [f'--json={record}', f'--realdata_dir={realdata}', '--sources=hilo',
          '--agents=latex_station_seeker']
  seeds = list(suites.get_eval_suite('latex_small').seeds)
  during = []

  def fly_cell(cell, path, chunk):
    del cell, path
    for action in during:
      action()
    return _flights(chunk), 'sounding (time-invariant)', True, 0.1

  monkeypatch.setattr(real_cells, 'fly_cell', fly_cell)
  return real_winds, record, argv, seeds, during


def test_two_writers_of_one_cell_keep_both_runs_seeds(real_winds_run):
  real_winds, record, argv, seeds, during = real_winds_run
  assert real_winds.main(argv + ['--seeds=2']) == 0

  def other_writer():  # A run with --seeds=5 writes seeds 2..4 meanwhile.
    data = json.loads(record.read_text())
    cell = data['cells'][_KEY]
    cell['flights'] += _flights(seeds[2:5], tw50=0.25)
    cell['runs'].append({'by': 'the other run'})
    record.write_text(json.dumps(data))
    during.clear()

  during.append(other_writer)
  assert real_winds.main(argv + ['--seeds=3']) == 0
  cell = json.loads(record.read_text())['cells'][_KEY]
  assert [f['seed'] for f in cell['flights']] == sorted(seeds[:5])
  assert {'by': 'the other run'} in cell['runs'] and len(cell['runs']) == 3
  assert cell['summary']['episodes'] == 5


@pytest.mark.parametrize('change, needle', [
    (lambda f: f.update(seed=123456789), 'is not a seed of suite'),
    (lambda f: f.update(tw50_window=7.5), 'tw50_window 7.5'),
    (lambda f: f.update(steps=-1), 'steps -1'),
    (lambda f: f.pop('tw50'), 'lacks fields'),
])
def test_resume_checks_the_records_flights(change, needle, real_winds_run,
                                           capsys):
  real_winds, record, argv, _, _ = real_winds_run
  assert real_winds.main(argv + ['--seeds=2']) == 0
  data = json.loads(record.read_text())
  change(data['cells'][_KEY]['flights'][0])
  record.write_text(json.dumps(data))
  capsys.readouterr()
  assert real_winds.main(argv + ['--seeds=3']) == 1
  assert needle in _one_line(capsys, 'real_winds.py')


@pytest.mark.parametrize('text, needle', [
    ('{"cells": {"hilo', 'truncated'),
    (json.dumps({'cells': {_KEY: {'flights': []}}}), 'needs settings'),
    (json.dumps({'cells': {_KEY: {'settings': {}, 'flights': 3, 'runs': []}}}),
     'needs settings'),
    (json.dumps({'cells': {_KEY: {'settings': {}, 'flights': [1],
                                  'runs': []}}}), 'lacks fields'),
])
def test_a_malformed_real_winds_record_is_one_line(text, needle,
                                                   real_winds_run, capsys):
  real_winds, record, argv, _, _ = real_winds_run
  record.write_text(text)
  assert real_winds.main(argv + ['--seeds=2']) == 1
  assert needle in _one_line(capsys, 'real_winds.py')
  assert record.read_text() == text


def test_real_winds_output_folder_checked_first(real_winds_run, tmp_path,
                                                capsys):
  real_winds, _, argv, _, _ = real_winds_run
  blocker = tmp_path / 'file'
  blocker.write_text('x')
  assert real_winds.main(argv[1:] + [f'--json={blocker / "r.json"}']) == 1
  assert '--json' in _one_line(capsys, 'real_winds.py')


# -- Item 7: a GRIB2 file with two messages of one field is refused. --------
def test_grib2_with_a_duplicated_message_is_refused(tmp_path):
  from ble_latex.wind import gridded  # pylint: disable=g-import-not-at-top
  grib = os.path.join(_DATA, 'gfs_2011-10-11T00Z_uv_10-250hPa_2p5deg.grib2')
  with open(grib, 'rb') as f:
    raw = f.read()
  end = raw.index(b'7777') + 4  # The first message, appended once more.
  path = tmp_path / 'twice.grib2'
  path.write_bytes(raw + raw[:end])
  with pytest.raises(errors.BadFileError, match='holds two messages of'):
    gridded.read_source(str(path))


# -- Item 3: a sounding's pressures are checked against their heights. ------
def _hilo_scaled(tmp_path, factor):
  hilo = os.path.join(_DATA, 'PHTO-Hilo_2023-11-01T00Z_uwyo.csv')
  with open(hilo, encoding='utf-8') as f:
    lines = f.read().splitlines()
  rows = [lines[0]] + [
      ','.join([repr(float(l.split(',')[0]) * factor), *l.split(',')[1:]])
      for l in lines[1:] if l.strip()]
  path = tmp_path / f'PHTO-Hilo_x{factor:g}_uwyo.csv'
  path.write_text('\n'.join(rows) + '\n')
  return str(path)


@pytest.mark.parametrize('factor', [100.0, 0.1, 1e34])
def test_a_sounding_in_other_pressure_units_is_refused(factor, tmp_path):
  from ble_latex.wind import sounding  # pylint: disable=g-import-not-at-top
  with pytest.raises(errors.BadFileError, match='PRES must be in hPa'):
    sounding.read(_hilo_scaled(tmp_path, factor))
  assert len(sounding.read(_hilo_scaled(tmp_path, 1.0)).pressure_pa) == 162


def test_launch_refuses_a_sounding_in_pa_in_one_line(tmp_path, capsys):
  from ble_latex.cli import launch  # pylint: disable=g-import-not-at-top
  path = _hilo_scaled(tmp_path, 100.0)
  assert launch.main([f'--output_dir={tmp_path / "o"}', f'--wind_file={path}',
                      '--grid=1,1,1', '--max_steps=1', '--draws=1']) == 1
  line = _one_line(capsys, 'ble-latex-launch')
  assert path in line and 'PRES must be in hPa' in line


def test_launch_world_params_go_through_check_params(tmp_path):
  from tests.wind import test_gridded  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import env_params  # pylint: disable=g-import-not-at-top
  from ble_latex.launch import scoring  # pylint: disable=g-import-not-at-top
  path = test_gridded.write_era5(tmp_path / 'era5.nc')
  bad = env_params.params_from_gin().replace(radius_km=-1.0)
  with pytest.raises(errors.ConfigError, match='radius_km'):
    scoring.era5_world(path, max_hours=0.0, params=bad, steps=1)


# -- Item 4: a launch applies the GriddedWindField bindings, or refuses them. --
@pytest.mark.parametrize('binding, needle', [
    ("GriddedWindField.snapshot_time = '9999-12-31T23:59'", 'snapshot'),
    ("GriddedWindField.start_dates = 'eval'", 'GriddedWindField.start_dates'),
    ("GriddedWindField.stations = 'per_seed'", 'GriddedWindField.stations'),
    ("GriddedWindField.path = '/elsewhere.nc'", 'GriddedWindField.path'),
])
def test_launch_world_applies_or_refuses_wind_bindings(binding, needle,
                                                       tmp_path):
  from tests.wind import test_gridded  # pylint: disable=g-import-not-at-top
  from ble_latex.launch import scoring  # pylint: disable=g-import-not-at-top
  path = test_gridded.write_era5(tmp_path / 'era5.nc')
  gin.clear_config()
  try:
    gin.parse_config(binding)
    with pytest.raises(errors.ConfigError, match=needle):
      scoring.era5_world(path, max_hours=0.0, steps=1)
  finally:
    gin.clear_config()


@pytest.mark.slow  # Two worlds drawn (jitted): ~10 s on 2 busy cores.
def test_launch_world_flies_a_bound_snapshot_time():
  from ble_latex.launch import scoring  # pylint: disable=g-import-not-at-top
  path = os.path.join(_DATA, 'gfs_2010-10-26T12Z_uv_10-300hPa_1deg_subset.nc')
  gin.clear_config()
  try:
    before = scoring.era5_world(path, max_hours=0.0, steps=1)
    gin.parse_config("GriddedWindField.snapshot_time = '2012-06-01T06:00'")
    after = scoring.era5_world(path, max_hours=0.0, steps=1)
  finally:
    gin.clear_config()
  assert before.describe['date'] == '2010-10-26T12:00:00'
  assert after.describe['date'] == '2012-06-01T06:00:00'
  moved = int(after.state.start_time_offset_s) - int(
      before.state.start_time_offset_s)
  import datetime as dt  # pylint: disable=g-import-not-at-top
  assert moved == (dt.datetime(2012, 6, 1, 6) -
                   dt.datetime(2010, 10, 26, 12)).total_seconds()


def test_launch_ascent_rates_are_positive_in_float32(tmp_path, capsys):
  from ble_latex.cli import launch  # pylint: disable=g-import-not-at-top
  from ble_latex.launch import ascent  # pylint: disable=g-import-not-at-top
  with pytest.raises(ValueError, match='float32'):
    ascent.Ascent(ascent_rate_mps=1e-40)
  assert launch.main([f'--output_dir={tmp_path / "o"}', '--from_ground',
                      '--descent_rate_mps=1e-45', '--grid=1,1,1']) == 2
  assert '--from_ground: ascent descent_rate_mps' in _one_line(
      capsys, 'ble-latex-launch')
