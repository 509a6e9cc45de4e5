# coding=utf-8
"""An ensemble file (GEFS / ERA5 EDA style `number` dimension) flies one
member, `Era5WindField.member` (issue 64, item 3); one out of range, or
asked of a file without members, is one line. Synthetic file: the committed
GFS NetCDF subset with three members (winds + member) at two times.
"""

import pathlib

import gin
import numpy as np
import pytest
import xarray as xr

from ble_latex import errors
from ble_latex.wind import era5

GFS_NC = (pathlib.Path(__file__).parent / 'data' / 'realwinds' /
          'gfs_2010-10-26T12Z_uv_10-300hPa_1deg_subset.nc')
NAMES = ('u-component_of_wind_isobaric', 'v-component_of_wind_isobaric')
PLACE = (0.0, 5000.0, 40.0, -103.0)  # (time [s], pressure [Pa], lat, lon)


@pytest.fixture(name='ensemble')
def _ensemble(tmp_path):
  one = xr.open_dataset(GFS_NC).load()
  times = [one.assign_coords(time=one.time + np.timedelta64(6 * i, 'h'))
           for i in range(2)]
  series = xr.concat(times, dim='time')
  members = []
  for k in range(3):
    member = series.copy()
    for name in NAMES:
      member[name] = series[name] + k
    members.append(member)
  path = tmp_path / 'ensemble.nc'
  xr.concat(members, dim='number').assign_coords(
      number=[0, 1, 2]).to_netcdf(path)
  return str(path)


def test_one_member_flies(ensemble):
  first = era5.load(ensemble, member=0)
  second = era5.load(ensemble, member=2)
  assert first.uv.shape == second.uv.shape and first.times.size == 2
  np.testing.assert_allclose(second.interpolate(*PLACE),
                             first.interpolate(*PLACE) + 2.0, atol=1e-4)
  assert second.description == 'analysis (member 2 of 3)'
  # The gin binding, default 0.
  with gin.unlock_config():
    gin.bind_parameter('Era5WindField.member', 1)
  try:
    bound = era5.load(ensemble)
    assert bound.description == 'analysis (member 1 of 3)'
    assert era5.settings(path=ensemble).load() is bound
  finally:
    gin.clear_config()
  assert era5.load(ensemble).description == 'analysis (member 0 of 3)'


def test_a_member_out_of_range_is_one_line(ensemble):
  with pytest.raises(errors.ConfigError) as raised:
    era5.load(ensemble, member=3)
  message = str(raised.value)
  assert '\n' not in message
  assert '3 ensemble members' in message and '(0..2)' in message
  assert 'Era5WindField.member = 3' in message
  with pytest.raises(errors.ConfigError) as raised:
    era5.load(str(GFS_NC), member=1)
  assert 'no ensemble member dimension' in str(raised.value)
  with pytest.raises(errors.ConfigError, match='index >= 0'):
    era5.load(ensemble, member=-1)
  with pytest.raises(errors.ConfigError, match='index >= 0'):
    era5.settings(path=ensemble, member='1')
