# coding=utf-8
"""A GRIB2 wind file's NetCDF copy, for a machine without eccodes.

A lent GPU's image has no eccodes, and eccodes' wheels (with eckit's,
~45 MB) do not fit the device's 64 MiB transfer beside the checkout.
`write_netcdf_copy` decodes the file with the project's reader
(`analysis.open_dataset`: cfgrib + eccodes), writes the winds and their axes
to NetCDF (the CF standard names and units the reader finds), and refuses
a copy that does not read back (`gridded.read_source`) to the same arrays, bit
for bit: times, pressure [Pa], latitude and longitude [deg], u and v [m/s].
`digest` is the arrays' SHA-256, which a run flying the copy records
(`benchmarks/real_winds.py --source_copy`). Command:
`benchmarks/gpu/decode_grib.py`.
"""

import hashlib
from typing import Iterable

import numpy as np

from ble_latex import errors
from ble_latex.wind import analysis
from ble_latex.wind import gridded


def digest(arrays: Iterable[np.ndarray]) -> str:
  """SHA-256 of the arrays' dtypes, shapes and bytes, in order."""
  sha = hashlib.sha256()
  for a in arrays:
    a = np.ascontiguousarray(a)
    sha.update(str((a.dtype, a.shape)).encode())
    sha.update(a.tobytes())
  return sha.hexdigest()


def write_netcdf_copy(grib: str, out: str, *,
                      by: str = 'ble_latex.wind.grib_copy') -> str:
  """Writes `grib`'s winds to the NetCDF file `out`; the arrays' `digest`.

  `by` names the writer in the copy's `source` attribute.

  Raises:
    errors.ConfigError: `grib` is not a GRIB file.
    errors.BadFileError: The copy does not read back to `grib`'s arrays.
  """
  if analysis.kind_of(grib) != 'grib':
    raise errors.ConfigError(f'{grib} is not a GRIB file')
  label, original = gridded.read_source(grib)[:2]
  dataset, _, names = analysis.open_dataset(grib, label)
  u, v = names['variables']
  keep = dataset[[u, v]]
  for name in list(keep.variables):
    attrs = keep[name].attrs
    keep[name].attrs = {k: attrs[k] for k in ('standard_name', 'units',
                                               'long_name') if k in attrs}
  keep.attrs = {'source': f'decoded from {grib} by {by} (cfgrib + eccodes)'}
  keep.to_netcdf(out)
  copy = gridded.read_source(out)[1]
  same = all(a.dtype == b.dtype and a.shape == b.shape and
             np.array_equal(a, b) for a, b in zip(original, copy))
  if not same:
    raise errors.BadFileError(f'{out} does not read back to {grib}\'s arrays')
  return digest(original)
