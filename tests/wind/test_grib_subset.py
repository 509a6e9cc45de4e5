# coding=utf-8
"""Many GRIB2 files of one run load fast and join as read one by one
(issue 64, item 3: "13 files take 58 s to load").

The files are the committed GFS slice's u/v messages at three lead times,
each with messages `gridded.load` must skip (wind direction on the same levels,
u at a height above ground), as a GFS download holds; eccodes writes them.
`benchmarks/grib_load_speed.py` measures the speed on 13 full GFS files.
"""

import pathlib

import numpy as np
import pytest

from ble_latex.wind import grib_subset
from ble_latex.wind import gridded

from tests import helpers

SLICE = (helpers.REAL_WINDS /
         'gfs_2011-10-11T00Z_uv_10-250hPa_2p5deg.grib2')
HOURS = (72, 75, 78)


def _write(path, hour, index):
  """The slice's fields at one lead time (winds + index [m/s]), and others."""
  eccodes = pytest.importorskip('eccodes')
  pytest.importorskip('cfgrib')
  eccodes.codes_grib_multi_support_on()
  try:
    with open(SLICE, 'rb') as f, open(path, 'wb') as out:
      while (field := eccodes.codes_grib_new_from_file(f)) is not None:
        clone = eccodes.codes_clone(field)
        eccodes.codes_set(clone, 'forecastTime', hour)
        values = eccodes.codes_get_values(clone)
        eccodes.codes_set_values(clone, values + index)
        eccodes.codes_write(clone, out)
        for key, value in (('parameterNumber', 0),  # Wind direction.
                           ('typeOfFirstFixedSurface', 103)):  # Above ground.
          other = eccodes.codes_clone(clone)
          eccodes.codes_set(other, key, value)
          eccodes.codes_set_values(other, values + 1000.0)  # Not a wind.
          eccodes.codes_write(other, out)
          eccodes.codes_release(other)
        eccodes.codes_release(clone)
        eccodes.codes_release(field)
  finally:
    eccodes.codes_grib_multi_support_off()
  return str(path)


def test_joined_files_equal_the_files_read_one_by_one(tmp_path, monkeypatch):
  paths = [_write(tmp_path / f'f{h:03d}.grib2', h, i)
           for i, h in enumerate(HOURS)]
  joined = gridded.load(paths)
  assert joined.description == 'GRIB2 run 2011-10-08T00Z +72..+78 h'
  assert joined.times.size == len(HOURS)
  # One by one, each file read whole by cfgrib (no messages skipped).
  monkeypatch.setattr(grib_subset, 'wind_messages', lambda path, out: False)
  for k, path in enumerate(paths):
    one = gridded.load(path)
    assert one.time_invariant and one.times[0] == joined.times[k]
    np.testing.assert_array_equal(one.uv[0], joined.uv[k])
    for name in ('pressure', 'latitude', 'longitude'):
      np.testing.assert_array_equal(getattr(one, name),
                                    getattr(joined, name))
  # Not the others' values (+1000 m/s): the slice's winds + k, to the
  # packing's precision (re-encoded by eccodes).
  reference = gridded.load(str(SLICE))
  for k in range(len(HOURS)):
    np.testing.assert_allclose(joined.uv[k], reference.uv[0] + k, atol=0.51)


def test_only_messages_that_are_not_winds_are_skipped(tmp_path):
  eccodes = pytest.importorskip('eccodes')
  path = _write(tmp_path / 'f072.grib2', 72, 0)
  whole = pathlib.Path(path).read_bytes()
  subset = tmp_path / 'kept.grib2'
  assert grib_subset.wind_messages(path, str(subset))
  assert 0 < subset.stat().st_size < len(whole)
  counts = []
  for name in (path, subset):
    with open(name, 'rb') as f:
      counts.append(eccodes.codes_count_in_file(f))
  assert counts[0] == 3 * counts[1]  # Each wind with its two others.
  # A file it cannot frame (truncated, or a length past its end) is read
  # whole, for cfgrib to judge.
  cut = tmp_path / 'cut.grib2'
  cut.write_bytes(whole[:-10])
  assert not grib_subset.wind_messages(str(cut), str(subset))
  huge = bytearray(whole)
  huge[8:16] = (2**62).to_bytes(8, 'big')  # Section 0's total length.
  cut.write_bytes(bytes(huge))
  assert not grib_subset.wind_messages(str(cut), str(subset))
  # A file of winds only is read whole.
  assert not grib_subset.wind_messages(str(SLICE), str(subset))
