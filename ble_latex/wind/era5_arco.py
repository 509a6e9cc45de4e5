# coding=utf-8
"""ERA5 winds from Google's analysis-ready ARCO-ERA5 Zarr store.

A second source of the files `gridded.load` reads, beside the CDS requests of
`era5_requests.build_requests`: Google's public, cloud-optimised copy of ERA5
(https://cloud.google.com/storage/docs/public-datasets/era5), read anonymously
with xarray + zarr (+ gcsfs for `gs://` stores; `pip install
'ble_latex[arco]'`). No account, licence click or request queue; the data
are the same ERA5 reanalysis on its native 0.25 degree grid.

`fetch` selects exactly what the CDS request of the same parameters asks for
(`era5_requests.build_requests`: the area target +- half width, the
pressure levels in the range, every day and hour of the dates) from the
store's variables `u_component_of_wind`, `v_component_of_wind` with dims
(time, level, latitude, longitude), level in hPa, longitude 0..360 (any convention is
accepted), and writes one NetCDF file in the new CDS layout (`u`, `v` on
`valid_time`, `pressure_level` [hPa], `latitude`, `longitude`). Unlike CDS,
nothing is regridded: the file keeps the store's grid (0.25 deg for the
public store; `grid_deg` is not used), points inside the area only.

Only the selected values are read (lazily, `chunks=None`). Before anything is
written the store is checked: a store that cannot be opened, a missing
variable or dimension, wind or pressure units that are not m/s and hPa/Pa,
an area, level or time outside the store (or after its `valid_time_stop`)
are ValueErrors naming the store. The data are written to `<output>.part`,
read back with `gridded.load` (which refuses NaN, absurd winds, too few values
...), and only then renamed to `output`: a bad selection leaves no file.
"""

import contextlib
import datetime as dt
import importlib
import os
from typing import Any, Dict, Iterator, List, Optional, Sequence, Tuple

import numpy as np
import xarray as xr

from ble_latex.wind import gridded
from ble_latex.wind import gridded_checks

# Google's public ARCO-ERA5 store: 37 pressure levels, hourly, 0.25 deg.
DEFAULT_STORE = ('gs://gcp-public-data-arco-era5/ar/'
                 'full_37-1h-0p25deg-chunk-1.zarr-v3')
# Store variable of each file variable.
VARIABLES = {'u': 'u_component_of_wind', 'v': 'v_component_of_wind'}
EXTRA = "pip install 'ble_latex[arco]'"
# m/s units the reader accepts (`gridded.load`'s list).
_WIND_UNITS = gridded_checks.WIND_UNITS
# Coordinates within this of an area edge count as on it. # [deg]
_EDGE_TOLERANCE_DEG = 1e-6


class ArcoUnavailableError(ImportError):
  """zarr (or gcsfs for a gs:// store) is not installed."""


def require_packages(store: str) -> None:
  """Checks that the packages reading `store` are installed.

  Args:
    store: A local path or URL of a Zarr store.

  Raises:
    ArcoUnavailableError: zarr, or gcsfs for a `gs://` store, is missing;
      the message names the extra to install.
  """
  needed = ['zarr'] + (['gcsfs'] if store.startswith(('gs://', 'gcs://'))
                       else [])
  missing = []
  for name in needed:
    try:
      importlib.import_module(name)
    except ImportError:
      missing.append(name)
  if missing:
    raise ArcoUnavailableError(
        f'the ARCO-ERA5 source needs {" and ".join(needed)} (not installed: '
        f'{", ".join(missing)}); {EXTRA}')


def request_times(requests: Sequence[Tuple[str, Dict[str, Any]]]
                  ) -> np.ndarray:
  """Every (day, hour) the CDS requests ask for, sorted.

  Args:
    requests: `era5_requests.build_requests` output.

  Returns:
    datetime64[ns] times (naive UTC).
  """
  times = []
  for _, request in requests:
    year, month = int(request['year'][0]), int(request['month'][0])
    for day in request['day']:
      for clock in request['time']:
        hour, minute = (int(x) for x in clock.split(':'))
        times.append(np.datetime64(
            dt.datetime(year, month, int(day), hour, minute), 'ns'))
  return np.array(sorted(times), dtype='datetime64[ns]')


def selection(requests: Sequence[Tuple[str, Dict[str, Any]]]
              ) -> Dict[str, Any]:
  """The area, levels and times of CDS requests, for a Zarr store.

  Args:
    requests: `era5_requests.build_requests` output.

  Returns:
    {'times': datetime64 array, 'levels_hpa': [hPa], 'north', 'west',
    'south', 'east': area edges [deg]}.
  """
  north, west, south, east = requests[0][1]['area']
  return {'times': request_times(requests),
          'levels_hpa': [float(p) for p in requests[0][1]['pressure_level']],
          'north': float(north), 'west': float(west), 'south': float(south),
          'east': float(east)}


def open_store(store: str) -> xr.Dataset:
  """Opens a Zarr store lazily (anonymous access for cloud stores).

  Args:
    store: Local path or URL (e.g. `DEFAULT_STORE`).

  Returns:
    The lazily opened dataset.

  Raises:
    ArcoUnavailableError: zarr/gcsfs missing.
    ValueError: the store cannot be opened (missing, unreachable, not Zarr).
  """
  require_packages(store)
  options = ({'token': 'anon'} if '://' in store else None)
  try:
    return xr.open_zarr(store, chunks=None, storage_options=options)
  except Exception as error:  # pylint: disable=broad-except
    raise ValueError(
        f'ARCO-ERA5 store {store} could not be opened '
        f'({type(error).__name__}: {_first_line(error)})') from error


def _first_line(error: BaseException) -> str:
  return str(error).strip().split('\n', 1)[0]


@contextlib.contextmanager
def _named_store(store: str) -> Iterator[None]:
  """Re-raises the file checks of `gridded` (shared) as errors of the store."""
  try:
    yield
  except ValueError as error:
    message = str(error).replace(f'ERA5 file {store}',
                                 f'ARCO-ERA5 store {store}', 1)
    raise ValueError(message) from error


def _variable(dataset: xr.Dataset, name: str, store: str) -> xr.DataArray:
  """Store variable `name` as (time, level, latitude, longitude), checked."""
  if name not in dataset.data_vars:
    raise ValueError(
        f'ARCO-ERA5 store {store} has no variable {name!r} (found: '
        f'{sorted(str(v) for v in dataset.data_vars)[:20]})')
  array = dataset[name]
  unit = str(array.attrs.get('units', '')).strip()
  if unit not in _WIND_UNITS:
    raise ValueError(
        f'ARCO-ERA5 store {store}: variable {name!r} has units {unit!r}, '
        f'expected m/s ({list(_WIND_UNITS)})')
  dims = [str(d) for d in array.dims]
  with _named_store(store):
    wanted = [
        gridded.find_dim(dims, candidates, what, store, name)
        for candidates, what in ((gridded.TIME_DIMS, 'time'),
                                 (gridded.PRESSURE_DIMS, 'pressure-level'),
                                 (gridded.LATITUDE_DIMS, 'latitude'),
                                 (gridded.LONGITUDE_DIMS, 'longitude'))]
  if sorted(dims) != sorted(wanted):
    raise ValueError(
        f'ARCO-ERA5 store {store}: variable {name!r} has dims {dims}, '
        f'expected {wanted}')
  for dim in wanted:
    if dim not in array.coords:
      raise ValueError(f'ARCO-ERA5 store {store} has no coordinate values '
                       f'for dimension {dim!r}')
  for dim in wanted[1:]:  # Level, latitude, longitude: finite numbers.
    values = np.asarray(array[dim].values)
    if values.dtype.kind not in 'iuf' or not np.all(np.isfinite(values)):
      raise ValueError(
          f'ARCO-ERA5 store {store}: coordinate {dim!r} must hold finite '
          f'numbers, got {values.dtype} values {values[:5].tolist()}')
  return array.transpose(*wanted)


def _axis_indices(values: np.ndarray, low: float,
                  high: float) -> Optional[np.ndarray]:
  """Indices of `values` in [low, high], or None if the axis does not reach
  within one grid spacing of both ends (or holds fewer than 2 of them)."""
  values = np.asarray(values, dtype=np.float64)
  inside = np.nonzero((values >= low - _EDGE_TOLERANCE_DEG) &
                      (values <= high + _EDGE_TOLERANCE_DEG))[0]
  if inside.size < 2:
    return None
  spacing = float(np.median(np.abs(np.diff(np.sort(values)))))
  if (values[inside].min() > low + spacing or
      values[inside].max() < high - spacing):
    return None
  return inside


def _outside(store: str, what: str, low: float, high: float,
             values: np.ndarray) -> ValueError:
  return ValueError(
      f'ARCO-ERA5 store {store}: the requested {what} [{low:g}, {high:g}] '
      f'is outside the store ({what} {np.min(values):g}..'
      f'{np.max(values):g})')


def _latitude_indices(latitude: np.ndarray, south: float, north: float,
                      store: str) -> np.ndarray:
  """Indices of the store's latitudes in [south, north]."""
  inside = _axis_indices(latitude, south, north)
  if inside is None:
    raise _outside(store, 'latitude', south, north, latitude)
  return inside


def _longitude_indices(longitude: np.ndarray, west: float, east: float,
                       store: str) -> Tuple[np.ndarray, np.ndarray]:
  """Indices of the store's longitudes in [west, east] (any convention).

  Returns:
    (indices, the longitudes in the request's convention, west..east,
    ascending [deg E]).
  """
  longitude = np.asarray(longitude, dtype=np.float64)
  offset = (longitude - west + _EDGE_TOLERANCE_DEG) % 360.0 - (
      _EDGE_TOLERANCE_DEG)  # [deg] East of `west`.
  inside = _axis_indices(offset, 0.0, east - west)
  if inside is None:
    raise _outside(store, 'longitude', west, east, longitude)
  order = inside[np.argsort(offset[inside], kind='stable')]
  turns = np.round((longitude[order] - west - offset[order]) / 360.0)
  return order, longitude[order] - 360.0 * turns  # Exact shifts.


def _time_indices(store_times: np.ndarray, times: np.ndarray,
                  attrs: Dict[str, Any], store: str) -> np.ndarray:
  """Indices of `times` in the store's time axis; all must be there.

  A `valid_time_stop` attribute (the public store is allocated beyond its
  data) ends the valid times.
  """
  store_times = np.asarray(store_times).astype('datetime64[ns]')
  valid = np.ones(store_times.shape, dtype=bool)
  stop = attrs.get('valid_time_stop')
  if stop is not None:
    valid = store_times <= np.datetime64(str(stop), 'ns')
  ok = np.zeros(times.shape, dtype=bool)
  indices = np.zeros(times.shape, dtype=np.int64)
  if store_times.size:
    order = np.argsort(store_times, kind='stable')
    position = np.searchsorted(store_times[order], times)
    indices = order[np.clip(position, 0, store_times.size - 1)]
    ok = (store_times[indices] == times) & valid[indices]
  if not ok.all():
    covered = (f'{_date(store_times[valid].min())} to '
               f'{_date(store_times[valid].max())}' if valid.any() else
               'no time')
    raise ValueError(
        f'ARCO-ERA5 store {store} has no data for {int((~ok).sum())} of the '
        f'{times.size} requested times (first {_date(times[~ok][0])}); the '
        f'store covers {covered}')
  return indices


def _date(time: np.datetime64) -> str:
  return np.datetime_as_string(time, unit='m').replace('T', ' ')


def select(dataset: xr.Dataset, wanted: Dict[str, Any],
           store: str) -> xr.Dataset:
  """The request's part of an ARCO-ERA5 dataset, in the new CDS layout.

  Args:
    dataset: The (lazily) opened store.
    wanted: `selection(requests)`.
    store: The store's path or URL (for errors).

  Returns:
    A lazy dataset with `u`, `v` [m/s] on (`valid_time`, `pressure_level`
    [hPa], `latitude`, `longitude` [request's convention]).

  Raises:
    ValueError: a missing variable, dimension or coordinate, bad units, or a
      level, area or time outside the store.
  """
  arrays = {key: _variable(dataset, name, store)
            for key, name in VARIABLES.items()}
  u = arrays['u']
  for key, array in arrays.items():
    if array.dims != u.dims:
      raise ValueError(f'ARCO-ERA5 store {store}: {VARIABLES[key]!r} has '
                       f'dims {array.dims}, {VARIABLES["u"]!r} has {u.dims}')
  time_dim, level_dim, lat_dim, lon_dim = u.dims
  with _named_store(store):
    factor = gridded_checks.pressure_factor(u[level_dim], store)
  levels_pa = np.asarray(u[level_dim].values, dtype=np.float64) * factor
  level_indices = []
  for level in wanted['levels_hpa']:
    match = np.nonzero(np.isclose(levels_pa, level * 100.0, rtol=1e-6))[0]
    if not match.size:
      raise ValueError(
          f'ARCO-ERA5 store {store} has no pressure level {level:g} hPa '
          f'(levels: {sorted(float(p) / 100 for p in levels_pa)} hPa)')
    level_indices.append(int(match[0]))
  lat_indices = _latitude_indices(u[lat_dim].values, wanted['south'],
                                  wanted['north'], store)
  lon_indices, lon_values = _longitude_indices(
      u[lon_dim].values, wanted['west'], wanted['east'], store)
  time_indices = _time_indices(u[time_dim].values, wanted['times'],
                               dict(dataset.attrs), store)
  index = {time_dim: time_indices, level_dim: np.array(level_indices),
           lat_dim: lat_indices, lon_dim: lon_indices}
  coords = {
      'valid_time': ('valid_time', wanted['times']),
      'pressure_level': ('pressure_level',
                         np.array(wanted['levels_hpa'], dtype=np.float64),
                         {'units': 'hPa', 'long_name': 'pressure'}),
      'latitude': ('latitude',
                   np.asarray(u[lat_dim].values, np.float64)[lat_indices],
                   {'units': 'degrees_north'}),
      'longitude': ('longitude', lon_values, {'units': 'degrees_east'}),
  }
  out = {}
  for key, array in arrays.items():
    part = array.isel(index).drop_vars(list(array.coords))
    part = part.rename(dict(zip(u.dims, ('valid_time', 'pressure_level',
                                         'latitude', 'longitude'))))
    out[key] = part.assign_attrs(units='m s**-1')
  return xr.Dataset(out, coords=coords, attrs={
      'source': f'ARCO-ERA5 {store}', 'ble_latex_grid': 'native store grid'})


def check_no_constant_slab(selected: xr.Dataset, store: str) -> None:
  """Refuses a time and level whose wind is one value over the whole area.

  A Zarr chunk missing from a store reads as the array's `fill_value`
  (zarr's rule for chunks never written), silently: with a NaN fill the
  ERA5 checks refuse it, with `fill_value = 0` it would be written as a calm
  atmosphere. Real winds at one pressure level are never one exact value
  over an area of several grid points, whatever the fill, so a constant
  (time, level) slab of u or v is refused.

  Args:
    selected: The loaded selection (`select(...).load()`), dims (valid_time,
      pressure_level, latitude, longitude).
    store: The store (for errors).

  Raises:
    ValueError: naming the first constant slab's variable, time and level.
  """
  for key in VARIABLES:
    values = np.asarray(selected[key].values)
    if values.shape[2] * values.shape[3] < 2:
      continue
    flat = values.reshape(values.shape[0], values.shape[1], -1)
    constant = np.all(flat == flat[:, :, :1], axis=2)
    if np.any(constant):
      t, level = (int(i) for i in np.argwhere(constant)[0])
      time = selected['valid_time'].values[t]
      hpa = float(selected['pressure_level'].values[level])
      raise ValueError(
          f'ARCO-ERA5 store {store}: {VARIABLES[key]!r} at {_date(time)}, '
          f'{hpa:g} hPa is one value ({float(flat[t, level, 0]):g}) over the '
          'whole area: a missing chunk read as its fill value? nothing '
          'written')


def write(selected: xr.Dataset, output: str, store: str) -> str:
  """Reads the selection, writes it atomically, checks it with `gridded.load`.

  Args:
    selected: `select(...)`.
    output: The NetCDF file.
    store: The store (for errors).

  Returns:
    `output`.

  Raises:
    ValueError: reading the store failed, or the written data fail
      `gridded.load`'s checks (NaN, absurd winds, too few values); nothing is
      left at `output` or `output + '.part'`.
    OSError: `output` cannot be written.
  """
  try:
    loaded = selected.load()
  except Exception as error:  # pylint: disable=broad-except
    raise ValueError(
        f'ARCO-ERA5 store {store}: reading the winds failed '
        f'({type(error).__name__}: {_first_line(error)})') from error
  check_no_constant_slab(loaded, store)
  encoding = {name: {'dtype': 'float32', 'zlib': True, 'complevel': 4}
              for name in VARIABLES}
  folder = os.path.dirname(os.path.abspath(output))
  os.makedirs(folder, exist_ok=True)
  partial = output + '.part'
  try:
    try:
      loaded.to_netcdf(partial, encoding=encoding)
    except (OSError, RuntimeError) as error:  # netCDF4: RuntimeError (full
      # disk: 'NetCDF: HDF error').
      raise OSError(f'could not write {output} ({type(error).__name__}: '
                    f'{_first_line(error)}; is the disk full?)') from error
    try:
      gridded.load(partial)
    except ValueError as error:
      raise ValueError(
          f'ARCO-ERA5 store {store}: the selected winds fail the ERA5 '
          f'checks, nothing written: {error}') from error
    os.replace(partial, output)
  finally:
    if os.path.exists(partial):
      os.remove(partial)
  return output


def fetch(requests: Sequence[Tuple[str, Dict[str, Any]]], output: str, *,
          store: str = DEFAULT_STORE) -> str:
  """Writes the requests' ERA5 u, v from an ARCO-ERA5 store to `output`.

  Args:
    requests: `era5_requests.build_requests(...)` (its `grid` is not used:
      the store's grid is kept).
    output: The NetCDF file (new CDS layout, for `gridded.load`).
    store: Local path or URL of the Zarr store.

  Returns:
    `output`.

  Raises:
    ArcoUnavailableError: zarr/gcsfs missing.
    ValueError: bad or unreachable store, or a selection outside it.
    OSError: `output` cannot be written.
  """
  wanted = selection(requests)
  dataset = open_store(store)
  try:
    return write(select(dataset, wanted, store), output, store)
  finally:
    dataset.close()


def describe(requests: Sequence[Tuple[str, Dict[str, Any]]],
             store: str) -> Dict[str, Any]:
  """The selection as JSON-friendly values (for `--dry_run`)."""
  wanted = selection(requests)
  times: List[str] = [_date(t) for t in wanted['times']]
  return {'store': store,
          'variables': dict(VARIABLES),
          'times': {'first': times[0], 'last': times[-1],
                    'count': len(times)},
          'pressure_levels_hpa': wanted['levels_hpa'],
          'area': {k: wanted[k] for k in ('north', 'west', 'south', 'east')},
          'grid': 'the store\'s native grid (0.25 deg for the public store)'}

