# coding=utf-8
"""Real upper-air winds (issue 45): GFS NetCDF and GRIB2, UWyo soundings.

On the real bytes of tests/data/realwinds/ (PROVENANCE.md beside them): each
slice reads through `gridded.load` (the reader chosen by content), says its
source and "time-invariant", flies through the functional env and
`gymnasium.make('ble_latex/LatexBalloon-v0')` from the gin binding; each
bad-file case is one line, and exit 1 from `ble-latex-eval --wind_file`.
"""

import os

import ble_latex  # noqa: F401  pylint: disable=unused-import
import gin
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import xarray as xr

from ble_latex import errors
from ble_latex.envs import env_params
from ble_latex.envs import jax_env
from ble_latex.wind import analysis
from ble_latex.wind import gridded
from ble_latex.wind import gridded_jax
from ble_latex.wind import sounding

from tests import helpers

DATA = str(helpers.REAL_WINDS)
GFS_NC = os.path.join(DATA, 'gfs_2010-10-26T12Z_uv_10-300hPa_1deg_subset.nc')
GFS_GRIB = os.path.join(DATA, 'gfs_2011-10-11T00Z_uv_10-250hPa_2p5deg.grib2')
BOISE = os.path.join(DATA, 'BOI-Boise_2010-12-09T12Z_uwyo.txt')
HILO = os.path.join(DATA, 'PHTO-Hilo_2023-11-01T00Z_uwyo.csv')
# (file, source, a station inside it: lat [deg N], lon [deg E]).
SLICES = ((GFS_NC, 'analysis', 40.0, -103.0), (GFS_GRIB, 'GRIB2', 40.0, -103.0),
          (BOISE, 'sounding', 43.56, -116.21), (HILO, 'sounding', 19.72,
                                                 -155.05))
# Test ids: the file's name, not its absolute path (the same in any checkout).
_IDS = [os.path.basename(path) for path, *_ in SLICES]
_SEEDS = (0, 1)
_ACTIONS = np.array([[18_000.0, 1.0, -1.0], [19_000.0, 1.0, 1.0],
                     [17_000.0, 2.0, -1.0]], np.float32)


@pytest.mark.parametrize('path, source, lat, lon', SLICES, ids=_IDS)
def test_each_slice_reads_as_a_time_invariant_field(path, source, lat, lon):
  data = gridded.load(path)
  assert data.source == source
  assert data.time_invariant
  held = (f'; wind above its top, {data.site.top_m / 1000:.1f} km, held'
          if source == 'sounding' else '')
  run = ' run 2011-10-08T00Z +72 h' if source == 'GRIB2' else ''
  assert data.description == f'{source}{run} (time-invariant{held})'
  assert data.covers(lat, lon)
  # The same winds at the first time and ten days later.
  for t_s in (0.0, 1800.0, 10 * 86400.0):
    np.testing.assert_allclose(data.interpolate(t_s, 5000.0, lat, lon),
                               data.interpolate(0.0, 5000.0, lat, lon),
                               rtol=0, atol=1e-12)
  # Levels over the flight band, ascending pressure, finite winds.
  assert data.pressure[0] <= analysis.pressure_of_height(25_000.0)
  assert data.pressure[-1] >= analysis.pressure_of_height(15_000.0)
  assert np.all(np.diff(data.pressure) > 0) and np.all(np.isfinite(data.uv))
  assert gridded.start_window(data, center_lat=lat, center_lon=lon,
                              episode_hours=72.0, start_dates='eval') == (0, 0)


def test_us_standard_atmosphere_pressures():
  # US Standard Atmosphere 1976 (geopotential heights): each layer's formula
  # reaches the next layer's tabulated base pressure (22 632.1 Pa at 11 km,
  # 5474.89 Pa at 20 km, 868.019 Pa at 32 km) from its own base.
  for height, want in ((11_000.0 - 1e-6, 22632.1), (20_000.0 - 1e-6, 5474.89),
                       (32_000.0 - 1e-6, 868.019), (0.0, 101325.0)):
    assert analysis.pressure_of_height(height) == pytest.approx(want, 5e-5)
  # The flight band, 15-25 km: ~120 and ~25 hPa.
  assert analysis.pressure_of_height(15_000.0) == pytest.approx(12045.0, 1e-3)
  assert analysis.pressure_of_height(25_000.0) == pytest.approx(2511.0, 2e-3)


def test_gfs_netcdf_values_are_the_files_with_latitude_ascending():
  data = gridded.load(GFS_NC)
  with xr.open_dataset(GFS_NC) as raw:
    u = raw['u-component_of_wind_isobaric'].sel(
        isobaric3=5000.0, lat=44.0, lon=251.0).values.item()
    v = raw['v-component_of_wind_isobaric'].sel(
        isobaric3=5000.0, lat=36.0, lon=263.0).values.item()
  assert data.latitude[0] == 35.0 and data.latitude[-1] == 45.0
  np.testing.assert_allclose(data.interpolate(0.0, 5000.0, 44.0, 251.0)[0], u)
  # Longitude in -180..180 reaches the file's 0..360 grid.
  np.testing.assert_allclose(
      data.interpolate(0.0, 5000.0, 36.0, 263.0 - 360.0)[1], v)


def test_gfs_grib_values_are_the_messages():
  import cfgrib  # pylint: disable=g-import-not-at-top,unused-import
  data = gridded.load(GFS_GRIB)
  with xr.open_dataset(GFS_GRIB, engine='cfgrib', backend_kwargs={
      'indexpath': '', 'filter_by_keys': {'typeOfLevel': 'isobaricInhPa',
                                          'shortName': 'v'}}) as raw:
    v = raw['v'].sel(isobaricInhPa=50.0, latitude=40.0,
                     longitude=257.5).values.item()
  assert list(data.pressure) == [1000.0, 2000.0, 3000.0, 5000.0, 7000.0,
                                 10000.0, 15000.0, 20000.0, 25000.0]
  np.testing.assert_allclose(data.interpolate(0.0, 5000.0, 40.0, -102.5)[1],
                             v)


@pytest.mark.parametrize('path', (BOISE, HILO), ids=os.path.basename)
def test_a_sounding_is_its_column_everywhere(path):
  column = sounding.read(path)
  data = gridded.load(path)
  k = int(np.argmin(np.abs(column.pressure_pa - 5000.0)))
  p = column.pressure_pa[k]
  for lat, lon in ((0.0, 0.0), (43.5, -116.2), (-60.0, 170.0)):
    np.testing.assert_allclose(data.interpolate(3600.0, p, lat, lon),
                               [column.u_mps[k], column.v_mps[k]], atol=1e-9)


def _bind(path, lat, lon):
  gin.clear_config()
  gin.parse_config([
      'import ble_latex.envs.jax_env',
      'latex_episode.wind_field_factory = @GriddedWindField',
      f'GriddedWindField.path = {path!r}',
      f'GriddedWindField.center_lat = {lat}',
      f'GriddedWindField.center_lon = {lon}'])


@pytest.mark.slow
@pytest.mark.parametrize('path, source, lat, lon', SLICES, ids=_IDS)
def test_each_slice_flies_the_functional_env_and_gymnasium(path, source, lat,
                                                           lon):
  import gymnasium  # pylint: disable=g-import-not-at-top
  _bind(path, lat, lon)
  try:
    params = env_params.params_from_gin()
    grid = params.wind_grid
    assert grid is not None
    data = gridded.load(path)
    assert data.source == source
    np.testing.assert_array_equal(np.asarray(grid.uv),
                                  data.uv.astype(np.float32))
    env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
    keys = jnp.stack([jax.random.PRNGKey(s) for s in _SEEDS])
    obs0, state = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(keys,
                                                                   params)
    # The real winds are flown, not the VAE's.
    vae = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(
        keys, params.replace(wind_grid=None))[1]
    assert np.all(np.abs(np.asarray(state.wind_u) - np.asarray(vae.wind_u))
                  > 1e-3)
    step = jax.jit(jax.vmap(env.step_env, in_axes=(0, 0, 0, None)))
    observations = [np.asarray(obs0)]
    for action in _ACTIONS:
      obs, state, _, done, _ = step(keys, state, jnp.broadcast_to(
          action, (len(_SEEDS), 3)), params)
      observations.append(np.asarray(obs))
      assert np.all(np.isfinite(np.asarray(obs)))
      assert not np.any(np.asarray(done))
    single = gymnasium.make('ble_latex/LatexBalloon-v0',
                            normalize_actions=False)
    assert single.unwrapped.params.wind_grid is grid
    for i, seed in enumerate(_SEEDS):
      obs, _ = single.reset(seed=seed)
      np.testing.assert_allclose(obs, observations[0][i], atol=1e-4)
      for t, action in enumerate(_ACTIONS):
        obs = single.step(action)[0]
        np.testing.assert_allclose(obs, observations[t + 1][i], atol=1e-4)
    single.close()
  finally:
    gin.clear_config()


def _bad_files(folder):
  """(name, path, what the one-line error says) for each bad-file case."""
  with xr.open_dataset(GFS_NC) as raw:
    raw = raw.load()
  cases = []

  def write(name, dataset, needle):
    path = str(folder / name)
    dataset.to_netcdf(path)
    cases.append((name, path, needle))

  write('no_winds.nc', raw[['Geopotential_height_isobaric']],
        'has no wind variables')
  write('one_level.nc', raw.isel(isobaric3=[4]), 'hold 1 pressure level')
  write('no_band.nc', raw.sel(isobaric3=[1000.0, 2000.0, 3000.0, 5000.0]),
        'miss the flight band 13-22 km')
  nan = raw.copy(deep=True)
  nan['u-component_of_wind_isobaric'].loc[dict(isobaric3=5000.0, lat=40.0,
                                               lon=255.0)] = np.nan
  write('nan_in_band.nc', nan, 'NaN/inf winds')
  write('small_grid.nc', raw.sel(lat=slice(41.0, 39.0),
                                 lon=slice(254.0, 257.0)),
        'the grid spans 222 km north x 256 km east; a flight needs 400 km')

  def write_bytes(name, data, needle):
    path = str(folder / name)
    with open(path, 'wb') as f:
      f.write(data)
    cases.append((name, path, needle))

  with open(GFS_GRIB, 'rb') as f:
    grib = f.read()
  # Cut inside its 5th message (of 9), where cfgrib's default reads the 4
  # before it. A GRIB2 message's length is bytes 8-15 of its section 0.
  fifth = 0
  for _ in range(4):
    fifth += int.from_bytes(grib[fifth + 8:fifth + 16], 'big')
  assert grib[fifth:fifth + 4] == b'GRIB'
  write_bytes('truncated.grib2', grib[:fifth + 5_000],
              'is not a readable GRIB2 file')
  write_bytes('corrupt.grib2', b'GRIB' + bytes(range(256)) * 4,
              'is not a readable GRIB2 file')
  write_bytes('empty.nc', b'', 'is empty (0 bytes)')
  return cases


def test_each_bad_file_is_one_line_naming_it(tmp_path):
  for name, path, needle in _bad_files(tmp_path):
    with pytest.raises(errors.BadFileError) as raised:
      gridded.load(path)
    message = str(raised.value)
    assert needle in message, (name, message)
    assert path in message and '\n' not in message, (name, message)


@pytest.mark.slow
def test_each_bad_file_exits_1_from_eval(tmp_path, capsys):
  from ble_latex.cli import eval as eval_cli  # pylint: disable=g-import-not-at-top
  for name, path, needle in _bad_files(tmp_path):
    out = tmp_path / f'out_{name}'
    code = eval_cli.main([f'--output_dir={out}', '--agent=latex_random',
                          '--suite=latex_micro', f'--wind_file={path}'])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1, (name, err)
    assert len(err) == 1 and needle in err[0] and path in err[0], (name, err)
    assert err[0].startswith('ble-latex-eval: ')
  gin.clear_config()


@pytest.mark.slow
def test_eval_records_name_the_wind_source(tmp_path, capsys):
  import json  # pylint: disable=g-import-not-at-top
  from ble_latex.cli import eval as eval_cli  # pylint: disable=g-import-not-at-top
  out = tmp_path / 'out'
  code = eval_cli.main([
      f'--output_dir={out}', '--agent=latex_station_seeker',
      '--suite=latex_micro', '--max_episode_length=3',
      f'--wind_file={GFS_GRIB}', '--gin_bindings=GriddedWindField.center_lat=40.0',
      '--gin_bindings=GriddedWindField.center_lon=-103.0'])
  gin.clear_config()
  assert code == 0, capsys.readouterr().err
  records = json.loads((out / 'latex_micro' / 'latex_station_seeker.json'
                        ).read_text())
  want = f"GRIB2 run 2011-10-08T00Z +72 h (time-invariant): ['{GFS_GRIB}']"
  assert [r['wind_source'] for r in records] == [want] * len(records)
  summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
  assert summary['wind_source'] == want


@pytest.mark.parametrize('path, source, lat, lon', SLICES, ids=_IDS)
def test_bles_wind_field_flies_each_slice(path, source, lat, lon):
  """BLE's `WindField` (gym's agents) over the same time-invariant data."""
  import datetime as dt  # pylint: disable=g-import-not-at-top
  from balloon_learning_environment.utils import units  # pylint: disable=g-import-not-at-top
  from ble_latex.ble import gridded_field  # pylint: disable=g-import-not-at-top
  field = gridded_field.GriddedWindField(path=path, center_lat=lat, center_lon=lon)
  field.reset_forecast(jax.random.PRNGKey(3), dt.datetime(2000, 1, 1))
  assert field.start_date_time == gridded.load(path).start
  here = units.Distance(m=0.0)
  first = field.get_forecast(here, here, 5000.0, dt.timedelta(hours=0))
  later = field.get_forecast(here, here, 5000.0, dt.timedelta(hours=60))
  want = gridded.load(path).interpolate(0.0, 5000.0, lat, lon)
  for vector in (first, later):
    np.testing.assert_allclose([vector.u.meters_per_second,
                                vector.v.meters_per_second], want, atol=1e-6)
  assert source in gridded.load(path).description
