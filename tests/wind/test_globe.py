# coding=utf-8
"""A global wind grid has no edge (issue 64, "Why" 1 and 3).

A synthetic global file (10 deg longitudes 0..350, rows 80 S..80 N, random
winds) and the real GFS +72 h global GRIB2 slice: interpolation is bilinear
across the seam at the last longitude (numpy and JAX), a target west of
Greenwich is inside, no flight leaves the grid at the seam or over a pole,
per-seed stations span every longitude; a sounding's column is the same
anywhere on the sphere (Funafuti at 179.22 E, the poles). No network.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import xarray as xr

from ble_latex.wind import globe
from ble_latex.wind import gridded
from ble_latex.wind import gridded_jax
from ble_latex.wind import stations

from tests import helpers

LONS = np.arange(0.0, 360.0, 10.0)  # [deg E] 0..350: the seam at 350 -> 360.
LATS = np.arange(-80.0, 81.0, 20.0)  # [deg N] within one row of each pole.
LEVELS_HPA = np.array([20.0, 50.0, 100.0, 175.0])  # [hPa]
P_PA = 5000.0  # A query level. # [Pa]
REAL = helpers.REAL_WINDS
GFS_GLOBAL = REAL / 'gfs_2011-10-11T00Z_uv_10-250hPa_2p5deg.grib2'
HILO = REAL / 'PHTO-Hilo_2023-11-01T00Z_uwyo.csv'


@pytest.fixture(name='globe_file', scope='module')
def fixture_globe_file(tmp_path_factory):
  """A one-time global ERA5-layout file of random winds."""
  path = tmp_path_factory.mktemp('globe') / 'global.nc'
  rng = np.random.default_rng(64)
  shape = (1, LEVELS_HPA.size, LATS.size, LONS.size)
  dims = ('valid_time', 'pressure_level', 'latitude', 'longitude')
  coords = {'valid_time': [np.datetime64('2022-11-01T00:00', 'ns')],
            'pressure_level': ('pressure_level', LEVELS_HPA,
                               {'units': 'hPa'}),
            'latitude': ('latitude', LATS[::-1], {'units': 'degrees_north'}),
            'longitude': ('longitude', LONS, {'units': 'degrees_east'})}
  xr.Dataset({name: (dims, rng.normal(0.0, 10.0, shape), {'units': 'm s**-1'})
              for name in ('u', 'v')}, coords=coords).to_netcdf(path)
  return str(path)


def test_global_axes_are_recognised():
  assert globe.is_global_longitude(LONS)
  assert globe.is_global_longitude(np.arange(-180.0, 180.0, 0.5))
  assert globe.is_global_longitude(np.array([-180.0, 0.0]))  # A sounding's.
  assert not globe.is_global_longitude(np.arange(210.0, 311.0, 1.0))
  assert not globe.is_global_longitude(np.arange(0.0, 340.0, 10.0))
  assert globe.latitude_bounds(LATS, True) == (-90.0, 90.0)
  assert globe.latitude_bounds(LATS, False) == (-80.0, 80.0)
  assert globe.latitude_bounds(np.arange(-40.0, 41.0, 20.0), True) == (
      -40.0, 40.0)


def test_interpolation_is_bilinear_across_the_seam(globe_file):
  data = gridded.load(globe_file)
  assert data.global_longitude and data.longitude[-1] == 360.0
  west = data.interpolate(0.0, P_PA, 20.0, 350.0)
  east = data.interpolate(0.0, P_PA, 20.0, 0.0)
  mid = 0.5 * (west + east)
  # Without the wrapped column 355 and -5 were held at 350's wind.
  for lon in (355.0, -5.0, 715.0):
    np.testing.assert_allclose(data.interpolate(0.0, P_PA, 20.0, lon), mid,
                               atol=1e-12)
  grid = gridded_jax.grid_from_data(data, center_lat=51.5, center_lon=-1.0)
  lons = jnp.array([355.0, -5.0, 350.0, 0.0])
  got = np.asarray(gridded_jax.interpolate(grid, 0.0, P_PA, 20.0, lons))
  np.testing.assert_allclose(got, [mid, mid, west, east], atol=1e-4)


def test_a_target_west_of_greenwich_is_inside_a_global_file(globe_file):
  data = gridded.load(globe_file)
  assert data.covers(51.5, -1.0) and data.covers(89.9, 355.0)
  assert gridded.last_start_minute(data, center_lat=51.5, center_lon=-1.0,
                                   episode_hours=72.0) == 0


def test_the_real_global_grib2_is_seamless():
  pytest.importorskip('cfgrib')
  data = gridded.load(str(GFS_GLOBAL))
  assert data.global_longitude and data.latitude_bounds == (-90.0, 90.0)
  assert data.covers(51.5, -1.0)  # Refused as outside before (exit 2).
  grid = gridded_jax.grid_from_data(data, center_lat=51.5, center_lon=-1.0)
  assert not bool(gridded_jax.outside(grid, jnp.float32(-150e3),
                                      jnp.float32(0.0)))
  west = data.interpolate(0.0, P_PA, 50.0, 357.5)
  east = data.interpolate(0.0, P_PA, 50.0, 0.0)
  np.testing.assert_allclose(data.interpolate(0.0, P_PA, 50.0, -1.25),
                             0.5 * (west + east), atol=1e-9)


def test_no_flight_leaves_a_global_grid_at_the_seam_or_over_a_pole(
    globe_file):
  data = gridded.load(globe_file)
  grid = gridded_jax.grid_from_data(data, center_lat=51.5, center_lon=-1.0)
  # Here; 500 km east and west (across 0 E); 5000 km north (over the pole);
  # 16 000 km south (past 80 S, the last row).
  x = jnp.array([0.0, 500e3, -500e3, 0.0, 0.0])
  y = jnp.array([0.0, 0.0, 0.0, 5000e3, -16_000e3])
  assert not np.asarray(gridded_jax.outside(grid, x, y)).any()
  station = jnp.array([10.0, 359.0], jnp.float32)
  assert not np.asarray(gridded_jax.outside(grid, x, y, station)).any()
  lat, lon = gridded_jax.latlng(grid, x, y)
  assert float(lat[3]) > 80.0 and float(lat[4]) < -80.0
  uv = np.asarray(gridded_jax.forecast(grid, 0.0, x, y, P_PA))
  assert np.isfinite(uv).all()


def test_per_seed_stations_span_every_longitude_of_a_global_grid(
    globe_file):
  data = gridded.load(globe_file)
  box = stations.station_box(data.latitude, data.longitude, 400.0,
                             global_longitude=True)
  assert box == (-stations.MAX_STATION_ABS_LAT, stations.MAX_STATION_ABS_LAT,
                 0.0, 360.0)
  grid = gridded_jax.grid_from_data(data, stations='per_seed')
  keys = jax.random.split(jax.random.PRNGKey(0), 2000)
  drawn = np.asarray(jax.vmap(lambda k: gridded_jax.draw_station(grid, k))(keys))
  lon = drawn[:, 1] % 360.0
  # The 23.5 deg a 400 km margin skipped at 70 deg around the seam.
  assert ((lon > 350.0) | (lon < 10.0)).sum() > 20
  assert np.abs(drawn[:, 0]).max() <= stations.MAX_STATION_ABS_LAT + 1e-4


@pytest.mark.parametrize('lat, lon', [(-8.52, 179.22), (-90.0, 0.0),
                                      (90.0, -180.0), (0.0, 180.0),
                                      (19.72, -155.07)])
def test_a_sounding_flies_anywhere_on_the_sphere(lat, lon):
  data = gridded.load(str(HILO))
  assert data.covers(lat, lon)
  grid = gridded_jax.grid_from_data(data, center_lat=lat, center_lon=lon)
  column = data.interpolate(0.0, P_PA, 19.72, -155.07)
  got = gridded_jax.forecast(grid, 0.0, jnp.float32(0.0), jnp.float32(0.0),
                             P_PA)
  np.testing.assert_allclose(np.array(got), column, atol=1e-4)


@pytest.mark.slow
def test_a_flight_across_the_seam_does_not_leave_the_wind_domain(globe_file):
  # pylint: disable=g-import-not-at-top
  import gin
  from ble_latex.envs import env_params
  from ble_latex.envs import jax_env
  from ble_latex.flight import state as state_lib
  # pylint: enable=g-import-not-at-top
  gin.clear_config()
  grid = gridded_jax.grid_from_data(gridded.load(globe_file), center_lat=51.5,
                                    center_lon=-1.0, end_outside_domain=True)
  params = env_params.params_from_gin().replace(wind_grid=grid)
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  keys = jnp.stack([jax.random.PRNGKey(0)] * 2)
  state = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(keys, params)[1]
  # 150 km east and west of 1 W: 1.2 E and 3.2 W, across 0 E.
  state = state.replace(flight=state.flight.replace(
      x_m=jnp.array([150e3, -150e3], jnp.float32),
      y_m=jnp.zeros(2, jnp.float32)))
  step = jax.jit(jax.vmap(env.step_env, in_axes=(0, 0, 0, None)))
  action = jnp.broadcast_to(jnp.array([18_000.0, 1.0, 1.0]), (2, 3))
  after = step(keys, state, action, params)[1]
  left = int(state_lib.FlightStatus.LEFT_WIND_DOMAIN)
  assert left not in np.asarray(after.flight.status).tolist()
