# coding=utf-8
"""benchmarks/real_winds_paths.py: flight paths over a real GFS domain.

Its command line on the committed GFS slice (tests/data/realwinds/, as the
gfs_namerica file of a --realdata_dir), one seed of latex_station_seeker for
a few strides (slow: it compiles): it writes the PNG and the JSON record,
whose flight has its station inside the file's domain, TW50s in [0, 1] and
the strides asked for. And (fast) the package's conversions it draws with
(`tracks.path_lat_lon`, `tracks.circle_lat_lon`): the track's from the
station's frame to lat/lon and the station-keeping circle.
"""

import json
import os

import numpy as np
import pytest

from ble_latex.run import tracks
from ble_latex.wind import gridded
from ble_latex.wind import sources

from tests import helpers

GFS_NC = os.path.join(helpers.REAL_WINDS, 'gfs_2010-10-26T12Z_uv_10-300hPa_1deg_subset.nc')
_STEPS = 3


# Slow: ~40-60 s on the 2-core build box, almost all compiling (37 compiles,
# 44 s: the batched eval's reset and step, the stations' draw).
@pytest.mark.slow
def test_run_writes_the_figure_and_the_record(benchmark_script, tmp_path,
                                              capsys):
  realdata = tmp_path / 'realdata'
  copy = realdata / sources.SOURCES['gfs_namerica'].file
  copy.parent.mkdir(parents=True)
  copy.symlink_to(GFS_NC)
  png, record_path = tmp_path / 'paths.png', tmp_path / 'paths.json'
  assert benchmark_script('real_winds_paths.py').main([
      '--source=gfs_namerica', f'--realdata_dir={realdata}',
      '--agents=latex_station_seeker', '--seeds=1', '--suite=latex_small',
      f'--png={png}', f'--json={record_path}',
      f'--max_episode_length={_STEPS}']) == 0
  [printed] = capsys.readouterr().out.splitlines()
  assert json.loads(printed)['agent'] == 'latex_station_seeker'
  with open(png, 'rb') as f:
    assert f.read(8) == b'\x89PNG\r\n\x1a\n'
  with open(record_path, encoding='utf-8') as f:
    record = json.load(f)
  for key in ('command', 'date_utc', 'host', 'cpus', 'loadavg_before',
              'loadavg_after', 'git_head', 'runs', 'flights'):
    assert key in record, key
  assert record['wind_source'] == 'analysis (time-invariant)'
  assert record['station_bindings'] == ["GriddedWindField.stations = 'per_seed'"]
  assert record['radius_km'] == 50.0
  [flight] = record['flights']
  assert flight['agent'] == 'latex_station_seeker'
  assert flight['steps'] == _STEPS
  assert 0.0 <= flight['tw50_window'] <= 1.0
  assert 0.0 <= flight['tw50'] <= 1.0
  data = gridded.load(GFS_NC)
  assert data.covers(flight['station_lat'], flight['station_lon'])
  assert np.isfinite(flight['final_distance_km'])


def test_track_is_the_station_frame_offset_in_lat_lon():
  # 0 km: the station; 1 deg of meridian north (R = 6371 km); east on the
  # equator: 1 deg of longitude.
  path = [{'x_km': 0.0, 'y_km': 0.0}, {'x_km': 0.0, 'y_km': 111.19},
          {'x_km': 111.19, 'y_km': 0.0}]
  lats, lons = tracks.path_lat_lon(0.0, -100.0, path)
  np.testing.assert_allclose(lats, [0.0, 1.0, 0.0], atol=1e-3)
  np.testing.assert_allclose(lons, [-100.0, -100.0, -99.0], atol=1e-3)
  # Across the antimeridian: longitudes stay in -180..180.
  _, lons = tracks.path_lat_lon(0.0, 179.5, path)
  np.testing.assert_allclose(lons, [179.5, 179.5, -179.5], atol=1e-3)


def test_circle_is_the_radius_around_the_station_clockwise_from_north():
  lats, lons = tracks.circle_lat_lon(0.0, -100.0, 111.19, points=5)
  # North, east, south, west, north again: 1 deg each way on the equator.
  np.testing.assert_allclose(lats, [1.0, 0.0, -1.0, 0.0, 1.0], atol=1e-3)
  np.testing.assert_allclose(lons, [-100.0, -99.0, -100.0, -101.0, -100.0],
                             atol=1e-3)
  lats, _ = tracks.circle_lat_lon(45.0, 10.0, 50.0)
  assert len(lats) == 73
