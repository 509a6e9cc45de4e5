# coding=utf-8
"""The two kinds of refused input that commands report in one line.

Library code raises these (both are `ValueError`s, so callers that catch
ValueError keep working); every `ble-latex-*` command (`cli.common.run_absl`)
prints them as `PROG: message` without a traceback:

- `ConfigError`: a configuration the user gave is refused (an agent that does
  not fit the env, a gin binding that does not parse or whose value is out of
  range): a usage error, exit status 2.
- `BadFileError`: an input file is unusable (truncated, corrupt, not the
  expected format, impossible contents): a failure, exit status 1.
- `ResumeError` (a `ConfigError`): a run directory was started with other
  settings, or its logs miss episodes its checkpoint covers: exit status 2.
- `UsageError` (not a ValueError): a command-line value that library code
  checks for the commands (a wind file's --era5_dates, a --seeds list, an
  unknown agent or suite name) is refused; its message names the flag and is
  printed as is: exit status 2.

`unknown` words the message of an unknown name. Light on purpose: only the
standard library.
"""

import difflib
from typing import Iterable


class ConfigError(ValueError):
  """A configuration value or combination given by the user is refused."""


class BadFileError(ValueError):
  """An input file is truncated, corrupt or holds impossible values."""


class ResumeError(ConfigError):
  """A run directory cannot be resumed with these settings; nothing changed."""


class UsageError(Exception):
  """A command-line value checked below `cli/` is refused (one line, exit 2)."""


def unknown(what: str, name: str, valid: Iterable[str],
            label: str = 'valid') -> str:
  """"unknown agent 'x'; valid: a, b" (with a guess when one is close)."""
  valid = sorted(set(valid))
  close = difflib.get_close_matches(name, valid, n=1)
  guess = f' (did you mean {close[0]!r}?)' if close else ''
  return f'unknown {what} {name!r}{guess}; {label}: {", ".join(valid)}'
