# coding=utf-8
"""Tests of the wind-source comparison (`ble_latex.wind.stats`).

ERA5 sources are the synthetic files of tests/wind/test_gridded.py; the VAE source
decodes a few forecast keys only. No network.
"""

import jax
import numpy as np
import pytest

from ble_latex import errors
from ble_latex.wind import stats
from tests.wind import test_gridded  # pylint: disable=g-bad-import-order
from tests import helpers


@pytest.fixture(name='era5_file', scope='module')
def fixture_era5_file(tmp_path_factory):
  return test_gridded.write_era5(tmp_path_factory.mktemp('stats') / 'era5.nc')


def samples(u, v, pressures=(5000.0, 7000.0, 10000.0), label='x'):
  return stats.WindSamples(label, np.array(pressures), np.array(u, float),
                           np.array(v, float))


def test_era5_file_against_itself_is_at_distance_zero(era5_file):
  a = stats.sample_era5(era5_file, num_samples=200, seed=3)
  b = stats.sample_era5(era5_file, num_samples=200, seed=3)
  np.testing.assert_array_equal(a.pressures_pa, [5000.0, 10000.0])
  np.testing.assert_array_equal(a.u, b.u)
  result = stats.compare(a, b)
  assert result['wasserstein_u_mps'] == 0.0
  assert result['wasserstein_v_mps'] == 0.0
  for level in result['per_level']:
    assert level['wasserstein_u_mps'] == level['wasserstein_v_mps'] == 0.0
  diversity = result['direction_diversity']
  assert diversity['a'] == diversity['b']


def test_era5_samples_depend_on_the_seed(era5_file):
  a = stats.sample_era5(era5_file, num_samples=50, seed=1)
  c = stats.sample_era5(era5_file, num_samples=50, seed=2)
  assert a.u.shape == c.u.shape == (50, 2)
  assert not np.array_equal(a.u, c.u)


@pytest.mark.parametrize('shift', [3.0, -1.5])
def test_shifted_copy_is_at_the_shift(era5_file, tmp_path, shift):

  def edit(dataset):
    dataset['u'].values[...] += shift

  shifted = test_gridded.rewrite(era5_file, tmp_path / 'shifted.nc', edit)
  a = stats.sample_era5(era5_file, num_samples=300, seed=0)
  b = stats.sample_era5(shifted, num_samples=300, seed=0)
  result = stats.compare(a, b)
  assert result['wasserstein_u_mps'] == pytest.approx(abs(shift), abs=1e-9)
  assert result['wasserstein_v_mps'] == pytest.approx(0.0, abs=1e-12)
  for level in result['per_level']:
    assert level['wasserstein_u_mps'] == pytest.approx(abs(shift), abs=1e-9)
    assert level['u_mps']['b']['mean'] - level['u_mps']['a']['mean'] == (
        pytest.approx(shift))


def test_direction_diversity_hand_example():
  # Column 0: all east. Column 1: east, west, east (levels 0-1 and 1-2
  # oppose). Column 2: north, east (90 deg: not opposing), south.
  u = [[1, 2, 3], [1, -1, 1], [0, 1, 0]]
  v = [[0, 0, 0], [0, 0, 0], [1, 0, -1]]
  d = stats.direction_diversity(samples(u, v))
  assert d['opposing_any_fraction'] == pytest.approx(2 / 3)
  assert d['opposing_pair_fraction'] == pytest.approx(3 / 9)
  assert d['opposing_by_level'] == pytest.approx([2 / 3, 1 / 3, 2 / 3])
  np.testing.assert_allclose(d['pairs'], [[0, 1 / 3, 1 / 3], [1 / 3, 0, 1 / 3],
                                          [1 / 3, 1 / 3, 0]])


def test_wasserstein_hand_example():
  a = samples([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]], [[0.0] * 3] * 2, label='a')
  b = samples([[0.0, 2.0, 0.0], [1.0, 3.0, 1.0]], [[0.0] * 3] * 2, label='b')
  result = stats.compare(a, b)
  assert [r['wasserstein_u_mps'] for r in result['per_level']] == [0, 2, 0]
  assert result['sources'] == {'a': 'a', 'b': 'b'}


def test_vae_samples_are_deterministic_in_the_key():
  pressures = [5000.0, 7000.0, 10000.0, 12500.0]
  a = stats.sample_vae(jax.random.PRNGKey(0), pressures, num_fields=2,
                       points_per_field=3)
  b = stats.sample_vae(jax.random.PRNGKey(0), pressures, num_fields=2,
                       points_per_field=3)
  c = stats.sample_vae(jax.random.PRNGKey(1), pressures, num_fields=2,
                       points_per_field=3)
  assert a.u.shape == a.v.shape == (6, 4) and a.label == 'VAE'
  np.testing.assert_array_equal(a.u, b.u)
  np.testing.assert_array_equal(a.v, b.v)
  assert not np.array_equal(a.u, c.u)
  assert np.all(np.abs(a.u) < 100.0) and np.all(np.abs(a.v) < 100.0)


def test_bad_inputs_are_errors_naming_them(era5_file, tmp_path):
  few = test_gridded.write_era5(tmp_path / 'few.nc',
                                levels_hpa=np.array([20.0, 50.0, 175.0]))
  with pytest.raises(ValueError, match=r'hold 1 pressure level\(s\) in '
                     r'5000..14000 Pa .* the comparison needs 2 or more'):
    stats.sample_era5(few, num_samples=5)
  small = test_gridded.write_era5(tmp_path / 'small.nc',
                                  lat=np.array([2.0, 1.0, 0.0]))
  with pytest.raises(ValueError, match='too small for samples up to 200 km '
                     'from its centre'):
    stats.sample_era5(small, num_samples=5)
  nan = test_gridded.write_era5(tmp_path / 'nan.nc', nan=True)
  with pytest.raises(ValueError, match='has NaN/inf winds'):
    stats.sample_era5(nan, num_samples=5)
  with pytest.raises(FileNotFoundError, match='does not exist'):
    stats.sample_era5(str(tmp_path / 'missing.nc'), num_samples=5)
  a = stats.sample_era5(era5_file, num_samples=5)
  b = stats.sample_era5(era5_file, [5000.0, 7000.0], num_samples=5)
  with pytest.raises(ValueError, match='sampled at different pressure levels'):
    stats.compare(a, b)
  with pytest.raises(ValueError, match='non-finite winds'):
    samples([[np.nan] * 3], [[0.0] * 3])


# -- Item 7: levels outside a wind source are refused, not clamped. ---------
def test_wind_stats_levels_outside_the_file_are_refused(tmp_path, capsys):
  from tests.wind import test_gridded  # pylint: disable=g-import-not-at-top
  import jax  # pylint: disable=g-import-not-at-top
  from ble_latex.cli import plot  # pylint: disable=g-import-not-at-top
  from ble_latex.wind import stats  # pylint: disable=g-import-not-at-top
  era5_file = test_gridded.write_era5(tmp_path / 'era5.nc')  # 5000..10000 Pa.
  for levels in ([1.0, 2.0], [5000.0, 20000.0], [float('nan'), 5000.0]):
    with pytest.raises(errors.ConfigError, match='outside ERA5 file'):
      stats.sample_era5(era5_file, levels, num_samples=5)
  with pytest.raises(errors.ConfigError, match="outside the VAE"):
    stats.sample_vae(jax.random.PRNGKey(0), [1.0, 5000.0], num_fields=1,
                     points_per_field=1)
  out = tmp_path / 'plots'
  for against in ([], [f'--wind_stats_against={era5_file}']):
    assert plot.main([f'--output_dir={out}', '--wind_stats',
                      f'--era5_path={era5_file}',
                      '--wind_stats_pressures_pa=1,2', *against]) == 2
    assert 'pressure levels [1.0, 2.0] Pa are outside' in helpers.one_line(
        capsys, 'ble-latex-plot')
  assert not out.exists() or not list(out.iterdir())


# -- Item 17: wind statistics' sample counts are bounded. -------------------
@pytest.mark.parametrize('flag', ['--wind_stats_samples=2000000000',
                                  '--wind_stats_fields=100000',
                                  ])
def test_wind_stats_sample_counts_are_bounded(flag, tmp_path, capsys):
  from tests.wind import test_gridded  # pylint: disable=g-import-not-at-top
  from ble_latex.cli import plot  # pylint: disable=g-import-not-at-top
  era5_file = test_gridded.write_era5(tmp_path / 'era5.nc')
  out = tmp_path / 'plots'
  assert plot.main([f'--output_dir={out}', '--wind_stats',
                    f'--era5_path={era5_file}', '--wind_stats_points=1000',
                    flag]) == 2
  assert flag.split('=')[0] in helpers.one_line(capsys, 'ble-latex-plot')
