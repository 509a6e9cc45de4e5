# coding=utf-8
"""The one gin binder of every command: BLE's agent binding, the env defaults.

It lives in `run/` because it registers ble_latex's agents into BLE's registry
(`agents.register`) before BLE binds the agent's gin file; `configs` (below
`agents`) only finds the shipped gin files.
"""

from typing import Optional, Sequence

import gin

from ble_latex import configs
from ble_latex import errors


def bind_gin(agent: Optional[str], agent_gin_file: Optional[str],
             gin_files: Sequence[str], gin_bindings: Sequence[str], *,
             env_defaults: bool = True) -> None:
  """The gin binding of every command: BLE's, plus the env defaults.

  Parses, in order: the agent's gin file (BLE's
  `run_helpers.bind_gin_variables`, with the gym env's gin names declared:
  `agent_gin_file`, else the agent's registered default; none when `agent` is
  None, for commands that build no agent), ble_latex's env defaults
  (`configs.ENV_GIN_FILES`, unless `env_defaults` is False:
  `ble-latex-validate` flies the flight core alone), the user's `gin_files`,
  then `gin_bindings`.
  Works in a process whose gin config an earlier run locked (the demo).

  Args:
    agent: A registered agent name, or None.
    agent_gin_file: Replaces the agent's default gin file (with `agent`).
    gin_files: The user's gin files, after the env defaults.
    gin_bindings: The user's bindings, last.
    env_defaults: Parse `configs.ENV_GIN_FILES` first.

  Raises:
    OSError: A gin file cannot be read.
    errors.ConfigError (a ValueError): A binding or gin file is wrong
      (gin's errors other than OSError/ValueError read 'gin: ...').
  """
  files = [*(configs.env_gin_files() if env_defaults else []), *gin_files]
  try:
    with gin.unlock_config():
      if agent is None:
        gin.parse_config_files_and_bindings(files, gin_bindings)
      else:
        # pylint: disable=g-import-not-at-top
        from balloon_learning_environment.utils import run_helpers
        from ble_latex import agents
        import ble_latex.ble.gym_env  # The gym env's gin names, before parsing.
        # pylint: enable=g-import-not-at-top
        agents.register()
        run_helpers.bind_gin_variables(agent, agent_gin_file, gin_bindings,
                                       additional_gin_files=files)
  except (OSError, errors.ConfigError):
    raise
  except ValueError as e:
    raise errors.ConfigError(str(e)) from e
  except Exception as e:  # pylint: disable=broad-except  # gin's own errors.
    raise errors.ConfigError(f'gin: {type(e).__name__}: {e}') from e
