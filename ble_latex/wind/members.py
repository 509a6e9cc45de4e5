# coding=utf-8
"""One member of an ensemble wind file (GEFS, ERA5 EDA): which, and its slice.

An ensemble file holds its members along one dimension (cfgrib and ERA5's
EDA call it `number`; other NetCDF files `member`, `realization` or
`ensemble`). A flight flies one of them: `Era5WindField.member = k` (the
k-th along that dimension, 0-based; default 0, GEFS's control run). A
member the file does not hold is refused in one line.
"""

from typing import Any, Optional

import gin

from ble_latex import errors

# Names of an ensemble's member dimension.
MEMBER_DIMS = ('number', 'member', 'realization', 'ensemble')
BINDING = 'Era5WindField.member'


def check(member: Any) -> int:
  """The member index, checked: an int >= 0, else one line."""
  if isinstance(member, bool) or not isinstance(member, int) or member < 0:
    raise errors.ConfigError(
        f'{BINDING} = {member!r}: an ensemble member is an index >= 0 along '
        f"the file's member dimension ({'/'.join(MEMBER_DIMS)})")
  return member


def bound(member: Optional[int] = None) -> int:
  """`member` if given, else gin's `Era5WindField.member` (0 unbound)."""
  if member is None:
    try:
      member = gin.query_parameter(BINDING)
    except ValueError:  # Not bound.
      member = 0
  return check(member)


def about(sizes: Any, member: int, path: str, label: str) -> Optional[str]:
  """The member's label for records ('member 2 of 31'), None for a file
  without a member dimension (`sizes`: its dimensions' sizes).

  Raises:
    errors.ConfigError: The file holds fewer members, or none and
      `member` > 0 (one line).
  """
  dim = next((d for d in MEMBER_DIMS if sizes.get(d, 1) > 1), None)
  if dim is None:
    if member:
      raise errors.ConfigError(
          f'{label} file {path} holds no ensemble member dimension '
          f"({'/'.join(MEMBER_DIMS)}); {BINDING} = {member} needs one "
          '(leave it at 0)')
    return None
  size = int(sizes[dim])
  if member >= size:
    raise errors.ConfigError(
        f'{label} file {path} holds {size} ensemble members (dimension '
        f'{dim!r}); {BINDING} = {member} is out of range (0..{size - 1})')
  return f'member {member} of {size}'
