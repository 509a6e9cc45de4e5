# coding=utf-8
"""Station-keeping feasibility (`wind.feasibility`, `plots.feasibility`)."""

import json
import math
import os

from hypothesis import given, settings
from hypothesis import strategies as st
import numpy as np
import pytest

from ble_latex import errors
from ble_latex.wind import feasibility
from ble_latex.wind import gridded

from tests import helpers

DATA = helpers.REAL_WINDS
HILO = DATA / 'PHTO-Hilo_2023-11-01T00Z_uwyo.csv'
BOISE = DATA / 'BOI-Boise_2010-12-09T12Z_uwyo.txt'
GRIB = DATA / 'gfs_2011-10-11T00Z_uv_10-250hPa_2p5deg.grib2'


def test_opposing_winds_hold_zero_inside():
  # An equilateral triangle around zero, inradius 1 m/s.
  col = feasibility.column([[2.0, 0.0], [-1.0, math.sqrt(3.0)],
                            [-1.0, -math.sqrt(3.0)]])
  assert col.inside
  assert col.margin_mps == pytest.approx(1.0)
  assert col.gap_deg == pytest.approx(120.0)


def test_winds_in_one_half_plane_leave_zero_outside():
  col = feasibility.column([[5.0, 1.0], [4.0, 6.0], [7.0, -2.0]])
  assert not col.inside
  # Nearest point of the hull: on the edge (4, 6)-(5, 1) or at a vertex.
  a, b = np.array([4.0, 6.0]), np.array([5.0, 1.0])
  s = -a @ (b - a) / ((b - a) @ (b - a))
  expected = np.hypot(*(a + np.clip(s, 0, 1) * (b - a)))
  assert col.margin_mps == pytest.approx(-expected)
  assert col.gap_deg > 180.0


def test_degenerate_hulls():
  # Winds on one line through zero: zero on the segment (margin 0).
  assert feasibility.hull_margin([[3.0, 0.0], [-2.0, 0.0]]) == pytest.approx(
      0.0, abs=1e-12)
  # One line missing zero, one wind: the distance, negative.
  assert feasibility.hull_margin([[3.0, 4.0], [6.0, 8.0]]) == pytest.approx(
      -5.0)
  assert feasibility.hull_margin([[0.0, -2.0]]) == pytest.approx(-2.0)
  assert feasibility.largest_gap_deg([[1.0, 1.0]]) == 360.0


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(-40, 40), st.floats(-40, 40)),
                min_size=3, max_size=12),
       st.floats(0.05, 20.0), st.floats(-math.pi, math.pi))
def test_scaling_and_rotating_keep_feasibility(points, scale, angle):
  uv = np.asarray(points)
  base = feasibility.hull_margin(uv)
  rotation = np.array([[math.cos(angle), -math.sin(angle)],
                       [math.sin(angle), math.cos(angle)]])
  moved = feasibility.hull_margin(scale * uv @ rotation.T)
  # The margin scales with the winds; its sign (feasibility) is kept.
  assert moved == pytest.approx(scale * base, abs=1e-6 * (1 + scale) * 40)
  if abs(base) > 1e-6:
    assert (moved >= 0) == (base >= 0)


def test_band_winds_add_the_band_ends():
  height = np.array([10_000.0, 15_000.0, 20_000.0, 25_000.0])
  uv = np.array([[0.0, 0.0], [10.0, 0.0], [-10.0, 0.0], [0.0, 10.0]])
  winds = feasibility.band_winds(height, uv, (13_000.0, 22_000.0))
  np.testing.assert_allclose(winds, [[6.0, 0.0], [10.0, 0.0], [-10.0, 0.0],
                                     [-6.0, 4.0]])
  # Above the column's top the top's wind is held.
  held = feasibility.band_winds(height[:3], uv[:3], (13_000.0, 22_000.0))
  np.testing.assert_allclose(held[-1], [-10.0, 0.0])


def test_soundings_hilo_inside_boise_outside():
  hilo = feasibility.sounding_column(str(HILO)).column
  boise = feasibility.sounding_column(str(BOISE)).column
  assert hilo.inside and hilo.margin_mps > 1.0 and hilo.gap_deg < 90.0
  assert not boise.inside and boise.margin_mps < -3.0


def test_grid_map_and_point_agree_on_nodes():
  data = gridded.load(str(GRIB))
  fmap = feasibility.grid_map(data)
  assert fmap.margin_mps.shape == (data.latitude.size,
                                   data.longitude.size -
                                   int(data.global_longitude))
  assert 0.0 < fmap.inside.mean() < 1.0
  # The map's batched margins (no Qhull outside) are `column`'s.
  band = feasibility.pressure_band()
  for i in range(0, fmap.latitude.size, 6):
    for j in range(0, fmap.longitude.size, 11):
      col = feasibility.column(feasibility.band_winds(
          data.pressure, data.uv[0, :, i, j], band))
      assert (fmap.margin_mps[i, j], fmap.gap_deg[i, j],
              fmap.weakest_mps[i, j]) == pytest.approx(
                  (col.margin_mps, col.gap_deg, col.weakest_mps), abs=1e-9)
  i, j = 5, 7
  col, _ = feasibility.at(data, fmap.latitude[i], fmap.longitude[j])
  assert col.margin_mps == pytest.approx(fmap.margin_mps[i, j], abs=1e-6)
  with pytest.raises(errors.ConfigError, match='time index 3'):
    feasibility.grid_map(data, time_index=3)


def test_plot_command_writes_map_json_and_hodographs(tmp_path):
  from ble_latex.cli import plot  # pylint: disable=g-import-not-at-top
  out = tmp_path / 'out'
  assert plot.main(['--feasibility', f'--wind_file={GRIB}',
                    '--feasibility_sites=20:-155', f'--output_dir={out}']) == 0
  record = json.loads((out / 'feasibility.json').read_text())
  assert record['summary']['columns'] == len(record['latitude']) * len(
      record['longitude'])
  assert record['sites'][0]['lat'] == 20.0
  assert sorted(os.listdir(out)) == ['feasibility.json', 'feasibility_map.png',
                                     'hodograph_+20.00_-155.00.png']
  assert plot.main(['--feasibility', f'--wind_file={HILO}',
                    f'--output_dir={out}']) == 0
  assert json.loads((out / 'feasibility.json').read_text())['column'][
      'inside']


def test_plot_command_usage_errors(tmp_path, capsys):
  from ble_latex.cli import plot  # pylint: disable=g-import-not-at-top
  assert plot.main(['--feasibility',
                    '--output_dir=/tmp/x']) == 2
  assert '--feasibility needs --wind_file' in capsys.readouterr().err
  assert plot.main(['--feasibility', f'--wind_file={GRIB}',
                    '--feasibility_sites=20', '--output_dir=/tmp/x']) == 2
  assert 'LAT:LON' in capsys.readouterr().err
  out = tmp_path / 'outside'
  assert plot.main(['--feasibility', f'--wind_file={GRIB}',
                    '--feasibility_sites=95:0', f'--output_dir={out}']) == 2
  assert 'outside' in capsys.readouterr().err
  assert not out.exists() or not os.listdir(out)  # Nothing written.


def test_launch_keeps_feasible_stations_only():
  from ble_latex.launch import sites  # pylint: disable=g-import-not-at-top
  data = gridded.load(str(GRIB))
  fmap = feasibility.grid_map(data)
  i_in, j_in = np.argwhere(fmap.margin_mps > 0.5)[0]
  i_out, j_out = np.argwhere(fmap.margin_mps < -5.0)[0]
  found = sites.feasible_stations(str(GRIB), [
      (fmap.latitude[i_in], fmap.longitude[j_in]),
      (fmap.latitude[i_out], fmap.longitude[j_out])])
  assert [s['keep'] for s in found] == [True, False]
  assert found[1]['margin_mps'] < -5.0
  # A larger margin asked for drops the first too.
  strict = sites.feasible_stations(str(GRIB), [
      (fmap.latitude[i_in], fmap.longitude[j_in])],
                                   min_margin_mps=fmap.margin_mps[i_in, j_in]
                                   + 0.1)
  assert not strict[0]['keep']


@pytest.mark.slow  # ~12 s: the command's agent check imports TensorFlow.
def test_launch_command_skips_a_hopeless_station(tmp_path, capsys):
  from ble_latex.cli import launch  # pylint: disable=g-import-not-at-top
  out = tmp_path / 'launch'
  # Boise's column: zero 3.5 m/s outside; nothing is flown or written.
  assert launch.main([f'--wind_file={BOISE}', '--min_hull_margin_mps=0',
                      '--station_lat=43.56', '--station_lon=-116.21',
                      f'--output_dir={out}']) == 0
  said = capsys.readouterr().out
  assert 'skipped: zero lies outside the hull' in said and '3.54' in said
  assert not (out / 'launches.json').exists()
  assert launch.main(['--min_hull_margin_mps=0',
                      f'--output_dir={out}']) == 2
  assert 'need --wind_file' in capsys.readouterr().err
