# coding=utf-8
"""The one gin binder of every command, and the one-line words of its errors.

`bind_gin`: BLE's agent binding and the env defaults. It lives in `run/`
because it registers ble_latex's agents into BLE's registry
(`agents.register`) before BLE binds the agent's gin file; `configs` (below
`agents`) only finds the shipped gin files.

`one_line`, `refused_config_message`, `gin_usage_message`: what a command
(`cli.common.run_absl`) and a script print for a refused configuration, one
line each.
"""

from typing import List, Optional, Sequence

import gin

from ble_latex import configs
from ble_latex import errors
from ble_latex import gin_aliases

# gin's note on an exception raised inside a configurable's call.
_GIN_CALL_NOTE = 'In call to configurable '


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


def one_line(error: BaseException) -> str:
  """An exception's message as one line (gin's call notes become a suffix).

  Args:
    error: The exception; gin appends '  In call to configurable X (...)'
      lines to exceptions raised inside a configurable.

  Returns:
    Its first line, with ' (in gin configurable X)' for the innermost
    configurable gin noted.
  """
  text = str(error) or type(error).__name__
  first, *rest = text.split('\n')
  notes = [line.strip()[len(_GIN_CALL_NOTE):].split(' ', 1)[0].strip("'")
           for line in rest if line.strip().startswith(_GIN_CALL_NOTE)]
  if notes:
    first += f' (in gin configurable {notes[0]})'
  return first


def refused_config_message(error: ValueError) -> Optional[str]:
  """The one-line usage message of a refused configuration, else None.

  Refused: gin's unknown configurable/parameter (`gin_usage_message`), an
  `errors.ConfigError` (e.g. a gin binding that does not parse, an agent that
  does not fit the env), and a ValueError raised inside a gin configurable's
  call (gin notes it): a bound value the configurable's checks refuse.

  Args:
    error: The ValueError.

  Returns:
    The message, or None for an `errors.BadFileError` (a failure, not a
    usage error) and any other ValueError (a bug: re-raise it).
  """
  if isinstance(error, errors.BadFileError):
    return None
  message = gin_usage_message(error)
  if message is not None:
    return message
  if isinstance(error, errors.ConfigError) or _GIN_CALL_NOTE in str(error):
    return one_line(error)
  return None


def gin_usage_message(error: ValueError) -> Optional[str]:
  """One line for gin's unknown-configurable/parameter errors, else None."""
  first = str(error).split('\n', 1)[0]
  if first.startswith('No configurable matching '):
    name = first[len('No configurable matching '):].strip(" .'")
    return errors.unknown('gin configurable', name, _latex_configurables(),
                          label="ble_latex's (BLE's work too)")
  if "doesn't have a parameter named" in first:
    return f'gin binding: {first}'
  return None


def _latex_configurables() -> List[str]:
  from gin import config  # pylint: disable=g-import-not-at-top
  registry = config._REGISTRY  # pylint: disable=protected-access
  return sorted({c.name for _, c in registry.items()
                 if c.module.startswith('ble_latex') and
                 c.name not in gin_aliases.ALIASES})  # Not the old names.
