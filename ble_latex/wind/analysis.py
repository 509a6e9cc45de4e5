# coding=utf-8
"""Real upper-air wind sources: detection by content, and normalisation.

`gridded.load` reads every wind file through this module, which turns the
sources a user has into one CF-style dataset with ERA5's names (`u`, `v` on
`time`, `level`, `latitude`, `longitude`):
  - NetCDF (by its magic: `CDF\\x01/2/5` or HDF5's signature): the wind
    variables are found by CF `standard_name` (`eastward_wind`,
    `northward_wind`) or a known alias (`WIND_ALIASES`: `u`/`v`, `U`/`V`,
    `uwnd`/`vwnd`, GFS's `u-component_of_wind_isobaric`/`v-...`); the
    pressure dimension by name (`gridded.PRESSURE_DIMS`, or any name starting
    with `isobaric`, e.g. GFS's `isobaric3`, in Pa) or by a pressure `units`
    attribute;
  - GRIB2 (by its magic `GRIB`) through cfgrib + eccodes: the u and v
    messages on isobaric levels (`isobaricInhPa`);
  - anything else is read as a University of Wyoming sounding (text or CSV,
    `sounding.read`) and flown as a horizontally uniform column
    (`sounding_arrays`).
A file with one time step is a snapshot: `gridded.load` flies it as a
time-invariant field (`Era5Data.time_invariant`), and every record says so.

`check_flight_band` and `check_domain` add the checks of real sources (one
line naming the file, `errors.BadFileError`): levels that miss the altitudes
the balloon can reach (`reach.flight_band_m`, 13-22 km by default, in
pressure by the US Standard Atmosphere 1976), and a grid too small for a
station with its margins (`MIN_DOMAIN_M`).
"""

import contextlib
import dataclasses
import datetime as dt
import logging
import math
import os
import tempfile
from typing import Any, Dict, List, Optional, Sequence, Tuple, TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # xarray loads when a file is read (~2 s).
  import xarray as xr  # pylint: disable=g-bad-import-order

from ble_latex import errors
from ble_latex.wind import grib_subset
from ble_latex.wind import gridded_checks
from ble_latex.wind import reach
from ble_latex.wind import sounding

# CF standard names of the wind components.
STANDARD_NAMES = ('eastward_wind', 'northward_wind')
# Known (u, v) variable names, ERA5's first.
WIND_ALIASES = (('u', 'v'), ('U', 'V'), ('uwnd', 'vwnd'),
                ('u-component_of_wind_isobaric',
                 'v-component_of_wind_isobaric'))
_TIME_NAMES = ('valid_time', 'time')
_LAT_NAMES = ('latitude', 'lat')
_LON_NAMES = ('longitude', 'lon')
_PRESSURE_NAMES = ('pressure_level', 'level', 'isobaricInhPa', 'plev')
# Smallest extent of a gridded domain, each direction: a station with
# `STATION_MARGIN_M` of wind around it on every side. # [m]
STATION_MARGIN_M = 150_000.0  # [m]
MIN_DOMAIN_M = 2.0 * STATION_MARGIN_M + 100_000.0  # [m]
# A sounding's uniform column is stored on the whole sphere: pole to pole,
# and longitudes -180 and 0, a global axis (`globe`: closed at +180), so a
# site anywhere is inside and the field is uniform everywhere. # [deg]
SOUNDING_BOX_LAT = (-90.0, 90.0)  # [deg N]
SOUNDING_BOX_LON = (-180.0, 0.0)  # [deg E]
_MERIDIAN_M_PER_DEG = 6_371_000.0 * math.pi / 180.0  # [m/deg]
_GRIB_MAGIC = b'GRIB'
_NETCDF_MAGICS = (b'CDF\x01', b'CDF\x02', b'CDF\x05', b'\x89HDF')


def kind_of(path: str) -> str:
  """'grib', 'netcdf' or 'sounding', by the file's bytes.

  GRIB2 and NetCDF by their magic; text is a sounding; other bytes go to
  the NetCDF reader, whose error names them.

  Raises:
    errors.BadFileError: an empty file.
  """
  with open(path, 'rb') as f:
    head = f.read(4096)
  if not head:
    raise errors.BadFileError(f'wind file {path} is empty (0 bytes)')
  if head.startswith(_GRIB_MAGIC):
    return 'grib'
  if any(head.startswith(m) for m in _NETCDF_MAGICS):
    return 'netcdf'
  try:
    head[:-3].decode('utf-8')
  except UnicodeDecodeError:
    return 'netcdf'
  return 'netcdf' if b'\x00' in head else 'sounding'


# US Standard Atmosphere 1976 pressure of a height: its home is `reach`
# (the sounding reader checks its pressures with it too).
pressure_of_height = reach.pressure_of_height


def check_flight_band(path: str, pressure_pa: np.ndarray, label: str) -> None:
  """Refuses levels that do not span `reach.flight_band_m` (one line)."""
  band = reach.flight_band_m()
  low_pa = pressure_of_height(band[1])
  high_pa = pressure_of_height(band[0])
  if pressure_pa.size < 2:
    raise errors.BadFileError(
        f'{label} file {path} holds {pressure_pa.size} pressure level(s); a '
        f'flight needs levels over {reach.band_text(band)}')
  if pressure_pa.min() > low_pa or pressure_pa.max() < high_pa:
    raise errors.BadFileError(
        f'{label} file {path}: levels {pressure_pa.min() / 100:g}-'
        f'{pressure_pa.max() / 100:g} hPa miss {reach.band_text(band)}, '
        f'{low_pa / 100:.0f}-{high_pa / 100:.0f} hPa')


def check_domain(path: str, latitude: np.ndarray, longitude: np.ndarray,
                 label: str) -> None:
  """Refuses a grid smaller than `MIN_DOMAIN_M` in either direction."""
  if latitude.size < 2 or longitude.size < 2:
    raise errors.BadFileError(
        f'{label} file {path}: a grid of {latitude.size} x {longitude.size} '
        'lat/lon nodes is too small for a flight (at least 2 x 2)')
  mid = math.radians(0.5 * (latitude[0] + latitude[-1]))
  north_m = (latitude[-1] - latitude[0]) * _MERIDIAN_M_PER_DEG
  east_m = (longitude[-1] - longitude[0]) * _MERIDIAN_M_PER_DEG * math.cos(mid)
  if min(north_m, east_m) < MIN_DOMAIN_M:
    raise errors.BadFileError(
        f'{label} file {path}: the grid spans {north_m / 1000:.0f} km north x '
        f'{east_m / 1000:.0f} km east; a flight needs '
        f'{MIN_DOMAIN_M / 1000:.0f} km each way')


def _wind_names(dataset: 'xr.Dataset') -> Optional[Tuple[str, str]]:
  """(u, v) variable names by CF standard_name, then by alias."""
  by_standard = {}
  for name in dataset.data_vars:
    standard = str(dataset[name].attrs.get('standard_name', ''))
    if standard in STANDARD_NAMES and standard not in by_standard:
      by_standard[standard] = str(name)
  if len(by_standard) == 2:
    return by_standard[STANDARD_NAMES[0]], by_standard[STANDARD_NAMES[1]]
  for u, v in WIND_ALIASES:
    if u in dataset.data_vars and v in dataset.data_vars:
      return u, v
  return None


def _pressure_dim(array: 'xr.DataArray') -> Optional[str]:
  for dim in array.dims:
    dim = str(dim)
    if dim in _PRESSURE_NAMES or dim.startswith('isobaric'):
      return dim
  for dim in array.dims:
    if dim in array.coords and str(array[dim].attrs.get(
        'units', '')).strip().lower() in gridded_checks.PRESSURE_UNITS:
      return str(dim)
  return None


def _first(dims, names) -> Optional[str]:
  return next((str(d) for d in dims if str(d) in names), None)


def normalise(dataset: 'xr.Dataset', path: str, label: str
              ) -> Tuple['xr.Dataset', Dict[str, Tuple[str, ...]]]:
  """`dataset` with a time axis, and the names its winds and axes have.

  A wind without a time dimension takes its scalar time coordinate
  (`valid_time`, then `time`) as a time axis of one step. Names not found
  keep ERA5's candidates, so `gridded.read_file`'s errors name what is missing.

  Returns:
    (dataset, names): names maps 'variables', 'time', 'pressure',
    'latitude', 'longitude' to the candidates `gridded.Layout` takes.

  Raises:
    errors.BadFileError: no wind variables (one line naming the file).
  """
  winds = _wind_names(dataset)
  if winds is None:
    raise errors.BadFileError(
        f'{label} file {path} has no wind variables (found: '
        f'{sorted(str(v) for v in dataset.data_vars)}; expected CF '
        f'standard_name {"/".join(STANDARD_NAMES)} or one of '
        f'{["/".join(a) for a in WIND_ALIASES]})')
  array = dataset[winds[0]]
  if ('step' in array.dims and 'valid_time' in array.coords and
      array['valid_time'].dims == ('step',)):  # A run's steps: valid times.
    dataset = dataset.swap_dims({'step': 'valid_time'})
    array = dataset[winds[0]]
  dims = [str(d) for d in array.dims]
  level = _pressure_dim(array)
  lat, lon = _first(dims, _LAT_NAMES), _first(dims, _LON_NAMES)
  time = next((d for d in dims if d in _TIME_NAMES or d.startswith('time')),
              None)
  if time is None:
    scalar = next((c for c in _TIME_NAMES if c in array.coords and
                   array[c].ndim == 0), None)
    if scalar is not None:
      others = [c for c in _TIME_NAMES if c != scalar and c in dataset.coords]
      dataset = dataset.rename_vars({c: f'{c}_{scalar}' for c in others})
      dataset = dataset.assign({
          w: dataset[w].expand_dims(scalar) for w in winds})
      time = scalar
  names = {'variables': winds,
           'time': (time,) if time else _TIME_NAMES,
           'pressure': (level,) if level else _PRESSURE_NAMES,
           'latitude': (lat,) if lat else _LAT_NAMES,
           'longitude': (lon,) if lon else _LON_NAMES}
  return dataset, names


@dataclasses.dataclass(frozen=True)
class ForecastRun:
  """The run and lead times of forecast files (GRIB2 `time` and `step`).

  Attributes:
    runs: Each file's run (initial time), naive UTC.
    hours: The lead times read, over all files. # [h]
  """
  runs: Tuple[np.datetime64, ...]
  hours: Tuple[float, ...]

  @property
  def label(self) -> str:
    """E.g. 'run 2011-10-08T00Z +72 h', 'run 2011-10-08T00Z +72..+78 h'."""
    runs = sorted({str(r)[:13] + 'Z' for r in self.runs})
    hours = sorted(set(self.hours))
    lead = (f'+{hours[0]:g} h' if len(hours) == 1 else
            f'+{hours[0]:g}..+{hours[-1]:g} h')
    return (f'run {runs[0]}' if len(runs) == 1 else
            f'runs {runs[0]}..{runs[-1]}') + f' {lead}'

  @property
  def notes(self) -> List[str]:
    """Nothing more for the record than `label`."""
    return []

  @staticmethod
  def join(parts: Sequence[Optional['ForecastRun']]
           ) -> Optional['ForecastRun']:
    """The files' runs together; None unless every file names its run."""
    if not parts or any(p is None for p in parts):
      return None
    return ForecastRun(tuple(r for p in parts for r in p.runs),
                       tuple(h for p in parts for h in p.hours))


def forecast_run(dataset: 'xr.Dataset') -> Optional[ForecastRun]:
  """The run and lead times a (`normalise`d) GRIB2 dataset names, or None.

  cfgrib's scalar `time` (the run; `time_valid_time` once `normalise` made
  `valid_time` the time axis) and `step` (one lead time or one per time).
  """
  run = next((dataset[c] for c in ('time_valid_time', 'time')
              if c in dataset.coords and dataset[c].ndim == 0), None)
  step = dataset.coords.get('step')
  if run is None or step is None or not (
      np.issubdtype(run.dtype, np.datetime64) and
      np.issubdtype(step.dtype, np.timedelta64)):
    return None
  hours = np.atleast_1d(step.values) / np.timedelta64(1, 'h')
  return ForecastRun((run.values,), tuple(float(h) for h in hours))


@contextlib.contextmanager
def _quiet_cfgrib():
  """Silences cfgrib's 'skipping variable' logs while a GRIB file opens."""
  logger = logging.getLogger('cfgrib')
  level = logger.level
  logger.setLevel(logging.ERROR)
  try:
    yield
  finally:
    logger.setLevel(level)


def open_dataset(path: str, label: str
                 ) -> Tuple['xr.Dataset', str, Dict[str, Tuple[str, ...]]]:
  """Opens a GRIB2 or NetCDF file: (dataset, source label, `normalise` names).

  Raises:
    errors.BadFileError: an unreadable file, or as `normalise`.
  """
  import xarray as xr  # pylint: disable=g-import-not-at-top,redefined-outer-name
  kind = kind_of(path)
  try:
    if kind == 'grib':
      label = 'GRIB2' if label == 'ERA5' else label
      with tempfile.TemporaryDirectory(prefix='ble_latex_grib') as folder:
        dataset = _open_grib(path, label, folder)
    else:
      gridded_checks.check_file(path, label=label)
      dataset = xr.open_dataset(path)
  except errors.BadFileError:
    raise
  except Exception as error:  # pylint: disable=broad-except
    raise errors.BadFileError(
        f'{label} file {path} is not a readable '
        f'{"GRIB2" if kind == "grib" else "NetCDF"} file '
        f'({type(error).__name__}: {_first_line(error)})') from error
  names = _wind_names(dataset)
  if names is not None and names != ('u', 'v') and label == 'ERA5':
    label = 'analysis'
  try:
    dataset, names = normalise(dataset, path, label)
  except errors.BadFileError:
    dataset.close()
    raise
  return dataset, label, names


def _open_grib(path: str, label: str, folder: str) -> 'xr.Dataset':
  """u and v on isobaric levels of a GRIB2 file, loaded.

  Only the messages that may be winds are indexed and decoded
  (`grib_subset.wind_messages`, copied to `folder`); cfgrib indexes every
  message it is given, once per open.
  """
  import cfgrib  # pylint: disable=g-import-not-at-top
  import xarray as xr  # pylint: disable=g-import-not-at-top,redefined-outer-name
  read = os.path.join(folder, 'winds.grib2')
  if not grib_subset.wind_messages(path, read):
    read = path
  # The messages' headers only (no values decoded): a constant field
  # can declare a huge grid in a few bytes.
  stream = cfgrib.FileStream(read, errors='raise')
  messages = [m for _, m in stream.items()]
  points = sum(int(m['numberOfDataPoints']) for m in messages)
  gridded_checks.check_size(path, (points,), label=label)
  _check_unique_messages(path, label, messages)

  def opened(shorts):
    # The messages read above (errors='raise': a corrupt or truncated one
    # is an error; cfgrib's default logs it and reads those before it),
    # indexed and decoded once.
    part = xr.open_dataset(
        messages, engine='cfgrib', backend_kwargs={'filter_by_keys': {
            'typeOfLevel': 'isobaricInhPa', 'shortName': shorts}})
    with part:
      return part.load()

  with _quiet_cfgrib():
    try:  # One index of both components.
      return opened(['u', 'v'])
    except cfgrib.dataset.DatasetBuildError:
      # u and v on other levels or grids: each on its own, merged.
      return xr.merge([opened(short) for short in ('u', 'v')],
                      compat='override')


def _check_unique_messages(path: str, label: str,
                           messages: Sequence[Any]) -> None:
  """One GRIB message per wind component, pressure level and time.

  cfgrib keeps the first of two messages with the same keys and drops the
  other silently; a duplicated NetCDF level is refused, so is this.

  Raises:
    errors.BadFileError: One line naming the component, level and time.
  """
  seen = set()
  for message in messages:
    try:
      if (message['shortName'] not in ('u', 'v') or
          message['typeOfLevel'] != 'isobaricInhPa'):
        continue
      key = (message['shortName'], message['level'], message['dataDate'],
             message['dataTime'], str(message['stepRange']))
    except KeyError:
      continue  # Not a field cfgrib reads as a wind; it reads the rest.
    # An ensemble's members (GEFS: perturbationNumber, cfgrib's `number`)
    # are one field each (`members`).
    key += (message.get('number', None),)
    if key in seen:
      short, level, date, hhmm, step, number = key
      member = '' if number is None else f', member {number}'
      raise errors.BadFileError(
          f'{label} file {path} holds two messages of {short} at {level} hPa'
          f', run {date} {int(hhmm):04d}Z, step {step}{member} (one per '
          'component, level, time and member; cfgrib would keep the first '
          'and drop the other)')
    seen.add(key)


def _first_line(error: Exception) -> str:
  text = str(error).strip()
  return text.splitlines()[0] if text else ''


def sounding_arrays(path: str) -> Tuple[Tuple[np.ndarray, ...],
                                        sounding.Site]:
  """A sounding as a uniform one-time field on `SOUNDING_BOX_*`, and its site.

  Returns:
    (arrays, site): arrays as `gridded.read_file`'s (times (one: the
    observation time the file names, else the Unix epoch), pressure [Pa]
    ascending, latitude [deg N], longitude [deg E], uv [m/s] of shape (1,
    levels, 2, 2, 2)), the sounding's winds at every node; site: where and
    when the file says it was made (`sounding.Site`), and its top.

  Raises:
    errors.BadFileError: as `sounding.read`.
  """
  column = sounding.read(path)
  order = np.argsort(column.pressure_pa)
  pressure = column.pressure_pa[order]
  uv = np.stack([column.u_mps[order], column.v_mps[order]], axis=-1)
  uv = np.broadcast_to(uv[None, :, None, None, :],
                       (1, pressure.size, 2, 2, 2)).copy()
  when = column.site.time
  text = ('1970-01-01T00:00:00' if when is None else
          when.astimezone(dt.timezone.utc).strftime('%Y-%m-%dT%H:%M:%S'))
  times = np.array([text], dtype='datetime64[ns]')
  site = dataclasses.replace(column.site, top_m=float(column.height_m[-1]))
  return (times, pressure, np.array(SOUNDING_BOX_LAT, np.float64),
          np.array(SOUNDING_BOX_LON, np.float64), uv), site
