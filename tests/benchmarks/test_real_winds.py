# coding=utf-8
"""benchmarks/real_winds.py's planner path and GRIB2 copies (issue 45).

The planners fly by `run/planner_batch.py`'s batched core path, which
imports no BLE gym env (so no TensorFlow: a lent GPU's image has none), with
the records `eval_lib.evaluate` gives; a GRIB2 source can fly from a NetCDF
copy decoded here (`benchmarks/gpu/decode_grib.py`), refused unless the copy
reads to the original's arrays (`wind.grib_copy.digest`).
"""

import json
import os
import shutil

import gin
import numpy as np
import pytest

from ble_latex.run import planner_batch
from ble_latex.run import real_cells
from ble_latex.run import wind_file
from ble_latex.wind import grib_copy
from ble_latex.wind import gridded
from ble_latex.wind import sources

from tests import helpers

DATA = str(helpers.REAL_WINDS)
GFS_GRIB = os.path.join(DATA, 'gfs_2011-10-11T00Z_uv_10-250hPa_2p5deg.grib2')
HILO = os.path.join(DATA, 'PHTO-Hilo_2023-11-01T00Z_uwyo.csv')


@pytest.fixture
def decode_grib(benchmark_script):
  return benchmark_script(os.path.join('gpu', 'decode_grib.py'))


def test_the_decoded_copy_reads_to_the_grib_arrays(decode_grib, tmp_path,
                                                    capsys):
  out = str(tmp_path / 'copy.nc')
  assert decode_grib.main(['decode_grib.py', GFS_GRIB, out]) == 0
  printed = capsys.readouterr().out.strip()
  original = gridded.read_source(GFS_GRIB)[1]
  copy = gridded.read_source(out)[1]
  for a, b in zip(original, copy):
    np.testing.assert_array_equal(a, b)
  assert printed == grib_copy.digest(original) == grib_copy.digest(copy)
  # The digest sees a change of one value.
  changed = [a.copy() for a in copy]
  changed[4].flat[7] += 1.0
  assert grib_copy.digest(changed) != printed


def test_decode_grib_refuses_a_file_that_is_not_grib(decode_grib, tmp_path,
                                                      capsys):
  assert decode_grib.main(['decode_grib.py', HILO,
                           str(tmp_path / 'x.nc')]) == 2
  assert 'is not a GRIB file' in capsys.readouterr().err
  assert not (tmp_path / 'x.nc').exists()


@pytest.mark.parametrize('entry, message, status', [
    ('gfs_global=COPY@' + '0' * 64, 'reads to arrays of SHA-256', 1),
    ('gfs_global=COPY', 'is not NAME=PATH@SHA256', 2),
    ('nowhere=COPY@' + '0' * 64, 'is not NAME=PATH@SHA256', 2),
    ('gfs_global=MISSING@' + '0' * 64, 'no such file', 2),
])
def test_a_copy_that_is_not_the_source_is_refused(benchmark_script,
                                                  decode_grib, tmp_path,
                                                  capsys, entry, message,
                                                  status):
  real_winds = benchmark_script('real_winds.py')
  copy = str(tmp_path / 'copy.nc')
  assert decode_grib.main(['decode_grib.py', GFS_GRIB, copy]) == 0
  capsys.readouterr()
  entry = entry.replace('COPY', copy).replace(
      'MISSING', str(tmp_path / 'missing.nc'))
  record = tmp_path / 'record.json'
  code = real_winds.main(['--sources=gfs_global',
                          '--agents=latex_random', '--seeds=1',
                          f'--realdata_dir={tmp_path}',
                          f'--source_copy={entry}', f'--json={record}'])
  err = capsys.readouterr().err.strip().splitlines()
  assert code == status
  assert len(err) == 1 and message in err[0], err
  assert not record.exists()


@pytest.mark.slow
def test_the_planner_path_flies_eval_libs_records(tmp_path):
  """`planner_batch.fly_planner` = `eval_lib.evaluate`, per seed."""
  from ble_latex.run import eval_lib  # pylint: disable=g-import-not-at-top
  from ble_latex.run import suites  # pylint: disable=g-import-not-at-top
  folder = tmp_path / 'soundings'
  folder.mkdir()
  path = str(folder / os.path.basename(HILO))
  shutil.copy(HILO, path)
  bindings = wind_file.cell_bindings(
      {'suite': 'latex_small', 'station_mode': 'center',
       'station_lat_lon': list(sources.SOURCES['hilo'].site)}, path)
  seeds = list(suites.get_eval_suite('latex_small').seeds)[:2]
  # A binding left by an earlier flight in the process does not count.
  gin.parse_config("GriddedWindField.stations = 'per_seed'")
  planner, _, _ = planner_batch.fly_planner('latex_mpc', bindings, seeds, 3)
  agent, env = eval_lib.build(eval_lib.EvalSpec(
      agent='latex_mpc', gin_bindings=tuple(bindings)))
  evaluated = eval_lib.evaluate(agent, env, seeds, 3)
  assert [r['seed'] for r in planner] == seeds
  for a, b in zip(planner, evaluated):
    assert a['steps'] == b['steps'] == 3
    assert a['terminal_reason'] == b['terminal_reason']
    for key in ('reward', 'helium_vented_mols', 'sand_dropped_kg',
                'final_distance_km'):
      assert a[key] == pytest.approx(b[key], rel=1e-4, abs=1e-4), key


def _fake_flights(seeds):
  """Compact eval records of `seeds`, as `fly_cell` returns them."""
  return [{'seed': s, 'tw50': 0.5, 'tw50_window': 0.5, 'window_steps': 3,
           'reward': 1.0, 'steps': 3, 'helium_vented_mols': 0.0,
           'sand_dropped_kg': 0.0, 'terminal_reason': 'time_limit',
           'final_distance_km': 1.0} for s in seeds]


def test_a_cut_run_keeps_its_finished_chunks(benchmark_script, tmp_path,
                                             monkeypatch):
  """The record is rewritten after every --chunk seeds: a failure in the
  second chunk keeps the first's flights, and the next run flies the rest."""
  import json  # pylint: disable=g-import-not-at-top
  real_winds = benchmark_script('real_winds.py')
  realdata = tmp_path / 'realdata'
  (realdata / 'soundings').mkdir(parents=True)
  shutil.copy(HILO, realdata / 'soundings' / os.path.basename(HILO))
  calls, cut = [], [True]

  def fly_cell(cell, path, seeds):
    del cell, path
    calls.append(list(seeds))
    if cut[0] and len(calls) == 2:
      raise RuntimeError('cut')
    return _fake_flights(seeds), 'sounding (time-invariant)', True, 0.1

  monkeypatch.setattr(real_cells, 'fly_cell', fly_cell)
  record = tmp_path / 'r.json'
  key = 'hilo/latex_station_seeker/center'
  argv = [f'--json={record}', f'--realdata_dir={realdata}', '--sources=hilo',
          '--agents=latex_station_seeker', '--seeds=5', '--chunk=2']
  with pytest.raises(RuntimeError, match='cut'):
    real_winds.main(argv)
  cell = json.loads(record.read_text())['cells'][key]
  assert [f['seed'] for f in cell['flights']] == calls[0]
  assert cell['summary']['episodes'] == 2 and len(cell['runs']) == 1
  first, cut[0] = calls[0], False
  calls.clear()
  assert real_winds.main(argv) == 0
  cell = json.loads(record.read_text())['cells'][key]
  assert [len(c) for c in calls] == [2, 1]  # Only the 3 seeds it lacked.
  assert not set(first) & {s for c in calls for s in c}
  assert len(cell['flights']) == 5 and len(cell['runs']) == 3


def test_two_runs_on_other_cells_share_the_record(benchmark_script, tmp_path,
                                                  monkeypatch, capsys):
  """A chunk's write rereads the record under its lock: a run on another
  cell that wrote in between keeps its cell, and a write that finds the
  lock held waits for it (here: refuses after RECORD_WAIT_S, one line)."""
  import json  # pylint: disable=g-import-not-at-top
  from ble_latex import safe_io  # pylint: disable=g-import-not-at-top
  real_winds = benchmark_script('real_winds.py')
  realdata = tmp_path / 'realdata'
  (realdata / 'soundings').mkdir(parents=True)
  shutil.copy(HILO, realdata / 'soundings' / os.path.basename(HILO))
  record = tmp_path / 'r.json'

  def fly_cell(cell, path, seeds):
    del path
    if cell['agent'] == 'latex_random':  # The other run writes meanwhile.
      other = json.loads(record.read_text())
      other['cells']['elsewhere/x/center'] = {'flights': []}
      record.write_text(json.dumps(other))
    return _fake_flights(seeds), 'sounding (time-invariant)', True, 0.1

  monkeypatch.setattr(real_cells, 'fly_cell', fly_cell)
  argv = [f'--json={record}', f'--realdata_dir={realdata}', '--sources=hilo',
          '--seeds=2']
  assert real_winds.main(argv + ['--agents=latex_station_seeker']) == 0
  assert real_winds.main(argv + ['--agents=latex_random']) == 0
  cells = json.loads(record.read_text())['cells']
  assert set(cells) == {'hilo/latex_station_seeker/center',
                        'hilo/latex_random/center', 'elsewhere/x/center'}
  monkeypatch.setattr(real_winds, 'RECORD_WAIT_S', 0.2)
  before = record.read_bytes()
  capsys.readouterr()
  with safe_io.locked_file(str(record), what='real_winds record'):
    assert real_winds.main(argv + ['--agents=latex_station_seeker',
                                   '--seeds=3']) == 1
  err = capsys.readouterr().err.strip().splitlines()
  assert len(err) == 1 and 'real_winds record' in err[0], err
  assert 'in use by' in err[0] and '(waited 0.2 s)' in err[0], err
  assert record.read_bytes() == before


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
  shutil.copy(os.path.join(helpers.REAL_WINDS, 'PHTO-Hilo_2023-11-01T00Z_uwyo.csv'),
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
  assert needle in helpers.one_line(capsys, 'real_winds.py')


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
  assert needle in helpers.one_line(capsys, 'real_winds.py')
  assert record.read_text() == text


def test_real_winds_output_folder_checked_first(real_winds_run, tmp_path,
                                                capsys):
  real_winds, _, argv, _, _ = real_winds_run
  blocker = tmp_path / 'file'
  blocker.write_text('x')
  assert real_winds.main(argv[1:] + [f'--json={blocker / "r.json"}']) == 1
  assert '--json' in helpers.one_line(capsys, 'real_winds.py')
