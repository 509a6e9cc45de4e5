# coding=utf-8
"""The gin files shipped with ble_latex (where they are, by name).

The top-level `gin_configs/` folder installs as `ble_latex/gin_configs` in a
regular install; in an editable install from a checkout it stays beside the
package. `gin_file('latex_env.gin')` finds it in either place. Commands bind
them with `ble_latex.run.gin_binding.bind_gin`.

Importing this module appends that folder to gin's search path (after the
working directory, which gin searches first), so a shipped gin file can
`include` another by its name (`latex_wind_memory_lookahead.gin`) wherever
the command runs; such a file imports `ble_latex.configs` first.
"""

import os
import pathlib
from typing import Iterable, Optional

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


def _add_search_path() -> None:
  """Appends the gin files' folder to gin's search path (for `include`)."""
  for folder in _CANDIDATES:
    if folder.is_dir():
      gin.add_config_file_search_path(str(folder))
      return


_add_search_path()


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


def check_gin_files(paths: Iterable[Optional[str]]) -> None:
  """Each gin file exists as given or under BLE's folder (as gin finds it).

  Raises:
    errors.UsageError: One line naming the missing file (exit 2).
  """
  from ble_latex import quiet  # pylint: disable=g-import-not-at-top
  with quiet.third_party_noise():  # BLE's package import registers gym envs.
    import balloon_learning_environment  # pylint: disable=g-import-not-at-top
  ble_parent = os.path.dirname(
      os.path.dirname(balloon_learning_environment.__file__))
  shipped = [p.name for p in gin_dir().glob('*.gin')]
  for path in paths:
    if path is None or os.path.isfile(path) or os.path.isfile(
        os.path.join(ble_parent, path)):
      continue
    hint = (f' (shipped: {gin_file(os.path.basename(path))})'
            if os.path.basename(path) in shipped else '')
    raise errors.UsageError(
        f'{errors.unknown("gin file", path, shipped)}{hint}; shipped files '
        f'live in {gin_dir()}')
