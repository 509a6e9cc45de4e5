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
GFS_GRIB = GFS_NC.parent / 'gfs_2011-10-11T00Z_uv_10-250hPa_2p5deg.grib2'
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


def test_a_grib2_ensemble_flies_one_member(tmp_path):
  """GEFS style: the slice's fields as members 0..2 (product definition
  template 4.1, perturbationNumber; winds + member), and a message that is
  no wind. Its members are not duplicates of one field."""
  eccodes = pytest.importorskip('eccodes')
  pytest.importorskip('cfgrib')
  path = tmp_path / 'ensemble.grib2'
  eccodes.codes_grib_multi_support_on()
  try:
    with open(GFS_GRIB, 'rb') as f, open(path, 'wb') as out:
      fields = []
      while (field := eccodes.codes_grib_new_from_file(f)) is not None:
        fields.append(field)
      for k in range(3):
        for field in fields:
          clone = eccodes.codes_clone(field)
          for key, value in (('productDefinitionTemplateNumber', 1),
                             ('perturbationNumber', k),
                             ('numberOfForecastsInEnsemble', 3)):
            eccodes.codes_set(clone, key, value)
          eccodes.codes_set_values(clone,
                                   eccodes.codes_get_values(field) + k)
          eccodes.codes_write(clone, out)
          eccodes.codes_release(clone)
      other = eccodes.codes_clone(fields[0])
      eccodes.codes_set(other, 'parameterNumber', 0)  # Wind direction.
      eccodes.codes_write(other, out)
      for field in [other, *fields]:
        eccodes.codes_release(field)
  finally:
    eccodes.codes_grib_multi_support_off()
  first = era5.load(str(path), member=0)
  last = era5.load(str(path), member=2)
  assert last.description == ('GRIB2 run 2011-10-08T00Z +72 h '
                              '(time-invariant; member 2 of 3)')
  np.testing.assert_allclose(last.uv, first.uv + 2.0, atol=0.51)
  with pytest.raises(errors.ConfigError, match=r'3 ensemble members'):
    era5.load(str(path), member=3)
