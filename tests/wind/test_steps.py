# coding=utf-8
"""One GRIB2 file holding several forecast steps flies as a time series, and
records name the run and lead times (issue 64, "Why" 5, in part).

The files are the real GFS +72 h slice's u/v messages written again with
lead times +72, +75, +78 h (eccodes; winds + 0, 1, 2 m/s). No network.
"""

import gin
import numpy as np
import pytest
import xarray as xr

from ble_latex import errors
from ble_latex.wind import analysis
from ble_latex.wind import gridded
from ble_latex.wind import stations

from tests import helpers

REAL = helpers.REAL_WINDS
SLICE = REAL / 'gfs_2011-10-11T00Z_uv_10-250hPa_2p5deg.grib2'
GFS_NC = REAL / 'gfs_2010-10-26T12Z_uv_10-300hPa_1deg_subset.nc'
HOURS = (72, 75, 78)


def _write_steps(path, hours):
  """The slice's fields at each lead time, winds + its index [m/s]."""
  eccodes = pytest.importorskip('eccodes')
  pytest.importorskip('cfgrib')
  eccodes.codes_grib_multi_support_on()
  try:
    with open(SLICE, 'rb') as f:
      fields = []
      while (handle := eccodes.codes_grib_new_from_file(f)) is not None:
        fields.append(handle)
    with open(path, 'wb') as out:
      for hour in hours:
        for field in fields:
          clone = eccodes.codes_clone(field)
          eccodes.codes_set(clone, 'forecastTime', hour)
          eccodes.codes_set_values(clone, eccodes.codes_get_values(clone) +
                                   HOURS.index(hour))
          eccodes.codes_write(clone, out)
          eccodes.codes_release(clone)
    for field in fields:
      eccodes.codes_release(field)
  finally:
    eccodes.codes_grib_multi_support_off()
  return str(path)


def test_one_file_of_several_steps_is_a_time_series(tmp_path):
  data = gridded.load(_write_steps(tmp_path / 'steps.grib2', HOURS))
  assert not data.time_invariant
  assert data.times.tolist() == [
      np.datetime64(f'2011-10-11T{h:02d}:00', 'ns').astype(int)
      for h in (0, 3, 6)]
  assert data.description == 'GRIB2 run 2011-10-08T00Z +72..+78 h'
  first = data.interpolate(0.0, 5000.0, 10.0, 10.0)
  np.testing.assert_allclose(data.interpolate(5400.0, 5000.0, 10.0, 10.0),
                             first + 0.5, atol=1e-5)
  # The same steps as three files, joined along time.
  parts = [_write_steps(tmp_path / f'f{h:03d}.grib2', (h,)) for h in HOURS]
  joined = gridded.load(parts)
  np.testing.assert_array_equal(joined.uv, data.uv)
  assert joined.description == data.description


def test_a_series_off_the_era5_split_flies_per_seed_or_says_the_fix(
    tmp_path):
  data = gridded.load(_write_steps(tmp_path / 'steps.grib2', HOURS))
  # Not the paper's ERA5 target: per-seed stations, as on a snapshot.
  assert stations.file_defaults(data) == {'stations': 'per_seed'}
  with pytest.raises(errors.ConfigError) as raised:
    gridded.start_window(data, center_lat=0.0, center_lon=0.0,
                         episode_hours=3.0, start_dates='eval')
  message = str(raised.value)
  assert '--era5_dates=all' in message and '\n' not in message
  assert gridded.start_window(data, center_lat=0.0, center_lon=0.0,
                              episode_hours=3.0) == (0, 180)


def test_a_netcdf_analysis_with_several_times_is_a_time_series(tmp_path):
  one = xr.open_dataset(GFS_NC).load()
  steps = [one.assign_coords(time=one.time + np.timedelta64(6 * i, 'h'))
           for i in range(3)]
  for i, step in enumerate(steps):
    for name in ('u-component_of_wind_isobaric',
                 'v-component_of_wind_isobaric'):
      step[name] = step[name] + i
  path = tmp_path / 'series.nc'
  xr.concat(steps, dim='time').to_netcdf(path)
  data = gridded.load(str(path))
  assert not data.time_invariant and data.times.size == 3
  assert data.description == 'analysis'
  first = data.interpolate(0.0, 5000.0, 40.0, -103.0)
  np.testing.assert_allclose(data.interpolate(9 * 3600.0, 5000.0, 40.0,
                                              -103.0), first + 1.5, atol=1e-4)


def test_a_snapshot_names_its_run_and_lead_time():
  pytest.importorskip('cfgrib')
  data = gridded.load(str(SLICE))
  assert data.forecast == analysis.ForecastRun(
      (np.datetime64('2011-10-08T00:00', 'ns'),), (72.0,))
  assert data.description == 'GRIB2 run 2011-10-08T00Z +72 h (time-invariant)'
  runs = analysis.ForecastRun.join([
      data.forecast, analysis.ForecastRun(
          (np.datetime64('2011-10-08T06:00', 'ns'),), (66.0,))])
  assert runs.label == 'runs 2011-10-08T00Z..2011-10-08T06Z +66..+72 h'
  assert analysis.ForecastRun.join([data.forecast, None]) is None


def test_the_default_split_is_not_applied_to_a_series_other_than_era5(
    tmp_path):
  """eval's and train's default ERA5 splits refused a GFS series (the
  'eval' dates are not in it); they apply to ERA5 files only, and a given
  --era5_dates still does (refused in one line when the file lacks it)."""
  from ble_latex.run import wind_file  # pylint: disable=g-import-not-at-top
  path = _write_steps(tmp_path / 'steps.grib2', HOURS)
  gin.clear_config()
  try:
    for split in ('eval', 'train'):
      bindings = wind_file.era5_bindings(path, None, split)
      assert not any('start_dates' in b for b in bindings), bindings
    assert wind_file.era5_bindings(path, 'all', 'eval')[-1] == (
        'GriddedWindField.start_dates = None')
  finally:
    gin.clear_config()
  data = gridded.load(path)
  assert gridded.start_window(data, center_lat=0.0, center_lon=0.0,
                              episode_hours=3.0, start_dates=None) == (0, 180)
  with pytest.raises(errors.ConfigError, match='--era5_dates=all'):
    gridded.start_window(data, center_lat=0.0, center_lon=0.0,
                         episode_hours=3.0, start_dates='eval')


def test_a_series_shorter_than_the_flight_names_its_source_and_the_fix(
    tmp_path):
  data = gridded.load(_write_steps(tmp_path / 'steps.grib2', HOURS))
  with pytest.raises(errors.BadFileError) as raised:
    gridded.last_start_minute(data, center_lat=0.0, center_lon=0.0,
                              episode_hours=72.0)
  message = str(raised.value)
  assert message.startswith('GRIB2 file(s)') and '\n' not in message
  assert 'cover 6.0 h' in message
  assert 'bind GriddedWindField.episode_hours' in message
