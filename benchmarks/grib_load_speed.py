# coding=utf-8
"""How long `gridded.load` takes on many GRIB2 files of one run (issue 64).

Writes `--files` copies of a GFS GRIB2 file (default: the shared +72 h
global file, ~350 messages of which 52 are u/v on pressure levels) with
lead times +72, +75, ... h (eccodes, one field a message), then loads them as one time series
twice in one process: 'before' with the reader of 6e67606 (every message
indexed by cfgrib three times: headers, then u, then v), 'after' with
today's (`grib_subset.wind_messages`, one index). Checks both give the same
winds and writes the seconds and their ratio as JSON.

  .venv/bin/python benchmarks/grib_load_speed.py \
      [--grib=/work/shared/realdata/winds/gfs_2011-10-08T00Z_f072_global_2p5deg.grib2]
      [--files=13] [--output=benchmarks/records/grib_load_speed.json]
"""

import argparse
import datetime as dt
import json
import os
import platform
import tempfile
import time

import numpy as np

from ble_latex import safe_io
from ble_latex.run import episode_log
from ble_latex.wind import analysis
from ble_latex.wind import gridded
from ble_latex.wind import gridded_checks

DEFAULT_GRIB = ('/work/shared/realdata/winds/'
                'gfs_2011-10-08T00Z_f072_global_2p5deg.grib2')


def write_copies(source: str, folder: str, files: int):
  """`files` copies of `source`, lead time + 3 h each (eccodes)."""
  import eccodes  # pylint: disable=g-import-not-at-top
  paths = []
  eccodes.codes_grib_multi_support_on()  # u and v share messages there.
  try:
    for i in range(files):
      path = os.path.join(folder, f'gfs_copy{i:02d}.grib2')
      with open(source, 'rb') as f, open(path, 'wb') as out:
        while (handle := eccodes.codes_grib_new_from_file(f)) is not None:
          clone = eccodes.codes_clone(handle)  # One field a message.
          try:
            hour = eccodes.codes_get(clone, 'forecastTime')
            eccodes.codes_set(clone, 'forecastTime', hour + 3 * i)
          except eccodes.GribInternalError:
            pass  # A message without a lead time: copied as it is.
          eccodes.codes_write(clone, out)
          eccodes.codes_release(clone)
          eccodes.codes_release(handle)
      paths.append(path)
  finally:
    eccodes.codes_grib_multi_support_off()
  return paths


def open_grib_before(path, label, folder):
  """The reader of 6e67606: all messages, indexed three times."""
  del folder
  import cfgrib  # pylint: disable=g-import-not-at-top
  import xarray as xr  # pylint: disable=g-import-not-at-top
  stream = cfgrib.FileStream(path, errors='raise')
  messages = [m for _, m in stream.items()]
  points = sum(int(m['numberOfDataPoints']) for m in messages)
  gridded_checks.check_size(path, (points,), label=label)
  analysis._check_unique_messages(path, label, messages)  # pylint: disable=protected-access
  parts = []
  with analysis._quiet_cfgrib():  # pylint: disable=protected-access
    for short in ('u', 'v'):
      part = xr.open_dataset(
          path, engine='cfgrib', backend_kwargs={
              'indexpath': '', 'errors': 'raise', 'filter_by_keys': {
                  'typeOfLevel': 'isobaricInhPa', 'shortName': short}})
      parts.append(part.load())
  return xr.merge(parts, compat='override')


def timed_load(paths):
  gridded._load_cached.cache_clear()  # pylint: disable=protected-access
  start = time.perf_counter()
  data = gridded.load(paths)
  return time.perf_counter() - start, data


def main():
  parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
  parser.add_argument('--grib', default=DEFAULT_GRIB)
  parser.add_argument('--files', type=int, default=13)
  parser.add_argument('--output', default=str(episode_log.RECORDS_DIR / 'grib_load_speed.json'))
  args = parser.parse_args()
  if safe_io.output_problem(args.output):
    parser.error(f'--output: {safe_io.output_problem(args.output)}')
  import cfgrib  # pylint: disable=g-import-not-at-top,unused-import
  import xarray  # pylint: disable=g-import-not-at-top,unused-import
  with tempfile.TemporaryDirectory() as folder:
    paths = write_copies(args.grib, folder, args.files)
    timed_load(paths[:1])  # Warm: imports, eccodes' definitions.
    after_s, after = timed_load(paths)
    today = analysis._open_grib  # pylint: disable=protected-access
    analysis._open_grib = open_grib_before  # pylint: disable=protected-access
    try:
      before_s, before = timed_load(paths)
    finally:
      analysis._open_grib = today  # pylint: disable=protected-access
  np.testing.assert_array_equal(before.uv, after.uv)
  result = {
      'command': 'python benchmarks/grib_load_speed.py '
                 f'--grib={args.grib} --files={args.files}',
      'date_utc': dt.datetime.now(dt.timezone.utc).isoformat(
          timespec='seconds'),
      'machine': f'{platform.node()} {os.cpu_count()} cpus',
      'load_average': os.getloadavg(),
      'files': args.files,
      'shape': list(after.uv.shape),
      'wind_source': after.description,
      'before_s': round(before_s, 2),
      'after_s': round(after_s, 2),
      'speedup': round(before_s / after_s, 2),
  }
  print(json.dumps(result, indent=1))
  safe_io.atomic_write(args.output, json.dumps(result, indent=1) + '\n')


if __name__ == '__main__':
  main()
