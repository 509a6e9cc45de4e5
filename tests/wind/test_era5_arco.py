# coding=utf-8
"""Tests of the ARCO-ERA5 source (`ble_latex.wind.era5_arco`, `--source=arco`).

The tests write small local Zarr stores shaped like Google's public
ARCO-ERA5 store (variables `u_component_of_wind`, `v_component_of_wind` on
(time, level [millibars], latitude descending, longitude 0..360), hourly)
whose winds are the multi-linear functions of tests/wind/test_gridded.py, so the
written files can be checked exactly. No network, no gcsfs.
"""

import datetime as dt
import json
import os
import sys
import warnings

import numpy as np
import pytest
import xarray as xr

from ble_latex.ble import gridded_field
from ble_latex.cli import download_era5
from ble_latex.wind import era5_arco
from ble_latex.wind import era5_requests
from ble_latex.wind import gridded
from tests.wind import test_gridded  # pylint: disable=g-bad-import-order

pytest.importorskip('zarr')

LEVELS_HPA = np.array([10.0, 20.0, 30.0, 50.0, 70.0, 100.0, 125.0, 150.0,
                       175.0, 200.0])  # [hPa]
T0 = np.datetime64('2022-11-01T00:00', 'ns')
HOURS = 30  # 2022-11-01 00:00 .. 2022-11-02 05:00, hourly.
DAY = ['--start_date=2022-11-01', '--end_date=2022-11-01']
AREA = ['--half_width_deg=2']


def write_store(path, *, lat=np.arange(4.0, -2.01, -0.25),
                lon=np.arange(240.0, 254.01, 0.25), hours=HOURS,
                levels_hpa=LEVELS_HPA, level_units='millibars',
                wind_units='m s**-1', drop=(), nan_at=None, attrs=None,
                level_labels=None, missing_chunk_fill=None):
  """Writes a synthetic ARCO-ERA5-like Zarr store; returns its path as str.

  `missing_chunk_fill`: chunk the winds by time step, set the Zarr arrays'
  `fill_value` to it and delete u's chunk of time step 6 (a store with a
  chunk never written).
  """
  times = T0 + np.arange(hours) * np.timedelta64(1, 'h')
  t_h = (times - test_gridded.T0) / np.timedelta64(1, 'h')
  tt, pp, la, lo = np.meshgrid(t_h, levels_hpa, lat, lon, indexing='ij')
  lon_true = (lo + 180.0) % 360.0 - 180.0
  winds = {'u_component_of_wind': test_gridded.wind_u(tt, pp, la, lon_true),
           'v_component_of_wind': test_gridded.wind_v(tt, pp, la, lon_true)}
  if nan_at is not None:
    winds['u_component_of_wind'][nan_at] = np.nan
  dims = ('time', 'level', 'latitude', 'longitude')
  variables = {name: (dims, value.astype('float32'), {'units': wind_units})
               for name, value in winds.items() if name not in drop}
  variables['temperature'] = (dims, np.full(tt.shape, 210.0, 'float32'),
                              {'units': 'K'})
  dataset = xr.Dataset(variables, coords={
      'time': times, 'level': ('level', levels_hpa if level_labels is None
                               else level_labels, {'units': level_units}),
      'latitude': lat, 'longitude': lon}, attrs=attrs or {})
  encoding = ({} if missing_chunk_fill is None else
              {name: {'chunks': (1, *value[1].shape[1:])}
               for name, value in variables.items()})
  with warnings.catch_warnings():  # Consolidated metadata in Zarr v3.
    warnings.simplefilter('ignore', UserWarning)
    dataset.to_zarr(str(path), mode='w', encoding=encoding)
    if missing_chunk_fill is not None:
      import json  # pylint: disable=g-import-not-at-top
      import shutil  # pylint: disable=g-import-not-at-top
      import zarr  # pylint: disable=g-import-not-at-top
      for name in variables:
        meta_path = path / name / 'zarr.json'
        meta = json.loads(meta_path.read_text())
        meta['fill_value'] = missing_chunk_fill
        meta_path.write_text(json.dumps(meta))
      shutil.rmtree(path / 'u_component_of_wind' / 'c' / '6')
      zarr.consolidate_metadata(str(path))
  return str(path)


@pytest.fixture(name='store', scope='module')
def fixture_store(tmp_path_factory):
  return write_store(tmp_path_factory.mktemp('arco') / 'era5.zarr')


def requests(**kwargs):
  kwargs = {'start_date': dt.date(2022, 11, 1),
            'end_date': dt.date(2022, 11, 1), 'half_width_deg': 2.0,
            **kwargs}
  return era5_requests.build_requests(**kwargs)


def test_fetch_writes_the_cds_layout_era5_load_reads(store, tmp_path):
  output = era5_arco.fetch(requests(), str(tmp_path / 'era5.nc'),
                           store=store)
  with xr.open_dataset(output) as dataset:
    assert set(dataset.data_vars) == {'u', 'v'}
    assert dataset['u'].dims == ('valid_time', 'pressure_level', 'latitude',
                                 'longitude')
    assert dataset['pressure_level'].attrs['units'] == 'hPa'
  data = gridded.load(output)
  np.testing.assert_array_equal(
      data.times, T0 + np.arange(4) * np.timedelta64(6, 'h'))
  np.testing.assert_array_equal(data.pressure, 100.0 * np.array(
      era5_requests.pressure_levels_hpa()))
  # The store's native 0.25 deg grid inside the area (lon -115..-111).
  np.testing.assert_allclose(data.latitude, np.arange(-1.0, 3.01, 0.25))
  np.testing.assert_allclose(data.longitude, np.arange(-115.0, -110.99, 0.25))
  t, p, la, lo = np.meshgrid(data.time_s / 3600.0, data.pressure / 100.0,
                             data.latitude, data.longitude, indexing='ij')
  np.testing.assert_allclose(data.uv[..., 0], test_gridded.wind_u(t, p, la, lo),
                             rtol=1e-6, atol=1e-5)
  np.testing.assert_allclose(data.uv[..., 1], test_gridded.wind_v(t, p, la, lo),
                             rtol=1e-6, atol=1e-5)
  assert sorted(os.listdir(tmp_path)) == ['era5.nc']


def test_area_across_the_stores_longitude_seam(tmp_path):
  store = write_store(tmp_path / 'global.zarr', lat=np.array([2.0, 1.0, 0.0]),
                      lon=np.arange(0.0, 360.0, 1.0), hours=7)
  output = era5_arco.fetch(
      requests(center_lat=1.0, center_lon=0.0, half_width_deg=1.0,
               times=('00:00', '06:00')),
      str(tmp_path / 'era5.nc'), store=store)
  data = gridded.load(output)
  np.testing.assert_array_equal(data.longitude, [-1.0, 0.0, 1.0])
  np.testing.assert_allclose(
      data.interpolate(0.0, 5000.0, 1.0, -1.0)[0],
      test_gridded.wind_u(-0.0, 50.0, 1.0, -1.0), rtol=1e-6)


def test_command_writes_a_file_the_wind_field_flies(store, tmp_path, capsys):
  output = str(tmp_path / 'era5.nc')
  argv = ['--source=arco', f'--store={store}', f'--output={output}', *DAY,
          *AREA]
  assert download_era5.main(argv) == 0
  assert f'wrote {output}: 4 times' in capsys.readouterr().out
  field = gridded_field.GriddedWindField(path=output, episode_hours=12.0)
  assert field.data.uv.shape == (4, 8, 17, 17, 2)


def test_dry_run_prints_the_selection_without_zarr(monkeypatch, capsys):
  monkeypatch.setitem(sys.modules, 'zarr', None)
  assert download_era5.main(['--source=arco', '--dry_run']) == 0
  printed = json.loads(capsys.readouterr().out)
  assert printed['store'] == era5_arco.DEFAULT_STORE
  assert printed['times'] == {'first': '2022-11-01 00:00',
                              'last': '2023-01-31 18:00', 'count': 92 * 4}
  assert printed['area'] == {'north': 6.0, 'west': -118.0, 'south': -4.0,
                             'east': -108.0}


@pytest.mark.parametrize('missing, store', [
    ('zarr', 'local.zarr'), ('gcsfs', era5_arco.DEFAULT_STORE)])
def test_missing_packages_are_usage_errors_naming_the_extra(
    monkeypatch, capsys, tmp_path, missing, store):
  monkeypatch.setitem(sys.modules, missing, None)
  output = str(tmp_path / 'era5.nc')
  assert download_era5.main(['--source=arco', f'--store={store}',
                             f'--output={output}']) == 2
  error = capsys.readouterr().err
  assert error.count('\n') == 1, error
  assert error.startswith('ble-latex-download-era5: ')
  assert f'not installed: {missing}' in error
  assert "pip install 'ble_latex[arco]'" in error
  assert not os.listdir(tmp_path)


@pytest.mark.parametrize('flag', ['--grid_deg=0.25', '--no_merge',
                                  '--overwrite'])
def test_cds_only_flags_are_usage_errors_with_arco(capsys, flag):
  assert download_era5.main(['--source=arco', flag]) == 2
  assert f'{flag.split("=")[0]} is for --source=cds only' in (
      capsys.readouterr().err)


def test_store_without_arco_is_a_usage_error(capsys):
  assert download_era5.main(['--store=x.zarr', '--dry_run']) == 2
  assert '--store is for --source=arco only' in capsys.readouterr().err


BAD_STORES = {
    # Issue 48 items 17, 21: a string level, a NaN latitude (was dropped).
    'string level': (dict(level_labels=LEVELS_HPA.astype(int).astype(str)),
                     "coordinate 'level' must hold finite numbers"),
    'nan latitude': (dict(lat=np.concatenate([np.arange(4.0, -2.01, -0.25)[:-1],
                                              [np.nan]])),
                     "coordinate 'latitude' must hold finite numbers"),
    'missing variable': (dict(drop=('v_component_of_wind',)),
                         "has no variable 'v_component_of_wind'"),
    'wind units': (dict(wind_units='km h**-1'),
                   "'u_component_of_wind' has units 'km h**-1', expected m/s"),
    'level units': (dict(level_units='Pa'),
                    "pressure coordinate 'level' has units 'Pa' but values"),
    'missing level': (dict(levels_hpa=np.array([10.0, 20.0, 50.0, 100.0])),
                      'has no pressure level 30 hPa'),
    # Issue 48 item 6: a chunk never written reads as its fill value.
    'missing chunk, fill 0': (dict(missing_chunk_fill=0.0),
                              "'u_component_of_wind' at 2022-11-01 06:00, "),
    'missing chunk, fill 7': (dict(missing_chunk_fill=7.0),
                              'hPa is one value (7) over the whole area'),
    'nan': (dict(nan_at=(6, 3, 5, 20)),
            'fail the ERA5 checks, nothing written: ERA5 file'),
    'area': (dict(lon=np.arange(250.0, 260.01, 0.25)),
             'the requested longitude [-115, -111] is outside the store '
             '(longitude 250..260)'),
    'latitude': (dict(lat=np.arange(10.0, 1.99, -0.25)),
                 'the requested latitude [-1, 3] is outside the store'),
    'too short': (dict(hours=12),
                  'has no data for 2 of the 4 requested times (first '
                  '2022-11-01 12:00); the store covers 2022-11-01 00:00 to '
                  '2022-11-01 11:00'),
    'past valid_time_stop': (dict(attrs={'valid_time_stop': '2022-11-01T12'}),
                             'has no data for 1 of the 4 requested times'),
}


@pytest.mark.parametrize('case', sorted(BAD_STORES))
def test_bad_stores_are_one_line_errors_leaving_the_old_file(
    tmp_path, capsys, case):
  kwargs, message = BAD_STORES[case]
  store = write_store(tmp_path / 'bad.zarr', **kwargs)
  output = tmp_path / 'out' / 'era5.nc'
  output.parent.mkdir()
  output.write_bytes(b'old')
  argv = ['--source=arco', f'--store={store}', f'--output={output}', *DAY,
          *AREA]
  assert download_era5.main(argv) == 1
  error = capsys.readouterr().err
  assert error.count('\n') == 1, error
  assert error.startswith(f'ble-latex-download-era5: error: ARCO-ERA5 store '
                          f'{store}'), error
  assert message in error
  assert output.read_bytes() == b'old'
  assert os.listdir(output.parent) == ['era5.nc']


@pytest.mark.parametrize('store', ['missing.zarr', 'file'])
def test_unreachable_store_is_a_one_line_error(tmp_path, capsys, store):
  (tmp_path / 'file').write_text('not zarr')
  store = str(tmp_path / store)
  output = str(tmp_path / 'era5.nc')
  assert download_era5.main(['--source=arco', f'--store={store}',
                             f'--output={output}', *DAY]) == 1
  error = capsys.readouterr().err
  assert error.startswith(f'ble-latex-download-era5: error: ARCO-ERA5 store '
                          f'{store} could not be opened ('), error
  assert error.count('\n') == 1, error
  assert not os.path.exists(output)


@pytest.mark.parametrize('flag, message', [
    ('--center_lat=91', '--center_lat must be in [-90, 90] deg, got 91'),
    ('--start_date=0001-01-01', '--start_date: ERA5 covers 1940 to now, got '
     'year 1'),
    ('--end_date=9999-12-31', '--end_date: ERA5 covers 1940 to now, got year '
     '9999'),
])
def test_absurd_places_and_years_are_usage_errors_even_dry(flag, message,
                                                           capsys):
  """Issue 48 item 21: refused before any request, in a dry run too."""
  for source in ('--source=cds', '--source=arco'):
    assert download_era5.main(['--dry_run', source, flag]) == 2
    assert capsys.readouterr().err == (
        f'ble-latex-download-era5: {message}\n')


def test_full_disk_is_one_line(store, tmp_path, capsys, monkeypatch):
  """Issue 48 item 16: netCDF4 reports a full disk as RuntimeError."""
  def full(*unused_args, **unused_kwargs):
    raise RuntimeError('NetCDF: HDF error')
  monkeypatch.setattr(xr.Dataset, 'to_netcdf', full)
  output = tmp_path / 'era5.nc'
  assert download_era5.main(['--source=arco', f'--store={store}',
                             f'--output={output}', *DAY, *AREA]) == 1
  error = capsys.readouterr().err
  assert error.count('\n') == 1, error
  assert error.startswith(f'ble-latex-download-era5: error: could not write '
                          f'{output} (RuntimeError: NetCDF: HDF error; is the '
                          'disk full?)')
  assert not list(tmp_path.iterdir())
