"""A GRIB2 wind file decoded here into a NetCDF copy, for a machine without eccodes.

  python benchmarks/gpu/decode_grib.py GRIB2_FILE OUT.nc

A lent GPU's image has no eccodes, and eccodes' wheels (with eckit's,
~45 MB) do not fit the device's 64 MiB transfer beside the checkout. This
decodes the file with the project's reader (`analysis.open_dataset`:
cfgrib + eccodes), writes the winds and their axes to NetCDF (the CF
standard names and units the reader finds), and exits 1 unless the copy
reads back (`era5.read_source`) to the same arrays, bit for bit: times,
pressure [Pa], latitude and longitude [deg], u and v [m/s]. Prints the
arrays' SHA-256, which `benchmarks/real_winds.py --source_copy` records.
"""

import hashlib
import sys

import numpy as np

import ble_latex  # pylint: disable=unused-import
from ble_latex.wind import analysis
from ble_latex.wind import era5


def digest(arrays) -> str:
  sha = hashlib.sha256()
  for a in arrays:
    a = np.ascontiguousarray(a)
    sha.update(str((a.dtype, a.shape)).encode())
    sha.update(a.tobytes())
  return sha.hexdigest()


def main(argv) -> int:
  if len(argv) != 3:
    print('usage: decode_grib.py GRIB2_FILE OUT.nc', file=sys.stderr)
    return 2
  grib, out = argv[1], argv[2]
  if analysis.kind_of(grib) != 'grib':
    print(f'decode_grib.py: {grib} is not a GRIB file', file=sys.stderr)
    return 2
  label, original = era5.read_source(grib)[:2]
  dataset, _, names = analysis.open_dataset(grib, label)
  u, v = names['variables']
  keep = dataset[[u, v]]
  for name in list(keep.variables):
    attrs = keep[name].attrs
    keep[name].attrs = {k: attrs[k] for k in ('standard_name', 'units',
                                               'long_name') if k in attrs}
  keep.attrs = {'source': f'decoded from {grib} by benchmarks/gpu/'
                          'decode_grib.py (cfgrib + eccodes)'}
  keep.to_netcdf(out)
  copy = era5.read_source(out)[1]
  same = all(a.dtype == b.dtype and a.shape == b.shape and
             np.array_equal(a, b) for a, b in zip(original, copy))
  if not same:
    print(f'decode_grib.py: {out} does not read back to {grib}\'s arrays',
          file=sys.stderr)
    return 1
  print(digest(original))
  return 0


if __name__ == '__main__':
  sys.exit(main(sys.argv))
