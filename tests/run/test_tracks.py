"""Issue 65, item 1: flight tracks in lat/lon and UTC, their map, their
figure over time and their exports (KML, GeoJSON, CSV).

The lat/lon checks use an independent spherical formula (the great-circle
destination written out here in NumPy), not the project's conversion.
"""

import csv
import datetime as dt
import io
import json
import math
import os
from xml.etree import ElementTree

import numpy as np
import pytest

from ble_latex.cli import plot
from ble_latex.plots import exports
from ble_latex.plots import maps
from ble_latex.run import records
from ble_latex.run import tracks

from tests import helpers

DATA = helpers.REAL_WINDS
GFS_NC = DATA / 'gfs_2010-10-26T12Z_uv_10-300hPa_1deg_subset.nc'
EARTH_RADIUS_KM = 6371.0  # BLE's sphere.
KML = '{http://www.opengis.net/kml/2.2}'


def _destination(lat0, lon0, x_km, y_km):
  """Great-circle destination at bearing atan2(x, y), distance hypot(x, y)."""
  lat0, lon0 = math.radians(lat0), math.radians(lon0)
  bearing = math.atan2(x_km, y_km)
  d = math.hypot(x_km, y_km) / EARTH_RADIUS_KM
  lat = math.asin(math.sin(lat0) * math.cos(d) +
                  math.cos(lat0) * math.sin(d) * math.cos(bearing))
  lon = lon0 + math.atan2(math.sin(bearing) * math.sin(d) * math.cos(lat0),
                          math.cos(d) - math.sin(lat0) * math.sin(lat))
  return math.degrees(lat), (math.degrees(lon) + 180.0) % 360.0 - 180.0


def _haversine_km(lat0, lon0, lat1, lon1):
  p0, p1 = math.radians(lat0), math.radians(lat1)
  dp, dl = p1 - p0, math.radians(lon1 - lon0)
  a = (math.sin(dp / 2) ** 2 +
       math.cos(p0) * math.cos(p1) * math.sin(dl / 2) ** 2)
  return 2 * EARTH_RADIUS_KM * math.asin(math.sqrt(a))


def _record(seed=3, n=8, lat0=19.72, lon0=-155.05, located=True):
  flight = [{'t_s': 1200.0 * k, 'x_km': -30.0 + 9.0 * k,
             'y_km': 12.0 - 4.0 * k, 'altitude_m': 17_000.0 + 200.0 * k,
             'ascent_rate_mps': 0.0, 'decision': 'float',
             'helium_mols': 168.0 - 0.5 * k, 'sand_kg': 2.0 - 0.1 * k}
            for k in range(n)]
  record = {'seed': seed, 'reward': 1.0, 'tw50': 0.5, 'tw50_window': 0.5,
            'window_steps': n, 'steps': n - 1, 'helium_vented_mols': 0.0,
            'sand_dropped_kg': 0.0, 'terminal_reason': 'time_limit',
            'final_distance_km': 10.0, 'flight_path': flight}
  if not located:
    return record
  return tracks.locate_record(record, (lat0, lon0), tracks.STATION_NOMINAL,
                              dt.datetime(2023, 11, 1, tzinfo=dt.timezone.utc))


def _check_points(lat_lon, record, tol_deg=1e-5):
  """Each (lat, lon) against the station + x/y, independently."""
  path = record['flight_path']
  assert len(lat_lon) == len(path)
  for (lat, lon), point in zip(lat_lon, path):
    want = _destination(record['station_lat'], record['station_lon'],
                        point['x_km'], point['y_km'])
    assert lat == pytest.approx(want[0], abs=tol_deg)
    assert lon == pytest.approx(want[1], abs=tol_deg)
    # And the distance from the station is the offset's length.
    assert _haversine_km(record['station_lat'], record['station_lon'], lat,
                         lon) == pytest.approx(
                             math.hypot(point['x_km'], point['y_km']),
                             rel=1e-4, abs=1e-3)


# -- Coordinates. -------------------------------------------------------------


def test_points_are_the_great_circle_destination_of_their_offset():
  for lat0, lon0, x, y in ((1.0, -113.0, 40.0, -25.0),
                           (64.0, 179.9, 90.0, 10.0),  # Across 180.
                           (-45.0, 10.0, -300.0, 200.0)):
    lat, lon = tracks.point_lat_lon(lat0, lon0, x, y)
    assert (lat, lon) == pytest.approx(_destination(lat0, lon0, x, y),
                                       abs=1e-7)
    assert -180.0 <= lon < 180.0
  assert tracks.wrap_longitude(259.65) == pytest.approx(-100.35)


def test_located_record_carries_station_start_and_each_points_place_and_time():
  record = _record()
  assert record['start_utc'] == '2023-11-01T00:00:00Z'
  assert record['flight_path'][3]['utc'] == '2023-11-01T01:00:00Z'
  _check_points([(p['lat'], p['lon']) for p in record['flight_path']],
                record)
  records.validate_eval([record], 'x.json')
  # A record written before the fields: the same track, computed.
  old = _record(located=False)
  old.update(station_lat=record['station_lat'],
             station_lon=record['station_lon'])
  a, b = tracks.track(record), tracks.track(old)
  np.testing.assert_allclose(a.lat, b.lat, atol=1e-6)
  np.testing.assert_allclose(a.lon, b.lon, atol=1e-6)
  assert b.start_utc is None and b.utc(0) is None
  # No station at all: the nominal position, 1 N 113 W.
  bare = tracks.track(_record(located=False))
  assert (bare.station_lat, bare.station_lon) == (1.0, -113.0)
  assert bare.station_source == tracks.STATION_NOMINAL


@pytest.mark.parametrize('field, value, message', [
    ('lat', 91.0, "field 'lat': expected a finite number in [-90, 90]"),
    ('lon', 'x', "field 'lon': expected a finite number"),
    ('utc', 5, "field 'utc': expected a string"),
])
def test_a_bad_point_coordinate_is_named(field, value, message):
  record = _record()
  record['flight_path'][2][field] = value
  with pytest.raises(ValueError) as e:
    records.validate_eval([record], 'x.json')
  assert 'flight_path[2]' in str(e.value) and message in str(e.value)
  assert '\n' not in str(e.value)


def test_synthetic_winds_use_the_nominal_station_and_bles_date():
  import gin  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import env_params  # pylint: disable=g-import-not-at-top
  gin.clear_config()
  params = env_params.params_from_gin()
  where, source = tracks.stations(params, [0, 1])
  assert source == tracks.STATION_NOMINAL
  np.testing.assert_allclose(where, [[1.0, -113.0]] * 2)
  starts = tracks.start_times(params, [0, 1, 0])
  assert starts[0] == starts[2] != starts[1]
  assert all(s.year >= 2011 and s.tzinfo is not None for s in starts)


# -- Exports. -----------------------------------------------------------------


def test_exports_hold_each_points_lat_lon_altitude_and_time():
  flights = [tracks.track(_record(3)), tracks.track(_record(5, n=4))]
  root = ElementTree.fromstring(exports.to_kml(flights).encode('utf-8'))
  lines = root.findall(f'.//{KML}LineString/{KML}coordinates')
  assert len(lines) == 2
  for text, t in zip((line.text for line in lines), flights):
    triples = [tuple(map(float, c.split(','))) for c in text.split()]
    np.testing.assert_allclose([c[0] for c in triples], t.lon, atol=1e-6)
    np.testing.assert_allclose([c[1] for c in triples], t.lat, atol=1e-6)
    np.testing.assert_allclose([c[2] for c in triples], t.altitude_m,
                               atol=0.1)
  begins = [b.text for b in root.iter(f'{KML}begin')]
  assert begins == ['2023-11-01T00:00:00Z'] * 2

  collection = json.loads(exports.to_geojson(flights))
  assert collection['type'] == 'FeatureCollection'
  paths = [f for f in collection['features']
           if f['properties']['kind'] == 'path']
  assert [f['geometry']['type'] for f in paths] == ['LineString'] * 2
  np.testing.assert_allclose(
      [c[:2] for c in paths[1]['geometry']['coordinates']],
      np.stack([flights[1].lon, flights[1].lat], axis=1), atol=1e-6)
  assert paths[1]['properties']['utc'][-1] == '2023-11-01T01:00:00Z'

  rows = list(csv.DictReader(io.StringIO(exports.to_csv(flights))))
  assert tuple(rows[0]) == exports.CSV_COLUMNS and len(rows) == 12
  assert rows[-1]['seed'] == '5' and rows[-1]['utc'] == '2023-11-01T01:00:00Z'
  assert float(rows[2]['lat']) == pytest.approx(flights[0].lat[2], abs=1e-6)


# -- The command. -------------------------------------------------------------


def test_plot_draws_the_map_and_time_and_exports(tmp_path, capsys):
  source = tmp_path / 'a.json'
  source.write_text(json.dumps([_record(3), _record(5, n=4)]))
  out = tmp_path / 'plots'
  assert plot.main([f'--output_dir={out}', f'--eval_json={source}',
                    '--export=csv,kml,geojson']) == 0, capsys.readouterr().err
  names = {p.name for p in out.iterdir()}
  assert {plot.TRACK_MAP, plot.FLIGHT_TIME, 'tracks.kml', 'tracks.geojson',
          'tracks.csv'} <= names
  for name in (plot.TRACK_MAP, plot.FLIGHT_TIME):
    assert (out / name).read_bytes()[:4] == b'\x89PNG'


def test_the_map_draws_the_coast_from_the_shipped_grid():
  # Hilo: the Big Island's east coast (land west, the Pacific east).
  distance = maps.coast_distance_km(np.array([19.82, 19.72]),
                                    np.array([-155.47, -154.5]))
  assert distance is not None, 'landmetrics (constraints.txt) is missing'
  assert distance[0] < 0.0 < distance[1]
  fig = maps.plot_track_map([tracks.track(_record())], os.devnull)
  assert fig.axes[0].collections  # The land and the coast.


@pytest.mark.parametrize('args, code, message', [
    (['--export=kmz'], 2, '--export: unknown format(s) kmz'),
    (['--eval_json=MISSING'], 1, 'eval file not found'),
    (['--eval_json=CORRUPT'], 1, 'not a valid eval JSON file'),
    (['--eval_json=GOOD', '--output_dir=FILE/sub', '--export=csv'], 1,
     'error:'),
])
def test_bad_inputs_are_one_line(tmp_path, capsys, args, code, message):
  good = tmp_path / 'good.json'
  good.write_text(json.dumps([_record()]))
  corrupt = tmp_path / 'corrupt.json'
  corrupt.write_text('[{"seed": 1,')
  a_file = tmp_path / 'file'
  a_file.write_text('')
  names = {'MISSING': str(tmp_path / 'nope.json'), 'CORRUPT': str(corrupt),
           'GOOD': str(good), 'FILE': str(a_file)}
  argv = [f'--output_dir={tmp_path / "out"}']
  if not any(a.startswith('--eval_json') for a in args):
    argv.append(f'--eval_json={good}')
  for arg in args:
    for key, value in names.items():
      arg = arg.replace(key, value)
    argv.append(arg)
  assert plot.main(argv) == code
  err = capsys.readouterr().err.strip()
  assert message in err and len(err.splitlines()) == 1, err


# -- A real file, flown. ------------------------------------------------------


@pytest.mark.slow
@pytest.mark.ci
def test_a_flight_on_a_real_file_exports_its_track_in_lat_lon(tmp_path,
                                                              capsys):
  import gin  # pylint: disable=g-import-not-at-top
  from ble_latex.cli import eval as eval_cli  # pylint: disable=g-import-not-at-top
  from ble_latex.wind import gridded  # pylint: disable=g-import-not-at-top
  out = tmp_path / 'eval'
  code = eval_cli.main([
      f'--output_dir={out}', '--agent=latex_station_seeker',
      '--suite=latex_micro', '--max_episode_length=4', f'--wind_file={GFS_NC}'])
  gin.clear_config()
  assert code == 0, capsys.readouterr().err
  result = out / 'latex_micro' / 'latex_station_seeker.json'
  flown = records.load_eval(str(result))
  plots = tmp_path / 'plots'
  assert plot.main([f'--output_dir={plots}', f'--eval_json={result}',
                    '--export=kml,geojson,csv']) == 0, capsys.readouterr().err
  data = gridded.load(str(GFS_NC))
  rows = list(csv.DictReader(io.StringIO((plots / 'tracks.csv').read_text())))
  collection = json.loads((plots / 'tracks.geojson').read_text())
  paths = [f for f in collection['features']
           if f['properties']['kind'] == 'path']
  assert len(paths) == len(flown)
  for record, feature in zip(flown, paths):
    assert record['station_source'] == tracks.STATION_FROM_WIND_FILE
    # The station is inside the file's grid; the start is the file's time.
    assert data.latitude[0] <= record['station_lat'] <= data.latitude[-1]
    assert (float(data.longitude[0]) <= record['station_lon'] % 360.0 <=
            float(data.longitude[-1]))
    assert record['start_utc'] == '2010-10-26T12:00:00Z'
    _check_points([(p['lat'], p['lon']) for p in record['flight_path']],
                  record)
    _check_points([(c[1], c[0]) for c in feature['geometry']['coordinates']],
                  record)
    mine = [r for r in rows if int(r['seed']) == record['seed']]
    _check_points([(float(r['lat']), float(r['lon'])) for r in mine], record)
    assert [r['utc'] for r in mine] == [
        p['utc'] for p in record['flight_path']]
    assert mine[-1]['utc'] == tracks.utc_text(
        dt.datetime(2010, 10, 26, 12, tzinfo=dt.timezone.utc) +
        dt.timedelta(seconds=record['flight_path'][-1]['t_s']))
  kml = ElementTree.parse(plots / 'tracks.kml').getroot()
  assert len(kml.findall(f'.//{KML}LineString')) == len(flown)


@pytest.mark.slow
def test_launch_plan_on_a_0_360_file_speaks_minus_180_180_and_utc(
    tmp_path, capsys):
  import struct  # pylint: disable=g-import-not-at-top
  import gin  # pylint: disable=g-import-not-at-top
  from ble_latex.cli import launch as launch_command  # pylint: disable=g-import-not-at-top
  out = tmp_path / 'launch'
  status = launch_command.main([
      f'--output_dir={out}', f'--wind_file={GFS_NC}', '--station_lat=40',
      '--station_lon=-100', '--east_km=-30,30', '--north_km=-30,30',
      '--hours=0,3', '--grid=2,2,2', '--draws=1', '--max_steps=2',
      '--top=4', '--paths=1'])
  gin.clear_config()
  printed = capsys.readouterr().out
  assert status == 0
  plan = json.loads((out / 'launches.json').read_text())
  assert plan['world']['station_lon'] == pytest.approx(-100.0)
  assert plan['world']['winds_vary_in_time'] is False  # A snapshot.
  for row in plan['ranked']:
    assert -180.0 <= row['lon'] < 180.0
    assert (row['lat'], row['lon']) == pytest.approx(
        _destination(40.0, -100.0, row['east_km'], row['north_km']),
        abs=1e-5)
    assert row['launch_utc'] == tracks.utc_text(
        dt.datetime(2010, 10, 26, 12, tzinfo=dt.timezone.utc) +
        dt.timedelta(hours=row['hours']))
  best = plan['ranked'][0]
  line = next(l for l in printed.splitlines() if l.startswith('best launch'))
  assert f'{best["lat"]:.4f} N {-best["lon"]:.4f} W' in line
  assert best['launch_utc'] in line
  # A snapshot's winds are the same at every delay: the map alone.
  png = (out / 'launch_map.png').read_bytes()
  width, height = struct.unpack('>II', png[16:24])
  assert width < 1.5 * height, (width, height)


def test_an_undated_wind_file_writes_no_times():
  import gin  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import env_params  # pylint: disable=g-import-not-at-top
  from ble_latex.wind import gridded  # pylint: disable=g-import-not-at-top
  from ble_latex.wind import gridded_jax  # pylint: disable=g-import-not-at-top
  gin.clear_config()
  # The committed Hilo CSV names neither its site nor its time.
  data = gridded.load(str(DATA / 'PHTO-Hilo_2023-11-01T00Z_uwyo.csv'))
  params = env_params.params_from_gin().replace(
      wind_grid=gridded_jax.grid_from_data(data))
  assert tracks.start_times(params, [0, 1]) == [None, None]
  located = tracks.locate([_record(located=False)], params)[0]
  assert 'start_utc' not in located
  assert 'utc' not in located['flight_path'][0]
  assert tracks.track(located).utc(0) is None


def test_launch_progress_gives_an_eta(capsys, monkeypatch):
  from ble_latex.cli import launch as launch_command  # pylint: disable=g-import-not-at-top
  monkeypatch.setattr(launch_command.time, 'monotonic', lambda: 170.0)
  launch_command._progress(2048, 13448, start=100.0)  # pylint: disable=protected-access
  launch_command._progress(13448, 13448, start=100.0)  # pylint: disable=protected-access
  lines = capsys.readouterr().out.splitlines()
  assert lines == ['  2048/13448 launches, 70 s, ETA 6 min 29 s',
                   '  13448/13448 launches, 70 s']


# -- The Operators page's commands. -------------------------------------------

OPERATORS_PAGE = helpers.ROOT / 'docs' / 'operators.md'
# What makes the page's commands quick here: fewer seeds, strides, launches.
_SMALLER = (('latex_tiny', 'latex_micro'),
            ('--max_episode_length=72', '--max_episode_length=4'),
            ('--grid=7,7,1', '--grid=2,2,1'), ('--draws=2', '--draws=1'),
            ('--max_steps=36', '--max_steps=2'), ('--paths=3', '--paths=1'))


def _operators_commands():
  """The page's first `sh` block, one command per (continued) line."""
  import re  # pylint: disable=g-import-not-at-top
  block = re.search(r'```sh\n(.*?)```', OPERATORS_PAGE.read_text('utf-8'),
                    re.S).group(1)
  return [line.strip() for line in block.replace('\\\n', ' ').splitlines()
          if line.strip() and not line.strip().startswith('#')]


@pytest.mark.slow
@pytest.mark.ci
def test_the_operators_page_commands_run(tmp_path, capsys, monkeypatch):
  import shlex  # pylint: disable=g-import-not-at-top
  import gin  # pylint: disable=g-import-not-at-top
  from ble_latex.cli import eval as eval_cli  # pylint: disable=g-import-not-at-top
  from ble_latex.cli import launch as launch_cli  # pylint: disable=g-import-not-at-top
  programs = {'ble-latex-eval': eval_cli.main, 'ble-latex-plot': plot.main,
              'ble-latex-launch': launch_cli.main}
  commands = _operators_commands()
  assert [shlex.split(c)[0] for c in commands] == [
      'ble-latex-eval', 'ble-latex-plot', 'ble-latex-launch']
  monkeypatch.chdir(helpers.ROOT)  # Its paths.
  for command in commands:
    for big, small in _SMALLER:
      command = command.replace(big, small)
    program, *args = shlex.split(command.replace('ops/', f'{tmp_path}/ops/'))
    code = programs[program](args)
    gin.clear_config()
    assert code == 0, (command, capsys.readouterr().err[-2000:])
  (record,) = records.load_eval(
      str(tmp_path / 'ops/eval/latex_micro/latex_station_seeker.json'))
  assert (record['station_lat'], record['station_lon']) == (19.72, -155.05)
  assert record['start_utc'] == '2023-11-01T00:00:00Z'
  for name in (plot.TRACK_MAP, plot.FLIGHT_TIME, 'tracks.kml',
               'tracks.geojson', 'tracks.csv'):
    assert (tmp_path / 'ops/plots' / name).is_file(), name
  assert (tmp_path / 'ops/launch/launches.json').is_file()
  import re  # pylint: disable=g-import-not-at-top
  assert re.search(r'best launch: \d+\.\d{4} N \d+\.\d{4} W .* '
                   r'2010-10-26T1\d:00:00Z', capsys.readouterr().out)
