# coding=utf-8
"""Winds compared on real bytes (issue 45 item 7) and the real-winds records.

`ble_latex.wind.stats` on the committed slices of tests/data/realwinds/ (a
GFS NetCDF subset, two University of Wyoming soundings), `ble-latex-plot
--wind_stats --wind_file` on a sounding, `benchmarks/real_winds.py`'s
refusals and the tables `docs/hooks/tables.py` makes of the two records.
No network, no VAE decoding (the VAE side is in tests/wind/test_stats.py).
"""

import importlib
import json

import numpy as np
import pytest

from ble_latex.cli import plot
from ble_latex.plots import figures
from ble_latex.run import real_cells
from ble_latex.wind import analysis
from ble_latex.wind import stats

from tests import helpers

ROOT = helpers.ROOT
DATA = helpers.REAL_WINDS
GFS = str(DATA / 'gfs_2010-10-26T12Z_uv_10-300hPa_1deg_subset.nc')
BOISE = str(DATA / 'BOI-Boise_2010-12-09T12Z_uwyo.txt')
HILO = str(DATA / 'PHTO-Hilo_2023-11-01T00Z_uwyo.csv')


def samples(u, v, pressures=(5000.0, 7000.0, 10000.0), label='x'):
  return stats.WindSamples(label, np.array(pressures), np.array(u, float),
                           np.array(v, float))


def test_height_of_pressure_inverts_the_standard_atmosphere():
  heights = np.array([0.0, 5_000.0, 11_000.0, 15_000.0, 20_000.0, 25_000.0,
                      31_000.0])
  pressures = [analysis.pressure_of_height(h) for h in heights]
  np.testing.assert_allclose(stats.height_of_pressure(pressures), heights,
                             atol=1e-3)
  np.testing.assert_allclose(stats.height_of_pressure(stats.FLIGHT_BAND_PA),
                             [25_000.0, 15_000.0], atol=1e-3)
  # 50 hPa is ~20.6 km (US Standard Atmosphere 1976 tables: 20 576 m).
  assert stats.height_of_pressure(5000.0) == pytest.approx(20_576.0, abs=2.0)


def test_apart_fractions_hand_example():
  # Column 0: east, west (180 deg). Column 1: east, north (90 deg exactly).
  # Column 2: east, north-west (135 deg). Column 3: all east.
  # Column 4: a calm level has no direction.
  u = [[1, -2, 1], [1, 0, 1], [1, -1, 1], [1, 2, 3], [0, 1, 1]]
  v = [[0, 0, 0], [0, 3, 0], [0, 1, 0], [0, 0, 0], [0, 0, 0]]
  result = stats.apart_fractions(samples(u, v))
  assert result == {'ge90': pytest.approx(3 / 5),
                    'ge135': pytest.approx(2 / 5)}


def test_shear_hand_example():
  pressures = (5000.0, 10000.0)
  dz_km = float(np.diff(-stats.height_of_pressure(pressures))[0]) / 1000.0
  result = stats.shear(samples([[0.0, 3.0], [0.0, 0.0]],
                               [[0.0, 4.0], [0.0, 0.0]], pressures))
  assert result['shear_mps_per_km']['p95'] == pytest.approx(
      0.95 * 5.0 / dz_km)
  assert result['shear_mps_per_km']['mean'] == pytest.approx(2.5 / dz_km)
  assert result['spread_mps']['mean'] == pytest.approx(2.5)


def test_a_sounding_is_one_column_and_says_so():
  column = stats.sample_era5(BOISE, band=stats.FLIGHT_BAND_PA,
                             num_samples=500)
  assert column.single_column and column.u.shape == (1, column.u.shape[1])
  # Its levels in 15-25 km, its own winds (the file's 50 hPa row: from 345
  # deg at 9 knots).
  assert np.all((column.pressures_pa >= stats.FLIGHT_BAND_PA[0]) &
                (column.pressures_pa <= stats.FLIGHT_BAND_PA[1]))
  at_50 = list(column.pressures_pa).index(5000.0)
  speed = 9 * 1852.0 / 3600.0
  np.testing.assert_allclose(
      [column.u[0, at_50], column.v[0, at_50]],
      [-speed * np.sin(np.deg2rad(345.0)), -speed * np.cos(np.deg2rad(345.0))])
  profile = stats.profile(column)
  assert profile['single_column'] and profile['columns'] == 1
  assert 'single sample' in profile['note']
  assert set(profile['apart'].values()) <= {0.0, 1.0}
  # Every quantile of one sample is that sample.
  level = profile['speed_mps'][0]
  assert level['p5'] == level['p50'] == level['p95'] == level['mean']
  assert 14_900.0 < min(profile['heights_m']) and max(
      profile['heights_m']) < 25_100.0


def test_a_gfs_grid_sampled_over_its_domain():
  a = stats.sample_era5(GFS, band=stats.FLIGHT_BAND_PA, num_samples=300,
                        seed=1, region='domain')
  b = stats.sample_era5(GFS, band=stats.FLIGHT_BAND_PA, num_samples=300,
                        seed=1, region='domain')
  c = stats.sample_era5(GFS, band=stats.FLIGHT_BAND_PA, num_samples=300,
                        seed=2, region='domain')
  np.testing.assert_array_equal(a.pressures_pa, [3000.0, 5000.0, 7000.0,
                                                 10000.0])
  np.testing.assert_array_equal(a.u, b.u)
  assert not np.array_equal(a.u, c.u) and not a.single_column
  profile = stats.profile(a)
  assert profile['columns'] == 300 and 'note' not in profile
  assert 0.0 <= profile['apart']['ge135'] <= profile['apart']['ge90'] <= 1.0
  # The domain's winds (not clamped to one edge): they vary.
  assert np.std(a.u[:, 1]) > 1.0
  with pytest.raises(ValueError, match='region must be one of'):
    stats.sample_era5(GFS, num_samples=3, region='nowhere')
  with pytest.raises(ValueError, match=r'1 level\(s\) in .* a profile needs '
                     '2 or more'):
    stats.profile(samples([[1.0, 2.0, 3.0]], [[0.0] * 3],
                          (5000.0, 20000.0, 30000.0)))


def test_plot_wind_stats_takes_a_sounding(tmp_path, capsys):
  out = tmp_path / 'plots'
  assert plot.main([f'--output_dir={out}', '--wind_stats',
                    f'--wind_file={HILO}', f'--wind_stats_against={GFS}',
                    '--wind_stats_samples=40',
                    '--wind_stats_pressures_pa=5000,7000,10000']) == 0
  captured = capsys.readouterr()
  assert 'one column (a sounding): a single sample' in captured.err
  result = json.loads((out / plot.WIND_STATS_JSON).read_text())
  assert result['samples'] == {'a': 40, 'b': 1}
  assert 'single sample' in result['note']
  profiles = result['profiles']
  assert profiles['b']['single_column'] and profiles['b']['columns'] == 1
  assert profiles['a']['columns'] == 40
  assert profiles['a']['pressures_pa'] == [3000.0, 5000.0, 7000.0, 10000.0]
  assert (out / plot.WIND_STATS).stat().st_size > 0
  assert result['pressures_pa'] == [5000.0, 7000.0, 10000.0]
  # --era5_path stays an alias; the wind file is required.
  assert plot.main([f'--output_dir={out}', '--wind_stats']) == 2
  assert '--wind_stats needs --wind_file' in capsys.readouterr().err
  missing = tmp_path / 'missing.nc'
  assert plot.main([f'--output_dir={out}', '--wind_stats',
                    f'--era5_path={missing}']) == 1
  assert str(missing) in capsys.readouterr().err


def test_wind_compare_figure(tmp_path):
  grid = stats.profile(stats.sample_era5(GFS, band=stats.FLIGHT_BAND_PA,
                                         num_samples=50, region='domain'))
  column = stats.profile(stats.sample_era5(HILO, band=stats.FLIGHT_BAND_PA,
                                           num_samples=1))
  fig = figures.plot_wind_compare([grid, column], str(tmp_path / 'w.png'))
  assert (tmp_path / 'w.png').stat().st_size > 0
  titles = [ax.get_title() for ax in fig.axes]
  assert titles[1] == 'two levels >= 90 deg (dark) / >= 135 deg apart'
  legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
  assert legend[1].endswith('(one column)') and '50 columns' in legend[0]


def test_real_winds_refuses_bad_flags_in_one_line(tmp_path, capsys,
                                                  benchmark_script):
  real_winds = benchmark_script('real_winds.py')
  record = tmp_path / 'r.json'
  for argv, message in (
      (['--sources=nowhere'], "--sources: unknown ['nowhere']"),
      (['--agents=sac'], "--agents: unknown ['sac']"),
      (['--seeds=boise:x'], "--seeds: 'boise:x' is not N or SOURCE:N"),
      (['--seeds=mars:3'], "--seeds: 'mars' is not among --sources"),
      (['--station_mode=per_seed'], "--station_mode=per_seed is for GFS "
       "grids: ['boise', 'hilo'] are soundings"),
      (['--station_bindings=x=1'], '--station_bindings needs '
       '--station_mode=per_seed')):
    assert real_winds.main([f'--json={record}', *argv]) == 2, argv
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
  assert not record.exists()
  assert real_cells.seeds_per_source(['7', 'hilo:3'], ['boise', 'hilo']) == {
      'boise': 7, 'hilo': 3}
  assert real_cells.seeds_per_source([], ['boise']) == {
      'boise': real_cells.DEFAULT_SEEDS}
  with pytest.raises(ValueError, match="'hilo:0': N must be >= 1"):
    real_cells.seeds_per_source(['hilo:0'], ['hilo'])


def _tables(monkeypatch):
  """docs/hooks/tables.py, imported as MkDocs runs it (its folder on
  sys.path: it imports `learned.py` beside it)."""
  monkeypatch.syspath_prepend(str(ROOT / 'docs' / 'hooks'))
  return importlib.import_module('tables')


def test_tables_render_the_real_winds_record(tmp_path, monkeypatch):
  tables = _tables(monkeypatch)
  flights = [{'seed': s, 'tw50': 0.5, 'tw50_window': w, 'final_distance_km':
              10.0 * s, 'terminal_reason': r}
             for s, w, r in ((1, 0.25, 'ok'), (2, 0.75, 'out_of_sand'))]
  record = {'cells': {'hilo/sac_pretrained/center': {
      'settings': {'source': 'hilo', 'agent': 'sac_pretrained',
                   'station_mode': 'center', 'station_lat_lon': [19.72,
                                                                 -155.07],
                   'noise_scale': 2.3923},
      'summary': {'episodes': 2, 'tw50_window_mean': 0.5,
                  'tw50_window_std': 0.25, 'tw50_mean': 0.5, 'tw50_std': 0.0,
                  'out_of_resources_pct': 50.0},
      'flights': flights}}}
  path = tmp_path / 'real_winds.json'
  path.write_text(json.dumps(record), encoding='utf-8')
  monkeypatch.setattr(tables, 'REAL_WINDS', path)
  short = tables.real_winds_short().splitlines()
  assert short[0] == '| agent | sounding Hilo |'
  assert short[2] == '| `sac_pretrained` | 50.0 % (2 seeds) |'
  full = tables.real_winds_full().splitlines()
  assert full[2] == ('| `sac_pretrained` | sounding Hilo | site 19.72°, '
                     '-155.07° | 2 | 50.0 % ± 25.0 | 50.0 % ± 0.0 | 50 % '
                     '| 0 % | 15 |')
  # A cell flown before the noise scale was recorded is marked † (issue 64).
  del record['cells']['hilo/sac_pretrained/center']['settings']['noise_scale']
  path.write_text(json.dumps(record), encoding='utf-8')
  assert tables.real_winds_short().splitlines()[2] == (
      '| `sac_pretrained` | 50.0 % (2 seeds †) |')


def test_tables_render_the_committed_records(monkeypatch):
  tables = _tables(monkeypatch)
  if tables.REAL_WINDS.exists():
    rows = tables.real_winds_full().splitlines()[2:]
    assert rows and all('|' in r for r in rows)
  wind = tables.wind_compare().splitlines()
  assert wind[2].startswith("| BLE's VAE forecast |")
  assert any('1 (a single sample)' in row for row in wind[3:])
  assert len(wind) == 2 + len(json.loads(
      tables.WIND_COMPARE.read_text(encoding='utf-8'))['sources'])
