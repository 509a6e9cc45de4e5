# coding=utf-8
"""Old name of `ble_latex.agents.sac.trainer`, an alias until the next release.

Recorded operative configs (`operative_config.gin` of runs before issue 66)
begin with `import ble_latex.agents.sac_trainer`; this module makes that
import the trainer itself, so they still parse. New code imports
`ble_latex.agents.sac.trainer`.
"""

import sys

from ble_latex.agents.sac import trainer

sys.modules[__name__] = trainer
