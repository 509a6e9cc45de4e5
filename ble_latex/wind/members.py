# coding=utf-8
"""The members of an ensemble wind file (GEFS, ERA5 EDA): which one flies,
and members drawn as truths.

An ensemble file holds its members along one dimension (cfgrib and ERA5's
EDA call it `number`; other NetCDF files `member`, `realization` or
`ensemble`).

- The forecast the agents see: `GriddedWindField.member = k` (the k-th along
  that dimension, 0-based; default 0, GEFS's control run), or
  `GriddedWindField.member = 'mean'` (the ensemble mean).
- The truth the balloon flies in: that same member plus the simplex noise
  (`wind.forecast_error`), or, with `GriddedWindField.truth_members = True`,
  another member drawn per flight from its reset key (`truth_indices`: every
  member but the forecast's; every member under 'mean'). The members'
  spread is then the forecast error, and the noise's default scale is 0.

A member the file does not hold, or members asked of a file without them,
is refused in one line.
"""

from typing import Any, Optional, Sequence

import gin

from ble_latex import errors

# Names of an ensemble's member dimension.
MEMBER_DIMS = ('number', 'member', 'realization', 'ensemble')
BINDING = 'GriddedWindField.member'
TRUTH_BINDING = 'GriddedWindField.truth_members'
# `GriddedWindField.member`'s value flying the ensemble mean.
MEAN = 'mean'


def check(member: Any) -> Any:
  """The member, checked: an int >= 0 or 'mean', else one line."""
  if member == MEAN and isinstance(member, str):
    return member
  if isinstance(member, bool) or not isinstance(member, int) or member < 0:
    raise errors.ConfigError(
        f'{BINDING} = {member!r}: an ensemble member is an index >= 0 along '
        f"the file's member dimension ({'/'.join(MEMBER_DIMS)}), or "
        f"{MEAN!r} (the ensemble mean)")
  return member


def check_truth(truth_members: Any) -> bool:
  """`GriddedWindField.truth_members`, checked: a bool, else one line."""
  if not isinstance(truth_members, bool):
    raise errors.ConfigError(
        f'{TRUTH_BINDING} = {truth_members!r}: expected True (the truth is a '
        'member drawn per flight) or False')
  return truth_members


def bound(member: Any = None) -> Any:
  """`member` if given, else gin's `GriddedWindField.member` (0 unbound)."""
  if member is None:
    try:
      member = gin.query_parameter(BINDING)
    except ValueError:  # Not bound.
      member = 0
  return check(member)


def select(array: Any, dim: str, member: Any) -> Any:
  """An xarray variable without dimension `dim`: its only entry, the
  ensemble mean (member 'mean'), or member `member`."""
  if array.sizes[dim] == 1:
    return array.isel({dim: 0})
  if member == MEAN:
    return array.mean(dim, keep_attrs=True)
  return array.isel({dim: member})


def about(sizes: Any, member: Any, path: str, label: str) -> Optional[str]:
  """The member's label for records ('member 2 of 31', 'ensemble mean of
  31'), None for a file without a member dimension (`sizes`: its
  dimensions' sizes).

  Raises:
    errors.ConfigError: The file holds fewer members, or none and
      `member` is not 0 (one line).
  """
  dim = next((d for d in MEMBER_DIMS if sizes.get(d, 1) > 1), None)
  if dim is None:
    if member:
      raise errors.ConfigError(
          f'{label} file {path} holds no ensemble member dimension '
          f"({'/'.join(MEMBER_DIMS)}); {BINDING} = {member!r} needs one "
          '(leave it at 0)')
    return None
  size = int(sizes[dim])
  if member == MEAN:
    return f'ensemble mean of {size}'
  if member >= size:
    raise errors.ConfigError(
        f'{label} file {path} holds {size} ensemble members (dimension '
        f'{dim!r}); {BINDING} = {member} is out of range (0..{size - 1})')
  return f'member {member} of {size}'


def size_of(label: Optional[str]) -> int:
  """The ensemble's size from `about`'s label (1: no member dimension)."""
  return 1 if label is None else int(label.rsplit(' ', 1)[1])


def truth_indices(size: int, member: Any, path: Any) -> Sequence[int]:
  """The members a flight's truth is drawn from: all but the forecast's.

  Raises:
    errors.ConfigError: A file without members (one line naming it).
  """
  if size < 2:
    raise errors.ConfigError(
        f'{TRUTH_BINDING} = True: {path} holds no ensemble member dimension '
        f"({'/'.join(MEMBER_DIMS)}) to draw truths from")
  return [k for k in range(size) if member == MEAN or k != member]


def truth_label(size: int, member: Any) -> str:
  """The truth for records, e.g. 'the 30 members but 0 of 31, drawn per
  flight'."""
  indices = truth_indices(size, member, '')
  names = ('every member' if len(indices) == size else
           f'the {len(indices)} members but {member}')
  return f'{names} of {size}, drawn per flight'
