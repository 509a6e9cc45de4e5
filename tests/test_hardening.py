"""Issue 48 (hardening, third round): each refusal is one line at the one
place every entry point goes through; each test fails without its fix."""

import os
import pathlib

from absl import flags
import gin
import pytest

from ble_latex import errors
from ble_latex import gin_values
from ble_latex.cli import common as cli
from tests import helpers


def _one_line(capsys, prog):
  err = capsys.readouterr().err.strip().splitlines()
  assert len(err) == 1, err
  assert err[0].startswith(f'{prog}: '), err
  return err[0]


# -- Item 3: finite in float64 but infinite in the float32 core. ----------
@pytest.mark.parametrize('value', [1e39, -1e39, 3.5e38, 10**39, 10**400])
def test_a_number_beyond_float32_is_not_a_number(value):
  assert not gin_values.is_number(value)
  with pytest.raises(errors.ConfigError, match='float32'):
    gin_values.check_number('gin binding x.y', value)


def test_float32_range_is_still_a_number():
  assert gin_values.is_number(3.4e38) and gin_values.is_number(-1e30)
  assert gin_values.check_number('x', 1e38, minimum=0) == 1e38


@pytest.mark.parametrize('binding', [
    'latex_reward.sand_penalty_per_kg = 1e39',
    'latex_flight.superheat_day_k = 1e39',
    'latex_launch.payload_kg = -1e39',
])
def test_env_bindings_beyond_float32_are_refused(binding):
  from ble_latex.envs import env_params  # pylint: disable=g-import-not-at-top
  gin.clear_config()
  try:
    gin.parse_config(binding)
    with pytest.raises(ValueError, match=r'must be a finite number'):
      env_params.params_from_gin()
  finally:
    gin.clear_config()


def test_planner_cost_beyond_float32_is_refused():
  from ble_latex.agents.planning import agents as planners  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import jax_env  # pylint: disable=g-import-not-at-top
  gin.clear_config()
  try:
    gin.parse_config('LatexMpcAgent.sand_cost = 1e39')
    with pytest.raises(ValueError, match='sand_cost'):
      planners.AGENTS['latex_mpc'](3, (71,), action_low=jax_env.ACTION_LOW,
                                   action_high=jax_env.ACTION_HIGH)
  finally:
    gin.clear_config()


@pytest.mark.parametrize('text', ['a.b=1e39', 'a.b=1,-1e39'])
def test_sweep_grid_beyond_float32_is_refused(text):
  from ble_latex.run import sweep_lib  # pylint: disable=g-import-not-at-top
  with pytest.raises(sweep_lib.SpaceError, match='float32'):
    sweep_lib.parse_grid_flag(text)
  with pytest.raises(sweep_lib.SpaceError, match='float32'):
    sweep_lib.parse_space({'bindings': {'a.b': {'uniform': [0, 1e39]}}},
                          'space.json')


def _toy_command(argv, seen):
  values = flags.FlagValues()
  flags.DEFINE_float('ratio', 1.0, 'A float.', flag_values=values)
  flags.DEFINE_integer('count', 1, 'An int.', flag_values=values)

  def main(unused_argv):
    seen.append(gin.config_str())
    gin.parse_config('latex_launch.payload_kg = 7.0')
    return 0
  return cli.run_absl(main, 'toy', values, argv)


@pytest.mark.parametrize('flag', ['--ratio=nan', '--ratio=inf',
                                  '--ratio=-1e39',
                                  '--count=99999999999999999999'])
def test_number_flags_of_every_command_are_checked(flag, capsys):
  seen = []
  assert _toy_command([flag], seen) == 2
  assert not seen  # Refused before the command's main.
  assert flag.split('=')[0] in _one_line(capsys, 'toy')


def test_validate_max_error_percent_nan_is_a_usage_error(capsys):
  from ble_latex.cli import validate  # pylint: disable=g-import-not-at-top
  assert validate.main(['--max_error_percent=nan']) == 2
  assert '--max_error_percent' in _one_line(capsys, 'ble-latex-validate')


# -- Item 22: a command run twice binds afresh. ----------------------------
def test_a_command_does_not_keep_the_previous_runs_gin():
  seen = []
  gin.parse_config('latex_launch.payload_kg = 5.0')  # An earlier run's.
  try:
    assert _toy_command([], seen) == 0
    assert _toy_command([], seen) == 0
  finally:
    gin.clear_config()
  assert 'payload_kg' not in seen[0] and 'payload_kg' not in seen[1]


# -- Items 4, 12: training seeds in [0, 2**32). ---------------------------
@pytest.mark.parametrize('argv', [
    ['--trainer=jax', '--seed=4294967296'],
    ['--seed=-1'],
    ['--trainer=jax', '--seeds=0,99999999999999999999'],
    ['--seeds=4294967296'],
])
def test_train_refuses_seeds_beyond_2_32(argv, tmp_path, capsys):
  from ble_latex.cli import train  # pylint: disable=g-import-not-at-top
  base = tmp_path / 'run'
  assert train.main([f'--base_dir={base}', *argv]) == 2
  assert '[0, 4294967295]' in _one_line(capsys, 'ble-latex-train')
  assert not base.exists()  # No stray run or seed_ directory.


@pytest.mark.parametrize('seed', [2**32, -1, 10**20, True])
def test_both_trainers_refuse_seeds_beyond_2_32(seed, tmp_path):
  from ble_latex.run import jax_train  # pylint: disable=g-import-not-at-top
  from ble_latex.run import train_lib  # pylint: disable=g-import-not-at-top
  with pytest.raises(errors.ConfigError, match='training seed'):
    train_lib.train(agent_name='sac', env_name='LatexBalloon-v0',
                    base_dir=str(tmp_path / 'a'), num_iterations=1,
                    episodes_per_iteration=1, max_episode_length=1,
                    collectors=[], seed=seed)
  with pytest.raises(errors.ConfigError, match='training seed'):
    jax_train.train_seeds(runs=[(seed, str(tmp_path / 'b'))],
                          num_iterations=1)
  assert not os.listdir(tmp_path)


def test_sweep_refuses_seeds_beyond_2_32(tmp_path, capsys):
  from ble_latex.cli import sweep  # pylint: disable=g-import-not-at-top
  from ble_latex.run import sweep_lib  # pylint: disable=g-import-not-at-top
  rc = sweep.main([f'--sweep_dir={tmp_path / "s"}', '--grid=sac_trainer_config.gamma=0.9',
                   '--seeds=1,99999999999999999999', '--num_iterations=5'])
  assert rc == 2
  assert '[0, 4294967295]' in _one_line(capsys, 'ble-latex-sweep')
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


# -- Items 8-11: the eval command. ------------------------------------------
@pytest.mark.parametrize('argv, needle', [
    (['--agent=latex_mpc', '--env_name=LatexBalloonDiscrete-v0'],
     "Agent 'latex_mpc' acts in the Box"),
    (['--agent=latex_station_seeker', '--env_name=LatexBalloonDiscrete-v0'],
     "Agent 'latex_station_seeker' acts in the Box"),
    (['--num_shards=2', '--shard_idx=5'], '--shard_idx must be in [0, '),
    (['--max_episode_length=0'], 'max_episode_length'),
    (['--max_episode_length=-3'], 'max_episode_length'),
    (['--agent=latex_station_seeker', '--era5_path=/nonexistent.nc',
      '--era5_dates=0001-01-01T00:00+01:00,2022-01-01'],
     'years 1..9999'),
])
def test_eval_refusals_are_one_line(argv, needle, tmp_path, capsys):
  from ble_latex.cli import eval as eval_cli  # pylint: disable=g-import-not-at-top
  out = tmp_path / 'out'
  assert eval_cli.main([f'--output_dir={out}', *argv]) == 2
  assert needle in _one_line(capsys, 'ble-latex-eval')
  assert not out.exists() or not list(out.rglob('*'))  # No lock file left.


def test_era5_dates_that_overflow_are_a_config_error():
  from ble_latex.wind import gridded  # pylint: disable=g-import-not-at-top
  for pair in (('0001-01-01T00:00+01:00', '2022-01-01'),
               ('2022-01-01', '9999-12-31T23:00-05:00')):
    with pytest.raises(errors.ConfigError, match='years 1..9999'):
      gridded.start_dates_range(pair)


# -- Items 18, 19: policy files hold only what write_tree stores. -----------
_SHIPPED_POLICY = (helpers.ROOT / 'ble_latex' /
                   'agents' / 'policies' / 'sac_latex.msgpack')


def _crafted_policy(tmp_path, name, extra):
  """The shipped policy's bytes with `extra` entries added (msgpack)."""
  import msgpack  # pylint: disable=g-import-not-at-top
  # flax's arrays stay msgpack ext types here: repacked byte for byte.
  raw = msgpack.unpackb(_SHIPPED_POLICY.read_bytes(), raw=False,
                        strict_map_key=False)
  raw.update(extra)
  path = tmp_path / name
  path.write_bytes(msgpack.packb(raw))
  return path


@pytest.mark.parametrize('extra', [
    {'note': 'EXT'}, {7: 'an int key'}])
def test_policy_with_ext_type_or_int_key_is_refused_naming_it(
    extra, tmp_path, capsys):
  import msgpack  # pylint: disable=g-import-not-at-top
  from ble_latex.agents.sac import pretrained  # pylint: disable=g-import-not-at-top
  from ble_latex.cli import export_policy  # pylint: disable=g-import-not-at-top
  if extra.get('note') == 'EXT':
    extra = {'note': msgpack.ExtType(42, b'x')}
  path = _crafted_policy(tmp_path, 'crafted.msgpack', extra)
  with pytest.raises(errors.BadFileError, match=str(path)):
    pretrained.load_policy(str(path))
  out = tmp_path / 'out.msgpack'
  assert export_policy.main([f'--checkpoint={path}', f'--output={out}']) == 1
  assert str(path) in _one_line(capsys, 'ble-latex-export-policy')
  assert not out.exists()


def test_export_policy_to_a_pickle_name_is_a_usage_error(tmp_path, capsys):
  from ble_latex.cli import export_policy  # pylint: disable=g-import-not-at-top
  out = tmp_path / 'x.pkl'
  assert export_policy.main([
      f'--checkpoint={_SHIPPED_POLICY}',
      f'--output={out}']) == 2
  assert 'msgpack' in _one_line(capsys, 'ble-latex-export-policy')
  assert not out.exists()


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
    assert 'pressure levels [1.0, 2.0] Pa are outside' in _one_line(
        capsys, 'ble-latex-plot')
  assert not out.exists() or not list(out.iterdir())


# -- Every gin parameter of the settings builders, bound to odd values. -----
_ODD_VALUES = ('[1.0]', "'x'", 'None', '1e400', '-1', '{"a": 1}', '(1, 2)')


def _settings_builders():
  """{configurable: the function a command calls to build its settings}."""
  # pylint: disable=g-import-not-at-top
  from ble_latex.agents.planning import config as plan_config
  from ble_latex.agents.sac import trainer as sac_trainer
  from ble_latex.envs import env_params
  from ble_latex.run import dagger
  from ble_latex.wind import gridded
  # pylint: enable=g-import-not-at-top
  env = env_params.params_from_gin
  return {'latex_start': env, 'latex_episode': env,
          'latex_reward': env, 'latex_controller': env, 'latex_flight': env,
          'latex_launch': env,
          'LatexMpcAgent': lambda: plan_config.from_gin('latex_mpc'),
          'sac_trainer_config': sac_trainer.TrainerConfig,
          'dagger_config': dagger.DaggerConfig, 'GriddedWindField': gridded.settings}


def test_every_settings_binding_is_accepted_or_one_line_naming_it():
  # A list, dict or string where a number or name goes was a TypeError
  # traceback in two places (GriddedWindField.stations, dagger_config.teacher).
  import inspect  # pylint: disable=g-import-not-at-top
  builders = _settings_builders()
  wind_file = str(helpers.REAL_WINDS /
                 'gfs_2010-10-26T12Z_uv_10-300hPa_1deg_subset.nc')
  failures, tried = [], 0
  try:
    for name, build in sorted(builders.items()):
      configurable = gin.config._REGISTRY.get_match(name)  # pylint: disable=protected-access
      params = inspect.signature(configurable.wrapped).parameters
      for param in params:
        if param in ('kwargs', 'wind_field_factory', 'path'):
          continue
        for value in _ODD_VALUES:
          gin.clear_config()
          gin.parse_config(f'{name}.{param} = {value}')
          if name == 'GriddedWindField':
            gin.parse_config(f'GriddedWindField.path = {wind_file!r}')
          tried += 1
          try:
            build()
          except ValueError as error:  # errors.ConfigError is one.
            first = str(error).splitlines()[0] if str(error) else ''
            if param not in first:
              failures.append(f'{name}.{param} = {value}: {first}')
          except Exception as error:  # pylint: disable=broad-except
            failures.append(f'{name}.{param} = {value}: '
                            f'{type(error).__name__}: {error}')
  finally:
    gin.clear_config()
  assert tried > 500 and not failures, failures
