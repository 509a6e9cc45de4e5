# coding=utf-8
"""ble_latex.wind.grib_copy: a GRIB2 file's NetCDF copy, read back bit for bit.

(The command, `benchmarks/gpu/decode_grib.py`, in tests/benchmarks/test_real_winds.py.)
"""

import os

import numpy as np
import pytest
import xarray as xr

from ble_latex import errors
from ble_latex.wind import grib_copy
from ble_latex.wind import gridded

from tests import helpers

DATA = str(helpers.REAL_WINDS)
GFS_GRIB = os.path.join(DATA, 'gfs_2011-10-11T00Z_uv_10-250hPa_2p5deg.grib2')
HILO = os.path.join(DATA, 'PHTO-Hilo_2023-11-01T00Z_uwyo.csv')


def test_the_copy_reads_to_the_grib_arrays_and_names_its_writer(tmp_path):
  out = str(tmp_path / 'copy.nc')
  sha = grib_copy.write_netcdf_copy(GFS_GRIB, out, by='a test')
  original = gridded.read_source(GFS_GRIB)[1]
  copy = gridded.read_source(out)[1]
  for a, b in zip(original, copy):
    np.testing.assert_array_equal(a, b)
  assert sha == grib_copy.digest(original) == grib_copy.digest(copy)
  with xr.open_dataset(out) as written:
    assert written.attrs['source'] == (f'decoded from {GFS_GRIB} by a test '
                                       '(cfgrib + eccodes)')


def test_the_digest_sees_one_value_dtype_and_shape():
  arrays = [np.arange(6.0).reshape(2, 3), np.zeros(2, np.float32)]
  sha = grib_copy.digest(arrays)
  assert sha == grib_copy.digest([a.copy() for a in arrays])
  changed = [arrays[0].copy(), arrays[1]]
  changed[0].flat[4] += 1.0
  assert grib_copy.digest(changed) != sha
  assert grib_copy.digest([arrays[0].reshape(3, 2), arrays[1]]) != sha
  assert grib_copy.digest([arrays[0].astype(np.float32), arrays[1]]) != sha


def test_a_file_that_is_not_grib_is_refused_before_writing(tmp_path):
  with pytest.raises(errors.ConfigError, match='is not a GRIB file'):
    grib_copy.write_netcdf_copy(HILO, str(tmp_path / 'x.nc'))
  assert not (tmp_path / 'x.nc').exists()
