"""ble_latex.launch.scoring: its grids bounded before allocating, its world
built through the env's checks and the GriddedWindField bindings (issue 67)."""

import os

import gin
import pytest

from ble_latex import errors

from tests import helpers


def test_launch_library_grid_is_bounded_before_meshgrid():
  from ble_latex.launch import scoring  # pylint: disable=g-import-not-at-top
  space = scoring.SearchSpace(east_km=(-1.0, 1.0), north_km=(-1.0, 1.0),
                              hours=(0.0, 1.0))
  with pytest.raises(errors.ConfigError, match='balloons, more than'):
    scoring.grid(space, 100000, 100000, 100)
  with pytest.raises(errors.ConfigError, match='balloons, more than'):
    scoring.uniform(space, 10**8, None)


def test_launch_world_params_go_through_check_params(tmp_path):
  from tests.wind import test_gridded  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import env_params  # pylint: disable=g-import-not-at-top
  from ble_latex.launch import scoring  # pylint: disable=g-import-not-at-top
  path = test_gridded.write_era5(tmp_path / 'era5.nc')
  bad = env_params.params_from_gin().replace(radius_km=-1.0)
  with pytest.raises(errors.ConfigError, match='radius_km'):
    scoring.era5_world(path, max_hours=0.0, params=bad, steps=1)


# -- Item 4: a launch applies the GriddedWindField bindings, or refuses them. --
@pytest.mark.parametrize('binding, needle', [
    ("GriddedWindField.snapshot_time = '9999-12-31T23:59'", 'snapshot'),
    ("GriddedWindField.start_dates = 'eval'", 'GriddedWindField.start_dates'),
    ("GriddedWindField.stations = 'per_seed'", 'GriddedWindField.stations'),
    ("GriddedWindField.path = '/elsewhere.nc'", 'GriddedWindField.path'),
])
def test_launch_world_applies_or_refuses_wind_bindings(binding, needle,
                                                       tmp_path):
  from tests.wind import test_gridded  # pylint: disable=g-import-not-at-top
  from ble_latex.launch import scoring  # pylint: disable=g-import-not-at-top
  path = test_gridded.write_era5(tmp_path / 'era5.nc')
  gin.clear_config()
  try:
    gin.parse_config(binding)
    with pytest.raises(errors.ConfigError, match=needle):
      scoring.era5_world(path, max_hours=0.0, steps=1)
  finally:
    gin.clear_config()


@pytest.mark.slow  # Two worlds drawn (jitted): ~10 s on 2 busy cores.
def test_launch_world_flies_a_bound_snapshot_time():
  from ble_latex.launch import scoring  # pylint: disable=g-import-not-at-top
  path = os.path.join(helpers.REAL_WINDS, 'gfs_2010-10-26T12Z_uv_10-300hPa_1deg_subset.nc')
  gin.clear_config()
  try:
    before = scoring.era5_world(path, max_hours=0.0, steps=1)
    gin.parse_config("GriddedWindField.snapshot_time = '2012-06-01T06:00'")
    after = scoring.era5_world(path, max_hours=0.0, steps=1)
  finally:
    gin.clear_config()
  assert before.describe['date'] == '2010-10-26T12:00:00'
  assert after.describe['date'] == '2012-06-01T06:00:00'
  moved = int(after.state.start_time_offset_s) - int(
      before.state.start_time_offset_s)
  import datetime as dt  # pylint: disable=g-import-not-at-top
  assert moved == (dt.datetime(2012, 6, 1, 6) -
                   dt.datetime(2010, 10, 26, 12)).total_seconds()
