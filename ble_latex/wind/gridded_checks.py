# coding=utf-8
"""Checks of upper-air wind files: whole files, coordinates, units, winds.

The checks `gridded.load` (the reader) runs on every file before its winds
reach a flight, each failure one line (`errors.BadFileError`) that names the
file:
  - `check_file`: a path that is a directory, missing, or cut: NetCDF3
    (classic, 64-bit offset, CDF-5) files shorter than the data and records
    their header declares, NetCDF4 (HDF5) files shorter than the end-of-file
    address of their superblock;
  - `pressure_factor`: the pressure coordinate's `units` (Pa, hPa, mbar) and
    values that contradict them (hPa numbers labelled Pa, and back);
  - `check_coordinates`: NaN/inf, unordered or repeated axis values, times
    not increasing, pressures <= 0, latitudes outside [-90, 90], longitudes
    outside [-180, 360] or holding one meridian twice (-113 and 247);
  - `check_time_steps`: gaps in time (a step longer than `GAP_MEDIAN_FACTOR`
    x the median step or than `MAX_TIME_STEP`), never interpolated across;
  - `check_size`: winds that would not fit this machine's memory once read
    (a crafted file can declare 1e12 values and hold none);
  - `check_winds`: NaN winds (declared fill values) and winds above
    `MAX_WIND_MPS` (undeclared fill values such as 9.97e36, corrupt data).

`expand_paths` turns a path, glob pattern or list of them into the files
to read (a pattern that matches nothing is an error).

Every check takes the source's `label` ('ERA5' by default), the name its
messages give the file, so readers of other CF-style files (GFS analyses)
reuse them.
"""

import glob
import math
import os
import struct
from typing import (BinaryIO, Optional, Sequence, Tuple, TYPE_CHECKING,
                    Union)

import numpy as np

if TYPE_CHECKING:  # xarray loads when a file is read (~2 s).
  import xarray as xr  # pylint: disable=g-bad-import-order

from ble_latex import errors
from ble_latex import safe_io

# `units` attributes of the pressure coordinate, and their factor to Pa.
PRESSURE_UNITS = {'pa': 1.0, 'hpa': 100.0, 'mbar': 100.0, 'millibars': 100.0,
                  'millibar': 100.0, 'mb': 100.0}
# `units` attributes of a wind variable that mean m/s.
WIND_UNITS = ('m s**-1', 'm s-1', 'm/s', 'm.s-1', 'meters per second')
# Largest wind component a file may hold. ERA5's strongest winds (jet
# streams, the stratospheric polar-night jet) stay below it; NetCDF's default
# fill value 9.97e36 written without a `_FillValue` attribute, or corrupt
# data, are far above it. # [m/s]
MAX_WIND_MPS = 200.0
# Pressure values against their `units` (ERA5's levels are 1..1000 hPa):
# hPa (mbar) values above _MAX_HPA are Pa numbers (ERA5's deepest level is
# 1000 hPa; no surface pressure reaches 1100 hPa); Pa values below _MIN_PA
# (ERA5's top level, 1 hPa) are hPa numbers, and Pa values all <=
# _MAX_PA_CHECKED (10 hPa) must be ERA5 levels (100, 200, 300, 500, 700, 1000
# Pa), else they are hPa numbers (e.g. 125, 150 "Pa"). Every real ERA5 level
# set passes, in hPa and in Pa.
_MAX_HPA = 1100.0  # [hPa]
_MIN_PA = 100.0  # [Pa]
_MAX_PA_CHECKED = 1000.0  # [Pa]
# Deepest pressure level a file may hold: no surface pressure reaches it.
MAX_PRESSURE_PA = _MAX_HPA * 100.0  # [Pa]
# Time axis rule: a step between consecutive times (of one file, or of files
# joined along time) longer than GAP_MEDIAN_FACTOR x the median step or than
# MAX_TIME_STEP is a gap (missing data, a missing month, files from other
# years); the winds are not interpolated across it, the data is refused.
GAP_MEDIAN_FACTOR = 2.0
MAX_TIME_STEP = np.timedelta64(24, 'h')
# ERA5's 37 standard pressure levels. # [hPa]
ERA5_PRESSURE_LEVELS_HPA = (
    1, 2, 3, 5, 7, 10, 20, 30, 50, 70, 100, 125, 150, 175, 200, 225, 250, 300,
    350, 400, 450, 500, 550, 600, 650, 700, 750, 775, 800, 825, 850, 875, 900,
    925, 950, 975, 1000)

# NetCDF3 (classic, 64-bit offset, CDF-5) header: type sizes and list tags.
_NC3_TYPE_SIZES = {1: 1, 2: 1, 3: 2, 4: 4, 5: 4, 6: 8, 7: 1, 8: 2, 9: 4,
                   10: 8, 11: 8}  # [bytes]
_NC3_DIMENSION, _NC3_VARIABLE, _NC3_ATTRIBUTE = 0x0A, 0x0B, 0x0C
_HDF5_SIGNATURE = b'\x89HDF\r\n\x1a\n'


def time_text(time: np.datetime64) -> str:
  """A time for messages, to the minute (naive UTC)."""
  return np.datetime_as_string(time, unit='m')


def axis_text(axis: np.ndarray, most: int = 8) -> str:
  """A coordinate axis for messages, shortened to `most` values."""
  values = [f'{v:g}' for v in axis[:most]]
  return '[' + ', '.join(values) + (', ...]' if axis.size > most else ']')


def pressure_factor(coordinate: 'xr.DataArray', path: str, *,
                    label: str = 'ERA5') -> float:
  """Factor that converts the pressure coordinate to Pa.

  Args:
    coordinate: The pressure coordinate.
    path: The file (for errors).
    label: The source's name in errors.

  Returns:
    The factor from the coordinate's units to Pa.

  Raises:
    ValueError: unknown units, or values that contradict the units (see
      `_MAX_HPA`, `_MIN_PA`): hPa numbers labelled Pa or Pa numbers labelled
      hPa.
  """
  unit = str(coordinate.attrs.get('units', '')).strip()
  if unit:
    factor = PRESSURE_UNITS.get(unit.lower())
    if factor is None:
      raise errors.BadFileError(
          f'{label} file {path}: pressure coordinate {coordinate.name!r} has '
          f'unknown units {unit!r} (expected one of '
          f'{sorted(PRESSURE_UNITS)})')
    values = np.asarray(coordinate.values, dtype=np.float64).reshape(-1)
    values = values[np.isfinite(values)]
    if values.size:
      low, high = float(values.min()), float(values.max())
      if factor == 1.0:
        levels_pa = np.array(ERA5_PRESSURE_LEVELS_HPA, dtype=np.float64) * 100
        on_levels = np.isclose(values[:, None], levels_pa, rtol=1e-6,
                               atol=0.0).any(axis=1).all()
        wrong = low < _MIN_PA or (high <= _MAX_PA_CHECKED and not on_levels)
        other = 'hPa'
      else:
        wrong, other = high > _MAX_HPA, 'Pa'
      if wrong:
        raise errors.BadFileError(
            f'{label} file {path}: pressure coordinate {coordinate.name!r} has '
            f'units {unit!r} but values {low:g}..{high:g}, which look like '
            f'{other} (ERA5 levels are 1..1000 hPa = 100..100000 Pa); fix '
            'its units attribute')
    return factor
  # No units: ERA5 levels are 1..1000 hPa, in Pa they are >= 100.
  return 100.0 if float(np.nanmax(coordinate.values)) <= 1100.0 else 1.0


class _HeaderReader:
  """Reads a file's header, with errors when it runs past the end."""

  def __init__(self, file: BinaryIO, size: int, path: str, label: str):
    self._file = file
    self._size = size
    self._path = path
    self._label = label

  def read(self, count: int) -> bytes:
    """The next `count` bytes; ValueError (truncated) if there are fewer."""
    self.need(count)
    return self._file.read(count)

  def need(self, count: int) -> None:
    """ValueError (truncated) if fewer than `count` bytes are left."""
    if count > self._size - self._file.tell():
      raise errors.BadFileError(
          f'{self._label} file {self._path} is truncated: its header runs past '
          f'the end of the file ({self._size} bytes); download it again')

  def corrupt(self, why: str) -> ValueError:
    return errors.BadFileError(
        f'{self._label} file {self._path} is not a readable NetCDF file '
        f'(corrupt NetCDF3 header: {why})')


def _netcdf3_needed_size(file: BinaryIO, size: int, path: str,
                         label: str) -> Tuple[int, str]:
  """Least size of a NetCDF3 file from its header, and what ends there.

  The header (NetCDF classic format spec) gives each variable's type,
  dimensions and data offset (`begin`) and the number of records; the data
  of fixed-size variables ends at begin + size, that of record variables at
  begin + (numrecs - 1) * record size + their size per record. Padding is
  not counted, so a complete file is never too short.

  Args:
    file: The file, positioned at its start.
    size: Its size. # [bytes]
    path: Its path (for errors).
    label: The source's name in errors ('ERA5').

  Returns:
    (least size [bytes], why: what ends there).

  Raises:
    ValueError: a header that runs past the end of the file (truncated) or
      is malformed.
  """
  reader = _HeaderReader(file, size, path, label)
  version = reader.read(4)[3]
  count_size = 8 if version == 5 else 4  # NON_NEG
  offset_size = 4 if version == 1 else 8  # OFFSET

  def number() -> int:
    return int.from_bytes(reader.read(count_size), 'big')

  def skip_name() -> str:
    length = number()
    return reader.read(length + (-length) % 4)[:length].decode(
        'utf-8', 'replace')

  def list_length(tag: int) -> int:
    found, length = struct.unpack('>I', reader.read(4))[0], number()
    if found not in (0, tag) or (found == 0 and length):
      raise reader.corrupt(f'list tag {found:#x} where {tag:#x} belongs')
    reader.need(4 * length)  # Each element takes at least 4 bytes.
    return length

  def skip_attributes():
    for _ in range(list_length(_NC3_ATTRIBUTE)):
      skip_name()
      nc_type = struct.unpack('>I', reader.read(4))[0]
      if nc_type not in _NC3_TYPE_SIZES:
        raise reader.corrupt(f'attribute type {nc_type}')
      nbytes = number() * _NC3_TYPE_SIZES[nc_type]
      reader.read(nbytes + (-nbytes) % 4)

  numrecs = number()
  streaming = numrecs == 2**(8 * count_size) - 1  # Unknown count.
  dims = []
  for _ in range(list_length(_NC3_DIMENSION)):
    skip_name()
    dims.append(number())
  skip_attributes()
  variables = []  # (name, item size, dim lengths, is record, begin)
  for _ in range(list_length(_NC3_VARIABLE)):
    name = skip_name()
    dim_ids = [number() for _ in range(number())]
    if any(i >= len(dims) for i in dim_ids):
      raise reader.corrupt(f'variable {name!r} has dimension ids {dim_ids} '
                           f'but there are {len(dims)} dimensions')
    skip_attributes()
    nc_type = struct.unpack('>I', reader.read(4))[0]
    if nc_type not in _NC3_TYPE_SIZES:
      raise reader.corrupt(f'variable {name!r} has type {nc_type}')
    number()  # vsize: redundant (and clipped for large variables).
    begin = int.from_bytes(reader.read(offset_size), 'big')
    shape = [dims[i] for i in dim_ids]
    is_record = bool(dim_ids) and dims[dim_ids[0]] == 0
    variables.append((name, _NC3_TYPE_SIZES[nc_type],
                      shape[1:] if is_record else shape, is_record, begin))
  needed, what = file.tell(), 'header'
  record = [v for v in variables if v[3]]
  per_record = [item * math.prod(shape) for _, item, shape, _, _ in record]
  # One record variable is not padded; several are, each to 4 bytes.
  record_size = (per_record[0] if len(record) == 1 else
                 sum(n + (-n) % 4 for n in per_record))
  for name, item, shape, is_record, begin in variables:
    if not is_record:
      end = begin + item * math.prod(shape)
    elif streaming or not numrecs:
      continue
    else:
      end = begin + (numrecs - 1) * record_size + item * math.prod(shape)
    if end > needed:
      needed, what = end, f'variable {name!r}'
  return needed, f'its NetCDF3 header puts the end of {what} at byte {needed}'


def _hdf5_needed_size(file: BinaryIO, size: int, path: str,
                      label: str) -> Optional[Tuple[int, str]]:
  """Least size of an HDF5 (NetCDF4) file from its superblock, or None.

  The superblock (at 0, or 512, 1024, ... after a user block) stores the
  end-of-file address; HDF5 files are at least that long.

  Args:
    file: The file.
    size: Its size. # [bytes]
    path: Its path (for errors).
    label: The source's name in errors ('ERA5').

  Returns:
    (least size [bytes], why), or None if the file is not HDF5 or its
    superblock has no end-of-file address.

  Raises:
    ValueError: the superblock itself is cut (truncated).
  """
  offset = 0
  while offset < size:
    file.seek(offset)
    head = file.read(64)
    if head.startswith(_HDF5_SIGNATURE) or _HDF5_SIGNATURE.startswith(head):
      break  # A signature, or the start of one at the end of the file.
    offset = 512 if offset == 0 else 2 * offset
  else:
    return None
  truncated = errors.BadFileError(
      f'{label} file {path} is truncated: its HDF5 superblock is cut at '
      f'{size} bytes; download it again')
  if len(head) < 14:
    raise truncated
  version = head[8]
  if version in (0, 1):
    address_size, start = head[13], 24 if version == 0 else 28
  elif version in (2, 3):
    address_size, start = head[9], 12
  else:
    return None
  if address_size not in (2, 4, 8):
    return None
  # Base address, free-space (v0/1) or extension (v2/3) address, end of file.
  eof_at = start + 2 * address_size
  if len(head) < eof_at + address_size:
    raise truncated
  eof = int.from_bytes(head[eof_at:eof_at + address_size], 'little')
  if eof == 2**(8 * address_size) - 1:
    return None  # Undefined address.
  needed = offset + eof
  return needed, f'its HDF5 superblock puts the end at byte {needed}'


# How to get a missing wind file, by its name's ending (the content, which
# picks the reader, cannot be read).
_HINTS = (((".grib2", ".grb2", ".grib", ".grb"),
           'a GFS analysis: download one with ble-latex-download-gfs'),
          ((".csv", ".txt"), 'a University of Wyoming sounding: save one '
           'from weather.uwyo.edu (docs/winds.md)'))


def missing_hint(path: str, label: str = 'ERA5') -> str:
  """' (what the file is and how to get it)' for a missing wind file."""
  name = os.path.basename(path).lower()
  for endings, hint in _HINTS:
    if name.endswith(endings):
      return f' ({hint})'
  if label == 'ERA5':
    return (' (an ERA5 or other NetCDF analysis: download ERA5 with '
            'ble-latex-download-era5, GFS with ble-latex-download-gfs)')
  return ''


def not_regular(path: str, label: str = 'ERA5') -> None:
  """Refuses a path that exists but is not a regular file (a FIFO, a
  device, a socket) or a symbolic link that loops or dangles.

  Raises:
    errors.BadFileError: One line naming `path` and what it is.
  """
  import stat  # pylint: disable=g-import-not-at-top
  if not os.path.lexists(path):
    return
  try:
    mode = os.stat(path).st_mode
  except OSError as e:  # ELOOP: a symlink loop; ENOENT: a dangling link.
    raise errors.BadFileError(
        f'{label} file {path} is a symbolic link that cannot be followed '
        f'({e.strerror or e})') from e
  if not stat.S_ISREG(mode) and not stat.S_ISDIR(mode):
    kind = ('a FIFO' if stat.S_ISFIFO(mode) else 'a socket' if
            stat.S_ISSOCK(mode) else 'a device')
    raise errors.BadFileError(f'{label} file {path} is {kind}, not a '
                              'regular file')


def check_file(path: str, *, label: str = 'ERA5') -> None:
  """Checks that `path` is a whole file: not a directory, missing or cut.

  NetCDF3 files (classic, 64-bit offset, CDF-5) must hold every variable's
  data and all records their header declares; NetCDF4 (HDF5) files must
  reach the end-of-file address of their superblock. Other files are left
  to the NetCDF library.

  Args:
    path: A file.
    label: The source's name in errors.

  Raises:
    IsADirectoryError: `path` is a directory.
    FileNotFoundError: `path` does not exist.
    ValueError: the file is truncated (shorter than its header says) or its
      NetCDF3 header is malformed.
  """
  if os.path.isdir(path):
    raise IsADirectoryError(
        f'{label} path {path} is a directory, not a NetCDF file (give a file '
        f'or a glob pattern such as {os.path.join(path, "*.nc")})')
  if not os.path.isfile(path):
    not_regular(path, label)
    raise FileNotFoundError(f'{label} file {path} does not exist'
                            f'{missing_hint(path, label)}')
  size = os.path.getsize(path)
  with open(path, 'rb') as file:
    magic = file.read(4)
    file.seek(0)
    if magic[:3] == b'CDF' and magic[3:] in (b'\x01', b'\x02', b'\x05'):
      needed = _netcdf3_needed_size(file, size, path, label)
    else:
      needed = _hdf5_needed_size(file, size, path, label)
  if needed is not None and needed[0] > size:
    raise errors.BadFileError(
        f'{label} file {path} is truncated: it has {size} bytes but '
        f'{needed[1]} (an interrupted download or copy?); download it again')


def check_coordinates(path: str, times: np.ndarray, pressure: np.ndarray,
                      latitude: np.ndarray, longitude: np.ndarray, *,
                      label: str = 'ERA5') -> None:
  """Checks one file's coordinate values as stored (before sorting).

  Args:
    path: The file (for errors).
    times: Its times (datetime64, no NaT).
    pressure: Its pressure levels in the file's units.
    latitude: Its latitudes. # [deg N]
    longitude: Its longitudes. # [deg E]
    label: The source's name in errors.

  Raises:
    errors.BadFileError: NaN/inf coordinates; times not strictly increasing;
      pressure, latitude or longitude not strictly monotonic (duplicates or
      out of order); pressure levels <= 0; latitudes outside [-90, 90];
      longitudes outside [-180, 360], spanning 360 deg or more, or holding
      one meridian twice in the two conventions (e.g. -113 and 247).
  """
  for name, axis in (('pressure', pressure), ('latitude', latitude),
                     ('longitude', longitude)):
    if not np.all(np.isfinite(axis)):
      raise errors.BadFileError(
          f'{label} file {path}: {name} coordinate has NaN/inf '
          'values')
  steps = np.diff(times)
  if np.any(steps <= np.timedelta64(0)):
    i = int(np.nonzero(steps <= np.timedelta64(0))[0][0])
    raise errors.BadFileError(
        f'{label} file {path}: times are not strictly increasing '
        f'({time_text(times[i])} is followed by {time_text(times[i + 1])})')
  for name, axis in (('pressure', pressure), ('latitude', latitude),
                     ('longitude', longitude)):
    steps = np.diff(axis)
    if not (np.all(steps > 0) or np.all(steps < 0)):
      ordered = np.sort(axis)
      repeated = ordered[1:][np.diff(ordered) == 0]
      what = (f'value {repeated[0]:g} more than once' if repeated.size else
              'values out of order')
      raise errors.BadFileError(
          f'{label} file {path}: {name} coordinate is not strictly '
          f'monotonic ({what}: {axis_text(axis)})')
  if pressure.size and pressure.min() <= 0:
    raise errors.BadFileError(
        f'{label} file {path}: pressure level {pressure.min():g} is '
        f'not positive ({axis_text(pressure)})')
  for name, axis, low, high in (('latitude', latitude, -90.0, 90.0),
                                ('longitude', longitude, -180.0, 360.0)):
    outside = axis[(axis < low) | (axis > high)]
    if outside.size:
      raise errors.BadFileError(
          f'{label} file {path}: {name} {outside[0]:g} is outside '
          f'[{low:g}, {high:g}]')
  if longitude.size and longitude.max() - longitude.min() >= 360.0:
    wrapped = (longitude + 180.0) % 360.0 - 180.0
    order = np.argsort(wrapped, kind='stable')
    same = np.nonzero(np.diff(wrapped[order]) == 0)[0]
    if same.size:
      a, b = sorted(longitude[order[same[0]:same[0] + 2]])
      raise errors.BadFileError(
          f'{label} file {path}: longitudes {a:g} and {b:g} are the same '
          'meridian (the file mixes the -180..180 and 0..360 conventions)')
    raise errors.BadFileError(
        f'{label} file {path}: longitudes span {longitude.min():g} to '
        f'{longitude.max():g}, 360 deg or more (use one convention: '
        '-180..180 or 0..360)')


def check_time_steps(times: np.ndarray, sources: Sequence[str], *,
                     label: str = 'ERA5') -> None:
  """Refuses gaps in a sorted time axis (see `GAP_MEDIAN_FACTOR`).

  Args:
    times: Strictly increasing times (datetime64).
    sources: The file each time comes from (for errors).
    label: The source's name in errors.

  Raises:
    ValueError: a step longer than GAP_MEDIAN_FACTOR x the median step or
      than MAX_TIME_STEP; the message names the gap's two times and files.
  """
  steps = np.diff(times)
  if not steps.size:
    return
  median = np.median(steps.astype('timedelta64[s]').astype(np.int64))
  limit = min(GAP_MEDIAN_FACTOR * float(median),
              MAX_TIME_STEP / np.timedelta64(1, 's'))
  seconds = steps / np.timedelta64(1, 's')
  gaps = np.nonzero(seconds > limit)[0]
  if not gaps.size:
    return
  i = int(gaps[0])
  files = (f'{label} file {sources[i]}' if sources[i] == sources[i + 1] else
           f'{label} files {sources[i]} and {sources[i + 1]}')
  raise errors.BadFileError(
      f'{files}: time gap from {time_text(times[i])} to '
      f'{time_text(times[i + 1])} ({seconds[i] / 3600:g} h; the median step '
      f'is {median / 3600:g} h, at most {GAP_MEDIAN_FACTOR:g}x that and '
      f'{MAX_TIME_STEP / np.timedelta64(1, "h"):g} h are allowed): winds are '
      'not interpolated across a gap; download the missing times')


# Bytes a wind value of each component takes while a file is read: u and v
# as float64, their stack and its sorted copy (`gridded.read_file`). # [B]
READ_BYTES_PER_VALUE = 4 * 8


def memory_bytes() -> int:
  """The memory available now (not the physical: other processes hold
  some). # [B]"""
  return safe_io.available_memory_bytes()


def check_size(path: str, shape: Sequence[int], *,
               label: str = 'ERA5') -> None:
  """Refuses winds whose reading needs more than this machine's memory.

  Args:
    path: The file (for errors).
    shape: One wind component's shape, as the file declares it (GRIB2:
      the data points of all its messages, an upper bound).
    label: The source's name in errors.

  Raises:
    errors.BadFileError: `READ_BYTES_PER_VALUE` x the values per component
      is above `memory_bytes()` (checked before anything is read).
  """
  values = math.prod(int(n) for n in shape)
  need, have = values * READ_BYTES_PER_VALUE, memory_bytes()
  if need > have:
    raise errors.BadFileError(
        f'{label} file {path} declares winds of shape {tuple(shape)} '
        f'({values:,} values): reading them needs {need / 2**30:,.1f} '
        f'GiB, more than the {have / 2**30:,.1f} GiB available now (cut the '
        'area or period)')


def check_winds(path: str, uv: np.ndarray, *, names: Sequence[str],
                time_dim: str, times: np.ndarray, pressure: np.ndarray,
                latitude: np.ndarray, longitude: np.ndarray,
                label: str = 'ERA5') -> None:
  """Refuses NaN/inf winds and winds above `MAX_WIND_MPS` in one file.

  Args:
    path: The file (for errors).
    uv: Its winds, (time, pressure, latitude, longitude, 2). # [m/s]
    names: The file's names of u and v.
    time_dim: The file's name of the time dimension.
    times: Its times (datetime64).
    pressure: Its pressure levels. # [Pa]
    latitude: Its latitudes. # [deg N]
    longitude: Its longitudes. # [deg E]
    label: The source's name in errors.

  Raises:
    errors.BadFileError: NaN/inf winds (declared fill values; the counts of
      each component), or |u| or |v| above `MAX_WIND_MPS` (undeclared fill
      values, corrupt data; the first such value and where it is).
  """
  bad = ~np.isfinite(uv)
  if bad.any():
    counts = bad.reshape(-1, 2).sum(axis=0)
    raise errors.BadFileError(
        f'{label} file {path} has NaN/inf winds: {int(counts[0])} values of '
        f'{names[0]} and {int(counts[1])} of {names[1]} (check the requested '
        'area and levels)')
  absurd = np.abs(uv) > MAX_WIND_MPS
  if absurd.any():
    k = 0 if absurd[..., 0].any() else 1
    name = names[k]
    first = tuple(int(i) for i in np.argwhere(absurd[..., k])[0])
    it, ip, ilat, ilon = first
    raise errors.BadFileError(
        f'{label} file {path}: variable {name!r} has '
        f'{int(absurd[..., k].sum())} values with |{name}| > '
        f'{MAX_WIND_MPS:g} m/s (first {uv[first + (k,)]:.4g} m/s at '
        f'{time_dim} {time_text(times[it])}, pressure '
        f'{pressure[ip]:g} Pa, latitude {latitude[ilat]:g}, longitude '
        f'{longitude[ilon]:g}): an undeclared fill value (no _FillValue or '
        'missing_value attribute) or corrupt data')


def check_pressure_pa(path: str, pressure: np.ndarray, *,
                      label: str = 'ERA5') -> None:
  """Refuses levels below the ground (> `MAX_PRESSURE_PA`). # [Pa]"""
  if pressure.max() > MAX_PRESSURE_PA:
    raise errors.BadFileError(
        f'{label} file {path}: pressure level {pressure.max():g} Pa is below '
        f'the ground (levels must be <= {MAX_PRESSURE_PA:g} Pa = '
        f'{MAX_PRESSURE_PA / 100:g} hPa)')


def expand_paths(path: Union[str, Sequence[str]]) -> Tuple[str, ...]:
  """Expands a path, a glob pattern or a list of them into sorted files.

  Args:
    path: A file, a glob pattern (e.g. 'era5_*.nc'), or a list of them; `~`
      and environment variables are expanded.

  Returns:
    The absolute file paths, sorted, without duplicates.

  Raises:
    FileNotFoundError: if a pattern matches nothing or a file is missing.
  """
  patterns = [path] if isinstance(path, (str, os.PathLike)) else list(path)
  if not patterns:
    raise FileNotFoundError('No ERA5 file given (empty path list)')
  files = []
  for pattern in patterns:
    pattern = os.path.expandvars(os.path.expanduser(os.fspath(pattern)))
    if glob.has_magic(pattern):
      matches = glob.glob(pattern)
      if not matches:
        raise FileNotFoundError(f'No ERA5 file matches {pattern} (download '
                                'with ble-latex-download-era5)')
      files.extend(matches)
    else:
      files.append(pattern)
  return tuple(sorted({os.path.abspath(f) for f in files}))
