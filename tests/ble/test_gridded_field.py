# coding=utf-8
"""Tests of a wind file as BLE's `WindField` (`ble.gridded_field`).

`GriddedWindField` over the synthetic files of tests/wind/test_gridded.py: BLE's
geometry, the sampled start, columns, edges, noise and the gym env on it.
No network.
"""

import datetime as dt
import math
import types

import ble_latex  # noqa: F401  pylint: disable=unused-import
from balloon_learning_environment.env import wind_field
from balloon_learning_environment.utils import units
import jax
import numpy as np
import pytest

from ble_latex.ble import gridded_field
# pylint: disable=g-bad-import-order,unused-import
from tests.wind.test_gridded import (  # The synthetic files.
    as_tuple, CENTER, fixture_era5_file, latlng, make_field, T0, wind_u,
    wind_v, write_era5)
# pylint: enable=g-bad-import-order,unused-import


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


# Start time sampling and noise.


def test_start_sampling_is_deterministic_and_fits_the_episode(era5_file):
  field = gridded_field.GriddedWindField(path=era5_file, episode_hours=6.0)
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
    gridded_field.GriddedWindField(path=era5_file, episode_hours=72.0)


def test_forecast_before_reset_is_an_error(era5_file):
  field = gridded_field.GriddedWindField(path=era5_file, episode_hours=6.0)
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
  field = gridded_field.GriddedWindField(path=era5_file, episode_hours=6.0,
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


# The environment.


@pytest.mark.slow
@pytest.mark.ci
def test_env_flies_at_the_sampled_era5_start(tmp_path):
  from ble_latex.ble import gym_env as env_lib  # pylint: disable=g-import-not-at-top
  path = write_era5(tmp_path / 'era5.nc')
  env = env_lib.LatexBalloonEnv(
      wind_field_factory=lambda: gridded_field.GriddedWindField(
          path=path, episode_hours=1.0),
      episode_steps=2, seed=0)
  # A GriddedWindField flies its grid in the core (`EnvParams.wind_grid`).
  assert env.arena.params.wind_grid is not None
  reference = gridded_field.GriddedWindField(path=path, episode_hours=1.0)
  starts = []
  for _ in range(2):
    env.reset(seed=5)
    start = env.arena.driver.start_date_time
    starts.append(start)
    assert env.arena.get_balloon_state().date_time == start
    env.step(np.array([17_000.0, 1.0, 1.0]))
  assert starts[0] == starts[1]
  # Inside the data, 1 h before its end (the draw is the field's own:
  # test_gridded_jax.test_start_draw_is_era5_wind_fields).
  assert reference.data.start <= starts[0] <= (
      reference.data.end - dt.timedelta(hours=1))


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
def test_full_random_episode_on_era5_wind(tmp_path):
  from ble_latex.ble import gym_env as env_lib  # pylint: disable=g-import-not-at-top
  times = T0 + np.arange(17) * np.timedelta64(6, 'h')  # 4 days of data.
  path = write_era5(tmp_path / 'era5_4d.nc', times=times)
  env = env_lib.LatexBalloonEnv(
      wind_field_factory=lambda: gridded_field.GriddedWindField(path=path), seed=0)
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
  field = gridded_field.GriddedWindField(path=era5_file, episode_hours=6.0)
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
