# coding=utf-8
"""Tests of the ERA5 downloads: the CDS requests and ble-latex-download-era5.

Over the synthetic files of tests/wind/test_gridded.py, with fake clients: no
network.
"""

import datetime as dt
import json
import os
import sys
import types

import ble_latex  # noqa: F401  pylint: disable=unused-import
import numpy as np
import pytest
import xarray as xr

from ble_latex.cli import download_era5
from ble_latex.wind import era5_requests
from ble_latex.wind import gridded
# pylint: disable=g-bad-import-order,unused-import
from tests.wind.test_gridded import (  # The synthetic files.
    TIMES, write_era5)
# pylint: enable=g-bad-import-order,unused-import


# Requests and the download command.


def test_paper_requests_are_exact():
  requests = era5_requests.build_requests()
  assert [month for month, _ in requests] == ['2022-11', '2022-12', '2023-01']
  month, request = requests[0]
  assert request == {
      'product_type': ['reanalysis'],
      'variable': ['u_component_of_wind', 'v_component_of_wind'],
      'year': ['2022'],
      'month': ['11'],
      'day': [f'{d:02d}' for d in range(1, 31)],
      'time': ['00:00', '06:00', '12:00', '18:00'],
      'pressure_level': ['20', '30', '50', '70', '100', '125', '150', '175'],
      'area': [6.0, -118.0, -4.0, -108.0],
      'grid': [0.4, 0.4],
      'data_format': 'netcdf',
      'download_format': 'unarchived',
  }
  assert requests[1][1]['day'][-1] == '31'
  assert requests[2][1]['year'] == ['2023'] and requests[2][1]['month'] == [
      '01']
  assert len(requests[2][1]['day']) == 31
  del month


def test_requests_for_partial_months():
  requests = era5_requests.build_requests(start_date=dt.date(2022, 12, 30),
                                 end_date=dt.date(2023, 1, 2),
                                 half_width_deg=2.0, min_pressure_hpa=50,
                                 max_pressure_hpa=100)
  assert [(m, r['day']) for m, r in requests] == [
      ('2022-12', ['30', '31']), ('2023-01', ['01', '02'])]
  assert requests[0][1]['area'] == [3.0, -115.0, -1.0, -111.0]
  assert requests[0][1]['pressure_level'] == ['50', '70', '100']
  with pytest.raises(ValueError, match='before start_date'):
    era5_requests.build_requests(start_date=dt.date(2023, 1, 2),
                        end_date=dt.date(2023, 1, 1))
  with pytest.raises(ValueError, match='No ERA5 pressure level'):
    era5_requests.build_requests(min_pressure_hpa=21, max_pressure_hpa=29)


def test_dry_run_prints_json_without_cdsapi(monkeypatch, capsys, tmp_path):
  monkeypatch.setitem(sys.modules, 'cdsapi', None)  # Importing it fails.
  output = str(tmp_path / 'era5_paper.nc')
  assert download_era5.main(['--dry_run', '--output', output]) == 0
  printed = json.loads(capsys.readouterr().out)
  assert printed['dataset'] == 'reanalysis-era5-pressure-levels'
  assert printed['output'] == output
  assert [r['request'] for r in printed['requests']] == [
      r for _, r in era5_requests.build_requests()]
  assert [r['target'] for r in printed['requests']] == [
      str(tmp_path / f'era5_paper_{m}.nc')
      for m in ('2022-11', '2022-12', '2023-01')]
  assert not list(tmp_path.iterdir())


def test_missing_credentials_is_a_clear_error(monkeypatch, capsys, tmp_path):
  monkeypatch.setitem(sys.modules, 'cdsapi', None)
  monkeypatch.delenv('CDSAPI_URL', raising=False)
  monkeypatch.delenv('CDSAPI_KEY', raising=False)
  monkeypatch.setenv('CDSAPI_RC', str(tmp_path / 'no_cdsapirc'))
  assert download_era5.main(['--output', str(tmp_path / 'x.nc')]) == 2
  err = capsys.readouterr().err
  assert f'no CDS API credentials: {tmp_path / "no_cdsapirc"} does not ' in err


def test_download_with_fake_client_writes_and_joins_months(
    monkeypatch, capsys, tmp_path):
  retrieved = []

  class FakeClient:

    def retrieve(self, dataset, request, target):
      retrieved.append((dataset, request))
      year, month = int(request['year'][0]), int(request['month'][0])
      days = [int(d) for d in request['day']]
      times = np.array([np.datetime64(dt.datetime(year, month, d, h))
                        for d in days for h in (0, 6, 12, 18)],
                       dtype='datetime64[ns]')
      write_era5(target, times=times, lat=np.array([2.0, 1.0, 0.0]),
                 lon=np.array([-114.0, -113.0, -112.0]),
                 levels_hpa=np.array([50.0, 70.0, 100.0]),
                 dtype='float32', t0=times[0])

  monkeypatch.setitem(sys.modules, 'cdsapi',
                      types.SimpleNamespace(Client=FakeClient))
  monkeypatch.setenv('CDSAPI_URL', 'https://example.invalid/api')
  monkeypatch.setenv('CDSAPI_KEY', 'fake')
  output = str(tmp_path / 'era5.nc')
  argv = ['--output', output, '--start_date', '2022-12-31', '--end_date',
          '2023-01-01', '--half_width_deg', '1']
  assert download_era5.main(argv) == 0
  assert [r['month'] for _, r in retrieved] == [['12'], ['01']]
  data = gridded.load(output)
  assert data.times.size == 8
  assert data.start == dt.datetime(2022, 12, 31, tzinfo=dt.timezone.utc)
  assert 'wrote' in capsys.readouterr().out
  # Months already there are not fetched again.
  assert download_era5.main(argv) == 0
  assert len(retrieved) == 2


def test_failed_retrieval_is_a_clear_error(monkeypatch, capsys, tmp_path):

  class FailingClient:

    def retrieve(self, dataset, request, target):
      raise RuntimeError('403 Forbidden: required licences not accepted')

  monkeypatch.setitem(sys.modules, 'cdsapi',
                      types.SimpleNamespace(Client=FailingClient))
  monkeypatch.setenv('CDSAPI_URL', 'https://example.invalid/api')
  monkeypatch.setenv('CDSAPI_KEY', 'fake')
  assert download_era5.main(['--output', str(tmp_path / 'x.nc')]) == 1
  assert 'CDS request for 2022-11 failed (RuntimeError: 403' in (
      capsys.readouterr().err)
  assert not list(tmp_path.iterdir())


def recording_client(calls):
  """A fake cdsapi module whose client records its calls (never called)."""

  class Client:

    def retrieve(self, dataset, request, target):
      calls.append((dataset, request, target))
      raise AssertionError('no request expected')

  return types.SimpleNamespace(Client=Client)


@pytest.mark.parametrize('dry_run', [False, True])
def test_output_directory_is_a_usage_error(monkeypatch, capsys, tmp_path,
                                           dry_run):
  calls = []
  monkeypatch.setitem(sys.modules, 'cdsapi', recording_client(calls))
  monkeypatch.setenv('CDSAPI_URL', 'https://example.invalid/api')
  monkeypatch.setenv('CDSAPI_KEY', 'fake')
  existing = tmp_path / 'existing'
  existing.mkdir()
  for output in (str(existing), str(tmp_path / 'new') + '/',
                 str(tmp_path / 'new') + os.sep, str(existing) + '/'):
    argv = ['--output', output] + (['--dry_run'] if dry_run else [])
    assert download_era5.main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ''
    assert captured.err == (
        f'ble-latex-download-era5: error: --output {output} is a directory; give a file name such as '
        f'{os.path.join(output, "era5_paper.nc")}\n')
  assert not calls
  assert [p.name for p in tmp_path.iterdir()] == ['existing']
  assert not list(existing.iterdir())


def test_output_under_a_file_is_a_usage_error(monkeypatch, capsys, tmp_path):
  calls = []
  monkeypatch.setitem(sys.modules, 'cdsapi', recording_client(calls))
  monkeypatch.setenv('CDSAPI_URL', 'https://example.invalid/api')
  monkeypatch.setenv('CDSAPI_KEY', 'fake')
  (tmp_path / 'file').write_text('x')
  output = str(tmp_path / 'file' / 'era5.nc')
  assert download_era5.main(['--output', output]) == 2
  assert capsys.readouterr().err == (
      f'ble-latex-download-era5: error: --output {output}: {tmp_path / "file"} is not a directory\n')
  assert not calls


def test_monthly_target_directory_is_a_usage_error(monkeypatch, capsys,
                                                   tmp_path):
  calls = []
  monkeypatch.setitem(sys.modules, 'cdsapi', recording_client(calls))
  monkeypatch.setenv('CDSAPI_URL', 'https://example.invalid/api')
  monkeypatch.setenv('CDSAPI_KEY', 'fake')
  (tmp_path / 'era5_2022-12.nc').mkdir()
  assert download_era5.main(['--output', str(tmp_path / 'era5.nc')]) == 2
  assert capsys.readouterr().err == (
      f'ble-latex-download-era5: error: {tmp_path / "era5_2022-12.nc"} (the file for 2022-12) is a '
      'directory\n')
  assert not calls


@pytest.mark.parametrize('exception', [RuntimeError, KeyboardInterrupt])
def test_failed_retrieval_leaves_no_part_file(monkeypatch, capsys, tmp_path,
                                              exception):

  class HalfClient:

    def retrieve(self, dataset, request, target):
      with open(target, 'wb') as f:
        f.write(b'CDF\x01 half a download')
      raise exception('connection reset')

  monkeypatch.setitem(sys.modules, 'cdsapi',
                      types.SimpleNamespace(Client=HalfClient))
  monkeypatch.setenv('CDSAPI_URL', 'https://example.invalid/api')
  monkeypatch.setenv('CDSAPI_KEY', 'fake')
  argv = ['--output', str(tmp_path / 'x.nc')]
  if exception is KeyboardInterrupt:
    with pytest.raises(KeyboardInterrupt):
      download_era5.main(argv)
  else:
    assert download_era5.main(argv) == 1
    assert 'CDS request for 2022-11 failed' in capsys.readouterr().err
  assert not list(tmp_path.iterdir())


def test_failed_merge_leaves_no_part_file(monkeypatch, capsys, tmp_path):
  sources = [write_era5(tmp_path / f'era5_{m}.nc', times=times)
             for m, times in (('2022-11', TIMES[:2]), ('2022-12', TIMES[2:]))]
  written = []

  def failing_to_netcdf(self, path, *args, **kwargs):
    del self, args, kwargs
    written.append(path)
    with open(path, 'wb') as f:
      f.write(b'CDF\x01 half written')
    raise OSError(28, 'No space left on device')

  monkeypatch.setattr(xr.Dataset, 'to_netcdf', failing_to_netcdf)
  output = str(tmp_path / 'era5.nc')
  with pytest.raises(OSError, match='No space left'):
    download_era5.merge_files(sources, output)
  assert written == [output + '.part']
  assert sorted(p.name for p in tmp_path.iterdir()) == [
      'era5_2022-11.nc', 'era5_2022-12.nc']
  # The command reports it as a one-line error.
  assert download_era5.main(['--output', output, '--start_date', '2022-11-01',
                             '--end_date', '2022-12-31']) == 1
  assert capsys.readouterr().err.startswith(
      f'ble-latex-download-era5: error: could not write {output} (OSError: [Errno 28] No space left')
  assert sorted(p.name for p in tmp_path.iterdir()) == [
      'era5_2022-11.nc', 'era5_2022-12.nc']


# -- Item 22: ble-latex-download-era5's grid spacing is bounded. ------------
@pytest.mark.parametrize('grid', ['1e-30', '0.001', '50'])
def test_download_era5_grid_deg_out_of_range_is_refused(grid, capsys):
  from ble_latex.cli import download_era5  # pylint: disable=g-import-not-at-top
  assert download_era5.main(['--dry_run', f'--grid_deg={grid}']) == 2
  assert 'grid_deg must be in [0.05, ' in capsys.readouterr().err


def test_download_era5_paper_grid_is_accepted(capsys):
  from ble_latex.cli import download_era5  # pylint: disable=g-import-not-at-top
  assert download_era5.main(['--dry_run', '--grid_deg=0.25']) == 0
