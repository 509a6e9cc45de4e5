"""The algorithms' subpackages (issue 66 item 3): old gin names still bind.

The SAC and planner modules moved into `agents/sac/` and `agents/planning/`;
their gin configurables keep the module strings they had, so module-qualified
bindings in gin files, commands and recorded operative configs name the same
values, and `ble_latex.agents.sac_trainer` (the first import of every recorded
jitted-trainer config) is the trainer itself.
"""

import gin
import pytest

from tests import helpers

REPO = helpers.ROOT


@pytest.fixture(autouse=True)
def _clear_gin():
  gin.clear_config()
  yield
  gin.clear_config()


def test_the_old_trainer_module_is_the_trainer():
  # pylint: disable=g-import-not-at-top
  import ble_latex.agents.sac_trainer as old
  from ble_latex.agents.sac import trainer
  # pylint: enable=g-import-not-at-top
  assert old is trainer


def test_module_qualified_gin_names_keep_their_module_strings():
  # pylint: disable=g-import-not-at-top,unused-import
  from ble_latex.agents.planning import config as plan_config
  from ble_latex.agents.sac import agent
  from ble_latex.agents.sac import ensemble
  from ble_latex.agents.sac import trainer
  # pylint: enable=g-import-not-at-top,unused-import
  gin.parse_config([
      'ble_latex.agents.sac.SACAgent.hidden_units = 64',
      'ble_latex.agents.ensemble.SACEnsembleAgent.seed = 3',
      'ble_latex.agents.sac_trainer.sac_trainer_config.num_envs = 4',
      'ble_latex.agents.planners.LatexMpcAgent.beam_width = 4',
  ])
  assert gin.query_parameter(
      'ble_latex.agents.sac.SACAgent.hidden_units') == 64
  assert gin.query_parameter(
      'ble_latex.agents.ensemble.SACEnsembleAgent.seed') == 3
  assert trainer.TrainerConfig().num_envs == 4
  assert plan_config.from_gin('latex_mpc').beam_width == 4


def test_a_recorded_trainer_config_imports_the_trainer():
  records = sorted((REPO / 'benchmarks').glob('**/operative_config.gin'))
  first = {r.read_text().splitlines()[0] for r in records}
  if not first:
    pytest.skip('no recorded operative config')
  assert 'import ble_latex.agents.sac_trainer' in first
  gin.parse_config('import ble_latex.agents.sac_trainer\n'
                   'sac_trainer_config.num_envs = 2')
  # pylint: disable=g-import-not-at-top
  from ble_latex.agents.sac import trainer
  # pylint: enable=g-import-not-at-top
  assert trainer.TrainerConfig().num_envs == 2
