# coding=utf-8
"""ERA5 winds in JAX (`wind.gridded_jax`, `winds.era5_wind`) against BLE's.

The reference is `wind.gridded` (scipy interpolation in float64, BLE's
geometry and simplex noise): the device grid interpolates as
`Era5Data.interpolate` to float32 rounding, converts x/y as BLE's
`calculate_latlng_from_offset`, draws `GriddedWindField`'s start from the same
key, and the functional env flown on it (vmapped, jitted) flies the
Gymnasium env's flight of the `GriddedWindField` object (host callbacks). No
network: synthetic files (`test_gridded.write_era5`) and arrays.
"""

import datetime as dt
import functools

import ble_latex  # noqa: F401  pylint: disable=unused-import
from balloon_learning_environment.utils import spherical_geometry
from balloon_learning_environment.utils import units
import gymnasium
from hypothesis import given
from hypothesis import settings
from hypothesis import strategies as st
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import s2sphere as s2

from ble_latex.ble import gridded_field
from ble_latex.envs import env_params
from ble_latex.envs import env_types
from ble_latex.envs import jax_env
from ble_latex.envs import observed_winds
from ble_latex.envs import winds
from ble_latex.wind import gridded
from ble_latex.wind import gridded_jax
from tests.wind import test_gridded

# Irregular axes (a 3 h step among 6 h ones, uneven levels, 0.4 deg grid).
_HOURS = np.array([0.0, 6.0, 12.0, 15.0, 21.0, 27.0, 33.0])  # [h]
_PRESSURE_PA = np.array([2000.0, 3000.0, 5000.0, 7000.0, 10000.0, 12500.0,
                         15000.0, 17500.0])  # [Pa]
_LATS = np.arange(-3.0, 5.0 + 1e-9, 0.4)  # [deg N]
_LONS = np.arange(-117.0, -109.0 + 1e-9, 0.4)  # [deg E]
# Interpolation: float32 grid and arithmetic against scipy in float64.
_WIND_ATOL = 1e-4  # [m/s]
_ENV_SEEDS = (0, 1, 2)
_ACTIONS = [(18_000.0, 1.0, -1.0), (18_000.0, 1.0, 1.0),
            (15_500.0, 1.0, -1.0), (16_000.0, 1.0, 1.0),
            (19_000.0, 1.0, -1.0), (17_000.0, 1.0, -1.0)]


def _random_data(lons=_LONS, seed=0):
  """`Era5Data` with random winds (not multi-linear) on irregular axes."""
  times = np.datetime64('2022-11-01T00:00', 'ns') + (
      _HOURS * 3600).astype('timedelta64[s]')
  uv = np.random.default_rng(seed).normal(
      0.0, 15.0, (len(_HOURS), len(_PRESSURE_PA), len(_LATS), len(lons), 2))
  return gridded.Era5Data(('random',), times, _HOURS * 3600.0, _PRESSURE_PA,
                          _LATS, np.asarray(lons, np.float64), uv)


_DATA = _random_data()
_GRID = gridded_jax.grid_from_data(_DATA, episode_hours=6.0)
_INTERPOLATE = jax.jit(gridded_jax.interpolate)


@settings(max_examples=200, deadline=None)
@given(t_h=st.floats(-5.0, 40.0), p=st.floats(500.0, 25_000.0),
       lat=st.floats(-5.0, 7.0), lon=st.floats(-120.0, -106.0),
       turns=st.sampled_from([-1, 0, 1]))
def test_interpolate_equals_era5_data(t_h, p, lat, lon, turns):
  # Inside and outside every axis (clipped), any longitude convention.
  # The same float32 coordinates to both.
  t, p, lat, lon = np.float32([t_h * 3600.0, p, lat, lon + 360.0 * turns])
  expected = _DATA.interpolate(t, p, lat, lon)
  got = np.asarray(_INTERPOLATE(_GRID, t, p, lat, lon))
  np.testing.assert_allclose(got, expected, atol=_WIND_ATOL, rtol=0)


def test_interpolate_broadcasts_like_era5_data():
  rng = np.random.default_rng(1)
  t = rng.uniform(0.0, 33 * 3600.0, (5, 1)).astype(np.float32)
  p = rng.uniform(2000.0, 17_500.0, (1, 7)).astype(np.float32)
  lat = rng.uniform(-3, 5, (5, 1)).astype(np.float32)
  lon = rng.uniform(-117, -109, (5, 1)).astype(np.float32)
  expected = _DATA.interpolate(t, p, lat, lon)
  got = np.asarray(_INTERPOLATE(_GRID, t, p, lat, lon))
  assert got.shape == expected.shape == (5, 7, 2)
  np.testing.assert_allclose(got, expected, atol=_WIND_ATOL, rtol=0)


@pytest.mark.parametrize('lons, center', [
    (_LONS, (1.0, -113.0)),
    (_LONS + 360.0, (1.0, -113.0)),  # File in 0..360, target in -180..180.
    (_LONS, (4.6, 246.5)),           # Target in 0..360, file in -180..180.
])
def test_latlng_is_bles_geometry(lons, center):
  data = _random_data(lons)
  grid = gridded_jax.grid_from_data(data, center_lat=center[0],
                                    center_lon=center[1], episode_hours=6.0)
  rng = np.random.default_rng(2)
  xy = np.concatenate([[[0.0, 0.0], [0.0, 3e5], [-4e5, 0.0]],
                       rng.uniform(-6e5, 6e5, (40, 2))])
  lat, lon = jax.jit(gridded_jax.latlng)(grid, xy[:, 0], xy[:, 1])
  origin = s2.LatLng.from_degrees(*center)
  for (x, y), got_lat, got_lon in zip(xy, np.asarray(lat), np.asarray(lon)):
    ll = spherical_geometry.calculate_latlng_from_offset(
        origin, units.Distance(m=x), units.Distance(m=y))
    # Float32 rounding: 2e-5 deg (~2 m; float32's step at 250 deg is 1.5e-5).
    assert float(got_lat) == pytest.approx(ll.lat().degrees, abs=2e-5)
    assert float(got_lon) == pytest.approx(
        float(data.wrap_longitude(ll.lng().degrees)), abs=2e-5)
    assert abs(got_lon - 0.5 * (lons[0] + lons[-1])) <= 180.0  # File's.


def test_grid_checks_the_flight_as_era5_wind_field():
  with pytest.raises(ValueError, match='outside the area'):
    gridded_jax.grid_from_data(_DATA, center_lat=20.0, episode_hours=6.0)
  with pytest.raises(ValueError, match='shorter than episode_hours'):
    gridded_jax.grid_from_data(_DATA)  # 33 h of data, 72 h flights.


@pytest.fixture(name='era5_path', scope='module')
def fixture_era5_path(tmp_path_factory):
  """An ERA5 file: 4 days, +-15 deg around the paper's target, random winds."""
  folder = tmp_path_factory.mktemp('era5')
  times = test_gridded.T0 + np.arange(17) * np.timedelta64(6, 'h')
  path = test_gridded.write_era5(
      folder / 'linear.nc', times=times, lat=np.arange(16.0, -14.01, -1.0),
      lon=np.arange(-128.0, -97.99, 1.0),
      levels_hpa=np.array([20.0, 30.0, 50.0, 70.0, 100.0, 125.0, 150.0,
                           175.0]))
  rng = np.random.default_rng(5)

  def random_winds(dataset):
    for name in ('u', 'v'):
      dataset[name].values = rng.normal(0.0, 6.0, dataset[name].shape)

  return test_gridded.rewrite(path, folder / 'era5.nc', random_winds)


@pytest.mark.parametrize('episode_hours', [6.0, 24.0, 48.0])
def test_start_draw_is_era5_wind_fields(era5_path, episode_hours):
  field = gridded_field.GriddedWindField(path=era5_path,
                                   episode_hours=episode_hours)
  grid = gridded_jax.grid_from_data(field.data, episode_hours=episode_hours)
  draw = jax.jit(gridded_jax.draw_start_minute)
  minutes = []
  for seed in range(12):
    wind_key = jax.random.PRNGKey(seed)
    field.reset(wind_key, dt.datetime(2012, 3, 4))
    _, forecast_key = jax.random.split(wind_key)  # BLE's WindField.reset.
    minute = int(draw(grid, forecast_key))
    minutes.append(minute)
    assert field.start_date_time == field.data.start + dt.timedelta(
        minutes=minute)
  assert len(set(minutes)) > 1


@functools.lru_cache(maxsize=None)
def _params(path, episode_hours=24.0):
  """(params without, with the ERA5 grid of `path`), gin defaults (no
  earlier module's bindings: tests/conftest.py clears them per module)."""
  params = env_params.params_from_gin()
  grid = gridded_jax.grid_from_data(gridded.load(path),
                                    episode_hours=episode_hours)
  return params, params.replace(wind_grid=grid)


@pytest.mark.parametrize('add_noise', [True, False])
def test_env_wind_is_era5_wind_fields(era5_path, add_noise):
  params, with_grid = _params(era5_path)
  with_grid = with_grid.replace(wind_grid=with_grid.wind_grid.replace(
      add_noise=add_noise))
  env = jax_env.LatexBalloonJaxEnv()
  field = gridded_field.GriddedWindField(path=era5_path, episode_hours=24.0,
                                   add_noise=add_noise)
  points = [(0.0, 0.0, 9000.0, 0.0), (120e3, -40e3, 5200.0, 5.5 * 3600),
            (-300e3, 250e3, 13900.0, 20 * 3600.0)]
  wind = env.wind_for(with_grid)
  ground_truth = jax.jit(wind.ground_truth)
  forecast_column = jax.jit(wind.forecast_column)
  for seed in (3, 8):
    state, keys = jax.jit(env.draw)(jax_env.arena_key(
        jax.random.PRNGKey(seed)), with_grid)
    assert state.forecast is None  # No VAE forecast drawn.
    field.reset(keys['wind'], dt.datetime(2012, 3, 4))
    # The flight's date is the ERA5 start.
    assert env_types.START_EPOCH + dt.timedelta(
        seconds=int(state.start_time_offset_s)) == field.start_date_time
    for x, y, p, t in points:
      args = (units.Distance(m=x), units.Distance(m=y), p,
              dt.timedelta(seconds=t))
      truth = field.get_ground_truth(*args)
      u, v = ground_truth(state, jnp.float32(x), jnp.float32(y),
                                        jnp.float32(p), jnp.float32(t))
      np.testing.assert_allclose(
          [u, v], [truth.u.meters_per_second, truth.v.meters_per_second],
          atol=_WIND_ATOL)
      pressures = jnp.asarray([p, 6000.0, 12000.0], jnp.float32)
      column = field.get_forecast_column(args[0], args[1],
                                         np.asarray(pressures), args[3])
      cu, cv = forecast_column(
          state, jnp.float32(x), jnp.float32(y), pressures, jnp.float32(t))
      np.testing.assert_allclose(
          np.stack([cu, cv], axis=-1),
          [[w.u.meters_per_second, w.v.meters_per_second] for w in column],
          atol=_WIND_ATOL)


@pytest.mark.slow
@pytest.mark.ci
def test_drifted_column_on_era5_winds(era5_path):
  """`latex_observation.wind_lookahead` on ERA5 winds: each level's 6-stride
  Euler drift (integrated here one level at a time), finite where the
  drifts run past the grid's edge (the field is held constant there)."""
  _, with_grid = _params(era5_path)
  params = with_grid.replace(wind_lookahead=6)
  env = jax_env.LatexBalloonJaxEnv()
  wind = env.wind_for(params)
  state, _ = jax.jit(env.draw)(jax_env.arena_key(jax.random.PRNGKey(4)),
                               params)
  levels = jnp.asarray([6000.0, 9000.0, 13000.0], jnp.float32)
  for x0 in (20e3, 1.6e6):  # Near the target; at the grid's eastern edge.
    placed = state.replace(flight=state.flight.replace(
        x_m=jnp.float32(x0), y_m=jnp.float32(-10e3)))
    u, v = observed_winds.column(placed, params, wind, levels)
    assert np.all(np.isfinite(u)) and np.all(np.isfinite(v))
    for i, level in enumerate(levels):
      x, y = jnp.float32(x0), jnp.float32(-10e3)
      for k in range(6):
        du, dv = wind.forecast_column(placed, x, y, level[None],
                                      placed.flight.time_s + 1200.0 * k)
        x, y = x + 1200.0 * du[0], y + 1200.0 * dv[0]
      np.testing.assert_allclose(
          [u[i], v[i]], [(x - x0) / 7200.0, (y + 10e3) / 7200.0],
          rtol=1e-4, atol=1e-3)


@pytest.mark.slow
@pytest.mark.ci
def test_grid_is_an_argument_shared_by_the_balloons(era5_path):
  _, with_grid = _params(era5_path)
  env = jax_env.LatexBalloonJaxEnv()
  reset = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))
  keys = jax.random.split(jax.random.PRNGKey(0), 4)
  _, state = reset(keys, with_grid)
  grid = with_grid.wind_grid
  # The state holds no copy of the grid.
  assert max(leaf.size for leaf in jax.tree.leaves(state)) < grid.uv.size
  # Other winds on the same grid shape: the same compiled function.
  other = grid.replace(uv=grid.uv * 0.5)
  _, state2 = reset(keys, with_grid.replace(wind_grid=other))
  assert reset._cache_size() == 1  # pylint: disable=protected-access
  assert not np.allclose(state.wind_u, state2.wind_u)


def test_wind_grid_and_another_wind_is_an_error(era5_path):
  _, with_grid = _params(era5_path)
  other = winds.Wind(winds.ground_truth_wind, winds.forecast_column)
  with pytest.raises(ValueError, match='wind_grid'):
    # Traced only (the refusal comes before anything is computed).
    jax.eval_shape(jax_env.LatexBalloonJaxEnv(wind=other).reset,
                   jax.random.PRNGKey(0), with_grid)


def _jax_flight(params, seeds, actions):
  """Observations and (x, y, altitude) of balloons flown by the JAX env."""
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)

  @jax.jit
  def fly(keys, params):
    obs, state = jax.vmap(env.reset, in_axes=(0, None))(keys, params)

    def one(state, action):
      action = jnp.broadcast_to(action, (len(seeds), 3))
      obs, state, _, _, _ = jax.vmap(env.step_env, in_axes=(0, 0, 0, None))(
          keys, state, action, params)
      f = state.flight
      return state, (obs, jnp.stack([f.x_m, f.y_m, f.altitude_m], -1))

    _, (all_obs, where) = jax.lax.scan(one, state, actions)
    return jnp.concatenate([obs[None], all_obs]), where

  keys = jnp.stack([jax.random.PRNGKey(s) for s in seeds])
  obs, where = fly(keys, params)
  return np.asarray(obs).swapaxes(0, 1), np.asarray(where).swapaxes(0, 1)


class HostGriddedWindField(gridded_field.GriddedWindField):
  """`GriddedWindField` as a third-party BLE WindField: flown through host
  callbacks (scipy, float64), the reference of the JAX grid (an
  `GriddedWindField` itself flies its grid)."""


def _gymnasium_flight(params, path, seed, actions, episode_hours=24.0):
  """The same from the Gymnasium env flying `GriddedWindField` (callbacks)."""
  from ble_latex.ble import wind as ble_wind  # pylint: disable=g-import-not-at-top
  env = gymnasium.make(
      'ble_latex/LatexBalloon-v0', params=params, normalize_actions=False,
      host_wind=ble_wind.host_wind(HostGriddedWindField(
          path=path, episode_hours=episode_hours)))
  assert env.unwrapped._wind_field is not None  # pylint: disable=protected-access
  obs, _ = env.reset(seed=seed)
  all_obs, where = [obs], []
  for action in np.asarray(actions):
    obs, _, terminated, truncated, _ = env.step(action)
    flight = env.unwrapped.flight
    all_obs.append(obs)
    where.append([flight['x_m'], flight['y_m'], flight['altitude_m']])
    if terminated or truncated:
      break
  env.close()
  return np.stack(all_obs), np.array(where, np.float64)


@functools.lru_cache(maxsize=None)
def _gridded_jax_flight(path):
  """`_jax_flight` of `_ENV_SEEDS` with `_ACTIONS` on `path`'s grid (one
  compile for the two tests that compare other envs with it)."""
  _, with_grid = _params(path)
  return _jax_flight(with_grid, _ENV_SEEDS,
                     jnp.asarray(_ACTIONS, jnp.float32))


@pytest.mark.slow
@pytest.mark.ci
def test_flight_is_the_gymnasium_envs_on_era5_wind_field(era5_path):
  params, _ = _params(era5_path)
  actions = jnp.asarray(_ACTIONS, jnp.float32)
  obs, where = _gridded_jax_flight(era5_path)
  for i, seed in enumerate(_ENV_SEEDS):
    ref_obs, ref_where = _gymnasium_flight(params, era5_path, seed,
                                              actions)
    # Features in [-1, 1]; x, y, altitude [m] after 2 hours.
    np.testing.assert_allclose(obs[i], ref_obs, atol=1e-4, rtol=0)
    np.testing.assert_allclose(where[i], ref_where, atol=1.0, rtol=0)


@pytest.mark.slow
@pytest.mark.ci
def test_vector_env_flies_the_grid_in_its_params(era5_path):
  """The batched Gymnasium env flies ERA5 from `params.wind_grid` too."""
  from ble_latex.envs import gymnasium_vector  # pylint: disable=g-import-not-at-top
  _, with_grid = _params(era5_path)
  actions = jnp.asarray(_ACTIONS, jnp.float32)
  obs, _ = _gridded_jax_flight(era5_path)
  envs = gymnasium_vector.LatexBalloonVectorEnv(len(_ENV_SEEDS),
                                             params=with_grid)
  first, _ = envs.reset(seed=_ENV_SEEDS[0])
  assert list(_ENV_SEEDS) == list(range(_ENV_SEEDS[0],
                                        _ENV_SEEDS[0] + len(_ENV_SEEDS)))
  np.testing.assert_allclose(first, obs[:, 0], atol=1e-4, rtol=0)
  stepped = envs.step(np.broadcast_to(np.asarray(actions[0]),
                                      (len(_ENV_SEEDS), 3)))[0]
  np.testing.assert_allclose(stepped, obs[:, 1], atol=1e-4, rtol=0)
  envs.close()


@pytest.mark.slow
def test_three_day_flights_are_the_gymnasium_envs(era5_path):
  # Issue 27: within 100 m over 216 strides on several seeds.
  params, with_grid = _params(era5_path, 72.0)
  rng = np.random.default_rng(0)
  actions = jnp.asarray(rng.uniform((15_000.0, 1.0, -1.0),
                                    (20_000.0, 5.0, 1.0), (216, 3)),
                        jnp.float32)
  seeds = (0, 1, 2, 3)
  _, where = _jax_flight(with_grid, seeds, actions)
  for i, seed in enumerate(seeds):
    _, ref_where = _gymnasium_flight(params, era5_path, seed, actions,
                                        episode_hours=72.0)
    steps = len(ref_where)
    assert steps > 100
    np.testing.assert_allclose(where[i][:steps], ref_where, atol=100.0,
                               rtol=0)
