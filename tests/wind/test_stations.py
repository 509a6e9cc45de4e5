"""Issue 45, items 4 and 3: stations on a gridded wind source, leaving its
domain, a sounding's site and date, and `ble-latex-launch --wind_file`.

On the real bytes of tests/data/realwinds/ (PROVENANCE.md beside them).
"""

import datetime as dt
import math
import os

import ble_latex  # noqa: F401  pylint: disable=unused-import
import gin
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex import errors
from ble_latex.envs import env_params
from ble_latex.envs import env_types
from ble_latex.envs import jax_env
from ble_latex.flight import state as state_lib
from ble_latex.run import records
from ble_latex.wind import gridded
from ble_latex.wind import gridded_jax
from ble_latex.wind import sounding
from ble_latex.wind import stations

from tests import helpers

DATA = str(helpers.REAL_WINDS)
GFS_NC = os.path.join(DATA, 'gfs_2010-10-26T12Z_uv_10-300hPa_1deg_subset.nc')
BOISE = os.path.join(DATA, 'BOI-Boise_2010-12-09T12Z_uwyo.txt')
HILO = os.path.join(DATA, 'PHTO-Hilo_2023-11-01T00Z_uwyo.csv')
# The UWyo TEXT:LIST page around the Boise table: its title and station block
# (the layout of weather.uwyo.edu's pages; the committed file is the bare
# table).
_PAGE_HEAD = ('<HTML>\n<TITLE>University of Wyoming - Radiosonde Data</TITLE>'
              '\n<H2>72681 BOI Boise Observations at 12Z 09 Dec 2010</H2>\n'
              '<PRE>\n')
_PAGE_TAIL = ('</PRE><H3>Station information and sounding indices</H3><PRE>\n'
              '                         Station identifier: BOI\n'
              '                             Station number: 72681\n'
              '                           Observation time: 101209/1200\n'
              '                           Station latitude: 43.56\n'
              '                          Station longitude: -116.21\n'
              '                          Station elevation: 874.0\n</PRE>\n')
_SEEDS = np.arange(6)


@pytest.fixture(scope='module')
def gfs():
  return gridded.load(GFS_NC)


def _params(grid):
  gin.clear_config()
  return env_params.params_from_gin().replace(wind_grid=grid)


# -- Stations per seed. -------------------------------------------------------
def test_station_box_keeps_the_margin_from_every_edge(gfs):
  lat_lo, lat_hi, lon_lo, lon_hi = stations.station_box(
      gfs.latitude, gfs.longitude, 400.0)
  deg = 400.0 / stations.KM_PER_DEG  # 3.6 deg of latitude.
  assert lat_lo == pytest.approx(35.0 + deg) and lat_hi == pytest.approx(
      45.0 - deg)
  # Along the parallel at the box's poleward edge: 400 km to each side.
  km = (lon_lo - 250.0) * stations.KM_PER_DEG * math.cos(math.radians(lat_hi))
  assert km == pytest.approx(400.0) and lon_hi == pytest.approx(
      265.0 - (lon_lo - 250.0))
  with pytest.raises(errors.ConfigError) as info:
    stations.station_box(gfs.latitude, gfs.longitude, 600.0, gfs.paths)
  assert 'station_margin_km = 600' in str(info.value)
  assert GFS_NC in str(info.value) and '\n' not in str(info.value)
  for bad in (-1.0, float('nan'), 'far'):
    with pytest.raises(errors.ConfigError, match='station_margin_km'):
      stations.check_margin(bad)
  with pytest.raises(errors.ConfigError, match="'per_seed'"):
    stations.check_mode('random')


def test_per_seed_stations_are_reproducible_and_inside_the_box(gfs):
  grid = gridded_jax.grid_from_data(gfs, stations='per_seed')
  box = np.asarray(grid.station_box)
  params = _params(grid)
  many = jax_env.flight_stations(params, np.arange(2000))
  listed = many[:len(_SEEDS)]
  # Seed s flies station s: the same every time, what reset draws.
  np.testing.assert_array_equal(
      jax_env.flight_stations(params, np.arange(2000))[:len(_SEEDS)], listed)
  one = jax_env.station_of(jax_env.arena_key(jax.random.PRNGKey(3)), grid)
  np.testing.assert_allclose(listed[3], [float(one[0]), float(one[1]) - 360],
                             atol=1e-9)
  lon = listed[:, 1] + 360.0
  assert np.all((listed[:, 0] >= box[0]) & (listed[:, 0] <= box[1]))
  assert np.all((lon >= box[2]) & (lon <= box[3]))
  assert len({tuple(np.round(d, 3)) for d in listed}) == len(_SEEDS)
  # Over many seeds they fill the box, equal areas equally likely.
  sin = np.sin(np.radians(many[:, 0]))
  sin_box = np.sin(np.radians(box[:2]))
  mid = 0.5 * (sin_box[0] + sin_box[1])
  assert 0.45 < np.mean(sin < mid) < 0.55
  assert 0.45 < np.mean(many[:, 1] + 360.0 < 0.5 * (box[2] + box[3])) < 0.55
  # The forecast around a station is the file's winds there.
  station = jnp.asarray([float(one[0]), float(one[1])], jnp.float32)
  column = jax.jit(gridded_jax.forecast)(grid, 0.0, 0.0, 0.0,
                                         jnp.float32(5000.0), station)
  np.testing.assert_allclose(
      np.asarray(column),
      gfs.interpolate(0.0, 5000.0, float(one[0]), float(one[1])), atol=2e-3)


@pytest.mark.slow
def test_per_seed_stations_are_flown(gfs):
  grid = gridded_jax.grid_from_data(gfs, stations='per_seed')
  params = _params(grid)
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  keys = jnp.stack([jax.random.PRNGKey(int(s)) for s in _SEEDS])
  reset = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))
  obs, state = reset(keys, params)
  drawn = np.asarray(state.station, np.float64)
  listed = jax_env.flight_stations(params, _SEEDS)
  np.testing.assert_allclose(listed[:, 0], drawn[:, 0], atol=1e-9)
  np.testing.assert_allclose(listed[:, 1], drawn[:, 1] - 360.0, atol=1e-9)
  assert np.all(np.isfinite(np.asarray(obs)))
  # The measured wind is the file's around each flight's own station.
  f = state.flight
  lat, lon = jax.vmap(gridded_jax.latlng, in_axes=(None, 0, 0, 0))(
      grid, f.x_m, f.y_m, state.station)
  want = gfs.interpolate(0.0, np.asarray(f.pressure_pa), np.asarray(lat),
                         np.asarray(lon))
  noise = np.hypot(np.asarray(state.wind_u) - want[:, 0],
                   np.asarray(state.wind_v) - want[:, 1])
  assert np.all(noise < 10.0)  # BLE's simplex noise only.
  # The other draws of the world are those of a fixed station.
  fixed = gridded_jax.grid_from_data(gfs, center_lat=40.0, center_lon=-103.0)
  fixed_state = reset(keys, params.replace(wind_grid=fixed))[1]
  assert fixed_state.station is None
  np.testing.assert_array_equal(np.asarray(fixed_state.flight.x_m),
                                np.asarray(f.x_m))
  np.testing.assert_array_equal(np.asarray(fixed_state.start_time_offset_s),
                                np.asarray(state.start_time_offset_s))


def test_fixed_stations_are_todays_default(gfs, tmp_path):
  grid = gridded_jax.grid_from_data(gfs, center_lat=40.0, center_lon=-103.0)
  assert grid.station_box is None
  assert jax_env.flight_stations(_params(grid), [0, 5]).tolist() == [
      pytest.approx([40.0, -103.0], abs=1e-4)] * 2
  assert jax_env.flight_stations(_params(None), [0]) is None
  # A sounding has no domain to draw stations in.
  with pytest.raises(errors.ConfigError, match='needs a gridded source'):
    gridded_jax.grid_from_data(gridded.load(HILO), stations='per_seed')
  # gin: the mode and the margin reach the grid.
  gin.clear_config()
  gin.parse_config([
      'import ble_latex.envs.jax_env',
      'latex_episode.wind_field_factory = @GriddedWindField',
      f'GriddedWindField.path = {GFS_NC!r}',
      "GriddedWindField.stations = 'per_seed'",
      'GriddedWindField.station_margin_km = 300.0'])
  try:
    box = np.asarray(env_params.params_from_gin().wind_grid.station_box)
    assert box[0] == pytest.approx(35.0 + 300.0 / stations.KM_PER_DEG)
  finally:
    gin.clear_config()


def test_end_outside_domain_defaults():
  ends = stations.end_outside_domain
  assert not ends(None, 'ERA5', 'fixed')  # The paper's: edges held.
  assert ends(None, 'ERA5', 'per_seed')
  assert ends(None, 'analysis', 'fixed') and ends(None, 'GRIB2', 'fixed')
  assert not ends(None, 'sounding', 'fixed')
  assert not ends(True, 'sounding', 'fixed')
  assert not ends(False, 'GRIB2', 'per_seed') and ends(True, 'ERA5', 'fixed')
  with pytest.raises(errors.ConfigError, match='end_outside_domain'):
    ends('yes', 'ERA5', 'fixed')


# -- Leaving the domain. ------------------------------------------------------
def test_outside_is_beyond_the_grids_nodes(gfs):
  from ble_latex.envs import winds  # pylint: disable=g-import-not-at-top
  assert 'left_wind_domain' in records.TERMINAL_REASONS
  assert 'left_wind_domain' not in records.OUT_OF_RESOURCES_REASONS
  grid = gridded_jax.grid_from_data(gfs, center_lat=40.0, center_lon=-103.0)
  # 0 km; 700 km east (lon -94.8: the grid ends at -95); 600 km west (lon
  # -110.04) and south (lat 34.6); 400 km east (lon -98.3).
  x = jnp.array([0.0, 700e3, -600e3, 0.0, 400e3])
  y = jnp.array([0.0, 0.0, 0.0, -600e3, 0.0])
  assert np.asarray(gridded_jax.outside(grid, x, y)).tolist() == [
      False, True, True, True, False]
  # Around a flight's own station, the same.
  station = jnp.array([40.0, 257.0], jnp.float32)
  assert np.asarray(gridded_jax.outside(grid, x, y, station)).tolist() == [
      False, True, True, True, False]
  assert grid.end_outside_domain and winds.era5_wind(grid).outside
  held = gridded_jax.grid_from_data(gfs, center_lat=40.0, center_lon=-103.0,
                                    end_outside_domain=False)
  assert winds.era5_wind(held).outside is None  # Edge values held.
  assert winds.GENERATIVE_WIND.outside is None


@pytest.mark.slow
def test_a_flight_that_leaves_the_grid_ends_with_its_own_reason(gfs):
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  grid = gridded_jax.grid_from_data(gfs, center_lat=40.0, center_lon=-103.0)
  params = _params(grid)
  keys = jnp.stack([jax.random.PRNGKey(0)] * 2)
  state = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(keys, params)[1]
  # The station and 700 km east of it (outside).
  state = state.replace(flight=state.flight.replace(
      x_m=jnp.array([0.0, 700e3], jnp.float32),
      y_m=jnp.zeros(2, jnp.float32)))
  step = jax.jit(jax.vmap(env.step_env, in_axes=(0, 0, 0, None)))
  action = jnp.broadcast_to(jnp.array([18_000.0, 1.0, 1.0]), (2, 3))
  _, after, _, done, info = step(keys, state, action, params)
  left = int(state_lib.FlightStatus.LEFT_WIND_DOMAIN)
  assert np.asarray(after.flight.status).tolist() == [0, left]
  assert np.asarray(done).tolist() == [False, True]
  out = jax_env.info_dict(jax.tree.map(lambda a: np.asarray(a)[1],
                                       jax.device_get(info)))
  assert out['terminal_reason'] == 'left_wind_domain'
  assert not out['out_of_resources'] and not out['envelope_burst']
  # A finished flight stays where it ended.
  again = step(keys, after, action, params)[1]
  assert float(again.flight.x_m[1]) == float(after.flight.x_m[1])


# -- A sounding's site and date. ----------------------------------------------
def _page(tmp_path):
  path = tmp_path / 'boise_page.txt'
  with open(BOISE) as f:
    path.write_text(_PAGE_HEAD + f.read() + _PAGE_TAIL)
  return str(path)


def test_a_soundings_header_names_its_site_and_date(tmp_path):
  page = _page(tmp_path)
  column = sounding.read(page)
  bare = sounding.read(BOISE)
  np.testing.assert_array_equal(column.u_mps, bare.u_mps)
  assert column.site == sounding.Site(
      identifier='BOI', number='72681',
      time=dt.datetime(2010, 12, 9, 12, tzinfo=dt.timezone.utc),
      latitude=43.56, longitude=-116.21)
  assert bare.site == sounding.Site()  # The bare tables name nothing.
  assert sounding.read(HILO).site == sounding.Site()
  # The title alone gives the station and time.
  title_only = tmp_path / 'title.txt'
  with open(BOISE) as f:
    title_only.write_text(_PAGE_HEAD + f.read())
  site = sounding.read(str(title_only)).site
  assert (site.number, site.identifier, site.time) == (
      '72681', 'BOI', dt.datetime(2010, 12, 9, 12, tzinfo=dt.timezone.utc))
  assert site.latitude is None
  # CSV: the same key: value lines above the header row.
  csv = tmp_path / 'hilo.csv'
  with open(HILO) as f:
    csv.write_text('# Station number: 91285\n# Observation time: '
                   '231101/0000\n# Station latitude: 19.72\n# Station '
                   'longitude: -155.05\n' + f.read())
  hilo = sounding.read(str(csv))
  assert len(hilo.pressure_pa) == 162
  assert (hilo.site.number, hilo.site.time, hilo.site.latitude) == (
      '91285', dt.datetime(2023, 11, 1, tzinfo=dt.timezone.utc), 19.72)
  bad = tmp_path / 'bad.txt'
  bad.write_text(_PAGE_HEAD + open(BOISE).read() + _PAGE_TAIL.replace(
      '43.56', '143.56'))
  with pytest.raises(errors.BadFileError) as info:
    sounding.read(str(bad))
  assert 'station latitude' in str(info.value) and str(bad) in str(
      info.value) and '\n' not in str(info.value)


def test_a_soundings_date_is_its_flights_and_label(tmp_path):
  from ble_latex.envs import winds  # pylint: disable=g-import-not-at-top
  page = _page(tmp_path)
  data = gridded.load(page)
  assert data.start == dt.datetime(2010, 12, 9, 12, tzinfo=dt.timezone.utc)
  assert data.description == ('sounding BOI 72681 43.56N -116.21E '
                              '2010-12-09T12:00Z (time-invariant; wind above '
                              'its top, 32.3 km, held)')
  assert gridded.load(BOISE).description == (
      'sounding (time-invariant; wind above its top, 32.3 km, held)')
  epoch = env_types.START_EPOCH
  for when, want in ((None, dt.datetime(2010, 12, 9, 12)),
                     ('2023-06-21T06:00', dt.datetime(2023, 6, 21, 6))):
    grid = gridded_jax.grid_from_data(data, center_lat=43.56,
                                      center_lon=-116.21, snapshot_time=when)
    # The flight starts then (`draw`'s start), which sets its sun clock.
    start = winds.era5_start_offset_s(grid, jax.random.PRNGKey(0))
    offset = want.replace(tzinfo=dt.timezone.utc) - epoch
    assert int(start) == int(offset.total_seconds())
  with pytest.raises(errors.ConfigError, match='snapshot_time'):
    gridded_jax.grid_from_data(data, center_lat=43.56, center_lon=-116.21,
                               snapshot_time='soon')


def test_wind_file_defaults(tmp_path):
  from ble_latex.run import wind_file  # pylint: disable=g-import-not-at-top
  gin.clear_config()
  try:
    assert wind_file.file_defaults(GFS_NC) == [
        "GriddedWindField.stations = 'per_seed'"]
    assert wind_file.file_defaults(BOISE) == []  # No site in the file.
    assert wind_file.file_defaults(_page(tmp_path)) == [
        'GriddedWindField.center_lat = 43.56',
        'GriddedWindField.center_lon = -116.21']
    gin.parse_config(['import ble_latex.wind.gridded',
                      'GriddedWindField.center_lat = 40.0'])
    assert wind_file.file_defaults(GFS_NC) == []  # The user's station.
  finally:
    gin.clear_config()


# -- ble-latex-launch --wind_file. --------------------------------------------
def _bad_wind_file(tmp_path):
  bad = tmp_path / 'bad.nc'
  bad.write_bytes(b'CDF\x01' + b'\x00' * 64)
  return str(bad)


@pytest.mark.slow  # Importing the launch planner imports TensorFlow (~30 s).
def test_launch_wind_file_defaults_and_bad_files(tmp_path):
  from ble_latex.launch import scoring  # pylint: disable=g-import-not-at-top
  assert scoring.domain_centre(gridded.load(GFS_NC)) == (40.0, -102.5)
  assert scoring.domain_centre(gridded.load(_page(tmp_path))) == (43.56, -116.21)
  gin.clear_config()
  params = env_params.params_from_gin()
  # A bad file is the reader's error (exit 1), not a usage error (exit 2).
  with pytest.raises(errors.BadFileError):
    scoring.era5_world(_bad_wind_file(tmp_path), max_hours=1.0,
                       params=params)
  with pytest.raises(FileNotFoundError):
    scoring.era5_world(str(tmp_path / 'missing.nc'), max_hours=1.0,
                       params=params)
  with pytest.raises(errors.ConfigError, match='both latitude and longitude'):
    scoring.era5_world(GFS_NC, center_lat=40.0, max_hours=1.0,
                       params=params)


# Bindings of any type a gin file can hold, each refused as it is bound.
_BAD_BINDINGS = (('stations', [(41.0, -103.0)]), ('center_lat', [40.0]),
                 ('center_lat', '40'), ('center_lat', 91.0),
                 ('center_lon', float('nan')), ('episode_hours', [72]),
                 ('episode_hours', -1.0), ('add_noise', 'yes'),
                 ('station_margin_km', [1.0]), ('station_margin_km', -5.0))


@pytest.mark.parametrize('field, value', _BAD_BINDINGS)
def test_bad_era5_settings_are_one_line_naming_the_binding(field, value):
  with pytest.raises(errors.ConfigError) as info:
    gridded.settings(**{'path': GFS_NC, 'center_lat': 40.0,
                        'center_lon': -103.0, field: value})
  # Gin appends 'In call to configurable ...' lines; commands print the first.
  assert f'GriddedWindField.{field}' in str(info.value).splitlines()[0]


@pytest.mark.slow
@pytest.mark.ci  # ~15-25 s: the eval command's imports.
def test_a_list_of_stations_from_eval_is_a_usage_error(tmp_path, capsys):
  # It reached the grid cache as a key: TypeError, unhashable type 'list'.
  from ble_latex.cli import eval as eval_cli  # pylint: disable=g-import-not-at-top
  status = eval_cli.main([
      f'--output_dir={tmp_path}', '--agent=latex_random',
      '--suite=latex_micro', f'--wind_file={GFS_NC}',
      '--gin_bindings=GriddedWindField.stations = [(41.0, -103.0)]'])
  err = capsys.readouterr().err.strip().splitlines()
  gin.clear_config()
  assert status == 2, err
  assert len(err) == 1 and 'GriddedWindField.stations' in err[0], err


@pytest.mark.slow
def test_launch_command_bad_wind_file_exits_1(tmp_path, capsys):
  from ble_latex.cli import launch as launch_command  # pylint: disable=g-import-not-at-top
  bad = _bad_wind_file(tmp_path)
  for path in (bad, str(tmp_path / 'missing.nc')):
    status = launch_command.main([f'--output_dir={tmp_path / "out"}',
                                  '--grid=2,2,1', '--max_steps=2',
                                  f'--wind_file={path}'])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 1, err
    assert len(err) == 1 and err[0].startswith('ble-latex-launch: ')
    assert path in err[0]
  gin.clear_config()


@pytest.mark.slow
def test_launch_world_of_a_wind_file():
  from ble_latex.launch import scoring  # pylint: disable=g-import-not-at-top
  gin.clear_config()
  world = scoring.era5_world(GFS_NC, max_hours=1.0, steps=2)
  assert (world.describe['station_lat'],
          world.describe['station_lon']) == (40.0, -102.5)
  assert world.describe['source'] == 'analysis'
  assert world.describe['date'] == '2010-10-26T12:00:00'
  assert 'time-invariant' in world.describe['wind_source']
  assert world.params.wind_grid.end_outside_domain


@pytest.mark.slow
def test_eval_records_carry_each_flights_station(tmp_path, capsys):
  import json  # pylint: disable=g-import-not-at-top
  from ble_latex.cli import eval as eval_cli  # pylint: disable=g-import-not-at-top
  out = tmp_path / 'out'
  code = eval_cli.main([
      f'--output_dir={out}', '--agent=latex_station_seeker',
      '--suite=latex_micro', '--max_episode_length=2',
      f'--wind_file={GFS_NC}'])
  gin.clear_config()
  assert code == 0, capsys.readouterr().err
  got = json.loads((out / 'latex_micro' / 'latex_station_seeker.json'
                    ).read_text())
  grid = gridded_jax.grid_from_data(gridded.load(GFS_NC), stations='per_seed')
  want = jax_env.flight_stations(_params(grid), [r['seed'] for r in got])
  gin.clear_config()
  for record, (lat, lon) in zip(got, want):
    assert record['station_lat'] == pytest.approx(lat, abs=1e-5)
    assert record['station_lon'] == pytest.approx(lon, abs=1e-5)
  assert len({(r['station_lat'], r['station_lon']) for r in got}) == len(got)


def test_bles_era5_wind_field_refuses_per_seed_stations():
  from ble_latex.ble import gridded_field  # pylint: disable=g-import-not-at-top
  with pytest.raises(errors.ConfigError, match='fixed station'):
    gridded_field.GriddedWindField.from_settings(gridded.Era5Settings(
        path=GFS_NC, stations='per_seed'))
