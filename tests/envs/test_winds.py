# coding=utf-8
"""`gymnasium.make(..., wind_file=...)` and the functional env's params fly a
wind file (issue 64, "Why" 8). No network.
"""

import gymnasium
import numpy as np
import pytest

import ble_latex  # noqa: F401  pylint: disable=unused-import
from ble_latex import errors
from ble_latex.envs import env_params
from ble_latex.envs import winds
from ble_latex.wind import gridded
from ble_latex.wind import gridded_jax

from tests import helpers

REAL = helpers.REAL_WINDS
GFS = str(REAL / 'gfs_2010-10-26T12Z_uv_10-300hPa_1deg_subset.nc')
HILO = str(REAL / 'PHTO-Hilo_2023-11-01T00Z_uwyo.csv')


def test_the_functional_envs_params_take_a_wind_file():
  params = env_params.params_from_gin(wind_file=GFS)
  grid = params.wind_grid
  assert isinstance(grid, gridded_jax.Era5Grid)
  assert grid.station_box is not None  # Per-seed stations, as --wind_file.
  fixed = winds.grid_from_file(GFS, center_lat=40.0, center_lon=-103.0)
  assert fixed.station_box is None
  np.testing.assert_allclose(np.asarray(fixed.uv), np.asarray(grid.uv))
  with pytest.raises(errors.ConfigError, match='wind_file='):
    winds.grid_from_file(GFS, center_lat=0.0, center_lon=0.0)
  with pytest.raises(FileNotFoundError):
    winds.grid_from_file(str(REAL / 'missing.nc'))


def test_gymnasium_make_takes_a_wind_file():
  env = gymnasium.make('ble_latex/LatexBalloon-v0', wind_file=HILO)
  grid = env.unwrapped.params.wind_grid
  assert grid is not None  # A TypeError before.
  assert float(grid.pressure_pa[0]) == pytest.approx(
      gridded.load(HILO).pressure[0], rel=1e-6)
  env.close()
  with pytest.raises(errors.BadFileError):
    gymnasium.make('ble_latex/LatexBalloon-v0', wind_file=__file__)


@pytest.mark.slow
def test_gymnasium_make_flies_a_wind_file():
  env = gymnasium.make('ble_latex/LatexBalloon-v0', wind_file=HILO)
  try:
    obs, _ = env.reset(seed=3)
    obs, reward, _, _, _ = env.step(np.zeros(3, np.float32))
    assert np.isfinite(obs).all() and np.isfinite(reward)
  finally:
    env.close()
