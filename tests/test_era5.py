# coding=utf-8
"""Tests of the ERA5 wind field, its CDS request builder and downloader.

The tests write small synthetic ERA5 files (both CDS layouts) whose winds are
multi-linear functions of (time, pressure, latitude, longitude), so the
interpolated winds can be checked exactly. No network.
"""

import datetime as dt
import json
import math
import os
import re
import sys
import types

import ble_latex  # noqa: F401  pylint: disable=unused-import
from balloon_learning_environment.env import wind_field
from balloon_learning_environment.utils import spherical_geometry
from balloon_learning_environment.utils import units
import gin
from hypothesis import given
from hypothesis import settings
from hypothesis import strategies as st
import jax
import numpy as np
import pytest
import s2sphere as s2
import xarray as xr

from ble_latex import configs
from ble_latex import errors
from ble_latex.ble import era5_field
from ble_latex.cli import download_era5
from ble_latex.wind import era5
from ble_latex.wind import era5_checks
from ble_latex.wind import era5_requests

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
  field = era5_field.Era5WindField(path=path, **kwargs)
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
  data = era5.load(era5_file)
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
  data = era5.load(era5_file)
  # Midway between 50 and 100 hPa, 3 h, lat 1.5, lon -112.5.
  uv = data.interpolate(3 * 3600.0, 7500.0, 1.5, -112.5)
  # u = 2 + 0.5*3 + 0.01*75 + 0.3*1.5 - 0.2*0.5 + 0.05*1.5*0.5 + 0.001*3*75
  u = 2 + 1.5 + 0.75 + 0.45 - 0.1 + 0.0375 + 0.225
  # v = -1 + 0.1*3*1.5 + 0.002*75*0.5 - 0.4*1.5
  v = -1 + 0.45 + 0.075 - 0.6
  np.testing.assert_allclose(uv, [u, v], atol=1e-12)


@pytest.fixture(name='shared_data', scope='module')
def fixture_shared_data(tmp_path_factory):
  return era5.load(write_era5(tmp_path_factory.mktemp('era5') / 'era5.nc'))


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


def test_get_forecast_at_offsets_uses_ble_geometry(era5_file):
  field = make_field(era5_file)
  for x_km, y_km, hours, pressure in ((0.0, 0.0, 0.0, 9000.0),
                                      (60.0, -35.0, 2.5, 5000.0),
                                      (-120.0, 80.0, 5.75, 14000.0)):
    lat, lon = latlng(x_km, y_km)
    got = field.get_forecast(units.Distance(km=x_km), units.Distance(km=y_km),
                             pressure, dt.timedelta(hours=hours))
    assert isinstance(got, wind_field.WindVector)
    np.testing.assert_allclose(
        as_tuple(got), (wind_u(hours, pressure / 100, lat, lon),
                        wind_v(hours, pressure / 100, lat, lon)), atol=1e-9)


def test_x_is_east_and_y_is_north(era5_file):
  field = make_field(era5_file)
  t = dt.timedelta(hours=0)
  # 100 km east at lat 1: lon + 100 / (111.195 cos 1deg). v depends on lon
  # only via 0.002 p dlon: with p = 100 hPa, dv = 0.2 dlon.
  dlon = 100.0 / (6371.0 * math.pi / 180.0 * math.cos(math.radians(1.0)))
  east = field.get_forecast(units.Distance(km=100.0), units.Distance(km=0.0),
                            10000.0, t)
  centre = field.get_forecast(units.Distance(km=0.0), units.Distance(km=0.0),
                              10000.0, t)
  # (The great circle heading east dips ~1e-4 deg south over 100 km.)
  assert east.v.meters_per_second - centre.v.meters_per_second == (
      pytest.approx(0.2 * dlon, rel=1e-3))
  # 100 km north: lat + 0.8993 deg; v has -0.4 lat.
  north = field.get_forecast(units.Distance(km=0.0), units.Distance(km=100.0),
                             10000.0, t)
  assert north.v.meters_per_second - centre.v.meters_per_second == (
      pytest.approx(-0.4 * 100.0 / (6371.0 * math.pi / 180.0), rel=1e-6))


def test_forecast_uses_sampled_start_plus_elapsed(era5_file):
  field = make_field(era5_file)
  field.set_start_date_time(dt.datetime(2022, 11, 1, 4, 30))  # Naive = UTC.
  assert field.start_date_time == dt.datetime(2022, 11, 1, 4, 30,
                                              tzinfo=dt.timezone.utc)
  got = field.get_forecast(units.Distance(km=0.0), units.Distance(km=0.0),
                           6000.0, dt.timedelta(hours=2))
  np.testing.assert_allclose(as_tuple(got), (wind_u(6.5, 60.0, *CENTER),
                                             wind_v(6.5, 60.0, *CENTER)),
                             atol=1e-9)


def test_column_is_one_vectorised_call_matching_points(era5_file, monkeypatch):
  field = make_field(era5_file)
  pressures = np.linspace(5000.0, 14000.0, 25)
  x, y = units.Distance(km=30.0), units.Distance(km=-45.0)
  elapsed = dt.timedelta(hours=4, minutes=20)
  expected = [as_tuple(field.get_forecast(x, y, p, elapsed))
              for p in pressures]
  calls = []
  interpolate = field.data.interpolate
  monkeypatch.setattr(
      field, '_data', types.SimpleNamespace(
          interpolate=lambda *a: calls.append(1) or interpolate(*a)))
  column = field.get_forecast_column(x, y, pressures, elapsed)
  assert len(calls) == 1
  np.testing.assert_allclose([as_tuple(c) for c in column], expected,
                             rtol=0, atol=1e-12)


def test_outside_the_data_is_clipped_to_the_edge(era5_file):
  field = make_field(era5_file)
  far = field.get_forecast(units.Distance(km=2000.0),
                           units.Distance(km=-3000.0), 30000.0,
                           dt.timedelta(days=5))
  edge = (12.0, 175.0, -1.0, -111.0)  # Last time, max level, south, east.
  np.testing.assert_allclose(as_tuple(far), (wind_u(*edge), wind_v(*edge)),
                             atol=1e-9)
  high = field.get_forecast(units.Distance(km=0.0), units.Distance(km=0.0),
                            100.0, dt.timedelta(0))
  np.testing.assert_allclose(as_tuple(high), (wind_u(0, 20.0, *CENTER),
                                              wind_v(0, 20.0, *CENTER)),
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
  pa = era5.load(write_era5(tmp_path / 'pa.nc', pressure_unit='Pa'))
  hpa = era5.load(era5_file)
  np.testing.assert_array_equal(pa.pressure, [2000.0, 5000.0, 10000.0,
                                              17500.0])
  np.testing.assert_array_equal(hpa.pressure, pa.pressure)
  np.testing.assert_array_equal(hpa.latitude, np.sort(LATS))


def test_float32_file(tmp_path):
  data = era5.load(write_era5(tmp_path / 'f4.nc', dtype='float32'))
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
  np.testing.assert_allclose(era5.load(path).uv, era5.load(era5_file).uv,
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
  np.testing.assert_array_equal(era5.load(path).uv, era5.load(era5_file).uv)


def test_files_are_joined_along_time(tmp_path, era5_file):
  first = write_era5(tmp_path / 'era5_a.nc', times=TIMES[:2])
  second = write_era5(tmp_path / 'era5_b.nc', times=TIMES[2:])
  whole = era5.load(era5_file)
  for path in ([second, first], str(tmp_path / 'era5_?.nc')):
    joined = era5.load(path)
    np.testing.assert_array_equal(joined.times, whole.times)
    np.testing.assert_array_equal(joined.uv, whole.uv)


# Start time sampling and noise.


def test_start_sampling_is_deterministic_and_fits_the_episode(era5_file):
  field = era5_field.Era5WindField(path=era5_file, episode_hours=6.0)
  starts = []
  for seed in range(40):
    key = jax.random.PRNGKey(seed)
    field.reset(key, dt.datetime(2013, 5, 1, tzinfo=dt.timezone.utc))
    start = field.start_date_time
    field.reset(key, dt.datetime(2011, 1, 1, tzinfo=dt.timezone.utc))
    assert field.start_date_time == start
    assert field.data.start <= start
    assert start + dt.timedelta(hours=6) <= field.data.end
    assert start.second == 0 and start.microsecond == 0
    starts.append(start)
  assert len(set(starts)) > 30
  assert field.data.start == dt.datetime(2022, 11, 1, tzinfo=dt.timezone.utc)


def test_episode_longer_than_data_is_an_error(era5_file):
  with pytest.raises(ValueError, match=r'shorter than episode_hours = 72'):
    era5_field.Era5WindField(path=era5_file, episode_hours=72.0)


def test_forecast_before_reset_is_an_error(era5_file):
  field = era5_field.Era5WindField(path=era5_file, episode_hours=6.0)
  with pytest.raises(RuntimeError, match='reset'):
    field.get_forecast(units.Distance(km=0), units.Distance(km=0), 1e4,
                       dt.timedelta(0))


def test_non_finite_queries_are_errors(era5_file):
  field = make_field(era5_file)
  with pytest.raises(ValueError, match='Pressure must be finite'):
    field.get_forecast(units.Distance(km=0), units.Distance(km=0),
                       float('nan'), dt.timedelta(0))
  with pytest.raises(ValueError, match='Position must be finite'):
    field.get_forecast(units.Distance(km=float('inf')), units.Distance(km=0),
                       1e4, dt.timedelta(0))
  with pytest.raises(ValueError, match='outside the ERA5 data'):
    field.set_start_date_time(dt.datetime(2023, 1, 1))


@pytest.mark.parametrize('add_noise', [False, True])
def test_add_noise_switch(era5_file, add_noise):
  field = era5_field.Era5WindField(path=era5_file, episode_hours=6.0,
                                   add_noise=add_noise)
  field.reset(jax.random.PRNGKey(7), dt.datetime(2013, 1, 1))
  args = (units.Distance(km=20.0), units.Distance(km=-10.0), 8000.0,
          dt.timedelta(hours=1))
  forecast = as_tuple(field.get_forecast(*args))
  truth = as_tuple(field.get_ground_truth(*args))
  if add_noise:
    assert truth != pytest.approx(forecast, abs=1e-6)
  else:
    assert truth == forecast


# Bad files.


def test_missing_file(tmp_path):
  path = str(tmp_path / 'nope.nc')
  with pytest.raises(FileNotFoundError, match=f'ERA5 file {path} does not'):
    era5_field.Era5WindField(path=path)
  with pytest.raises(FileNotFoundError, match='No ERA5 file matches'):
    era5.load(str(tmp_path / 'era5_*.nc'))


def test_not_netcdf(tmp_path):
  path = tmp_path / 'garbage.nc'
  path.write_bytes(b'\x00\x01garbage, not NetCDF\xff' * 50)
  with pytest.raises(ValueError,
                     match=f'ERA5 file {path} is not a readable NetCDF'):
    era5.load(str(path))


def test_missing_variable(tmp_path):
  path = write_era5(tmp_path / 'no_u.nc', drop=('u',))
  with pytest.raises(ValueError) as error:
    era5.load(path)
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
    era5.load(path)


def test_nan_winds(tmp_path):
  path = write_era5(tmp_path / 'nan.nc', nan=True)
  with pytest.raises(ValueError, match=f'ERA5 file {path} has NaN/inf winds: '
                     '1 values of u and 0 of v'):
    era5.load(path)


def test_winds_beyond_memory_are_refused_before_reading(tmp_path, monkeypatch):
  # A crafted NetCDF4 file can declare 1e12 values and store none (chunks
  # never written); reading it asked for all of them. Here the machine's
  # memory is made smaller than a small file's winds.
  path = write_era5(tmp_path / 'era5.nc')
  uv = era5.read_file(path)[-1]
  need = uv[..., 0].size * era5_checks.READ_BYTES_PER_VALUE
  monkeypatch.setattr(era5_checks, 'memory_bytes', lambda: need - 1)
  with pytest.raises(errors.BadFileError) as info:
    era5.read_file(path)
  message = str(info.value)
  assert 'reading them needs' in message and path in message
  assert '\n' not in message
  # GRIB2: the sum of its messages' data points, from their headers.
  grib = os.path.join(os.path.dirname(os.path.abspath(__file__)), 'data',
                      'realwinds', 'gfs_2011-10-11T00Z_uv_10-250hPa_2p5deg.grib2')
  monkeypatch.setattr(era5_checks, 'memory_bytes', lambda: 1_000_000)
  with pytest.raises(errors.BadFileError, match=r'\(189,216 values\)'):
    era5.read_source(grib)


def test_target_outside_area(era5_file):
  with pytest.raises(ValueError, match=r'Target \(lat 10.0, lon -113.0\) lies '
                     'outside the area of ERA5 file'):
    era5_field.Era5WindField(path=era5_file, center_lat=10.0,
                             episode_hours=6.0)
  # The same target in the 0..360 convention is inside.
  era5_field.Era5WindField(path=era5_file, center_lon=247.0,
                           episode_hours=6.0)


def test_files_on_different_grids_are_not_joined(tmp_path, era5_file):
  other = write_era5(tmp_path / 'other.nc', times=TIMES + np.timedelta64(
      1, 'D'), lon=LONS + 0.5)
  with pytest.raises(ValueError, match='different longitudes'):
    era5.load([era5_file, other])


def test_single_level_is_an_error(tmp_path):
  path = write_era5(tmp_path / 'one.nc', levels_hpa=np.array([50.0]))
  with pytest.raises(ValueError, match='1 pressure level value'):
    era5.load(path)


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
    era5.load(path)
  assert str(error.value).startswith(f'ERA5 file {path}: {message}'), error


def test_pressure_below_the_ground_is_an_error(tmp_path):
  path = write_era5(tmp_path / 'deep.nc', pressure_unit='Pa',
                    levels_hpa=np.array([20.0, 50.0, 100.0, 1200.0]))
  with pytest.raises(ValueError, match=f'^ERA5 file {path}: pressure level '
                     '120000 Pa is below the ground'):
    era5.load(path)


def test_time_gap_between_joined_files_is_an_error(tmp_path):
  first = write_era5(tmp_path / 'era5_a.nc')
  later = TIMES + TEN_YEARS
  second = write_era5(tmp_path / 'era5_b.nc', times=later, t0=later[0])
  with pytest.raises(ValueError, match=(
      f'^ERA5 files {first} and {second}: time gap from 2022-11-01T12:00 to '
      r'2032-10-31T00:00 \(87636 h; the median step is 6 h')):
    era5.load(str(tmp_path / 'era5_?.nc'))
  # Files that follow on (one 6 h step) are joined (test above).
  era5.load([first, write_era5(tmp_path / 'next.nc', times=TIMES + 18 * HOUR)])


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
  data = era5.load(path)
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
      era5.load(path).uv,
      era5.load(write_era5(tmp_path / 'nc4.nc', layout='old')).uv)
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
      era5.load(cut)


def test_truncated_netcdf4_file_is_an_error(tmp_path, era5_file):
  content = open(era5_file, 'rb').read()
  for size in (len(content) - 10, len(content) // 2, 100, 30):
    cut = tmp_path / f'cut_{size}.nc'
    cut.write_bytes(content[:size])
    with pytest.raises(ValueError,
                       match=f'ERA5 file {re.escape(str(cut))} is truncated'):
      era5.load(str(cut))


def test_directory_is_an_error(tmp_path, era5_file):
  directory = tmp_path / 'era5_dir.nc'
  directory.mkdir()
  for path in (str(directory), [era5_file, str(directory)],
               str(tmp_path / 'era5_*')):
    with pytest.raises(IsADirectoryError,
                       match=f'ERA5 path {re.escape(str(directory))} is a '
                       'directory'):
      era5.load(path)
  with pytest.raises(IsADirectoryError, match='is a directory'):
    era5_field.Era5WindField(path=str(directory))


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
    era5.load(path)


def test_hpa_numbers_labelled_pa_above_10_hpa_are_errors(tmp_path):
  # 100..1000 hPa labelled Pa: no value below 100 Pa, but 125, 150 Pa are no
  # ERA5 levels.
  path = write_era5(tmp_path / 'p.nc', units_attr='Pa',
                    levels_hpa=np.array([100.0, 125.0, 150.0, 200.0]))
  with pytest.raises(ValueError, match="has units 'Pa' but values"):
    era5.load(path)


@pytest.mark.parametrize('pressure_unit', ['hPa', 'Pa'])
@pytest.mark.parametrize('levels_hpa', [
    era5_checks.ERA5_PRESSURE_LEVELS_HPA, (1, 2, 3, 5, 7, 10), (1, 2),
    (975, 1000)])
def test_every_era5_pressure_level_set_loads(tmp_path, pressure_unit,
                                             levels_hpa):
  levels = np.array(levels_hpa, dtype=np.float64)
  data = era5.load(write_era5(tmp_path / 'all.nc', times=TIMES[:2],
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
    era5.load(path)
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

  data = era5.load(rewrite(source, tmp_path / 'strong.nc', edit))
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
    era5.load(path)


# Other CF-style sources: the reader's `Layout`.


def test_a_layout_reads_another_sources_names(tmp_path, era5_file):
  """NCEP-style names (uwnd/vwnd on lev, lat, lon) read as ERA5's."""
  ncep = era5.Layout(label='NCEP', variables=('uwnd', 'vwnd'),
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
  got, want = era5.load(path, ncep), era5.load(era5_file)
  for name in ('times', 'time_s', 'pressure', 'latitude', 'longitude', 'uv'):
    np.testing.assert_array_equal(getattr(got, name), getattr(want, name))
  # The reader chosen by content finds uwnd/vwnd (an alias) and `lev` (a
  # pressure `units` attribute) itself.
  found = era5.load(path)
  assert found.source == 'analysis'
  np.testing.assert_array_equal(found.uv, want.uv)
  renamed['uwnd'].values[0, 0, 0, 0] = np.nan
  bad = str(tmp_path / 'ncep_nan.nc')
  renamed.to_netcdf(bad)
  with pytest.raises(errors.BadFileError) as error:
    era5.load(bad, ncep)
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
        [f"Era5WindField.path = '{era5_file}'",
         'Era5WindField.episode_hours = 6.0'])
    settings = era5.settings()  # gin's `Era5WindField.*`: plain values.
    assert settings == era5.Era5Settings(path=era5_file, episode_hours=6.0)
    field = era5_field.Era5WindField.from_settings(settings)
    assert field.add_noise and field.settings == settings
    factory = gin.query_parameter('latex_episode.wind_field_factory')
    assert factory.selector == 'Era5WindField'
    del env_lib
  finally:
    gin.clear_config()


# Requests and the download command.


def test_paper_requests_are_exact():
  requests = era5_requests.build_requests()
  assert [month for month, _ in requests] == ['2022-11', '2022-12', '2023-01']
  month, request = requests[0]
  assert request == {
      'product_type': ['reanalysis'],
      'variable': ['u_component_of_wind', 'v_component_of_wind'],
      'year': ['2022'],
      'month': ['11'],
      'day': [f'{d:02d}' for d in range(1, 31)],
      'time': ['00:00', '06:00', '12:00', '18:00'],
      'pressure_level': ['20', '30', '50', '70', '100', '125', '150', '175'],
      'area': [6.0, -118.0, -4.0, -108.0],
      'grid': [0.4, 0.4],
      'data_format': 'netcdf',
      'download_format': 'unarchived',
  }
  assert requests[1][1]['day'][-1] == '31'
  assert requests[2][1]['year'] == ['2023'] and requests[2][1]['month'] == [
      '01']
  assert len(requests[2][1]['day']) == 31
  del month


def test_requests_for_partial_months():
  requests = era5_requests.build_requests(start_date=dt.date(2022, 12, 30),
                                 end_date=dt.date(2023, 1, 2),
                                 half_width_deg=2.0, min_pressure_hpa=50,
                                 max_pressure_hpa=100)
  assert [(m, r['day']) for m, r in requests] == [
      ('2022-12', ['30', '31']), ('2023-01', ['01', '02'])]
  assert requests[0][1]['area'] == [3.0, -115.0, -1.0, -111.0]
  assert requests[0][1]['pressure_level'] == ['50', '70', '100']
  with pytest.raises(ValueError, match='before start_date'):
    era5_requests.build_requests(start_date=dt.date(2023, 1, 2),
                        end_date=dt.date(2023, 1, 1))
  with pytest.raises(ValueError, match='No ERA5 pressure level'):
    era5_requests.build_requests(min_pressure_hpa=21, max_pressure_hpa=29)


def test_dry_run_prints_json_without_cdsapi(monkeypatch, capsys, tmp_path):
  monkeypatch.setitem(sys.modules, 'cdsapi', None)  # Importing it fails.
  output = str(tmp_path / 'era5_paper.nc')
  assert download_era5.main(['--dry_run', '--output', output]) == 0
  printed = json.loads(capsys.readouterr().out)
  assert printed['dataset'] == 'reanalysis-era5-pressure-levels'
  assert printed['output'] == output
  assert [r['request'] for r in printed['requests']] == [
      r for _, r in era5_requests.build_requests()]
  assert [r['target'] for r in printed['requests']] == [
      str(tmp_path / f'era5_paper_{m}.nc')
      for m in ('2022-11', '2022-12', '2023-01')]
  assert not list(tmp_path.iterdir())


def test_missing_credentials_is_a_clear_error(monkeypatch, capsys, tmp_path):
  monkeypatch.setitem(sys.modules, 'cdsapi', None)
  monkeypatch.delenv('CDSAPI_URL', raising=False)
  monkeypatch.delenv('CDSAPI_KEY', raising=False)
  monkeypatch.setenv('CDSAPI_RC', str(tmp_path / 'no_cdsapirc'))
  assert download_era5.main(['--output', str(tmp_path / 'x.nc')]) == 2
  err = capsys.readouterr().err
  assert f'no CDS API credentials: {tmp_path / "no_cdsapirc"} does not ' in err


def test_download_with_fake_client_writes_and_joins_months(
    monkeypatch, capsys, tmp_path):
  retrieved = []

  class FakeClient:

    def retrieve(self, dataset, request, target):
      retrieved.append((dataset, request))
      year, month = int(request['year'][0]), int(request['month'][0])
      days = [int(d) for d in request['day']]
      times = np.array([np.datetime64(dt.datetime(year, month, d, h))
                        for d in days for h in (0, 6, 12, 18)],
                       dtype='datetime64[ns]')
      write_era5(target, times=times, lat=np.array([2.0, 1.0, 0.0]),
                 lon=np.array([-114.0, -113.0, -112.0]),
                 levels_hpa=np.array([50.0, 70.0, 100.0]),
                 dtype='float32', t0=times[0])

  monkeypatch.setitem(sys.modules, 'cdsapi',
                      types.SimpleNamespace(Client=FakeClient))
  monkeypatch.setenv('CDSAPI_URL', 'https://example.invalid/api')
  monkeypatch.setenv('CDSAPI_KEY', 'fake')
  output = str(tmp_path / 'era5.nc')
  argv = ['--output', output, '--start_date', '2022-12-31', '--end_date',
          '2023-01-01', '--half_width_deg', '1']
  assert download_era5.main(argv) == 0
  assert [r['month'] for _, r in retrieved] == [['12'], ['01']]
  data = era5.load(output)
  assert data.times.size == 8
  assert data.start == dt.datetime(2022, 12, 31, tzinfo=dt.timezone.utc)
  assert 'wrote' in capsys.readouterr().out
  # Months already there are not fetched again.
  assert download_era5.main(argv) == 0
  assert len(retrieved) == 2


def test_failed_retrieval_is_a_clear_error(monkeypatch, capsys, tmp_path):

  class FailingClient:

    def retrieve(self, dataset, request, target):
      raise RuntimeError('403 Forbidden: required licences not accepted')

  monkeypatch.setitem(sys.modules, 'cdsapi',
                      types.SimpleNamespace(Client=FailingClient))
  monkeypatch.setenv('CDSAPI_URL', 'https://example.invalid/api')
  monkeypatch.setenv('CDSAPI_KEY', 'fake')
  assert download_era5.main(['--output', str(tmp_path / 'x.nc')]) == 1
  assert 'CDS request for 2022-11 failed (RuntimeError: 403' in (
      capsys.readouterr().err)
  assert not list(tmp_path.iterdir())


def recording_client(calls):
  """A fake cdsapi module whose client records its calls (never called)."""

  class Client:

    def retrieve(self, dataset, request, target):
      calls.append((dataset, request, target))
      raise AssertionError('no request expected')

  return types.SimpleNamespace(Client=Client)


@pytest.mark.parametrize('dry_run', [False, True])
def test_output_directory_is_a_usage_error(monkeypatch, capsys, tmp_path,
                                           dry_run):
  calls = []
  monkeypatch.setitem(sys.modules, 'cdsapi', recording_client(calls))
  monkeypatch.setenv('CDSAPI_URL', 'https://example.invalid/api')
  monkeypatch.setenv('CDSAPI_KEY', 'fake')
  existing = tmp_path / 'existing'
  existing.mkdir()
  for output in (str(existing), str(tmp_path / 'new') + '/',
                 str(tmp_path / 'new') + os.sep, str(existing) + '/'):
    argv = ['--output', output] + (['--dry_run'] if dry_run else [])
    assert download_era5.main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ''
    assert captured.err == (
        f'ble-latex-download-era5: error: --output {output} is a directory; give a file name such as '
        f'{os.path.join(output, "era5_paper.nc")}\n')
  assert not calls
  assert [p.name for p in tmp_path.iterdir()] == ['existing']
  assert not list(existing.iterdir())


def test_output_under_a_file_is_a_usage_error(monkeypatch, capsys, tmp_path):
  calls = []
  monkeypatch.setitem(sys.modules, 'cdsapi', recording_client(calls))
  monkeypatch.setenv('CDSAPI_URL', 'https://example.invalid/api')
  monkeypatch.setenv('CDSAPI_KEY', 'fake')
  (tmp_path / 'file').write_text('x')
  output = str(tmp_path / 'file' / 'era5.nc')
  assert download_era5.main(['--output', output]) == 2
  assert capsys.readouterr().err == (
      f'ble-latex-download-era5: error: --output {output}: {tmp_path / "file"} is not a directory\n')
  assert not calls


def test_monthly_target_directory_is_a_usage_error(monkeypatch, capsys,
                                                   tmp_path):
  calls = []
  monkeypatch.setitem(sys.modules, 'cdsapi', recording_client(calls))
  monkeypatch.setenv('CDSAPI_URL', 'https://example.invalid/api')
  monkeypatch.setenv('CDSAPI_KEY', 'fake')
  (tmp_path / 'era5_2022-12.nc').mkdir()
  assert download_era5.main(['--output', str(tmp_path / 'era5.nc')]) == 2
  assert capsys.readouterr().err == (
      f'ble-latex-download-era5: error: {tmp_path / "era5_2022-12.nc"} (the file for 2022-12) is a '
      'directory\n')
  assert not calls


@pytest.mark.parametrize('exception', [RuntimeError, KeyboardInterrupt])
def test_failed_retrieval_leaves_no_part_file(monkeypatch, capsys, tmp_path,
                                              exception):

  class HalfClient:

    def retrieve(self, dataset, request, target):
      with open(target, 'wb') as f:
        f.write(b'CDF\x01 half a download')
      raise exception('connection reset')

  monkeypatch.setitem(sys.modules, 'cdsapi',
                      types.SimpleNamespace(Client=HalfClient))
  monkeypatch.setenv('CDSAPI_URL', 'https://example.invalid/api')
  monkeypatch.setenv('CDSAPI_KEY', 'fake')
  argv = ['--output', str(tmp_path / 'x.nc')]
  if exception is KeyboardInterrupt:
    with pytest.raises(KeyboardInterrupt):
      download_era5.main(argv)
  else:
    assert download_era5.main(argv) == 1
    assert 'CDS request for 2022-11 failed' in capsys.readouterr().err
  assert not list(tmp_path.iterdir())


def test_failed_merge_leaves_no_part_file(monkeypatch, capsys, tmp_path):
  sources = [write_era5(tmp_path / f'era5_{m}.nc', times=times)
             for m, times in (('2022-11', TIMES[:2]), ('2022-12', TIMES[2:]))]
  written = []

  def failing_to_netcdf(self, path, *args, **kwargs):
    del self, args, kwargs
    written.append(path)
    with open(path, 'wb') as f:
      f.write(b'CDF\x01 half written')
    raise OSError(28, 'No space left on device')

  monkeypatch.setattr(xr.Dataset, 'to_netcdf', failing_to_netcdf)
  output = str(tmp_path / 'era5.nc')
  with pytest.raises(OSError, match='No space left'):
    download_era5.merge_files(sources, output)
  assert written == [output + '.part']
  assert sorted(p.name for p in tmp_path.iterdir()) == [
      'era5_2022-11.nc', 'era5_2022-12.nc']
  # The command reports it as a one-line error.
  assert download_era5.main(['--output', output, '--start_date', '2022-11-01',
                             '--end_date', '2022-12-31']) == 1
  assert capsys.readouterr().err.startswith(
      f'ble-latex-download-era5: error: could not write {output} (OSError: [Errno 28] No space left')
  assert sorted(p.name for p in tmp_path.iterdir()) == [
      'era5_2022-11.nc', 'era5_2022-12.nc']


# The environment.


@pytest.mark.slow
@pytest.mark.ci
def test_env_flies_at_the_sampled_era5_start(tmp_path):
  from ble_latex.ble import gym_env as env_lib  # pylint: disable=g-import-not-at-top
  path = write_era5(tmp_path / 'era5.nc')
  env = env_lib.LatexBalloonEnv(
      wind_field_factory=lambda: era5_field.Era5WindField(
          path=path, episode_hours=1.0),
      episode_steps=2, seed=0)
  # An Era5WindField flies its grid in the core (`EnvParams.wind_grid`).
  assert env.arena.params.wind_grid is not None
  reference = era5_field.Era5WindField(path=path, episode_hours=1.0)
  starts = []
  for _ in range(2):
    env.reset(seed=5)
    start = env.arena.driver.start_date_time
    starts.append(start)
    assert env.arena.get_balloon_state().date_time == start
    env.step(np.array([17_000.0, 1.0, 1.0]))
  assert starts[0] == starts[1]
  # Inside the data, 1 h before its end (the draw is the field's own:
  # test_era5_jax.test_start_draw_is_era5_wind_fields).
  assert reference.data.start <= starts[0] <= (
      reference.data.end - dt.timedelta(hours=1))


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
def test_full_random_episode_on_era5_wind(tmp_path):
  from ble_latex.ble import gym_env as env_lib  # pylint: disable=g-import-not-at-top
  times = T0 + np.arange(17) * np.timedelta64(6, 'h')  # 4 days of data.
  path = write_era5(tmp_path / 'era5_4d.nc', times=times)
  env = env_lib.LatexBalloonEnv(
      wind_field_factory=lambda: era5_field.Era5WindField(path=path), seed=0)
  env.reset(seed=3)
  rng = np.random.default_rng(0)
  done, steps = False, 0
  while not done:
    _, reward, done, info = env.step(
        rng.uniform(env.action_space.low, env.action_space.high))
    steps += 1
    assert np.isfinite(reward)
  assert steps == 216 or info['out_of_resources'] or info['envelope_burst']
  assert info['time_limit'] == (steps == 216)


def test_era5_noise_equals_bles_simplex_noise(era5_file):
  import jax  # pylint: disable=g-import-not-at-top
  field = era5_field.Era5WindField(path=era5_file, episode_hours=6.0)
  key = jax.random.PRNGKey(4)
  field.reset(key, dt.datetime(2022, 11, 1, tzinfo=dt.timezone.utc))
  reference = wind_field.SimplexWindNoise()
  reference.reset_wind_noise(jax.random.split(key, num=2)[0], None)
  for x_km, y_km, p, h in [(0, 0, 9000.0, 1.0), (120, -40, 5200.0, 5.5),
                           (-300, 250, 13900.0, 0.0)]:
    args = (units.Distance(km=x_km), units.Distance(km=y_km), p,
            dt.timedelta(hours=h))
    assert as_tuple(field._noise_model.get_wind_noise(*args)) == as_tuple(  # pylint: disable=protected-access
        reference.get_wind_noise(*args))
