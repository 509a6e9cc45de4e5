# coding=utf-8
"""ERA5 reanalysis winds as a BLE wind field, and the CDS request builder.

The paper flies its balloon in ERA5 reanalysis winds (u, v on pressure
levels, 1 Nov 2022 - 31 Jan 2023, around lon -113, lat 1, 0.4 degree grid,
2000-17 500 Pa, 6-hourly) with BLE's simplex noise on top to emulate forecast
error. `Era5WindField` is that wind field: a `wind_field.WindField` whose
forecast is the ERA5 wind interpolated multi-linearly in (time, pressure,
latitude, longitude), and whose ground truth is forecast + BLE's
`SimplexWindNoise` (switch the noise off with `add_noise=False`).

Files: NetCDF files of the CDS dataset `reanalysis-era5-pressure-levels` with
variables `u` and `v` [m/s], in either layout
  - new CDS (2024-): dims `valid_time`, `pressure_level`, `latitude`,
    `longitude`;
  - old CDS: dims `time`, `level`, `latitude`, `longitude`;
pressure levels in hPa (or Pa, from the `units` attribute), latitude in any
order (ERA5 stores it descending), longitude in -180..180 or 0..360. A list of
files or a glob pattern (e.g. one file per month) is joined along time.

Loading checks the files: truncated files (NetCDF3: shorter than the header's
variables and records; NetCDF4: shorter than the HDF5 superblock's end of
file), pressure values that contradict their `units`, NaN winds (declared
fill values) and winds above `MAX_WIND_MPS` (undeclared fill values such as
9.97e36, corrupt data) are errors naming the file, and so are coordinates
no real ERA5 file holds: latitudes outside [-90, 90], longitudes outside
[-180, 360] or holding one meridian twice (-113 and 247: both conventions),
axes with duplicate or unordered values, pressure levels <= 0 or below the
ground (> 1100 hPa), times not increasing, and gaps in time (a step longer
than twice the median step or than 24 h, in one file or between joined
files), which are never interpolated across.

`build_requests` builds the exact `cdsapi` requests for such files
(`ble-latex-download-era5`, `ble_latex.cli.download_era5`, fetches them).
"""

import calendar
import dataclasses
import datetime as dt
import functools
import glob
import math
import os
import struct
from typing import (Any, BinaryIO, Dict, List, Optional, Sequence, Tuple,
                    TYPE_CHECKING, Union)

from balloon_learning_environment.env import wind_field
from balloon_learning_environment.utils import spherical_geometry
from balloon_learning_environment.utils import units
import gin
import jax
from jax import numpy as jnp
import numpy as np
import s2sphere as s2

if TYPE_CHECKING:  # xarray, pandas and SciPy load when a file is read (~2 s).
  import xarray as xr  # pylint: disable=g-bad-import-order

from ble_latex import errors


# Dimension names accepted in the files, new CDS layout first.
TIME_DIMS = ('valid_time', 'time')
PRESSURE_DIMS = ('pressure_level', 'level', 'isobaricInhPa', 'plev')
LATITUDE_DIMS = ('latitude', 'lat')
LONGITUDE_DIMS = ('longitude', 'lon')
WIND_VARIABLES = ('u', 'v')

# `units` attributes of the pressure coordinate, and their factor to Pa.
_PRESSURE_UNITS = {'pa': 1.0, 'hpa': 100.0, 'mbar': 100.0, 'millibars': 100.0,
                   'millibar': 100.0, 'mb': 100.0}
_WIND_UNITS = ('m s**-1', 'm s-1', 'm/s', 'm.s-1', 'meters per second')
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

# The paper's ERA5 data (Saunders et al. 2023, "RL problem", Wind).
DATASET = 'reanalysis-era5-pressure-levels'
PAPER_CENTER_LAT = 1.0  # [deg N]
PAPER_CENTER_LON = -113.0  # [deg E]
PAPER_START_DATE = dt.date(2022, 11, 1)
PAPER_END_DATE = dt.date(2023, 1, 31)
PAPER_MIN_PRESSURE_HPA = 20.0  # [hPa] = 2000 Pa
PAPER_MAX_PRESSURE_HPA = 175.0  # [hPa] = 17 500 Pa
PAPER_GRID_DEG = 0.4  # [deg]
PAPER_TIMES = ('00:00', '06:00', '12:00', '18:00')
# The held-out split of the paper's period by dates: flights start inside
# [first, end) of their split (`Era5WindField.start_dates`). Each gap is one
# 3-day episode, so a training flight never flies a validation or evaluation
# flight's winds (the last training start, 12 Dec 23:59, lands before 16 Dec).
DATE_SPLITS = {
    'train': ('2022-11-01', '2022-12-13'),
    'validation': ('2022-12-16', '2022-12-29'),
    'eval': ('2023-01-01', '2023-01-29'),
}
# Covers the 200 km start radius and the 500 km the balloon may drift.
DEFAULT_HALF_WIDTH_DEG = 5.0  # [deg]
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


@dataclasses.dataclass(frozen=True, eq=False)
class Era5Data:
  """ERA5 u, v on a regular (time, pressure, latitude, longitude) grid.

  All axes are strictly ascending; the arrays are read-only.

  Attributes:
    paths: The files the data came from.
    times: Grid times, naive UTC.
    time_s: Grid times relative to times[0]. # [s]
    pressure: Pressure levels. # [Pa]
    latitude: Latitudes. # [deg N]
    longitude: Longitudes (the file's convention). # [deg E]
    uv: Winds, shape (time, pressure, lat, lon, 2): eastward u and northward
      v. # [m/s]
  """
  paths: Tuple[str, ...]
  times: np.ndarray
  time_s: np.ndarray
  pressure: np.ndarray
  latitude: np.ndarray
  longitude: np.ndarray
  uv: np.ndarray

  def __post_init__(self):
    import scipy.interpolate  # pylint: disable=g-import-not-at-top
    axes = (self.time_s, self.pressure, self.latitude, self.longitude)
    object.__setattr__(self, '_interpolator',
                       scipy.interpolate.RegularGridInterpolator(
                           axes, self.uv, method='linear', bounds_error=False,
                           fill_value=None))
    object.__setattr__(self, '_low', np.array([a[0] for a in axes]))
    object.__setattr__(self, '_high', np.array([a[-1] for a in axes]))

  @property
  def start(self) -> dt.datetime:
    """First time in the data, UTC."""
    return _to_datetime(self.times[0])

  @property
  def end(self) -> dt.datetime:
    """Last time in the data, UTC."""
    return _to_datetime(self.times[-1])

  def wrap_longitude(self, lon: Union[float, np.ndarray]) -> np.ndarray:
    """Maps longitudes to the file's convention (within 180 deg of its centre).

    Args:
      lon: Longitudes in any convention. # [deg E]

    Returns:
      The same longitudes, shifted by multiples of 360 to lie within 180 deg
      of the centre of the file's longitude range. # [deg E]
    """
    centre = 0.5 * (self.longitude[0] + self.longitude[-1])
    return (np.asarray(lon, dtype=np.float64) - centre + 180.0) % 360.0 - (
        180.0 - centre)

  def covers(self, lat: float, lon: float) -> bool:
    """Whether the file's area holds (lat [deg N], lon [deg E], any convention)."""
    lon = float(self.wrap_longitude(lon))
    return bool(self.latitude[0] <= lat <= self.latitude[-1] and
                self.longitude[0] <= lon <= self.longitude[-1])

  def interpolate(self, time_s: Union[float, np.ndarray],
                  pressure: Union[float, np.ndarray],
                  latitude: Union[float, np.ndarray],
                  longitude: Union[float, np.ndarray]) -> np.ndarray:
    """Multi-linear interpolation of (u, v), clipped to the grid's edges.

    Inputs broadcast against each other. Points outside the grid take the
    value at the nearest edge in each axis (as BLE's generative wind field
    extends itself beyond its limits), so the field is constant beyond its
    time range, pressure range and area.

    Args:
      time_s: Time since `times[0]`. # [s]
      pressure: Pressure. # [Pa]
      latitude: Latitude. # [deg N]
      longitude: Longitude, any convention. # [deg E]

    Returns:
      Array of shape broadcast(inputs) + (2,) holding (u, v). # [m/s]
    """
    t, p, lat, lon = np.broadcast_arrays(
        np.asarray(time_s, dtype=np.float64),
        np.asarray(pressure, dtype=np.float64),
        np.asarray(latitude, dtype=np.float64),
        self.wrap_longitude(longitude))
    points = np.stack([t, p, lat, lon], axis=-1)
    points = np.clip(points, self._low, self._high)  # pytype: disable=attribute-error
    uv = self._interpolator(points.reshape(-1, 4))  # pytype: disable=attribute-error
    return uv.reshape(t.shape + (2,))


def _to_datetime(time: np.datetime64) -> dt.datetime:
  """A numpy datetime64 (naive UTC) as a timezone-aware UTC datetime."""
  seconds = (time - np.datetime64('1970-01-01T00:00:00')) / np.timedelta64(
      1, 's')
  return dt.datetime(1970, 1, 1, tzinfo=dt.timezone.utc) + dt.timedelta(
      seconds=float(seconds))


def _find_dim(dims: Sequence[str], candidates: Sequence[str], what: str,
              path: str, variable: str) -> str:
  for name in candidates:
    if name in dims:
      return name
  raise errors.BadFileError(
      f'ERA5 file {path} has no {what} dimension (expected one of '
      f'{list(candidates)}; variable {variable!r} has dims {list(dims)})')


def find_time_dim(dataset: 'xr.Dataset') -> Optional[str]:
  """The name of the time dimension of an ERA5 dataset, or None."""
  for name in TIME_DIMS:
    if name in dataset.dims:
      return name
  return None


def _pressure_factor(coordinate: 'xr.DataArray', path: str) -> float:
  """Factor that converts the pressure coordinate to Pa.

  Args:
    coordinate: The pressure coordinate.
    path: The file (for errors).

  Returns:
    The factor from the coordinate's units to Pa.

  Raises:
    ValueError: unknown units, or values that contradict the units (see
      `_MAX_HPA`, `_MIN_PA`): hPa numbers labelled Pa or Pa numbers labelled
      hPa.
  """
  unit = str(coordinate.attrs.get('units', '')).strip()
  if unit:
    factor = _PRESSURE_UNITS.get(unit.lower())
    if factor is None:
      raise errors.BadFileError(
          f'ERA5 file {path}: pressure coordinate {coordinate.name!r} has '
          f'unknown units {unit!r} (expected one of '
          f'{sorted(_PRESSURE_UNITS)})')
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
            f'ERA5 file {path}: pressure coordinate {coordinate.name!r} has '
            f'units {unit!r} but values {low:g}..{high:g}, which look like '
            f'{other} (ERA5 levels are 1..1000 hPa = 100..100000 Pa); fix '
            'its units attribute')
    return factor
  # No units: ERA5 levels are 1..1000 hPa, in Pa they are >= 100.
  return 100.0 if float(np.nanmax(coordinate.values)) <= 1100.0 else 1.0


def _read_variable(dataset: 'xr.Dataset', name: str,
                   path: str) -> 'xr.DataArray':
  """Variable `name` as (time, pressure, latitude, longitude) array."""
  if name not in dataset.data_vars:
    raise errors.BadFileError(
        f'ERA5 file {path} has no variable {name!r} (found: '
        f'{sorted(str(v) for v in dataset.data_vars)})')
  array = dataset[name]
  unit = str(array.attrs.get('units', '')).strip()
  if unit and unit not in _WIND_UNITS:
    raise errors.BadFileError(
        f'ERA5 file {path}: variable {name!r} has units {unit!r}, '
        f'expected m/s ({list(_WIND_UNITS)})')
  dims = [str(d) for d in array.dims]
  wanted = [_find_dim(dims, TIME_DIMS, 'time', path, name),
            _find_dim(dims, PRESSURE_DIMS, 'pressure-level', path, name),
            _find_dim(dims, LATITUDE_DIMS, 'latitude', path, name),
            _find_dim(dims, LONGITUDE_DIMS, 'longitude', path, name)]
  for dim in dims:
    if dim in wanted:
      continue
    if dim == 'expver':
      # Old CDS files mixing final ERA5 (expver 1) and preliminary ERA5T
      # (expver 5): each time is valid in exactly one of them.
      parts = [array.isel(expver=i) for i in range(array.sizes[dim])]
      array = functools.reduce(lambda a, b: a.combine_first(b), parts)
    elif array.sizes[dim] == 1:
      array = array.isel({dim: 0})
    else:
      raise errors.BadFileError(
          f'ERA5 file {path}: variable {name!r} has an unexpected dimension '
          f'{dim!r} of size {array.sizes[dim]} (expected dims {wanted})')
  for dim in wanted:
    if dim not in array.coords:
      raise errors.BadFileError(
          f'ERA5 file {path} has no coordinate values for '
          f'dimension {dim!r}')
  return array.transpose(*wanted)


class _HeaderReader:
  """Reads a file's header, with errors when it runs past the end."""

  def __init__(self, file: BinaryIO, size: int, path: str):
    self._file = file
    self._size = size
    self._path = path

  def read(self, count: int) -> bytes:
    """The next `count` bytes; ValueError (truncated) if there are fewer."""
    self.need(count)
    return self._file.read(count)

  def need(self, count: int) -> None:
    """ValueError (truncated) if fewer than `count` bytes are left."""
    if count > self._size - self._file.tell():
      raise errors.BadFileError(
          f'ERA5 file {self._path} is truncated: its header runs past the end '
          f'of the file ({self._size} bytes); download it again')

  def corrupt(self, why: str) -> ValueError:
    return errors.BadFileError(
        f'ERA5 file {self._path} is not a readable NetCDF file '
        f'(corrupt NetCDF3 header: {why})')


def _netcdf3_needed_size(file: BinaryIO, size: int,
                         path: str) -> Tuple[int, str]:
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

  Returns:
    (least size [bytes], why: what ends there).

  Raises:
    ValueError: a header that runs past the end of the file (truncated) or
      is malformed.
  """
  reader = _HeaderReader(file, size, path)
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


def _hdf5_needed_size(file: BinaryIO, size: int,
                      path: str) -> Optional[Tuple[int, str]]:
  """Least size of an HDF5 (NetCDF4) file from its superblock, or None.

  The superblock (at 0, or 512, 1024, ... after a user block) stores the
  end-of-file address; HDF5 files are at least that long.

  Args:
    file: The file.
    size: Its size. # [bytes]
    path: Its path (for errors).

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
      f'ERA5 file {path} is truncated: its HDF5 superblock is cut at '
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


def check_file(path: str) -> None:
  """Checks that `path` is a whole file: not a directory, missing or cut.

  NetCDF3 files (classic, 64-bit offset, CDF-5) must hold every variable's
  data and all records their header declares; NetCDF4 (HDF5) files must
  reach the end-of-file address of their superblock. Other files are left
  to the NetCDF library.

  Args:
    path: A file.

  Raises:
    IsADirectoryError: `path` is a directory.
    FileNotFoundError: `path` does not exist.
    ValueError: the file is truncated (shorter than its header says) or its
      NetCDF3 header is malformed.
  """
  if os.path.isdir(path):
    raise IsADirectoryError(
        f'ERA5 path {path} is a directory, not a NetCDF file (give a file or '
        f'a glob pattern such as {os.path.join(path, "era5_*.nc")})')
  if not os.path.isfile(path):
    raise FileNotFoundError(f'ERA5 file {path} does not exist (download it '
                            'with ble-latex-download-era5)')
  size = os.path.getsize(path)
  with open(path, 'rb') as file:
    magic = file.read(4)
    file.seek(0)
    if magic[:3] == b'CDF' and magic[3:] in (b'\x01', b'\x02', b'\x05'):
      needed = _netcdf3_needed_size(file, size, path)
    else:
      needed = _hdf5_needed_size(file, size, path)
  if needed is not None and needed[0] > size:
    raise errors.BadFileError(
        f'ERA5 file {path} is truncated: it has {size} bytes but {needed[1]} '
        '(an interrupted download or copy?); download it again')


def _open(path: str) -> 'xr.Dataset':
  """Opens one NetCDF file, with errors that name the file."""
  check_file(path)
  import xarray as xr  # pylint: disable=g-import-not-at-top,redefined-outer-name
  try:
    return xr.open_dataset(path)
  except Exception as error:  # pylint: disable=broad-except
    raise errors.BadFileError(f'ERA5 file {path} is not a readable NetCDF file '
                              f'({type(error).__name__}: {error})') from error


def _check_coordinates(path: str, times: np.ndarray, pressure: np.ndarray,
                       latitude: np.ndarray, longitude: np.ndarray) -> None:
  """Checks one file's coordinate values as stored (before sorting).

  Args:
    path: The file (for errors).
    times: Its times (datetime64, no NaT).
    pressure: Its pressure levels in the file's units.
    latitude: Its latitudes. # [deg N]
    longitude: Its longitudes. # [deg E]

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
          f'ERA5 file {path}: {name} coordinate has NaN/inf '
          'values')
  steps = np.diff(times)
  if np.any(steps <= np.timedelta64(0)):
    i = int(np.nonzero(steps <= np.timedelta64(0))[0][0])
    raise errors.BadFileError(
        f'ERA5 file {path}: times are not strictly increasing '
        f'({_time_text(times[i])} is followed by {_time_text(times[i + 1])})')
  for name, axis in (('pressure', pressure), ('latitude', latitude),
                     ('longitude', longitude)):
    steps = np.diff(axis)
    if not (np.all(steps > 0) or np.all(steps < 0)):
      ordered = np.sort(axis)
      repeated = ordered[1:][np.diff(ordered) == 0]
      what = (f'value {repeated[0]:g} more than once' if repeated.size else
              'values out of order')
      raise errors.BadFileError(
          f'ERA5 file {path}: {name} coordinate is not strictly '
          f'monotonic ({what}: {_axis_text(axis)})')
  if pressure.size and pressure.min() <= 0:
    raise errors.BadFileError(
        f'ERA5 file {path}: pressure level {pressure.min():g} is '
        f'not positive ({_axis_text(pressure)})')
  for name, axis, low, high in (('latitude', latitude, -90.0, 90.0),
                                ('longitude', longitude, -180.0, 360.0)):
    outside = axis[(axis < low) | (axis > high)]
    if outside.size:
      raise errors.BadFileError(
          f'ERA5 file {path}: {name} {outside[0]:g} is outside '
          f'[{low:g}, {high:g}]')
  if longitude.size and longitude.max() - longitude.min() >= 360.0:
    wrapped = (longitude + 180.0) % 360.0 - 180.0
    order = np.argsort(wrapped, kind='stable')
    same = np.nonzero(np.diff(wrapped[order]) == 0)[0]
    if same.size:
      a, b = sorted(longitude[order[same[0]:same[0] + 2]])
      raise errors.BadFileError(
          f'ERA5 file {path}: longitudes {a:g} and {b:g} are the same '
          'meridian (the file mixes the -180..180 and 0..360 conventions)')
    raise errors.BadFileError(
        f'ERA5 file {path}: longitudes span {longitude.min():g} to '
        f'{longitude.max():g}, 360 deg or more (use one convention: '
        '-180..180 or 0..360)')


def _time_text(time: np.datetime64) -> str:
  return np.datetime_as_string(time, unit='m')


def _axis_text(axis: np.ndarray, most: int = 8) -> str:
  """A coordinate axis for messages, shortened to `most` values."""
  values = [f'{v:g}' for v in axis[:most]]
  return '[' + ', '.join(values) + (', ...]' if axis.size > most else ']')


def _check_time_steps(times: np.ndarray, sources: Sequence[str]) -> None:
  """Refuses gaps in a sorted time axis (see `GAP_MEDIAN_FACTOR`).

  Args:
    times: Strictly increasing times (datetime64).
    sources: The file each time comes from (for errors).

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
  files = (f'ERA5 file {sources[i]}' if sources[i] == sources[i + 1] else
           f'ERA5 files {sources[i]} and {sources[i + 1]}')
  raise errors.BadFileError(
      f'{files}: time gap from {_time_text(times[i])} to '
      f'{_time_text(times[i + 1])} ({seconds[i] / 3600:g} h; the median step '
      f'is {median / 3600:g} h, at most {GAP_MEDIAN_FACTOR:g}x that and '
      f'{MAX_TIME_STEP / np.timedelta64(1, "h"):g} h are allowed): winds are '
      'not interpolated across a gap; download the missing times')


def _read_file(path: str) -> Tuple[np.ndarray, np.ndarray, np.ndarray,
                                   np.ndarray, np.ndarray]:
  """Reads one file: (times, pressure [Pa], lat, lon, uv), axes sorted."""
  with _open(path) as dataset:
    u = _read_variable(dataset, 'u', path)
    v = _read_variable(dataset, 'v', path)
    if u.dims != v.dims or u.shape != v.shape:
      raise errors.BadFileError(
          f'ERA5 file {path}: u has dims {u.dims} {u.shape} but '
          f'v has dims {v.dims} {v.shape}')
    time_dim, pressure_dim, lat_dim, lon_dim = u.dims
    times = u[time_dim].values
    if not np.issubdtype(times.dtype, np.datetime64):
      raise errors.BadFileError(
          f'ERA5 file {path}: time coordinate {time_dim!r} is '
          f'not a date/time (dtype {times.dtype})')
    if np.isnat(times).any():
      raise errors.BadFileError(
          f'ERA5 file {path}: time coordinate {time_dim!r} has '
          'missing (NaT) values')
    pressure = u[pressure_dim].values.astype(np.float64)
    latitude = u[lat_dim].values.astype(np.float64)
    longitude = u[lon_dim].values.astype(np.float64)
    _check_coordinates(path, times, pressure, latitude, longitude)
    pressure = pressure * _pressure_factor(u[pressure_dim], path)
    if pressure.max() > MAX_PRESSURE_PA:
      raise errors.BadFileError(
          f'ERA5 file {path}: pressure level {pressure.max():g} Pa is below '
          f'the ground (levels must be <= {MAX_PRESSURE_PA:g} Pa = '
          f'{MAX_PRESSURE_PA / 100:g} hPa)')
    try:
      uv = np.stack([u.values.astype(np.float64),
                     v.values.astype(np.float64)], axis=-1)
    except Exception as error:  # pylint: disable=broad-except
      raise errors.BadFileError(
          f'ERA5 file {path} is corrupt or truncated: reading '
          f'its winds failed ({type(error).__name__}: {error})') from error
  bad = ~np.isfinite(uv)
  if bad.any():
    counts = bad.reshape(-1, 2).sum(axis=0)
    raise errors.BadFileError(
        f'ERA5 file {path} has NaN/inf winds: {int(counts[0])} values of u '
        f'and {int(counts[1])} of v (check the requested area and levels)')
  absurd = np.abs(uv) > MAX_WIND_MPS
  if absurd.any():
    k = 0 if absurd[..., 0].any() else 1
    name = WIND_VARIABLES[k]
    first = tuple(int(i) for i in np.argwhere(absurd[..., k])[0])
    it, ip, ilat, ilon = first
    raise errors.BadFileError(
        f'ERA5 file {path}: variable {name!r} has '
        f'{int(absurd[..., k].sum())} values with |{name}| > '
        f'{MAX_WIND_MPS:g} m/s (first {uv[first + (k,)]:.4g} m/s at '
        f'{time_dim} {np.datetime_as_string(times[it], unit="m")}, pressure '
        f'{pressure[ip]:g} Pa, latitude {latitude[ilat]:g}, longitude '
        f'{longitude[ilon]:g}): an undeclared fill value (no _FillValue or '
        'missing_value attribute) or corrupt data')
  orders = [np.argsort(a, kind='stable')
            for a in (times, pressure, latitude, longitude)]
  uv = uv[np.ix_(*orders)]
  return (times[orders[0]], pressure[orders[1]], latitude[orders[2]],
          longitude[orders[3]], uv)


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


def load(path: Union[str, Sequence[str]]) -> Era5Data:
  """Loads ERA5 u, v from one or more files (joined along time).

  Results are cached per (files, modification times), so several
  environments share one copy.

  Args:
    path: A file, a glob pattern, or a list of them (see `expand_paths`).

  Returns:
    The data on ascending axes, pressure in Pa.

  Raises:
    FileNotFoundError: a file is missing.
    IsADirectoryError: a path (or a glob's match) is a directory.
    errors.BadFileError (a ValueError): a file is not NetCDF, is
      truncated, lacks a variable, dimension or coordinate, has pressure
      values that contradict their units, NaN winds (e.g. declared fill
      values) or winds above `MAX_WIND_MPS` (e.g. undeclared fill values),
      impossible coordinates (`_check_coordinates`), a gap in time
      (`_check_time_steps`), or files do not share one grid.
  """
  paths = expand_paths(path)
  for p in paths:
    if os.path.isdir(p) or not os.path.isfile(p):
      check_file(p)  # Raises.
  stamps = tuple((p, os.stat(p).st_mtime_ns, os.stat(p).st_size)
                 for p in paths)
  return _load_cached(stamps)


@functools.lru_cache(maxsize=4)
def _load_cached(stamps: Tuple[Tuple[str, int, int], ...]) -> Era5Data:
  paths = [p for p, _, _ in stamps]
  parts = [(p,) + _read_file(p) for p in paths]
  first_path, _, pressure, latitude, longitude, _ = parts[0]
  for p, _, other_p, other_lat, other_lon, _ in parts[1:]:
    for name, a, b in (('pressure levels', pressure, other_p),
                       ('latitudes', latitude, other_lat),
                       ('longitudes', longitude, other_lon)):
      if a.shape != b.shape or not np.allclose(a, b):
        raise errors.BadFileError(
            f'ERA5 files {first_path} and {p} have different {name}; they '
            'cannot be joined')
  times = np.concatenate([part[1] for part in parts])
  uv = np.concatenate([part[5] for part in parts], axis=0)
  order = np.argsort(times, kind='stable')
  times, uv = times[order], uv[order]
  sources = [paths[k] for k in np.repeat(
      np.arange(len(parts)), [len(part[1]) for part in parts])[order]]
  duplicate = np.nonzero(np.diff(times) == np.timedelta64(0))[0]
  if duplicate.size:
    i = int(duplicate[0])
    raise errors.BadFileError(
        f'ERA5 files {sources[i]} and {sources[i + 1]} both hold time '
        f'{_time_text(times[i])}')
  _check_time_steps(times, sources)
  for name, axis in (('time', times), ('pressure level', pressure),
                     ('latitude', latitude), ('longitude', longitude)):
    if axis.size < 2:
      raise errors.BadFileError(
          f'ERA5 file(s) {[s[0] for s in stamps]} hold {axis.size} '
          f'{name} value(s); interpolation needs at least 2')
  time_s = (times - times[0]) / np.timedelta64(1, 's')
  arrays = [times, time_s, pressure, latitude, longitude, uv]
  for a in arrays:
    a.flags.writeable = False
  return Era5Data(tuple(s[0] for s in stamps), *arrays)


def start_dates_range(start_dates: Any, what: str = 'Era5WindField.start_dates'
                      ) -> Optional[Tuple[dt.datetime, dt.datetime]]:
  """The [first, end) start range of `Era5WindField.start_dates`, UTC.

  Args:
    start_dates: None (any start in the data), a split of `DATE_SPLITS`
      ('train', 'validation', 'eval') or a (first, end) pair of ISO dates or
      date-times (strings, `datetime.date`s or `datetime.datetime`s; naive
      ones are UTC), first < end.
    what: The binding or flag named in errors.

  Returns:
    None, or (first, end) as aware UTC date-times.

  Raises:
    errors.ConfigError: anything else, in one line.
  """
  if start_dates is None:
    return None
  given = start_dates
  if isinstance(start_dates, str):
    if start_dates not in DATE_SPLITS:
      raise errors.ConfigError(
          f'{what} = {given!r}: not a split ({sorted(DATE_SPLITS)}) nor a '
          '(first, end) pair of dates')
    start_dates = DATE_SPLITS[start_dates]
  if not isinstance(start_dates, (tuple, list)) or len(start_dates) != 2:
    raise errors.ConfigError(
        f'{what} = {given!r}: expected a split ({sorted(DATE_SPLITS)}) or a '
        "(first, end) pair of dates, e.g. ('2022-11-01', '2022-12-13')")
  pair = []
  for value in start_dates:
    try:
      if isinstance(value, dt.datetime):
        when = value
      elif isinstance(value, dt.date):
        when = dt.datetime(value.year, value.month, value.day)
      else:
        when = dt.datetime.fromisoformat(str(value))
      if when.tzinfo is None:
        when = when.replace(tzinfo=dt.timezone.utc)
      # OverflowError: a date whose UTC time leaves years 1..9999.
      pair.append(when.astimezone(dt.timezone.utc))
    except (ValueError, OverflowError) as e:
      raise errors.ConfigError(
          f'{what} = {given!r}: {value!r} is not an ISO date (YYYY-MM-DD '
          'or YYYY-MM-DDTHH:MM) in years 1..9999 (UTC)') from e
  if not pair[0] < pair[1]:
    raise errors.ConfigError(f'{what} = {given!r}: the first date must come '
                             'before the end')
  return pair[0], pair[1]


def start_window(data: Era5Data, *, center_lat: float, center_lon: float,
                 episode_hours: float, start_dates: Any = None
                 ) -> Tuple[int, int]:
  """The minutes a flight may start at, after the data's first time.

  `last_start_minute`'s checks, and the starts restricted to `start_dates`
  (`start_dates_range`: [first, end), so the splits of `DATE_SPLITS` never
  share a start).

  Returns:
    (first, last) whole minutes after the data's first time, inclusive.

  Raises:
    ValueError: as `last_start_minute`; `errors.ConfigError`: bad
      `start_dates`, or no start of the range lies in the data with
      `episode_hours` after it.
  """
  last = last_start_minute(data, center_lat=center_lat, center_lon=center_lon,
                           episode_hours=episode_hours)
  window = start_dates_range(start_dates)
  if window is None:
    return 0, last
  first_s = (window[0] - data.start).total_seconds()
  end_s = (window[1] - data.start).total_seconds()
  first = max(0, math.ceil(first_s / 60.0))
  last = min(last, math.ceil(end_s / 60.0) - 1)
  if first > last:
    raise errors.ConfigError(
        f'Era5WindField.start_dates = {start_dates!r}: no flight of '
        f'{episode_hours:g} h can start in [{window[0]:%Y-%m-%d %H:%M}, '
        f'{window[1]:%Y-%m-%d %H:%M}) inside ERA5 file(s) {list(data.paths)} '
        f'({data.start:%Y-%m-%d %H:%M} to {data.end:%Y-%m-%d %H:%M})')
  return int(first), int(last)


def last_start_minute(data: Era5Data, *, center_lat: float, center_lon: float,
                      episode_hours: float) -> int:
  """Checks a flight against the data; the last minute a flight may start.

  Args:
    data: The ERA5 data.
    center_lat: Latitude of the station-keeping target. # [deg N]
    center_lon: Longitude of the station-keeping target. # [deg E]
    episode_hours: Flight length that must fit in the data after the
      start. # [h]

  Returns:
    The latest start, in whole minutes after the data's first time, such
    that `episode_hours` fit.

  Raises:
    ValueError: non-finite arguments, target outside the data's area, or
      (`errors.BadFileError`) data shorter than `episode_hours`.
  """
  for name, value in (('center_lat', center_lat),
                      ('center_lon', center_lon),
                      ('episode_hours', episode_hours)):
    if not math.isfinite(value):
      raise ValueError(f'Era5WindField.{name} must be finite, got {value}')
  if not -90.0 <= center_lat <= 90.0:
    raise ValueError(f'Era5WindField.center_lat must be in [-90, 90], got '
                     f'{center_lat}')
  if episode_hours < 0:
    raise ValueError(f'Era5WindField.episode_hours must be >= 0, got '
                     f'{episode_hours}')
  if not data.covers(center_lat, center_lon):
    raise ValueError(
        f'Target (lat {center_lat}, lon {center_lon}) lies outside the area '
        f'of ERA5 file(s) {list(data.paths)}: lat [{data.latitude[0]}, '
        f'{data.latitude[-1]}], lon [{data.longitude[0]}, '
        f'{data.longitude[-1]}]')
  span_s = float(data.time_s[-1])
  episode_s = episode_hours * 3600.0
  if episode_s > span_s:
    raise errors.BadFileError(
        f'ERA5 file(s) {list(data.paths)} cover {span_s / 3600:.1f} h '
        f'({data.start} to {data.end}), shorter than episode_hours = '
        f'{episode_hours}')
  return int((span_s - episode_s) // 60)


@gin.configurable
class Era5WindField(wind_field.WindField):
  """ERA5 reanalysis winds around a station-keeping target (paper's Wind).

  Positions are BLE's x (east), y (north) offsets from the target at
  (center_lat, center_lon), converted to latitude/longitude with BLE's
  `spherical_geometry.calculate_latlng_from_offset`. The forecast is the ERA5
  (u, v) interpolated multi-linearly in time, pressure, latitude and longitude
  (`Era5Data.interpolate`); outside the file's area, pressure range or time
  range the wind is clipped to the edge value (as BLE's generative field).
  The ground truth adds BLE's simplex noise unless `add_noise` is False.

  Each reset samples the flight's start time uniformly (whole minutes) from
  the file's time range such that `episode_hours` fit, and inside
  `start_dates` if given (the held-out split by dates, `DATE_SPLITS`), from
  the forecast key (same key, same start). The `date_time` BLE passes to `reset` is ignored
  (as BLE's generative field does); `start_date_time` holds the sampled
  start, and the arena uses it as the balloon's date and time.
  """

  def __init__(self,
               *,
               path: Union[str, Sequence[str]] = gin.REQUIRED,
               center_lat: float = PAPER_CENTER_LAT,  # [deg N]
               center_lon: float = PAPER_CENTER_LON,  # [deg E]
               episode_hours: float = 72.0,  # [h]
               add_noise: bool = True,
               start_dates: Any = None):
    """Loads the ERA5 file(s).

    Args:
      path: ERA5 NetCDF file, glob pattern (e.g. 'era5_paper_*.nc') or list
        of them; joined along time.
      center_lat: Latitude of the station-keeping target. # [deg N]
      center_lon: Longitude of the station-keeping target. # [deg E]
      episode_hours: Flight length that must fit in the data after the
        sampled start. # [h]
      add_noise: Whether the ground truth adds BLE's simplex noise to the
        forecast (the paper does).
      start_dates: None: flights start anywhere in the data; a split of
        `DATE_SPLITS` ('train', 'validation', 'eval') or a (first, end) pair
        of ISO dates: flights start in [first, end) (`start_window`).

    Raises:
      FileNotFoundError: a file is missing.
      IsADirectoryError: a path is a directory.
      ValueError: bad file (see `load`), target outside the file's area,
        non-finite arguments, or data shorter than `episode_hours`.
    """
    super().__init__()  # BLE's simplex noise (`SimplexWindNoise`).
    self._data = load(path)
    self._first_start, self._start_minutes = start_window(
        self._data, center_lat=center_lat, center_lon=center_lon,
        episode_hours=episode_hours, start_dates=start_dates)
    self.center_lat, self.center_lon = float(center_lat), float(center_lon)
    self.start_dates = start_dates
    self._center = s2.LatLng.from_degrees(center_lat, center_lon)
    self.episode_hours = float(episode_hours)
    self.add_noise = bool(add_noise)
    self.start_date_time: Optional[dt.datetime] = None
    self._start_offset_s: Optional[float] = None

  @property
  def data(self) -> Era5Data:
    """The loaded ERA5 data."""
    return self._data

  def reset_forecast(self, key: jnp.ndarray, date_time: dt.datetime) -> None:
    """Samples the flight's start time from the data's time range.

    The start is uniform over whole minutes in [first time, last time -
    episode_hours] (inside `start_dates`), drawn from `key` (the same key gives the same start).

    Args:
      key: A jax PRNGKey used for sampling the start time.
      date_time: Ignored (BLE's random date); see `start_date_time`.
    """
    del date_time
    minutes = jax.random.randint(key, (), self._first_start,
                                 self._start_minutes + 1).item()
    self.set_start_date_time(self._data.start + dt.timedelta(minutes=minutes))

  def set_start_date_time(self, start: dt.datetime) -> None:
    """Sets the flight's start time (e.g. to show the winds of a date).

    Args:
      start: Start time; naive times are taken as UTC. It must lie in the
        data's time range (the flight may run past its end: clipped).

    Raises:
      ValueError: if `start` is outside the data's time range.
    """
    if start.tzinfo is None:
      start = start.replace(tzinfo=dt.timezone.utc)
    if not self._data.start <= start <= self._data.end:
      raise ValueError(f'Start {start} is outside the ERA5 data '
                       f'({self._data.start} to {self._data.end})')
    self.start_date_time = start
    self._start_offset_s = (start - self._data.start).total_seconds()

  def _time_s(self, elapsed_time: dt.timedelta) -> float:
    """Time since the data's first time. # [s]"""
    if self._start_offset_s is None:
      raise RuntimeError('Must call reset before get_forecast.')
    return self._start_offset_s + elapsed_time.total_seconds()

  def _latlng(self, x: units.Distance,
              y: units.Distance) -> Tuple[float, float]:
    """(lat, lon) of the offset (x east, y north) from the target. # [deg]"""
    if not (math.isfinite(x.meters) and math.isfinite(y.meters)):
      raise ValueError(f'Position must be finite, got x={x}, y={y}')
    latlng = spherical_geometry.calculate_latlng_from_offset(
        self._center, x, y)
    return latlng.lat().degrees, latlng.lng().degrees

  def get_forecast(self, x: units.Distance, y: units.Distance, pressure: float,
                   elapsed_time: dt.timedelta) -> wind_field.WindVector:
    """ERA5 wind at a point (clipped to the data's edges outside it).

    Args:
      x: Distance east of the target (along the latitude parallel).
      y: Distance north of the target (along the meridian).
      pressure: Pressure. # [Pa]
      elapsed_time: Time since the start of the flight.

    Returns:
      The interpolated wind.

    Raises:
      RuntimeError: if called before reset().
      ValueError: for non-finite positions or pressure.
    """
    return self.get_forecast_column(x, y, [pressure], elapsed_time)[0]

  def get_forecast_column(
      self, x: units.Distance, y: units.Distance, pressures: Sequence[float],
      elapsed_time: dt.timedelta) -> List[wind_field.WindVector]:
    """ERA5 winds at several pressures above one point (one vectorised call).

    Args:
      x: Distance east of the target (along the latitude parallel).
      y: Distance north of the target (along the meridian).
      pressures: Pressures. # [Pa]
      elapsed_time: Time since the start of the flight.

    Returns:
      One interpolated wind per pressure.

    Raises:
      RuntimeError: if called before reset().
      ValueError: for non-finite positions or pressures.
    """
    time_s = self._time_s(elapsed_time)
    pressures = np.asarray(pressures, dtype=np.float64).reshape(-1)
    if not np.all(np.isfinite(pressures)):
      raise ValueError(f'Pressure must be finite, got {pressures}')
    lat, lon = self._latlng(x, y)
    uv = self._data.interpolate(time_s, pressures, lat, lon)
    return [wind_field.WindVector(units.Velocity(mps=float(u)),
                                  units.Velocity(mps=float(v)))
            for u, v in uv]

  def get_ground_truth(self, x: units.Distance, y: units.Distance,
                       pressure: float,
                       elapsed_time: dt.timedelta) -> wind_field.WindVector:
    """Forecast plus BLE's simplex noise (forecast only if not add_noise)."""
    if not self.add_noise:
      return self.get_forecast(x, y, pressure, elapsed_time)
    return super().get_ground_truth(x, y, pressure, elapsed_time)


def pressure_levels_hpa(min_hpa: float = PAPER_MIN_PRESSURE_HPA,
                        max_hpa: float = PAPER_MAX_PRESSURE_HPA) -> List[int]:
  """ERA5's standard pressure levels within [min_hpa, max_hpa]. # [hPa]

  Args:
    min_hpa: Lowest pressure wanted (the paper's 20 hPa). # [hPa]
    max_hpa: Highest pressure wanted (the paper's 175 hPa). # [hPa]

  Returns:
    The levels, ascending. # [hPa]

  Raises:
    ValueError: If no ERA5 level lies in the range.
  """
  levels = [p for p in ERA5_PRESSURE_LEVELS_HPA if min_hpa <= p <= max_hpa]
  if not levels:
    raise ValueError(f'No ERA5 pressure level in [{min_hpa}, {max_hpa}] hPa '
                     f'(levels: {list(ERA5_PRESSURE_LEVELS_HPA)})')
  return levels


def build_requests(
    *,
    center_lat: float = PAPER_CENTER_LAT,  # [deg N]
    center_lon: float = PAPER_CENTER_LON,  # [deg E]
    start_date: dt.date = PAPER_START_DATE,
    end_date: dt.date = PAPER_END_DATE,
    half_width_deg: float = DEFAULT_HALF_WIDTH_DEG,  # [deg]
    grid_deg: float = PAPER_GRID_DEG,  # [deg]
    min_pressure_hpa: float = PAPER_MIN_PRESSURE_HPA,  # [hPa]
    max_pressure_hpa: float = PAPER_MAX_PRESSURE_HPA,  # [hPa]
    times: Sequence[str] = PAPER_TIMES,
) -> List[Tuple[str, Dict[str, Any]]]:
  """CDS requests for ERA5 u, v around a target, one per calendar month.

  One request per month because CDS takes the Cartesian product of the
  year, month and day lists (a single request for Nov 2022 - Jan 2023 would
  also fetch Jan 2022 and Nov-Dec 2023) and to stay within CDS's size limits.
  The defaults are the paper's data.

  Args:
    center_lat: Target latitude. # [deg N]
    center_lon: Target longitude. # [deg E]
    start_date: First day (inclusive).
    end_date: Last day (inclusive).
    half_width_deg: The area is the target +- this. # [deg]
    grid_deg: Grid spacing CDS interpolates to. # [deg]
    min_pressure_hpa: Lowest pressure level. # [hPa]
    max_pressure_hpa: Highest pressure level. # [hPa]
    times: Hours of the day ('HH:MM').

  Returns:
    A list of (month 'YYYY-MM', request dict) for
    `cdsapi.Client().retrieve(DATASET, request, target)`.

  Raises:
    ValueError: on an empty date range or a bad area.
  """
  if end_date < start_date:
    raise ValueError(f'end_date {end_date} is before start_date {start_date}')
  for name, value in (('center_lat', center_lat), ('center_lon', center_lon),
                      ('half_width_deg', half_width_deg),
                      ('grid_deg', grid_deg)):
    if not math.isfinite(value):
      raise ValueError(f'{name} must be finite, got {value}')
  if not 0 < half_width_deg <= 90 or not grid_deg > 0:
    raise ValueError(f'half_width_deg must be in (0, 90] and grid_deg > 0, '
                     f'got {half_width_deg}, {grid_deg}')
  north = min(center_lat + half_width_deg, 90.0)
  south = max(center_lat - half_width_deg, -90.0)
  if north <= south:
    raise ValueError(f'Empty area around lat {center_lat}')
  area = [north, center_lon - half_width_deg, south,
          center_lon + half_width_deg]
  levels = [str(p) for p in pressure_levels_hpa(min_pressure_hpa,
                                                max_pressure_hpa)]
  requests = []
  year, month = start_date.year, start_date.month
  while (year, month) <= (end_date.year, end_date.month):
    first = max(start_date, dt.date(year, month, 1))
    last = min(end_date,
               dt.date(year, month, calendar.monthrange(year, month)[1]))
    requests.append((f'{year:04d}-{month:02d}', {
        'product_type': ['reanalysis'],
        'variable': ['u_component_of_wind', 'v_component_of_wind'],
        'year': [f'{year:04d}'],
        'month': [f'{month:02d}'],
        'day': [f'{d:02d}' for d in range(first.day, last.day + 1)],
        'time': list(times),
        'pressure_level': levels,
        'area': area,
        'grid': [grid_deg, grid_deg],
        'data_format': 'netcdf',
        'download_format': 'unarchived',
    }))
    year, month = (year + 1, 1) if month == 12 else (year, month + 1)
  return requests
