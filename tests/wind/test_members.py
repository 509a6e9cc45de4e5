# coding=utf-8
"""An ensemble file (GEFS / ERA5 EDA style `number` dimension) flies one
member, `GriddedWindField.member` (issue 64, item 3); one out of range, or
asked of a file without members, is one line. Synthetic file: the committed
GFS NetCDF subset with three members (winds + member) at two times.
"""

import gin
import numpy as np
import pytest
import xarray as xr

from ble_latex import errors
from ble_latex.wind import gridded

from tests import helpers

GFS_NC = (helpers.REAL_WINDS /
          'gfs_2010-10-26T12Z_uv_10-300hPa_1deg_subset.nc')
GFS_GRIB = GFS_NC.parent / 'gfs_2011-10-11T00Z_uv_10-250hPa_2p5deg.grib2'
NAMES = ('u-component_of_wind_isobaric', 'v-component_of_wind_isobaric')
PLACE = (0.0, 5000.0, 40.0, -103.0)  # (time [s], pressure [Pa], lat, lon)


@pytest.fixture(name='ensemble')
def _ensemble(tmp_path):
  one = xr.open_dataset(GFS_NC).load()
  times = [one.assign_coords(time=one.time + np.timedelta64(6 * i, 'h'))
           for i in range(2)]
  series = xr.concat(times, dim='time')
  members = []
  for k in range(3):
    member = series.copy()
    for name in NAMES:
      member[name] = series[name] + k
    members.append(member)
  path = tmp_path / 'ensemble.nc'
  xr.concat(members, dim='number').assign_coords(
      number=[0, 1, 2]).to_netcdf(path)
  return str(path)


def test_one_member_flies(ensemble):
  first = gridded.load(ensemble, member=0)
  second = gridded.load(ensemble, member=2)
  assert first.uv.shape == second.uv.shape and first.times.size == 2
  np.testing.assert_allclose(second.interpolate(*PLACE),
                             first.interpolate(*PLACE) + 2.0, atol=1e-4)
  assert second.description == 'analysis (member 2 of 3)'
  # The gin binding, default 0.
  with gin.unlock_config():
    gin.bind_parameter('GriddedWindField.member', 1)
  try:
    bound = gridded.load(ensemble)
    assert bound.description == 'analysis (member 1 of 3)'
    assert gridded.settings(path=ensemble).load() is bound
  finally:
    gin.clear_config()
  assert gridded.load(ensemble).description == 'analysis (member 0 of 3)'


def test_a_member_out_of_range_is_one_line(ensemble):
  with pytest.raises(errors.ConfigError) as raised:
    gridded.load(ensemble, member=3)
  message = str(raised.value)
  assert '\n' not in message
  assert '3 ensemble members' in message and '(0..2)' in message
  assert 'GriddedWindField.member = 3' in message
  with pytest.raises(errors.ConfigError) as raised:
    gridded.load(str(GFS_NC), member=1)
  assert 'no ensemble member dimension' in str(raised.value)
  with pytest.raises(errors.ConfigError, match='index >= 0'):
    gridded.load(ensemble, member=-1)
  with pytest.raises(errors.ConfigError, match='index >= 0'):
    gridded.settings(path=ensemble, member='1')


def test_a_grib2_ensemble_flies_one_member(tmp_path):
  """GEFS style: the slice's fields as members 0..2 (product definition
  template 4.1, perturbationNumber; winds + member), and a message that is
  no wind. Its members are not duplicates of one field."""
  eccodes = pytest.importorskip('eccodes')
  pytest.importorskip('cfgrib')
  path = tmp_path / 'ensemble.grib2'
  eccodes.codes_grib_multi_support_on()
  try:
    with open(GFS_GRIB, 'rb') as f, open(path, 'wb') as out:
      fields = []
      while (field := eccodes.codes_grib_new_from_file(f)) is not None:
        fields.append(field)
      for k in range(3):
        for field in fields:
          clone = eccodes.codes_clone(field)
          for key, value in (('productDefinitionTemplateNumber', 1),
                             ('perturbationNumber', k),
                             ('numberOfForecastsInEnsemble', 3)):
            eccodes.codes_set(clone, key, value)
          eccodes.codes_set_values(clone,
                                   eccodes.codes_get_values(field) + k)
          eccodes.codes_write(clone, out)
          eccodes.codes_release(clone)
      other = eccodes.codes_clone(fields[0])
      eccodes.codes_set(other, 'parameterNumber', 0)  # Wind direction.
      eccodes.codes_write(other, out)
      for field in [other, *fields]:
        eccodes.codes_release(field)
  finally:
    eccodes.codes_grib_multi_support_off()
  first = gridded.load(str(path), member=0)
  last = gridded.load(str(path), member=2)
  assert last.description == ('GRIB2 run 2011-10-08T00Z +72 h '
                              '(time-invariant; member 2 of 3)')
  np.testing.assert_allclose(last.uv, first.uv + 2.0, atol=0.51)
  with pytest.raises(errors.ConfigError, match=r'3 ensemble members'):
    gridded.load(str(path), member=3)


def test_the_ensemble_mean_flies(ensemble):
  mean = gridded.load(ensemble, member='mean')
  first = gridded.load(ensemble, member=0)
  assert mean.description == 'analysis (ensemble mean of 3)'
  np.testing.assert_allclose(mean.interpolate(*PLACE),
                             first.interpolate(*PLACE) + 1.0, atol=1e-4)
  with pytest.raises(errors.ConfigError, match="'mean'"):
    gridded.settings(path=ensemble, member='median')


def _truth_and_forecast(grid, truth_members):
  """(truth, forecast) [2, members, 8] of `grid` at 8 places, one row per
  truth member given (one jitted call: faster to compile than eager ops)."""
  import types  # pylint: disable=g-import-not-at-top
  import jax  # pylint: disable=g-import-not-at-top
  import jax.numpy as jnp  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import winds  # pylint: disable=g-import-not-at-top
  rows = len(truth_members)
  wind = winds.era5_wind(grid)
  x = jnp.tile(jnp.linspace(-5e4, 5e4, 8), (rows, 1))
  args = (x, -x, jnp.full((rows, 8), 5000.0),
          jnp.tile(jnp.linspace(0.0, 3e4, 8), (rows, 1)))

  @jax.jit
  def both(members):
    state = types.SimpleNamespace(
        noise_u=None, noise_v=None, station=None, truth_member=members,
        start_time_offset_s=(grid.first_time_min - winds._EPOCH_MIN) * 60)
    return (jnp.stack(wind.ground_truth(state, *args)),
            jnp.stack(wind.forecast_column(state, *args)))
  truth, forecast = both(jnp.asarray(truth_members, jnp.int32)[:, None])
  return np.asarray(truth), np.asarray(forecast)


def test_members_drawn_as_truths(ensemble):
  """Issue 64 item 3: the forecast one member (or the mean), each flight's
  truth another member drawn from its reset key; the noise 0 by default."""
  from ble_latex.envs import winds  # pylint: disable=g-import-not-at-top
  from ble_latex.wind import gridded_jax  # pylint: disable=g-import-not-at-top
  settings = gridded.Era5Settings(path=ensemble, member=0, truth_members=True,
                                  center_lat=40.0, center_lon=-103.0,
                                  episode_hours=3.0)
  grid = gridded_jax.grid_from_settings(settings)
  assert gridded_jax.has_truth_members(grid)
  assert grid.truth_uv.shape[0] == 2  # Members 1 and 2: not the forecast's.
  assert grid.noise_scale == 0.0  # The members' spread is the error.
  assert winds.wind_source_from_gin(settings).endswith(
      '; truth the 2 members but 0 of 3, drawn per flight')
  np.testing.assert_allclose(
      grid.truth_uv, np.stack([gridded.load(ensemble, member=k).uv
                               for k in (1, 2)]), atol=1e-5)
  mean = gridded_jax.grid_from_settings(gridded.Era5Settings(
      path=ensemble, member='mean', truth_members=True, center_lat=40.0,
      center_lon=-103.0, episode_hours=3.0))
  assert mean.truth_uv.shape[0] == 3  # Every member, under the mean.
  np.testing.assert_allclose(mean.uv, np.asarray(grid.uv) + 1.0, atol=1e-4)
  np.testing.assert_allclose(mean.truth_uv[2], grid.truth_uv[1], atol=1e-5)


@pytest.mark.slow  # ~14 s at load 10 on 2 cores: the winds' compile.
def test_each_flight_flies_its_truth_member(ensemble):
  """The env's truth reads the flight's member (`EnvState.truth_member`);
  its forecast stays the forecast member."""
  from ble_latex.wind import gridded_jax  # pylint: disable=g-import-not-at-top
  grid = gridded_jax.grid_from_settings(gridded.Era5Settings(
      path=ensemble, truth_members=True, center_lat=40.0, center_lon=-103.0,
      episode_hours=3.0))
  truth, forecast = _truth_and_forecast(grid, [0, 1])
  np.testing.assert_allclose(truth[:, 0], forecast[:, 0] + 1.0, atol=1e-3)
  np.testing.assert_allclose(truth[:, 1], forecast[:, 1] + 2.0, atol=1e-3)


def test_the_env_draws_a_truth_member_per_seed(ensemble):
  """The functional env's reset draws each flight's member (seeded)."""
  import jax  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import jax_env  # pylint: disable=g-import-not-at-top
  from ble_latex.wind import gridded_jax  # pylint: disable=g-import-not-at-top
  grid = gridded_jax.grid_from_settings(gridded.Era5Settings(
      path=ensemble, truth_members=True, center_lat=40.0, center_lon=-103.0,
      episode_hours=3.0))
  env = jax_env.LatexBalloonJaxEnv()
  params = env.default_params.replace(wind_grid=grid)
  draw = jax.jit(jax.vmap(lambda k, p: env.draw(k, p)[0].truth_member,
                          (0, None)))
  keys = jax.vmap(jax.random.PRNGKey)(np.arange(12))
  members = np.asarray(draw(keys, params))
  assert set(members.tolist()) == {0, 1}
  np.testing.assert_array_equal(members, draw(keys, params))  # Seeded.
  plain = gridded_jax.grid_from_settings(gridded.Era5Settings(
      path=ensemble, center_lat=40.0, center_lon=-103.0, episode_hours=3.0))
  assert jax.eval_shape(env.draw, keys[0], params.replace(
      wind_grid=plain))[0].truth_member is None


def test_member_truths_refused_in_one_line(ensemble):
  from ble_latex.ble import gridded_field  # pylint: disable=g-import-not-at-top
  from ble_latex.wind import gridded_jax  # pylint: disable=g-import-not-at-top
  with pytest.raises(errors.ConfigError, match='no ensemble member') as raised:
    gridded_jax.grid_from_settings(gridded.Era5Settings(
        path=str(GFS_NC), truth_members=True, center_lat=40.0,
        center_lon=-103.0))
  assert '\n' not in str(raised.value)
  with pytest.raises(errors.ConfigError, match='truth_members'):
    gridded.Era5Settings(path=ensemble, truth_members='yes')
  with pytest.raises(errors.ConfigError, match='bind one'):
    gridded_jax.grid_from_data(gridded.load(ensemble, member=0),
                               truth=gridded.load(ensemble, member=1),
                               truth_members=gridded_jax.member_truths(ensemble, 0),
                               center_lat=40.0, center_lon=-103.0,
                               episode_hours=3.0)
  with pytest.raises(errors.ConfigError, match='truth_members'):
    gridded_field.GriddedWindField.from_settings(gridded.Era5Settings(
        path=ensemble, truth_members=True))


@pytest.mark.slow
def test_a_launch_draws_member_truths_and_names_them(ensemble):
  from ble_latex.launch import scoring  # pylint: disable=g-import-not-at-top
  gin.clear_config()
  with gin.unlock_config():
    gin.bind_parameter('GriddedWindField.truth_members', True)
  try:
    world = scoring.era5_world(ensemble, max_hours=1.0, steps=2)
  finally:
    gin.clear_config()
  assert world.params.wind_grid.truth_uv.shape[0] == 2
  assert world.describe['wind_source'] == (
      f"analysis (member 0 of 3): ['{ensemble}']; truth the 2 members but 0 "
      'of 3, drawn per flight')
