# coding=utf-8
"""ble_latex.wind.sources: the real wind sources' registry and stations."""

import os
import shutil

import numpy as np
import pytest

from ble_latex import errors
from ble_latex.wind import grib_copy
from ble_latex.wind import gridded
from ble_latex.wind import sources

from tests import helpers

DATA = str(helpers.REAL_WINDS)
GFS_NC = os.path.join(DATA, 'gfs_2010-10-26T12Z_uv_10-300hPa_1deg_subset.nc')


def test_the_registry_names_grids_and_soundings():
  assert list(sources.SOURCES) == ['gfs_namerica', 'gfs_global', 'boise',
                                   'hilo']
  assert sources.GRIDS == ('gfs_namerica', 'gfs_global')
  for name, source in sources.SOURCES.items():
    # A tuple of (file, label, site), as the records' scripts unpack it.
    file, label, site = source
    assert file.startswith('soundings/' if site else 'winds/') and label
    assert sources.is_sounding(name) == (site is not None)
    assert sources.table_station_mode(name) == (
        'center' if site else 'per_seed')
  assert sources.path('hilo', '/data') == (
      '/data/soundings/PHTO-Hilo_2023-11-01T00Z_uwyo.csv')
  assert sources.unknown(['hilo', 'mars', 'boise', 'venus']) == ['mars',
                                                                  'venus']
  assert os.path.normpath(sources.REALDATA_DIR).endswith(
      os.path.join('shared', 'realdata'))


def test_center_is_a_soundings_site_or_a_grids_middle():
  # A sounding's site: its file is not read.
  assert sources.center('hilo', '/not/read') == (19.72, -155.07)
  data = gridded.load(GFS_NC)
  lat, lon = sources.center('gfs_namerica', GFS_NC)
  assert lat == pytest.approx(0.5 * (data.latitude[0] + data.latitude[-1]))
  middle = 0.5 * (data.longitude[0] + data.longitude[-1])
  assert lon == pytest.approx((middle + 180.0) % 360.0 - 180.0)
  assert -180.0 <= lon < 180.0 and data.covers(lat, lon)


def test_a_copy_is_checked_by_its_arrays_digest(tmp_path):
  copy = str(tmp_path / 'copy.nc')
  shutil.copy(GFS_NC, copy)
  sha = grib_copy.digest(gridded.read_source(GFS_NC)[1])
  sources.checked_copy(copy, sha)  # The same arrays: accepted.
  with pytest.raises(errors.BadFileError, match='reads to arrays of SHA-256'):
    sources.checked_copy(copy, '0' * 64)
  with pytest.raises(FileNotFoundError, match='no such file'):
    sources.checked_copy(str(tmp_path / 'missing.nc'), sha)
  np.testing.assert_array_equal(gridded.read_source(copy)[1][0],
                                gridded.read_source(GFS_NC)[1][0])
