"""`ble-latex-launch` (ble_latex.cli.launch): refusals in one line before
any work, one writer per output folder."""

import pytest

from tests import helpers


# -- Items 9, 14 and the lock: ble-latex-launch. ----------------------------
@pytest.mark.parametrize('argv, needle', [
    (['--grid=100000,100000,100'], 'balloons, more than'),
    (['--grid=2000,2000,1', '--draws=2'], 'balloons, more than'),
])
def test_launch_grid_too_big_is_refused_before_allocation(argv, needle,
                                                           tmp_path, capsys):
  from ble_latex.cli import launch  # pylint: disable=g-import-not-at-top
  assert launch.main([f'--output_dir={tmp_path / "o"}', *argv]) == 2
  assert needle in helpers.one_line(capsys, 'ble-latex-launch')


def test_launch_date_at_the_end_of_time_is_one_line(tmp_path, capsys):
  from tests.wind import test_gridded  # pylint: disable=g-import-not-at-top
  from ble_latex.cli import launch  # pylint: disable=g-import-not-at-top
  path = test_gridded.write_era5(tmp_path / 'era5.nc')
  assert launch.main([f'--output_dir={tmp_path / "o"}', f'--wind_file={path}',
                      '--date=9999-12-31T23:59', '--grid=1,1,1',
                      '--max_steps=1', '--draws=1']) == 2
  assert 'year 9999' in helpers.one_line(capsys, 'ble-latex-launch')


def test_launch_has_one_writer_per_output_dir(tmp_path, capsys):
  from ble_latex import safe_io  # pylint: disable=g-import-not-at-top
  from ble_latex.cli import launch  # pylint: disable=g-import-not-at-top
  out = tmp_path / 'o'
  with safe_io.locked_dir(str(out), what='launch output folder'):
    assert launch.main([f'--output_dir={out}', '--grid=1,1,1',
                        '--max_steps=1', '--draws=1']) == 1
  assert 'in use by' in helpers.one_line(capsys, 'ble-latex-launch')
  assert not (out / 'launches.json').exists()


def test_launch_refuses_a_sounding_in_pa_in_one_line(tmp_path, capsys):
  from ble_latex.cli import launch  # pylint: disable=g-import-not-at-top
  from tests.wind.test_sounding import _hilo_scaled  # pylint: disable=g-import-not-at-top
  path = _hilo_scaled(tmp_path, 100.0)
  assert launch.main([f'--output_dir={tmp_path / "o"}', f'--wind_file={path}',
                      '--grid=1,1,1', '--max_steps=1', '--draws=1']) == 1
  line = helpers.one_line(capsys, 'ble-latex-launch')
  assert path in line and 'PRES must be in hPa' in line


def test_launch_ascent_rates_are_positive_in_float32(tmp_path, capsys):
  from ble_latex.cli import launch  # pylint: disable=g-import-not-at-top
  from ble_latex.launch import ascent  # pylint: disable=g-import-not-at-top
  with pytest.raises(ValueError, match='float32'):
    ascent.Ascent(ascent_rate_mps=1e-40)
  assert launch.main([f'--output_dir={tmp_path / "o"}', '--from_ground',
                      '--descent_rate_mps=1e-45', '--grid=1,1,1']) == 2
  assert '--from_ground: ascent descent_rate_mps' in helpers.one_line(
      capsys, 'ble-latex-launch')
