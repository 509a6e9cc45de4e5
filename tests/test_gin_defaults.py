"""Every shipped gin file binds the code's defaults, or says why not.

A setting has one home, the code's default (issue 43): a gin file that binds
the same value again is a second home that can drift. Each binding of each
`gin_configs/*.gin` must equal the configurable's keyword default, or be
listed in `DIFFERS` with the reason it differs (a file that switches a mode
on, `MODE_FILES`, gives one reason for its bindings).
"""

import importlib
import inspect
import pathlib

import ble_latex  # noqa: F401  pylint: disable=unused-import
from ble_latex import configs
import gin
from gin import config_parser
import pytest

# Gin files whose purpose is to switch a mode on: every binding in them that
# differs from the default does so for the reason given.
MODE_FILES = {
    'latex_realistic.gin':
        'the realistic physics mode (issues 28, 44), off by default; '
        'the file is the one home of its values (flight.params.REALISTIC '
        'is read from it)',
    'valbal.gin':
        'a ValBal-sized system (issue 44) to check the realistic physics '
        'against ValBal\'s record: its payload, sand, band, actuator rates, '
        'launch site and time are the file\'s purpose',
}
# (gin file, 'configurable.parameter') -> why its value differs.
DIFFERS = {
    ('paper_era5.gin', 'latex_episode.wind_field_factory'):
        "the paper's ERA5 winds instead of BLE's generative field: the file's "
        'purpose',
    ('paper_era5.gin', 'GriddedWindField.path'):
        'a required argument (no default): the file the README downloads',
    ('latex_realistic_task.gin', 'latex_launch.sand_kg'):
        'the realistic task\'s resources (issue 63): ValBal\'s ballast '
        'fraction on this system, the paper\'s 2.0 kg the harder variant: '
        'the file\'s purpose',
    ('latex_wind_memory.gin', 'latex_observation.wind_memory'):
        'the observation corrected by measured winds (issue 47), off by '
        'default (the paper\'s observation): the file\'s purpose',
    ('latex_wind_lookahead.gin', 'latex_observation.wind_lookahead'):
        'the observation\'s column as 4-hour drifts (issue 47), off by '
        'default (the paper\'s observation): the file\'s purpose',
    ('latex_sun_observation.gin', 'latex_observation.sun'):
        'the sun at the balloon observed (issue 63), off by default (the '
        'paper\'s observation): the file\'s purpose',
    ('latex_sun_observation.gin', 'latex_observation.gas_temperature'):
        'the helium-air temperature difference observed (issue 63), off by '
        'default (the paper\'s observation): the file\'s purpose',
}
_MISSING = object()


def _gin_files():
  return sorted(pathlib.Path(configs.gin_dir()).glob('*.gin'))


def _bindings(path):
  """(name, value, default) of each binding of a gin file, in file order."""
  out = []
  with open(path) as f:
    parser = config_parser.ConfigParser(f, gin.config.ParserDelegate())
    for statement in parser:
      if isinstance(statement, config_parser.ImportStatement):
        importlib.import_module(statement.module)
        continue
      if isinstance(statement, config_parser.IncludeStatement):
        continue  # The included file is checked on its own.
      assert isinstance(statement, config_parser.BindingStatement), (
          f'{path.name}: only imports and bindings are expected, got '
          f'{statement}')
      configurable = gin.config._REGISTRY.get_match(statement.selector)  # pylint: disable=protected-access
      assert configurable is not None, statement.selector
      parameter = inspect.signature(configurable.wrapped).parameters.get(
          statement.arg_name)
      assert parameter is not None, (
          f'{path.name}: {statement.selector}.{statement.arg_name} is not '
          'a parameter')
      default = (_MISSING if parameter.default is inspect.Parameter.empty
                 else parameter.default)
      name = f'{configurable.name}.{statement.arg_name}'
      out.append((name, statement.value, default))
  return out


@pytest.mark.parametrize('path', _gin_files(), ids=lambda p: p.name)
def test_gin_file_binds_the_defaults_or_says_why_not(path):
  differ = []
  for name, value, default in _bindings(path):
    equal = default is not _MISSING and type(value) is type(default) and (
        value == default)
    if equal:
      assert (path.name, name) not in DIFFERS, (
          f'{path.name}: {name} equals the default now; drop it from DIFFERS')
    elif (path.name, name) not in DIFFERS and path.name not in MODE_FILES:
      differ.append(f'{name} = {value!r} (default {default!r})')
  assert not differ, (
      f'{path.name} binds values that differ from the code\'s defaults '
      f'without a reason in DIFFERS: {differ}')


def test_every_listed_difference_is_still_bound():
  bound = {(p.name, name) for p in _gin_files() for name, _, _ in _bindings(p)}
  assert set(DIFFERS) <= bound, sorted(set(DIFFERS) - bound)


def test_a_binding_that_differs_is_caught(tmp_path):
  """The check can fail: a gin file binding another value is reported."""
  path = tmp_path / 'other.gin'
  path.write_text('import ble_latex.agents.sac.trainer\n'
                  'sac_trainer_config.num_envs = 31\n'
                  'sac_trainer_config.gamma = 0.99\n')
  (num_envs, _, default), (gamma, value, gamma_default) = _bindings(path)
  assert num_envs == 'sac_trainer_config.num_envs' and default == 32
  assert gamma == 'sac_trainer_config.gamma' and value == gamma_default
  with pytest.raises(AssertionError, match='num_envs = 31'):
    test_gin_file_binds_the_defaults_or_says_why_not(path)


def test_no_shipped_gin_file_only_imports():
  for path in _gin_files():
    with open(path) as f:
      statements = list(config_parser.ConfigParser(
          f, gin.config.ParserDelegate()))
    assert any(not isinstance(s, config_parser.ImportStatement)
               for s in statements), f'{path.name} only imports'


def test_the_combined_observation_file_includes_the_two_beside_it(
    tmp_path, monkeypatch):
  from ble_latex.envs import env_params  # pylint: disable=g-import-not-at-top
  monkeypatch.chdir(tmp_path)  # The includes resolve wherever it runs.
  gin.clear_config()
  try:
    gin.parse_config_file(configs.gin_file('latex_wind_memory_lookahead.gin'))
    both = env_params.observation_settings()
  finally:
    gin.clear_config()
  assert (both['wind_memory'], both['wind_lookahead']) == (16, 12)
