# coding=utf-8
"""The forecast error on real files: BLE's noise scaled (`wind.forecast_error`)."""

import types

import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex import errors
from ble_latex.envs import winds
from ble_latex.run import real_cells
from ble_latex.wind import forecast_error
from ble_latex.wind import globe
from ble_latex.wind import gridded
from ble_latex.wind import gridded_jax
from ble_latex.wind import simplex

from tests import helpers

HILO = str(helpers.REAL_WINDS /
           'PHTO-Hilo_2023-11-01T00Z_uwyo.csv')


def test_default_scale_by_source():
  realistic = forecast_error.noise_scale(None, 'GRIB2')
  assert realistic == pytest.approx(2.5 / 1.045)
  assert forecast_error.noise_scale(None, 'analysis') == realistic
  assert forecast_error.noise_scale(None, 'sounding') == realistic
  assert forecast_error.noise_scale(None, 'ERA5') == 1.0  # The paper's.
  assert forecast_error.noise_scale(0, 'GRIB2') == 0.0
  assert forecast_error.noise_scale(3, 'ERA5') == 3.0
  assert '2.5 m/s rms' in forecast_error.describe(realistic)


@pytest.mark.parametrize('bad', [-1.0, float('nan'), True, '2', [1]])
def test_bad_scale_is_one_line(bad):
  with pytest.raises(errors.ConfigError, match='GriddedWindField.noise_scale'):
    gridded.Era5Settings(path=HILO, noise_scale=bad)


def _fake_noise(noise_u, noise_v, x_km, y_km, pressure, hours):
  """A cheap stand-in for BLE's noise (no simplex to compile). # [m/s]"""
  del noise_u, noise_v
  return 0.3 + 1e-3 * x_km + 1e-5 * pressure, 0.2 - 1e-3 * y_km + 0.01 * hours


def _truth_minus_forecast(grid):
  """Truth - forecast [2, 64] of `grid` along a line (x, p, t). # [m/s]"""
  wind = winds.era5_wind(grid)
  state = types.SimpleNamespace(
      noise_u=None, noise_v=None, station=None, truth_member=None,
      start_time_offset_s=(grid.first_time_min - winds._EPOCH_MIN) * 60)
  x = jnp.linspace(-2e5, 2e5, 64)
  p = jnp.linspace(5000.0, 15000.0, 64)
  t = jnp.linspace(0.0, 2e5, 64)
  truth = jnp.stack(wind.ground_truth(state, x, -x, p, t))
  forecast = jnp.stack(wind.forecast_column(state, x, -x, p, t))
  return np.asarray(truth - forecast, np.float64)


def test_truth_noise_scales_on_the_device(monkeypatch):
  monkeypatch.setattr(simplex, 'wind_noise_uv', _fake_noise)
  data = gridded.load(HILO)
  one = _truth_minus_forecast(gridded_jax.grid_from_data(data, noise_scale=1.0))
  x = np.linspace(-200.0, 200.0, 64)
  np.testing.assert_allclose(
      one[0], 0.3 + 1e-3 * x + 1e-5 * np.linspace(5000.0, 15000.0, 64),
      atol=1e-5)
  default = gridded_jax.grid_from_data(data)  # A sounding: the realistic size.
  assert default.noise_scale == pytest.approx(2.5 / 1.045)
  np.testing.assert_allclose(_truth_minus_forecast(default),
                             default.noise_scale * one, atol=1e-5)
  zero = gridded_jax.grid_from_data(data, noise_scale=0.0)
  assert not np.any(_truth_minus_forecast(zero))


def test_gin_settings_reach_the_grid():
  grid = gridded_jax.grid_from_settings(gridded.Era5Settings(path=HILO,
                                                       noise_scale=1.5))
  assert grid.noise_scale == 1.5
  assert gridded_jax.grid_from_settings(
      gridded.Era5Settings(path=HILO)).noise_scale == pytest.approx(2.5 / 1.045)


def test_ble_field_object_scales_its_noise(tmp_path):
  import datetime as dt  # pylint: disable=g-import-not-at-top
  import jax  # pylint: disable=g-import-not-at-top
  from balloon_learning_environment.utils import units  # pylint: disable=g-import-not-at-top
  from ble_latex.ble import gridded_field  # pylint: disable=g-import-not-at-top
  from tests.wind import test_gridded  # pylint: disable=g-import-not-at-top
  path = test_gridded.write_era5(tmp_path / 'era5.nc')
  args = (units.Distance(km=20.0), units.Distance(km=-10.0), 8000.0,
          dt.timedelta(hours=1))
  differences = {}
  for scale in (None, 1.0, 2.5, 0.0):
    field = gridded_field.GriddedWindField(path=path, episode_hours=6.0,
                                     noise_scale=scale)
    field.reset(jax.random.PRNGKey(7), dt.datetime(2013, 1, 1))
    truth, forecast = field.get_ground_truth(*args), field.get_forecast(*args)
    differences[scale] = np.array([
        truth.u.meters_per_second - forecast.u.meters_per_second,
        truth.v.meters_per_second - forecast.v.meters_per_second])
  np.testing.assert_array_equal(differences[None], differences[1.0])  # ERA5.
  assert np.abs(differences[1.0]).max() > 1e-3
  np.testing.assert_allclose(differences[2.5], 2.5 * differences[1.0],
                             rtol=1e-6, atol=1e-9)
  assert not differences[0.0].any()


def _pair(tmp_path, **truth_kwargs):
  from tests.wind import test_gridded  # pylint: disable=g-import-not-at-top
  forecast = test_gridded.write_era5(tmp_path / 'forecast.nc')
  truth_kwargs.setdefault('t0', test_gridded.T0 - np.timedelta64(12, 'h'))
  truth = test_gridded.write_era5(tmp_path / 'truth.nc', **truth_kwargs)
  return forecast, truth


def test_two_sources_truth_from_the_second_file(tmp_path):
  from tests.wind import test_gridded  # pylint: disable=g-import-not-at-top
  # The truth: other winds (another time origin), on a wider grid and a
  # longer time range than the forecast's.
  forecast_path, truth_path = _pair(
      tmp_path, lat=np.arange(5.0, -3.5, -0.5), lon=np.arange(-117.0, -108.5,
                                                              0.5),
      times=test_gridded.T0 + np.arange(-1, 5) * np.timedelta64(6, 'h'))
  settings = gridded.Era5Settings(path=forecast_path, truth_path=truth_path,
                                  center_lat=1.0, center_lon=-113.0,
                                  episode_hours=6.0)
  grid = gridded_jax.grid_from_settings(settings)
  assert grid.noise_scale == 0.0  # The truth file is the error.
  data = gridded.load(forecast_path)
  truth = gridded.load(truth_path)
  t_h = (data.times[:, None, None, None] - test_gridded.T0) / np.timedelta64(
      1, 'h')
  p = data.pressure[None, :, None, None] / 100.0
  lat = data.latitude[None, None, :, None]
  lon = data.longitude[None, None, None, :]
  # The truth's own multi-linear field, 12 h later than its origin.
  np.testing.assert_allclose(
      np.asarray(grid.truth_uv[..., 0]),
      np.broadcast_to(test_gridded.wind_u(t_h + 12.0, p, lat, lon),
                      grid.truth_uv.shape[:-1]), rtol=1e-5, atol=1e-4)
  np.testing.assert_allclose(np.asarray(grid.uv), data.uv, rtol=1e-6)
  state = types.SimpleNamespace(
      noise_u=None, noise_v=None, station=None, truth_member=None,
      start_time_offset_s=(grid.first_time_min - winds._EPOCH_MIN) * 60)
  wind = winds.era5_wind(grid)
  x = jnp.linspace(-5e4, 5e4, 8)
  args = (x, x, jnp.full(8, 7000.0), jnp.linspace(0.0, 3e4, 8))
  got_truth = np.stack(wind.ground_truth(state, *args))
  got_forecast = np.stack(wind.forecast_column(state, *args))
  lats, lons = np.array([globe.latlng_of_offset(1.0, -113.0, float(d),
                                              float(d)) for d in x]).T
  # The truth file starts 6 h before the forecast.
  want_truth = truth.interpolate(np.asarray(args[3]) + 6 * 3600.0, 7000.0,
                                 lats, lons)
  want_forecast = data.interpolate(np.asarray(args[3]), 7000.0, lats, lons)
  np.testing.assert_allclose(got_truth.T, want_truth, atol=2e-3)
  np.testing.assert_allclose(got_forecast.T, want_forecast, atol=2e-3)
  assert np.abs(want_truth - want_forecast).min() > 0.1
  assert 'truth' in winds.wind_source_from_gin(settings)


def test_two_sources_refuse_a_truth_that_misses_the_forecast(tmp_path):
  from tests.wind import test_gridded  # pylint: disable=g-import-not-at-top
  forecast_path, late = _pair(
      tmp_path, times=test_gridded.TIMES + np.timedelta64(6, 'h'))
  with pytest.raises(errors.ConfigError, match="valid times"):
    gridded_jax.grid_from_settings(gridded.Era5Settings(
        path=forecast_path, truth_path=late, episode_hours=6.0))
  small = test_gridded.write_era5(tmp_path / 'small.nc',
                                  lat=np.array([2.0, 1.0, 0.0, -1.0, -2.0]))
  with pytest.raises(errors.ConfigError, match="does not cover"):
    gridded_jax.grid_from_settings(gridded.Era5Settings(
        path=forecast_path, truth_path=small, episode_hours=6.0))


def test_real_winds_cells_record_the_noise_scale(benchmark_script, tmp_path,
                                                 monkeypatch, capsys):
  """benchmarks/real_winds.py: a cell records its truth's noise scale, and a
  cell flown before (no scale recorded: BLE's noise at scale 1) is refused
  on resume instead of merging flights of two noise sizes."""
  import json  # pylint: disable=g-import-not-at-top
  import os  # pylint: disable=g-import-not-at-top
  import shutil  # pylint: disable=g-import-not-at-top
  real_winds = benchmark_script('real_winds.py')
  realdata = tmp_path / 'realdata'
  (realdata / 'soundings').mkdir(parents=True)
  shutil.copy(HILO, realdata / 'soundings' / os.path.basename(HILO))
  flights = lambda seeds: [{'seed': s, 'tw50': 0.5, 'tw50_window': 0.5,
                            'window_steps': 3, 'reward': 1.0, 'steps': 3,
                            'helium_vented_mols': 0.0, 'sand_dropped_kg': 0.0,
                            'terminal_reason': 'time_limit',
                            'final_distance_km': 1.0} for s in seeds]
  monkeypatch.setattr(real_cells, 'fly_cell', lambda cell, path, seeds: (
      flights(seeds), 'sounding (time-invariant)', True, 0.1))
  record = tmp_path / 'r.json'
  argv = [f'--json={record}', f'--realdata_dir={realdata}', '--sources=hilo',
          '--agents=latex_random', '--seeds=2']
  assert real_winds.main(argv) == 0
  key = 'hilo/latex_random/center'
  cells = json.loads(record.read_text())
  assert cells['cells'][key]['settings']['noise_scale'] == pytest.approx(
      2.3923)
  del cells['cells'][key]['settings']['noise_scale']  # As flown before.
  record.write_text(json.dumps(cells))
  capsys.readouterr()
  assert real_winds.main(argv[:-1] + ['--seeds=3']) == 2
  assert 'other settings (noise_scale)' in capsys.readouterr().err
