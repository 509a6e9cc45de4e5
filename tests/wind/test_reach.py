# coding=utf-8
"""Files are accepted by the altitudes the balloon reaches (issue 64, "Why"
2 and 6).

A sounding that tops out at 22.5 km (many radiosondes burst below 25 km) is
flown, the wind above its top held and named in the record; the band is
the flight's (`latex_controller.band_low_m/band_high_m`, gin-bound); a
sounding that names no site or time says so in one logged line; eval and
train take --station_lat/--station_lon. No network.
"""

import logging

import gin
import numpy as np
import pytest

from ble_latex import errors
from ble_latex.flight import params as flight_params_lib
from ble_latex.run import wind_file
from ble_latex.wind import gridded
from ble_latex.wind import gridded_jax
from ble_latex.wind import reach
from ble_latex.wind import sounding

from tests import helpers

REAL = helpers.REAL_WINDS
BOISE = str(REAL / 'BOI-Boise_2010-12-09T12Z_uwyo.txt')
GFS = str(REAL / 'gfs_2010-10-26T12Z_uv_10-300hPa_1deg_subset.nc')


def _sounding(tmp_path, top_m, name='short.csv', header=''):
  """A UWyo CSV from 1000 hPa to `top_m`, winds turning with height."""
  heights = np.linspace(100.0, top_m, 60)
  pressures = [1013.25 * np.exp(-h / 7000.0) for h in heights]
  rows = [f'{p:.1f},{h:.0f},{(i * 17) % 360},{10 + i % 7}'
          for i, (p, h) in enumerate(zip(pressures, heights))]
  path = tmp_path / name
  path.write_text(header + 'PRES,HGHT,DRCT,SKNT\n' + '\n'.join(rows) + '\n',
                  encoding='utf-8')
  return str(path)


def test_the_band_is_the_flights():
  assert reach.flight_band_m() == (flight_params_lib.DEFAULTS.band_low_m,
                                   flight_params_lib.DEFAULTS.band_high_m)
  with gin.unlock_config():
    gin.bind_parameter('latex_controller.band_high_m', 24_000.0)
  try:
    assert reach.flight_band_m()[1] == 24_000.0
  finally:
    gin.clear_config()


def test_a_sounding_that_stops_at_22_5_km_flies_and_says_its_top_is_held(
    tmp_path):
  data = gridded.load(_sounding(tmp_path, 22_495.0))  # Refused before (25 km).
  assert data.description == (
      'sounding (time-invariant; wind above its top, 22.5 km, held)')
  top = data.interpolate(0.0, data.pressure[0], 0.0, 0.0)
  np.testing.assert_allclose(data.interpolate(0.0, 1000.0, 0.0, 0.0), top)


def test_a_sounding_below_the_band_is_refused_naming_it(tmp_path):
  path = _sounding(tmp_path, 21_000.0)
  with pytest.raises(errors.BadFileError) as raised:
    sounding.read(path)
  message = str(raised.value)
  assert path in message and 'the flight band 13-22 km' in message
  assert '\n' not in message
  with gin.unlock_config():  # A balloon kept below 20 km: it flies.
    gin.bind_parameter('latex_controller.band_high_m', 20_000.0)
  try:
    assert sounding.read(path).height_m[-1] == pytest.approx(21_000.0)
  finally:
    gin.clear_config()


def test_a_sounding_without_site_or_time_warns_in_one_line(caplog):
  data = gridded.load(BOISE)
  with caplog.at_level(logging.WARNING, logger='ble_latex.wind.gridded_jax'):
    gridded_jax.grid_from_data(data)
  lines = [r.getMessage() for r in caplog.records]
  assert len(lines) == 1 and '\n' not in lines[0]
  assert 'names no site or time' in lines[0] and '1970-01-01' in lines[0]
  assert '--station_lat' in lines[0]
  caplog.clear()
  with caplog.at_level(logging.WARNING, logger='ble_latex.wind.gridded_jax'):
    gridded_jax.grid_from_data(data, center_lat=43.56, center_lon=-116.21,
                               snapshot_time='2010-12-09T12:00')
    gridded_jax.grid_from_data(gridded.load(GFS), center_lat=40.0,
                               center_lon=-103.0)
  assert not caplog.records


def test_station_flags_bind_a_fixed_station():
  assert wind_file.station_bindings(None, None) == []
  assert wind_file.station_bindings(51.5, -1.0) == [
      "GriddedWindField.stations = 'fixed'", 'GriddedWindField.center_lat = 51.5',
      'GriddedWindField.center_lon = -1.0']
  for lat, lon in ((51.5, None), (None, 1.0), (91.0, 0.0)):
    with pytest.raises(errors.UsageError):
      wind_file.station_bindings(lat, lon)
  station = wind_file.station_bindings(40.0, -103.0)
  bindings = wind_file.era5_bindings(GFS, 'all', 'eval', station=station)
  assert bindings[2:5] == station  # Instead of per-seed stations.
  assert "GriddedWindField.stations = 'per_seed'" in wind_file.era5_bindings(
      GFS, 'all', 'eval')
  with pytest.raises(errors.UsageError, match='needs ERA5 winds'):
    wind_file.era5_bindings(None, None, 'eval', station=station)


@pytest.mark.parametrize('command', ['eval', 'train', 'launch'])
def test_eval_train_and_launch_take_a_station(command):
  module = __import__(f'ble_latex.cli.{command}', fromlist=['FLAGS'])
  assert 'station_lat' in module.FLAGS and 'station_lon' in module.FLAGS
