"""A GRIB2 wind file decoded here into a NetCDF copy, for a machine without eccodes.

  python benchmarks/gpu/decode_grib.py GRIB2_FILE OUT.nc

A lent GPU's image has no eccodes (`ble_latex.wind.grib_copy`, which does
the work): this writes the winds and their axes to NetCDF and exits 1
unless the copy reads back to the same arrays, bit for bit. Prints the
arrays' SHA-256 (`grib_copy.digest`), which `benchmarks/real_winds.py
--source_copy` checks (`ble_latex.wind.sources.checked_copy`) and records.
"""

import sys

import ble_latex  # pylint: disable=unused-import
from ble_latex import errors
from ble_latex.wind import grib_copy


def main(argv) -> int:
  if len(argv) != 3:
    print('usage: decode_grib.py GRIB2_FILE OUT.nc', file=sys.stderr)
    return 2
  grib, out = argv[1], argv[2]
  try:
    print(grib_copy.write_netcdf_copy(grib, out,
                                      by='benchmarks/gpu/decode_grib.py'))
  except errors.BadFileError as e:
    print(f'decode_grib.py: {e}', file=sys.stderr)
    return 1
  except errors.ConfigError as e:
    print(f'decode_grib.py: {e}', file=sys.stderr)
    return 2
  return 0


if __name__ == '__main__':
  sys.exit(main(sys.argv))
