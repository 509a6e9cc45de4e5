r"""How far the wind at a global grid's seam moved when the seam closed (issue 64).

  python benchmarks/wind_seam.py [FILE]

FILE (default: the shared GFS +72 h global 2.5 deg GRIB2) must be a global
grid (`ble_latex.wind.globe`). In its last cell (the last longitude to the
first + 360) the reader used to hold the last column's wind; it now
interpolates bilinearly to the first column. Prints, at 50, 70 and 100 hPa,
the largest difference between the two (per component, over every latitude
and 11 longitudes across the cell) and, for scale, the same difference
between every other pair of neighbouring columns (largest, and the median
over pairs of each pair's largest). Prints the command, date, machine and
load too.
"""

import datetime as dt
import os
import platform
import sys

import numpy as np

from ble_latex.wind import gridded

DEFAULT = os.path.join(os.path.dirname(__file__), '..', '..', 'shared',
                       'realdata', 'winds',
                       'gfs_2011-10-08T00Z_f072_global_2p5deg.grib2')


def main(argv):
  path = os.path.abspath(argv[1] if len(argv) > 1 else DEFAULT)
  data = gridded.load(path)
  if not data.global_longitude:
    sys.exit(f'wind_seam: {path} is not a global grid')
  now_utc = dt.datetime.now(dt.timezone.utc)
  print(f'command: python {" ".join(argv)}; {now_utc:%Y-%m-%d %H:%M} UTC; '
        f'{platform.node()} ({os.cpu_count()} cores), load '
        f'{os.getloadavg()[0]:.1f}; {path}')
  lat, last = data.latitude, float(data.longitude[-2])
  lats, lons = np.meshgrid(lat, np.linspace(last, data.longitude[-1], 11),
                           indexing='ij')
  for hpa in (50.0, 70.0, 100.0):
    now = data.interpolate(0.0, hpa * 100.0, lats, lons)
    held = data.interpolate(0.0, hpa * 100.0, lats, np.full_like(lons, last))
    gap = np.abs(now - held)
    at = lat[np.unravel_index(gap.argmax(), gap.shape)[0]]
    level = int(np.argmin(np.abs(data.pressure - hpa * 100.0)))
    pairs = np.abs(np.diff(data.uv[0, level], axis=1))[:, :-1]
    per_pair = pairs.max(axis=(0, 2))
    print(f'{hpa:g} hPa: seam cell, held vs bilinear: up to {gap.max():.2f} '
          f'm/s (at {at:g} deg N); other neighbouring columns: up to '
          f'{per_pair.max():.2f} m/s, median of their largest '
          f'{np.median(per_pair):.2f} m/s')


if __name__ == '__main__':
  main(sys.argv)
