"""Old gin names (LatexBalloonEnv, create_state, ...): aliases for one release."""

import re
import warnings

import gin
import jax
import numpy as np
import pytest

from ble_latex import errors
from ble_latex import gin_aliases
from ble_latex.envs import env_params
from ble_latex.flight import params as flight_params_lib  # pylint: disable=unused-import

from tests import helpers

REPO = helpers.ROOT
# Old name -> (new name, a keyword and a value that differs from its default).
RENAMED = {
    'LatexBalloonEnv': ('latex_episode', 'episode_steps', '10'),
    'LatexBalloonArena': ('latex_start', 'max_start_distance_km', '100.0'),
    'create_state': ('latex_launch', 'sand_kg', '1.5'),
    'AltitudeController': ('latex_controller', 'min_drop_kg', '0.01'),
    'LatexBalloon': ('latex_flight', 'latitude_deg', '20.0'),
}


@pytest.fixture(autouse=True)
def _clear_gin():
  gin.clear_config()
  yield
  gin.clear_config()


def _params(bindings):
  gin.clear_config()
  gin.parse_config(bindings)
  with warnings.catch_warnings():
    warnings.simplefilter('ignore', FutureWarning)
    return env_params.params_from_gin().replace(decoder=None)


def _same(a, b):
  return jax.tree.all(jax.tree.map(
      lambda x, y: bool(np.all(np.asarray(x) == np.asarray(y))), a, b))


def test_the_aliases_are_the_documented_ones():
  assert {old: new for old, (new, _, _) in RENAMED.items()}.items() <= (
      gin_aliases.ALIASES.items())
  page = (REPO / 'docs' / 'commands.md').read_text()
  for old, (new, _, _) in RENAMED.items():
    assert f'`{old}`' in page and f'`{new}`' in page, old


def test_old_and_new_names_give_the_same_params():
  default = _params([])
  new = _params([f'{new}.{key} = {value}'
                 for new, key, value in RENAMED.values()])
  old = _params([f'{old}.{key} = {value}'
                 for old, (_, key, value) in RENAMED.items()])
  assert _same(old, new) and not _same(new, default)
  assert (new.episode_steps, new.flight.initial_sand_kg) == (10, 1.5)
  # The old module string of the env's names still parses.
  spelled = _params(['ble_latex.envs.jax_env.LatexBalloonEnv.episode_steps = '
                     '10'])
  assert spelled.episode_steps == 10


def test_an_old_name_warns_naming_the_new_binding():
  gin.parse_config('LatexBalloonEnv.episode_steps = 10')
  with pytest.warns(FutureWarning,
                    match=r'LatexBalloonEnv\.\* is deprecated .*bind '
                    r'latex_episode\.episode_steps'):
    assert env_params.episode()['episode_steps'] == 10


def test_both_names_bound_differently_is_a_one_line_error():
  assert _params(['latex_episode.episode_steps = 10',
                  'LatexBalloonEnv.episode_steps = 10']).episode_steps == 10
  gin.parse_config(['latex_launch.sand_kg = 1.5', 'create_state.sand_kg = 2.5'])
  with pytest.raises(errors.ConfigError,
                     match=r'^gin bindings create_state\.sand_kg = 2\.5 and '
                     r'latex_launch\.sand_kg = 1\.5 differ: .*bind '
                     r'latex_launch\.sand_kg only$'):
    env_params.params_from_gin()


def test_a_caller_keyword_wins_over_both_names():
  gin.parse_config('LatexBalloonArena.max_start_distance_km = 100.0')
  with warnings.catch_warnings():
    warnings.simplefilter('ignore', FutureWarning)
    assert env_params.start(max_start_distance_km=5.0)[
        'max_start_distance_km'] == 5.0


def test_the_operative_config_parses_back_to_the_same_params():
  first = _params(['LatexBalloonEnv.episode_steps = 10',
                   'latex_launch.sand_kg = 1.5'])
  recorded = gin.operative_config_str()
  assert 'LatexBalloonEnv.episode_steps = 10' in recorded
  assert 'latex_episode.episode_steps' not in recorded
  assert _same(_params(recorded), first)


def test_a_recorded_run_with_the_old_names_loads():
  # Records written before the rename bind every flight and env value
  # under the old names; they load to the params of the new names.
  records = sorted((REPO / 'benchmarks').glob('**/operative_config.gin'))
  record = next((r for r in records if 'LatexBalloonEnv.' in r.read_text()),
                None)
  if record is None:
    pytest.skip('no recorded operative config with the old names')
  old_names = '|'.join(RENAMED)
  lines = [line for line in record.read_text().splitlines()
           if re.match(rf'({old_names})\.\w+ = ', line)]
  assert len(lines) > 30
  renamed = [re.sub(rf'^({old_names})\.',
                    lambda m: RENAMED[m.group(1)][0] + '.', line)
             for line in lines]
  assert _same(_params(lines), _params(renamed))
