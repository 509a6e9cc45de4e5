# coding=utf-8
"""The altitude controller's settings and the action contract (gym side).

The controller itself (Eq. hdot_des, Eq. float, Eq. ballast, Eq. vent and
the altitude-band guard of Eq. fullcontroller) is the flight core's
`ble_latex.flight.controller`, run once per action by
`ble_latex.flight.dynamics.step`. This module keeps what the envs and gin
files see:

- `ACTION_LOW` / `ACTION_HIGH`: the Box of (a0 desired altitude [m], a1 time
  factor [.], a2 float flag [.]), and `validate_action`, the one check of an
  action at the env boundary;
- `Decision`: the controller's decision as the strings of `info`.
"""

import datetime as dt
import enum
import math
from typing import Any

import numpy as np

from ble_latex.flight import controller as core_controller
from ble_latex.flight import state as state_lib

# Action bounds (a0 [m], a1 [.], a2 [.]), paper "Method"; the core's.
ACTION_LOW = core_controller.ACTION_LOW
ACTION_HIGH = core_controller.ACTION_HIGH
# Controller stride Delta t between actions.
STRIDE = dt.timedelta(minutes=20)


class Decision(enum.Enum):
  """What the controller did at an action (values are the info strings)."""
  NOTHING = 'nothing'
  FLOAT = 'float'
  VENT = 'vent'
  BALLAST = 'ballast'


def validate_action(action: Any) -> np.ndarray:
  """Checks an action (a0, a1, a2) and returns it as a float64 array.

  Args:
    action: Array of shape (3,) or a flat sequence of 3 numbers inside
      [ACTION_LOW, ACTION_HIGH]; (1, 3), (3, 1) and other shapes are refused.

  Returns:
    The action as np.float64 array of shape (3,).

  Raises:
    ValueError: wrong shape, NaN/inf, or out of range (naming the component).
  """
  try:
    if np.asarray(action).dtype.kind not in 'iuf':
      raise TypeError(f'not numeric (dtype {np.asarray(action).dtype})')
    a = np.asarray(action, dtype=np.float64)
  except (TypeError, ValueError, OverflowError) as e:
    raise ValueError(
        f'action must be 3 numbers (a0 desired altitude [m], a1 time factor, '
        f'a2 float flag), got {action!r}') from e
  if a.shape != (3,):
    raise ValueError(f'action must have shape (3,) (a0, a1, a2), got shape '
                     f'{a.shape}: {action!r}')
  names = ('a0 (desired altitude [m])', 'a1 (time factor)',
           'a2 (float flag)')
  for i, name in enumerate(names):
    if not math.isfinite(a[i]):
      raise ValueError(f'action {name} must be finite, got {a[i]}')
    if not ACTION_LOW[i] <= a[i] <= ACTION_HIGH[i]:
      raise ValueError(f'action {name} must be in [{ACTION_LOW[i]:g}, '
                       f'{ACTION_HIGH[i]:g}], got {a[i]}')
  return a


def decision(code: int) -> Decision:
  """The `Decision` of a core `flight.state.DecisionCode`."""
  return Decision[state_lib.DecisionCode(int(code)).name]
