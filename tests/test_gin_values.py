"""ble_latex.gin_values: numbers bound through gin (float32's range and
"> 0" in float32), and every settings builder's refusal of odd values."""

import gin
import pytest

from ble_latex import errors
from ble_latex import gin_values

from tests import helpers


# -- Item 3: finite in float64 but infinite in the float32 core. ----------
@pytest.mark.parametrize('value', [1e39, -1e39, 3.5e38, 10**39, 10**400])
def test_a_number_beyond_float32_is_not_a_number(value):
  assert not gin_values.is_number(value)
  with pytest.raises(errors.ConfigError, match='float32'):
    gin_values.check_number('gin binding x.y', value)


def test_float32_range_is_still_a_number():
  assert gin_values.is_number(3.4e38) and gin_values.is_number(-1e30)
  assert gin_values.check_number('x', 1e38, minimum=0) == 1e38


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


# -- Item 6: "> 0" holds in float32 (XLA flushes subnormals to 0). ---------
@pytest.mark.parametrize('value', [1e-40, 1e-46, 1e-39])
def test_a_positive_number_that_is_0_in_float32_is_refused(value):
  assert not gin_values.is_positive(value)
  with pytest.raises(errors.ConfigError, match='float32'):
    gin_values.check_number('gin binding x.y', value, above=0.0)
  with pytest.raises(errors.ConfigError, match='float32'):
    gin_values.check_number('gin binding x.y', -value, below=0.0)
  assert gin_values.check_number('x', 1.2e-38, above=0.0) == 1.2e-38
