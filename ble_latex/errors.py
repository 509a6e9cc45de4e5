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

Light on purpose: no imports.
"""


class ConfigError(ValueError):
  """A configuration value or combination given by the user is refused."""


class BadFileError(ValueError):
  """An input file is truncated, corrupt or holds impossible values."""


class ResumeError(ConfigError):
  """A run directory cannot be resumed with these settings; nothing changed."""
