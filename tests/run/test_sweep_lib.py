"""ble_latex.run.sweep_lib: a sweep's grid and seeds, checked before any run."""

import pytest

from ble_latex import errors

from tests import helpers


@pytest.mark.parametrize('text', ['a.b=1e39', 'a.b=1,-1e39'])
def test_sweep_grid_beyond_float32_is_refused(text):
  from ble_latex.run import sweep_lib  # pylint: disable=g-import-not-at-top
  with pytest.raises(sweep_lib.SpaceError, match='float32'):
    sweep_lib.parse_grid_flag(text)
  with pytest.raises(sweep_lib.SpaceError, match='float32'):
    sweep_lib.parse_space({'bindings': {'a.b': {'uniform': [0, 1e39]}}},
                          'space.json')


def test_sweep_refuses_seeds_beyond_2_32(tmp_path, capsys):
  from ble_latex.cli import sweep  # pylint: disable=g-import-not-at-top
  from ble_latex.run import sweep_lib  # pylint: disable=g-import-not-at-top
  rc = sweep.main([f'--sweep_dir={tmp_path / "s"}', '--grid=sac_trainer_config.gamma=0.9',
                   '--seeds=1,99999999999999999999', '--num_iterations=5'])
  assert rc == 2
  assert '[0, 4294967295]' in helpers.one_line(capsys, 'ble-latex-sweep')
  assert not (tmp_path / 's').exists()
  space = sweep_lib.merge(None, [sweep_lib.parse_grid_flag(
      'sac_trainer_config.gamma=0.9')], None)
  settings = sweep_lib.SweepSettings(
      sweep_dir=str(tmp_path / 's'), points=tuple(sweep_lib.points(space)),
      seeds=(2**32,), num_iterations=5, policy_snapshot_period=5,
      validation_episodes=1, gin_files=(), gin_bindings=(),
      asha_grace_period=None, cpus_per_trial=1.0)
  with pytest.raises(errors.ConfigError, match='training seed'):
    sweep_lib.check_points(settings)
