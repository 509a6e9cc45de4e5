# coding=utf-8
"""The gin files shipped with ble_latex, and the one gin binder of commands.

The top-level `gin_configs/` folder installs as `ble_latex/gin_configs` in a
regular install; in an editable install from a checkout it stays beside the
package. `gin_file('sac.gin')` finds it in either place.
"""

import pathlib
from typing import Optional, Sequence

import gin

from ble_latex import errors

_PACKAGE = pathlib.Path(__file__).resolve().parent
_CANDIDATES = (_PACKAGE / 'gin_configs', _PACKAGE.parent / 'gin_configs')
# The env defaults every command parses first, in this order.
ENV_GIN_FILES = ('latex_physics.gin', 'latex_env.gin')


def gin_dir() -> pathlib.Path:
  """The folder holding ble_latex's gin files."""
  for folder in _CANDIDATES:
    if folder.is_dir():
      return folder
  raise FileNotFoundError(
      'ble_latex gin_configs folder not found; looked in '
      f'{[str(c) for c in _CANDIDATES]}')


def env_gin_files() -> list:
  """Paths of ENV_GIN_FILES."""
  return [gin_file(name) for name in ENV_GIN_FILES]


def gin_file(name: str) -> str:
  """Path of the shipped gin file `name` (e.g. 'latex_env.gin')."""
  path = gin_dir() / name
  if not path.is_file():
    available = sorted(p.name for p in gin_dir().glob('*.gin'))
    raise FileNotFoundError(
        f'No gin file {name!r} in {gin_dir()}; available: {available}')
  return str(path)


def bind_gin(agent: Optional[str], agent_gin_file: Optional[str],
             gin_files: Sequence[str], gin_bindings: Sequence[str], *,
             env_defaults: bool = True) -> None:
  """The gin binding of every command: BLE's, plus the env defaults.

  Parses, in order: the agent's gin file (BLE's `run_helpers.bind_gin_variables`:
  `agent_gin_file`, else the agent's registered default; none when `agent` is
  None, for commands that build no agent), ble_latex's env defaults
  (`ENV_GIN_FILES`, unless `env_defaults` is False: `ble-latex-validate`
  flies the flight core alone), the user's `gin_files`, then
  `gin_bindings`.
  Works in a process whose gin config an earlier run locked (the demo).

  Args:
    agent: A registered agent name, or None.
    agent_gin_file: Replaces the agent's default gin file (with `agent`).
    gin_files: The user's gin files, after the env defaults.
    gin_bindings: The user's bindings, last.
    env_defaults: Parse `ENV_GIN_FILES` first.

  Raises:
    OSError: A gin file cannot be read.
    errors.ConfigError (a ValueError): A binding or gin file is wrong
      (gin's errors other than OSError/ValueError read 'gin: ...').
  """
  files = [*(env_gin_files() if env_defaults else []), *gin_files]
  try:
    with gin.unlock_config():
      if agent is None:
        gin.parse_config_files_and_bindings(files, gin_bindings)
      else:
        # pylint: disable=g-import-not-at-top
        from balloon_learning_environment.utils import run_helpers
        from ble_latex import agents
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
