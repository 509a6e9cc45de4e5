# coding=utf-8
"""Tests of the one reader of wind files (`wind.gridded`) and its checks.

The tests write small synthetic ERA5 files (both CDS layouts) whose winds are
multi-linear functions of (time, pressure, latitude, longitude), so the
interpolated winds can be checked exactly. No network. The files and helpers
here serve the other wind tests too (`import test_gridded`).
"""

import datetime as dt
import os
import re

import ble_latex  # noqa: F401  pylint: disable=unused-import
from balloon_learning_environment.utils import spherical_geometry
from balloon_learning_environment.utils import units
import gin
from hypothesis import given
from hypothesis import settings
from hypothesis import strategies as st
import numpy as np
import pytest
import s2sphere as s2
import xarray as xr

from ble_latex import configs
from ble_latex import errors
from ble_latex.ble import gridded_field
from ble_latex.wind import gridded
from ble_latex.wind import gridded_checks

from tests import helpers

T0 = np.datetime64('2022-11-01T00:00', 'ns')
TIMES = T0 + np.arange(3) * np.timedelta64(6, 'h')  # 12 h of data.
LEVELS_HPA = np.array([20.0, 50.0, 100.0, 175.0])  # [hPa]
LATS = np.array([3.0, 2.0, 1.0, 0.0, -1.0])  # Descending, as ERA5. # [deg N]
LONS = np.array([-115.0, -114.0, -113.0, -112.0, -111.0])  # [deg E]
CENTER = (1.0, -113.0)  # (lat, lon) [deg]


def wind_u(t_h, p_hpa, lat, lon):
  """Multi-linear u: exact under multi-linear interpolation. # [m/s]"""
  dlon = lon + 113.0
  return (2.0 + 0.5 * t_h + 0.01 * p_hpa + 0.3 * lat - 0.2 * dlon +
          0.05 * lat * dlon + 0.001 * t_h * p_hpa)


def wind_v(t_h, p_hpa, lat, lon):
  """Multi-linear v. # [m/s]"""
  dlon = lon + 113.0
  return -1.0 + 0.1 * t_h * lat + 0.002 * p_hpa * dlon - 0.4 * lat


def write_era5(path, *, layout='new', pressure_unit='hPa', lat=LATS,
               lon=LONS, times=TIMES, levels_hpa=LEVELS_HPA, drop=(),
               nan=False, dtype='float64', units_attr=None, file_format=None,
               coords_first=False, unlimited_dims=(), t0=T0):
  """Writes a synthetic ERA5 file; returns its path as str.

  `units_attr` overrides the pressure coordinate's `units` attribute (not its
  values); `file_format` is xarray's (e.g. 'NETCDF3_CLASSIC'); with
  `coords_first` the coordinates come first in the file, as in old CDS files.
  The winds' time origin is `t0` (far from it they exceed real winds).
  """
  t_h = (times - t0) / np.timedelta64(1, 'h')
  tt, pp, la, lo = np.meshgrid(t_h, levels_hpa, lat, lon, indexing='ij')
  lon_true = (lo + 180.0) % 360.0 - 180.0
  u = wind_u(tt, pp, la, lon_true).astype(dtype)
  v = wind_v(tt, pp, la, lon_true).astype(dtype)
  if nan:
    u[1, 2, 0, 3] = np.nan
  if layout == 'new':
    dims = ('valid_time', 'pressure_level', 'latitude', 'longitude')
    p_attrs = {'units': 'hPa', 'long_name': 'pressure'}
  else:
    dims = ('time', 'level', 'latitude', 'longitude')
    p_attrs = {'units': 'millibars', 'long_name': 'pressure_level'}
  levels = levels_hpa
  if pressure_unit == 'Pa':
    levels, p_attrs = levels_hpa * 100.0, {'units': 'Pa'}
  if units_attr is not None:
    p_attrs = dict(p_attrs, units=units_attr)
  coords = {dims[0]: times, dims[1]: (dims[1], levels, p_attrs),
            'latitude': ('latitude', lat, {'units': 'degrees_north'}),
            'longitude': ('longitude', lon, {'units': 'degrees_east'})}
  if layout == 'new':
    coords['number'] = 0
    coords['expver'] = ('valid_time', np.array(['0001'] * len(times)))
  variables = {'u': (dims, u, {'units': 'm s**-1'}),
               'v': (dims, v, {'units': 'm s**-1'}),
               't': (dims, np.full(u.shape, 210.0), {'units': 'K'})}
  for name in drop:
    del variables[name]
  if coords_first:
    dataset = xr.Dataset(coords=coords)
    for name, variable in variables.items():
      dataset[name] = variable
  else:
    dataset = xr.Dataset(variables, coords=coords)
  dataset.to_netcdf(path, format=file_format,
                    unlimited_dims=list(unlimited_dims))
  return str(path)


@pytest.fixture(name='era5_file')
def fixture_era5_file(tmp_path):
  return write_era5(tmp_path / 'era5.nc')


def make_field(path, **kwargs):
  kwargs.setdefault('episode_hours', 6.0)
  field = gridded_field.GriddedWindField(path=path, **kwargs)
  field.set_start_date_time(dt.datetime(2022, 11, 1, tzinfo=dt.timezone.utc))
  return field


def latlng(x_km, y_km):
  ll = spherical_geometry.calculate_latlng_from_offset(
      s2.LatLng.from_degrees(*CENTER), units.Distance(km=x_km),
      units.Distance(km=y_km))
  return ll.lat().degrees, ll.lng().degrees


def as_tuple(vector):
  return (vector.u.meters_per_second, vector.v.meters_per_second)


# Interpolation.


def test_interpolate_off_grid_points_exact(era5_file):
  data = gridded.load(era5_file)
  t_h = np.array([0.0, 1.5, 7.25, 12.0])
  p_hpa = np.array([20.0, 33.0, 140.5, 175.0])
  lat = np.array([-1.0, 0.3, 1.77, 2.9])
  lon = np.array([-114.6, -113.0, -111.2, -112.45])
  uv = data.interpolate(t_h * 3600.0, p_hpa * 100.0, lat, lon)
  np.testing.assert_allclose(uv[:, 0], wind_u(t_h, p_hpa, lat, lon),
                             rtol=0, atol=1e-9)
  np.testing.assert_allclose(uv[:, 1], wind_v(t_h, p_hpa, lat, lon),
                             rtol=0, atol=1e-9)


def test_interpolate_hand_computed_value(era5_file):
  data = gridded.load(era5_file)
  # Midway between 50 and 100 hPa, 3 h, lat 1.5, lon -112.5.
  uv = data.interpolate(3 * 3600.0, 7500.0, 1.5, -112.5)
  # u = 2 + 0.5*3 + 0.01*75 + 0.3*1.5 - 0.2*0.5 + 0.05*1.5*0.5 + 0.001*3*75
  u = 2 + 1.5 + 0.75 + 0.45 - 0.1 + 0.0375 + 0.225
  # v = -1 + 0.1*3*1.5 + 0.002*75*0.5 - 0.4*1.5
  v = -1 + 0.45 + 0.075 - 0.6
  np.testing.assert_allclose(uv, [u, v], atol=1e-12)


@pytest.fixture(name='shared_data', scope='module')
def fixture_shared_data(tmp_path_factory):
  return gridded.load(write_era5(tmp_path_factory.mktemp('era5') / 'era5.nc'))


@settings(max_examples=60, deadline=None)
@given(t_h=st.floats(-5.0, 20.0), p_hpa=st.floats(5.0, 300.0),
       lat=st.floats(-3.0, 5.0), lon=st.floats(-118.0, -108.0))
def test_interpolate_is_exact_inside_and_clipped_outside(shared_data, t_h,
                                                         p_hpa, lat, lon):
  uv = shared_data.interpolate(t_h * 3600.0, p_hpa * 100.0, lat, lon)
  clipped = (np.clip(t_h, 0.0, 12.0), np.clip(p_hpa, 20.0, 175.0),
             np.clip(lat, -1.0, 3.0), np.clip(lon, -115.0, -111.0))
  np.testing.assert_allclose(uv, [wind_u(*clipped), wind_v(*clipped)],
                             atol=1e-9)


# Layouts and units.


@pytest.mark.parametrize('kwargs', [
    dict(layout='old'),
    dict(pressure_unit='Pa'),
    dict(layout='old', pressure_unit='Pa'),
    dict(lat=LATS[::-1]),
    dict(lon=LONS % 360.0),
    dict(layout='old', lat=LATS[::-1], lon=LONS % 360.0),
    dict(levels_hpa=LEVELS_HPA[::-1]),
])
def test_layouts_give_the_same_winds(tmp_path, era5_file, kwargs):
  reference = make_field(era5_file)
  other = make_field(write_era5(tmp_path / 'other.nc', **kwargs))
  rng = np.random.default_rng(0)
  for _ in range(5):
    x, y = (units.Distance(km=k) for k in rng.uniform(-150, 150, 2))
    pressures = rng.uniform(1000.0, 20000.0, 7)
    elapsed = dt.timedelta(hours=rng.uniform(0.0, 6.0))
    np.testing.assert_allclose(
        [as_tuple(w) for w in other.get_forecast_column(
            x, y, pressures, elapsed)],
        [as_tuple(w) for w in reference.get_forecast_column(
            x, y, pressures, elapsed)], rtol=0, atol=1e-9)


def test_pressure_axis_is_pa_whatever_the_file_unit(tmp_path, era5_file):
  pa = gridded.load(write_era5(tmp_path / 'pa.nc', pressure_unit='Pa'))
  hpa = gridded.load(era5_file)
  np.testing.assert_array_equal(pa.pressure, [2000.0, 5000.0, 10000.0,
                                              17500.0])
  np.testing.assert_array_equal(hpa.pressure, pa.pressure)
  np.testing.assert_array_equal(hpa.latitude, np.sort(LATS))


def test_float32_file(tmp_path):
  data = gridded.load(write_era5(tmp_path / 'f4.nc', dtype='float32'))
  uv = data.interpolate(3600.0, 6000.0, 0.5, -112.5)
  np.testing.assert_allclose(uv, [wind_u(1.0, 60.0, 0.5, -112.5),
                                  wind_v(1.0, 60.0, 0.5, -112.5)], atol=1e-5)


def test_packed_int16_file(tmp_path, era5_file):
  # Old CDS files store u, v as int16 with scale_factor / add_offset.
  path = str(tmp_path / 'packed.nc')
  with xr.open_dataset(write_era5(tmp_path / 'plain.nc', layout='old')) as ds:
    packing = {'dtype': 'int16', 'scale_factor': 1e-3, 'add_offset': 5.0,
               '_FillValue': -32767}
    ds.load().to_netcdf(path, encoding={'u': packing, 'v': packing})
  np.testing.assert_allclose(gridded.load(path).uv, gridded.load(era5_file).uv,
                             atol=6e-4)


def test_old_cds_expver_dimension_is_combined(tmp_path, era5_file):
  # Old CDS files mixing ERA5 (expver 1) and ERA5T (expver 5) carry an
  # `expver` dimension; each time is valid (non-NaN) in one of them.
  with xr.open_dataset(write_era5(tmp_path / 'plain.nc', layout='old')) as ds:
    ds = ds.load()
  parts = []
  for number, valid in ((1, [True, True, False]), (5, [False, False, True])):
    mask = xr.DataArray(valid, dims='time')
    parts.append(ds[['u', 'v']].where(mask).expand_dims(expver=[number]))
  path = str(tmp_path / 'expver.nc')
  xr.concat(parts, dim='expver').to_netcdf(path)
  np.testing.assert_array_equal(gridded.load(path).uv, gridded.load(era5_file).uv)


def test_files_are_joined_along_time(tmp_path, era5_file):
  first = write_era5(tmp_path / 'era5_a.nc', times=TIMES[:2])
  second = write_era5(tmp_path / 'era5_b.nc', times=TIMES[2:])
  whole = gridded.load(era5_file)
  for path in ([second, first], str(tmp_path / 'era5_?.nc')):
    joined = gridded.load(path)
    np.testing.assert_array_equal(joined.times, whole.times)
    np.testing.assert_array_equal(joined.uv, whole.uv)


# Bad files.


def test_missing_file(tmp_path):
  path = str(tmp_path / 'nope.nc')
  with pytest.raises(FileNotFoundError, match=f'ERA5 file {path} does not'):
    gridded_field.GriddedWindField(path=path)
  with pytest.raises(FileNotFoundError, match='No ERA5 file matches'):
    gridded.load(str(tmp_path / 'era5_*.nc'))


def test_not_netcdf(tmp_path):
  path = tmp_path / 'garbage.nc'
  path.write_bytes(b'\x00\x01garbage, not NetCDF\xff' * 50)
  with pytest.raises(ValueError,
                     match=f'ERA5 file {path} is not a readable NetCDF'):
    gridded.load(str(path))


def test_missing_variable(tmp_path):
  path = write_era5(tmp_path / 'no_u.nc', drop=('u',))
  with pytest.raises(ValueError) as error:
    gridded.load(path)
  assert str(error.value).startswith(
      f"ERA5 file {path} has no wind variables (found: ['t', 'v']; expected "
      'CF standard_name eastward_wind/northward_wind or one of')
  assert '\n' not in str(error.value)


def test_missing_dimension(tmp_path):
  path = str(tmp_path / 'surface.nc')
  dims = ('valid_time', 'latitude', 'longitude')
  zeros = np.zeros((3, 5, 5))
  xr.Dataset({'u': (dims, zeros), 'v': (dims, zeros)},
             coords={'valid_time': TIMES, 'latitude': LATS,
                     'longitude': LONS}).to_netcdf(path)
  with pytest.raises(ValueError,
                     match=f"ERA5 file {path} has no pressure-level dimension"
                     r".*'pressure_level', 'level'.*variable 'u' has dims "
                     r"\['valid_time', 'latitude', 'longitude'\]"):
    gridded.load(path)


def test_nan_winds(tmp_path):
  path = write_era5(tmp_path / 'nan.nc', nan=True)
  with pytest.raises(ValueError, match=f'ERA5 file {path} has NaN/inf winds: '
                     '1 values of u and 0 of v'):
    gridded.load(path)


def test_winds_beyond_memory_are_refused_before_reading(tmp_path, monkeypatch):
  # A crafted NetCDF4 file can declare 1e12 values and store none (chunks
  # never written); reading it asked for all of them. Here the machine's
  # memory is made smaller than a small file's winds.
  path = write_era5(tmp_path / 'era5.nc')
  uv = gridded.read_file(path)[-1]
  need = uv[..., 0].size * gridded_checks.READ_BYTES_PER_VALUE
  monkeypatch.setattr(gridded_checks, 'memory_bytes', lambda: need - 1)
  with pytest.raises(errors.BadFileError) as info:
    gridded.read_file(path)
  message = str(info.value)
  assert 'reading them needs' in message and path in message
  assert '\n' not in message
  # GRIB2: the sum of its messages' data points, from their headers.
  grib = os.path.join(helpers.REAL_WINDS, 'gfs_2011-10-11T00Z_uv_10-250hPa_2p5deg.grib2')
  monkeypatch.setattr(gridded_checks, 'memory_bytes', lambda: 1_000_000)
  with pytest.raises(errors.BadFileError, match=r'\(189,216 values\)'):
    gridded.read_source(grib)


def test_target_outside_area(era5_file):
  with pytest.raises(ValueError, match=r'Target \(lat 10.0, lon -113.0\) lies '
                     'outside the area of ERA5 file'):
    gridded_field.GriddedWindField(path=era5_file, center_lat=10.0,
                             episode_hours=6.0)
  # The same target in the 0..360 convention is inside.
  gridded_field.GriddedWindField(path=era5_file, center_lon=247.0,
                           episode_hours=6.0)


def test_files_on_different_grids_are_not_joined(tmp_path, era5_file):
  other = write_era5(tmp_path / 'other.nc', times=TIMES + np.timedelta64(
      1, 'D'), lon=LONS + 0.5)
  with pytest.raises(ValueError, match='different longitudes'):
    gridded.load([era5_file, other])


def test_single_level_is_an_error(tmp_path):
  path = write_era5(tmp_path / 'one.nc', levels_hpa=np.array([50.0]))
  with pytest.raises(ValueError, match='1 pressure level value'):
    gridded.load(path)


def with_coordinate(source, path, name, values):
  """Copies an ERA5 file with coordinate `name` replaced (same winds)."""
  def edit(dataset):
    dataset.coords[name] = (name, np.asarray(values),
                            dataset[name].attrs)
  return rewrite(source, path, edit)


HOUR = np.timedelta64(1, 'h')
TEN_YEARS = np.timedelta64(3652, 'D')


@pytest.mark.parametrize('name, values, message', [
    ('latitude', [200.0, 2.0, 1.0, 0.0, -1.0],
     'latitude 200 is outside [-90, 90]'),
    ('latitude', [95.0, 94.0, 93.0, 92.0, 91.0],
     'latitude 95 is outside [-90, 90]'),
    ('latitude', [-91.0, -92.0, -93.0, -94.0, -95.0],
     'latitude -91 is outside [-90, 90]'),
    ('longitude', [-115.0, -114.0, -113.0, -112.0, 1000.0],
     'longitude 1000 is outside [-180, 360]'),
    ('longitude', [-181.0, -114.0, -113.0, -112.0, -111.0],
     'longitude -181 is outside [-180, 360]'),
    ('longitude', [-115.0, -114.0, -113.0, 246.0, 247.0],
     'longitudes -114 and 246 are the same meridian'),
    ('longitude', [-115.0, -114.0, -113.0, -112.0, 246.5],
     'longitudes span -115 to 246.5, 360 deg or more'),
    ('longitude', [-115.0, -113.0, -114.0, -112.0, -111.0],
     'longitude coordinate is not strictly monotonic (values out of order'),
    ('latitude', [3.0, 2.0, 2.0, 0.0, -1.0],
     'latitude coordinate is not strictly monotonic (value 2 more than '
     'once: [3, 2, 2, 0, -1])'),
    ('pressure_level', [-20.0, 50.0, 100.0, 175.0],
     'pressure level -20 is not positive'),
    ('pressure_level', [0.0, 50.0, 100.0, 175.0],
     'pressure level 0 is not positive'),
    ('pressure_level', [20.0, 20.0, 100.0, 175.0],
     'pressure coordinate is not strictly monotonic'),
    ('valid_time', [T0, T0 + 12 * HOUR, T0 + 6 * HOUR],
     'times are not strictly increasing (2022-11-01T12:00 is followed by '
     '2022-11-01T06:00)'),
    ('valid_time', [T0, T0, T0 + 6 * HOUR],
     'times are not strictly increasing'),
    ('valid_time', [T0, T0 + 6 * HOUR, T0 + 6 * HOUR + TEN_YEARS],
     'time gap from 2022-11-01T06:00 to 2032-10-31T06:00 (87648 h; the '
     'median step is 43827 h'),
    ('valid_time', [T0, T0 + 6 * HOUR, T0 + 36 * HOUR],
     'time gap from 2022-11-01T06:00 to 2022-11-02T12:00 (30 h'),
])
def test_impossible_coordinates_are_errors(tmp_path, era5_file, name, values,
                                           message):
  path = with_coordinate(era5_file, tmp_path / 'bad.nc', name, values)
  with pytest.raises(ValueError) as error:
    gridded.load(path)
  assert str(error.value).startswith(f'ERA5 file {path}: {message}'), error


def test_pressure_below_the_ground_is_an_error(tmp_path):
  path = write_era5(tmp_path / 'deep.nc', pressure_unit='Pa',
                    levels_hpa=np.array([20.0, 50.0, 100.0, 1200.0]))
  with pytest.raises(ValueError, match=f'^ERA5 file {path}: pressure level '
                     '120000 Pa is below the ground'):
    gridded.load(path)


def test_time_gap_between_joined_files_is_an_error(tmp_path):
  first = write_era5(tmp_path / 'era5_a.nc')
  later = TIMES + TEN_YEARS
  second = write_era5(tmp_path / 'era5_b.nc', times=later, t0=later[0])
  with pytest.raises(ValueError, match=(
      f'^ERA5 files {first} and {second}: time gap from 2022-11-01T12:00 to '
      r'2032-10-31T00:00 \(87636 h; the median step is 6 h')):
    gridded.load(str(tmp_path / 'era5_?.nc'))
  # Files that follow on (one 6 h step) are joined (test above).
  gridded.load([first, write_era5(tmp_path / 'next.nc', times=TIMES + 18 * HOUR)])


@pytest.mark.parametrize('name, values', [
    ('latitude', [90.0, 89.0, 88.0, 87.0, 86.0]),
    ('latitude', [-86.0, -87.0, -88.0, -89.0, -90.0]),
    ('longitude', [-180.0, -179.0, -178.0, -177.0, -176.0]),
    ('longitude', [178.0, 179.0, 180.0, 181.0, 182.0]),
    ('longitude', [356.0, 357.0, 358.0, 359.0, 360.0]),
    ('longitude', [-2.0, -1.0, 0.0, 1.0, 2.0]),
    ('valid_time', [T0, T0 + HOUR, T0 + 2 * HOUR]),
    ('valid_time', [T0, T0 + 24 * HOUR, T0 + 48 * HOUR]),
])
def test_real_coordinates_load(tmp_path, era5_file, name, values):
  path = with_coordinate(era5_file, tmp_path / 'ok.nc', name, values)
  data = gridded.load(path)
  axis = {'latitude': data.latitude, 'longitude': data.longitude,
          'valid_time': data.times}[name]
  np.testing.assert_array_equal(axis, np.sort(np.asarray(values)))


@pytest.mark.parametrize('unlimited_dims', [(), ('time',)])
@pytest.mark.parametrize('coords_first', [True, False])
@pytest.mark.parametrize('file_format', ['NETCDF3_CLASSIC', 'NETCDF3_64BIT'])
def test_truncated_netcdf3_file_is_an_error(tmp_path, file_format,
                                            coords_first, unlimited_dims):
  # Old CDS files are NetCDF3 with the coordinates first: cut, they used to
  # load with wrong winds (or fail with "time more than once").
  path = write_era5(tmp_path / 'whole.nc', layout='old',
                    file_format=file_format, coords_first=coords_first,
                    unlimited_dims=unlimited_dims)
  np.testing.assert_array_equal(
      gridded.load(path).uv,
      gridded.load(write_era5(tmp_path / 'nc4.nc', layout='old')).uv)
  content = open(path, 'rb').read()
  for size in (len(content) - 8, len(content) * 3 // 4, len(content) // 2,
               60):
    cut = str(tmp_path / f'cut_{size}.nc')
    with open(cut, 'wb') as f:
      f.write(content)
    with open(cut, 'r+b') as f:
      f.truncate(size)
    with pytest.raises(ValueError,
                       match=f'ERA5 file {re.escape(cut)} is truncated'):
      gridded.load(cut)


def test_truncated_netcdf4_file_is_an_error(tmp_path, era5_file):
  content = open(era5_file, 'rb').read()
  for size in (len(content) - 10, len(content) // 2, 100, 30):
    cut = tmp_path / f'cut_{size}.nc'
    cut.write_bytes(content[:size])
    with pytest.raises(ValueError,
                       match=f'ERA5 file {re.escape(str(cut))} is truncated'):
      gridded.load(str(cut))


def test_directory_is_an_error(tmp_path, era5_file):
  directory = tmp_path / 'era5_dir.nc'
  directory.mkdir()
  for path in (str(directory), [era5_file, str(directory)],
               str(tmp_path / 'era5_*')):
    with pytest.raises(IsADirectoryError,
                       match=f'ERA5 path {re.escape(str(directory))} is a '
                       'directory'):
      gridded.load(path)
  with pytest.raises(IsADirectoryError, match='is a directory'):
    gridded_field.GriddedWindField(path=str(directory))


@pytest.mark.parametrize('pressure_unit, units_attr', [
    ('hPa', 'Pa'), ('Pa', 'hPa'), ('Pa', 'millibars')])
def test_pressure_values_contradicting_units_are_errors(tmp_path,
                                                        pressure_unit,
                                                        units_attr):
  path = write_era5(tmp_path / 'p.nc', pressure_unit=pressure_unit,
                    units_attr=units_attr)
  with pytest.raises(ValueError,
                     match=f'ERA5 file {re.escape(path)}: pressure coordinate '
                     f"'pressure_level' has units '{units_attr}' but values "):
    gridded.load(path)


def test_hpa_numbers_labelled_pa_above_10_hpa_are_errors(tmp_path):
  # 100..1000 hPa labelled Pa: no value below 100 Pa, but 125, 150 Pa are no
  # ERA5 levels.
  path = write_era5(tmp_path / 'p.nc', units_attr='Pa',
                    levels_hpa=np.array([100.0, 125.0, 150.0, 200.0]))
  with pytest.raises(ValueError, match="has units 'Pa' but values"):
    gridded.load(path)


@pytest.mark.parametrize('pressure_unit', ['hPa', 'Pa'])
@pytest.mark.parametrize('levels_hpa', [
    gridded_checks.ERA5_PRESSURE_LEVELS_HPA, (1, 2, 3, 5, 7, 10), (1, 2),
    (975, 1000)])
def test_every_era5_pressure_level_set_loads(tmp_path, pressure_unit,
                                             levels_hpa):
  levels = np.array(levels_hpa, dtype=np.float64)
  data = gridded.load(write_era5(tmp_path / 'all.nc', times=TIMES[:2],
                                 levels_hpa=levels,
                                 pressure_unit=pressure_unit))
  np.testing.assert_array_equal(data.pressure, levels * 100.0)


FILL = 9.969209968386869e36  # NetCDF's default float fill value.


def rewrite(source, path, edit, encoding=None):
  """Copies an ERA5 file with `edit(dataset)` applied; returns the path."""
  with xr.open_dataset(source) as dataset:
    dataset = dataset.load()
  edit(dataset)
  dataset.to_netcdf(path, encoding=encoding)
  return str(path)


@pytest.mark.parametrize('name, value', [('u', FILL), ('v', -FILL),
                                         ('v', 250.0)])
def test_undeclared_fill_values_and_absurd_winds_are_errors(tmp_path, name,
                                                            value):
  source = write_era5(tmp_path / 'f4.nc', dtype='float32')

  def edit(dataset):
    dataset[name].values[2, 1, 0, 3] = value
    dataset[name].values[2, 3, 4, 4] = value

  path = rewrite(source, tmp_path / 'fill.nc', edit,
                 encoding={name: {'_FillValue': None}})
  with pytest.raises(ValueError) as error:
    gridded.load(path)
  message = str(error.value)
  assert message.startswith(f'ERA5 file {path}: variable {name!r} has 2 '
                            f'values with |{name}| > 200 m/s (first ')
  assert 'valid_time 2022-11-01T12:00, pressure 5000 Pa, latitude 3' in (
      message)
  assert 'undeclared fill value' in message


def test_strong_but_possible_winds_load(tmp_path):
  source = write_era5(tmp_path / 'f4.nc', dtype='float32')

  def edit(dataset):
    dataset['u'].values[0, 0, 0, 0] = -199.0
    dataset['v'].values[1, 1, 1, 1] = 180.0

  data = gridded.load(rewrite(source, tmp_path / 'strong.nc', edit))
  assert data.uv.min() == -199.0 and data.uv.max() == 180.0


@pytest.mark.parametrize('attribute', ['_FillValue', 'missing_value'])
def test_declared_fill_values_are_nan_errors(tmp_path, attribute):
  source = write_era5(tmp_path / 'f4.nc', dtype='float32')

  def edit(dataset):
    dataset['u'].values[0, 0, 0, 0] = FILL

  encoding = {'u': {attribute: np.float32(FILL)}}
  if attribute == 'missing_value':
    encoding['u']['_FillValue'] = None
  path = rewrite(source, tmp_path / 'declared.nc', edit, encoding=encoding)
  with pytest.raises(ValueError, match=f'ERA5 file {re.escape(path)} has '
                     'NaN/inf winds: 1 values of u and 0 of v'):
    gridded.load(path)


# Other CF-style sources: the reader's `Layout`.


def test_a_layout_reads_another_sources_names(tmp_path, era5_file):
  """NCEP-style names (uwnd/vwnd on lev, lat, lon) read as ERA5's."""
  ncep = gridded.Layout(label='NCEP', variables=('uwnd', 'vwnd'),
                        time=('time',), pressure=('lev',), latitude=('lat',),
                        longitude=('lon',))

  def rename(dataset):
    return dataset.rename({'u': 'uwnd', 'v': 'vwnd', 'valid_time': 'time',
                           'pressure_level': 'lev', 'latitude': 'lat',
                           'longitude': 'lon'})

  with xr.open_dataset(era5_file) as dataset:
    renamed = rename(dataset.load())
  path = str(tmp_path / 'ncep.nc')
  renamed.to_netcdf(path)
  got, want = gridded.load(path, ncep), gridded.load(era5_file)
  for name in ('times', 'time_s', 'pressure', 'latitude', 'longitude', 'uv'):
    np.testing.assert_array_equal(getattr(got, name), getattr(want, name))
  # The reader chosen by content finds uwnd/vwnd (an alias) and `lev` (a
  # pressure `units` attribute) itself.
  found = gridded.load(path)
  assert found.source == 'analysis'
  np.testing.assert_array_equal(found.uv, want.uv)
  renamed['uwnd'].values[0, 0, 0, 0] = np.nan
  bad = str(tmp_path / 'ncep_nan.nc')
  renamed.to_netcdf(bad)
  with pytest.raises(errors.BadFileError) as error:
    gridded.load(bad, ncep)
  assert str(error.value).startswith(
      f'NCEP file {bad} has NaN/inf winds: 1 values of uwnd and 0 of vwnd')


# Gin.


def test_paper_gin_file_binds_the_field(era5_file):
  # BLE's env modules register gin configurables when imported: before the
  # parse locks the config (it passed only where an earlier test of the same
  # worker had imported them).
  from ble_latex.ble import gym_env as env_lib  # pylint: disable=g-import-not-at-top
  try:
    gin.parse_config_files_and_bindings(
        [configs.gin_file('paper_era5.gin')],
        [f"GriddedWindField.path = '{era5_file}'",
         'GriddedWindField.episode_hours = 6.0'])
    settings = gridded.settings()  # gin's `GriddedWindField.*`: plain values.
    assert settings == gridded.Era5Settings(path=era5_file, episode_hours=6.0)
    field = gridded_field.GriddedWindField.from_settings(settings)
    assert field.add_noise and field.settings == settings
    factory = gin.query_parameter('latex_episode.wind_field_factory')
    assert factory.selector == 'GriddedWindField'
    del env_lib
  finally:
    gin.clear_config()


def test_era5_dates_that_overflow_are_a_config_error():
  from ble_latex.wind import gridded  # pylint: disable=g-import-not-at-top
  for pair in (('0001-01-01T00:00+01:00', '2022-01-01'),
               ('2022-01-01', '9999-12-31T23:00-05:00')):
    with pytest.raises(errors.ConfigError, match='years 1..9999'):
      gridded.start_dates_range(pair)


def test_the_wind_memory_guard_uses_available_memory(monkeypatch):
  from ble_latex import safe_io  # pylint: disable=g-import-not-at-top
  from ble_latex.wind import gridded_checks  # pylint: disable=g-import-not-at-top
  monkeypatch.setattr(safe_io, 'available_memory_bytes', lambda: 10**6)
  assert gridded_checks.memory_bytes() == 10**6
  with pytest.raises(errors.BadFileError, match='available now'):
    gridded_checks.check_size('f.nc', (10, 10, 10, 1000))


@pytest.mark.parametrize('name, needle', [
    ('gfs.grib2', 'ble-latex-download-gfs'),
    ('PHTO_uwyo.csv', 'University of Wyoming sounding'),
    ('station.txt', 'University of Wyoming sounding'),
])
def test_a_missing_wind_file_hint_names_its_kind(name, needle, tmp_path):
  from ble_latex.wind import gridded  # pylint: disable=g-import-not-at-top
  with pytest.raises(FileNotFoundError) as info:
    gridded.load(str(tmp_path / name))
  assert needle in str(info.value)
  assert 'download-era5' not in str(info.value)


def test_a_fifo_or_symlink_loop_is_not_called_missing(tmp_path):
  from ble_latex.wind import gridded  # pylint: disable=g-import-not-at-top
  from ble_latex.wind import sounding  # pylint: disable=g-import-not-at-top
  fifo = tmp_path / 'winds.nc'
  os.mkfifo(fifo)
  loop = tmp_path / 'loop.nc'
  os.symlink(loop, loop)
  for path, needle in ((fifo, 'is a FIFO'), (loop, 'symbolic link')):
    with pytest.raises(errors.BadFileError, match=needle):
      gridded.load(str(path))
  with pytest.raises(errors.BadFileError, match='is a FIFO'):
    sounding.read(str(fifo))


def test_wind_file_fifo_is_one_line_exit_1(tmp_path, capsys):
  from ble_latex.cli import plot  # pylint: disable=g-import-not-at-top
  fifo = tmp_path / 'winds.nc'
  os.mkfifo(fifo)
  assert plot.main([f'--output_dir={tmp_path / "p"}', '--wind_stats',
                    f'--wind_file={fifo}']) == 1
  assert 'is a FIFO' in helpers.one_line(capsys, 'ble-latex-plot')


# -- Item 7: a GRIB2 file with two messages of one field is refused. --------
def test_grib2_with_a_duplicated_message_is_refused(tmp_path):
  from ble_latex.wind import gridded  # pylint: disable=g-import-not-at-top
  grib = os.path.join(helpers.REAL_WINDS, 'gfs_2011-10-11T00Z_uv_10-250hPa_2p5deg.grib2')
  with open(grib, 'rb') as f:
    raw = f.read()
  end = raw.index(b'7777') + 4  # The first message, appended once more.
  path = tmp_path / 'twice.grib2'
  path.write_bytes(raw + raw[:end])
  with pytest.raises(errors.BadFileError, match='holds two messages of'):
    gridded.read_source(str(path))
