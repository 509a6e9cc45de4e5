# coding=utf-8
"""Checks of configured values, and reading BLE's gin bindings without BLE.

A gin binding can only exist for a configurable that is registered: gin
refuses to parse `perciatelli_reward_function.reward_dropoff = 0.5` unless
the module declaring it (BLE's `balloon_env`) was imported. So a
configurable whose module is not in `sys.modules` has no bindings, and its
keyword defaults are all there is (`imported_bindings`). That lets the JAX
env (`env_params.params_from_gin`) check that BLE's reward bindings only
repeat its own without importing BLE's balloon/env modules and TensorFlow
behind them; every gin name the env reads is a configurable of the core
itself.

This module is also the one home of the checks of configured numbers (`require`,
`check_number`, `check_int`, `check_bool`): every env, physics and reward
value is checked with them, naming the gin binding that set it.

Light on purpose: only gin, NumPy and the standard library.
"""

import inspect
import math
import numbers
import sys
from typing import Any, Callable, Dict, Mapping, Optional

import gin
import numpy as np

from ble_latex import errors


def effective_bindings(function: Callable[..., Any]) -> Dict[str, Any]:
  """A gin configurable's keyword defaults overridden by its gin bindings."""
  target = inspect.unwrap(function)
  values = {name: p.default for name, p in
            inspect.signature(target).parameters.items()
            if p.default is not inspect.Parameter.empty}
  values.update(gin.get_bindings(function))
  return values


def imported_bindings(module: str, name: str, defaults: Mapping[str, Any],
                      *, bound_only: bool = False) -> Dict[str, Any]:
  """`effective_bindings` of `module.name` if that module is imported.

  Args:
    module: The module declaring the configurable, e.g. 'ble_latex.ble.gym_env'.
    name: The configurable's attribute in that module.
    defaults: Values when the module is not imported (it then has no
      bindings): the configurable's keyword defaults, restated.
    bound_only: Add only the gin bindings, not the keyword defaults.

  Returns:
    `defaults` updated with the configurable's keyword defaults (unless
    `bound_only`) and gin bindings where `module` is in `sys.modules`, else
    `defaults`.
  """
  values = dict(defaults)
  loaded = sys.modules.get(module)
  if loaded is not None:
    function = getattr(loaded, name)
    values.update(gin.get_bindings(function) if bound_only else
                  effective_bindings(function))
  return values


# -- Checks of configured numbers (one home for every env/physics value). --
def require(ok: bool, name: str, requirement: str, value: Any,
            why: str = '') -> None:
  """Raises `errors.ConfigError('{name} must be {requirement}, got ...')`.

  A `ConfigError` is a `ValueError`; commands print it as one line, exit 2.

  Args:
    ok: Whether the value meets the requirement.
    name: What the value is, e.g. 'gin binding latex_launch.sand_kg'.
    requirement: e.g. 'a finite number >= 0'.
    value: The value as given.
    why: Appended to the message (the consequence), e.g. ': ...'.
  """
  if not ok:
    raise errors.ConfigError(
        f'{name} must be {requirement}, got {value!r}{why}')


def _require(ok: bool, binding: str, requirement: str, value: Any) -> None:
  require(ok, f'gin binding {binding}', requirement, value,
          ': the reward would leave its declared range (-inf, 1]')


def is_real(value: Any) -> bool:
  """A real number: Python/NumPy int or float, or a 0-d numeric array.

  bool (also NumPy's), strings, None and anything else are not.
  """
  if isinstance(value, (bool, np.bool_)):
    return False
  if isinstance(value, numbers.Real):
    return True
  shape, dtype = getattr(value, 'shape', None), getattr(value, 'dtype', None)
  return shape == () and dtype is not None and np.dtype(dtype).kind in 'iuf'


# The flight core computes in float32: a value finite in float64 but beyond
# float32's largest (3.4e38) is inf there (and NaN once multiplied by 0).
FLOAT32_MAX = float(np.finfo(np.float32).max)
# XLA on CPU flushes float32 subnormals to 0: a value below float32's smallest
# normal (1.2e-38) in magnitude is 0 in the core, so "> 0" must mean >= this.
FLOAT32_TINY = float(np.finfo(np.float32).tiny)


def core_float(value: Any) -> float:
  """`value` as the float32 core sees it: rounded, subnormals flushed to 0."""
  x = float(np.float32(value))
  return 0.0 if abs(x) < FLOAT32_TINY else x


def is_positive(value: Any) -> bool:
  """A number (`is_number`) that is > 0 in the float32 core (>= 1.2e-38)."""
  return is_number(value) and core_float(value) > 0


def is_number(value: Any) -> bool:
  """A real number (`is_real`) that is finite in float32 (the core's float).

  1e39 is finite in float64 but inf in float32; every check of a configured
  number refuses it, as it refuses inf and NaN.
  """
  if not is_real(value):
    return False
  try:
    x = float(value)
  except OverflowError:  # An int beyond float64 (10**400).
    return False
  return math.isfinite(x) and abs(x) <= FLOAT32_MAX


def check_number(name: str, value: Any, *, minimum: Optional[float] = None,
                 above: Optional[float] = None,
                 maximum: Optional[float] = None,
                 below: Optional[float] = None, why: str = '') -> float:
  """A finite real number within the given bounds, as float.

  Args:
    name: What the value is (in the message), e.g. 'gin binding
      latex_launch.payload_kg'.
    value: The value.
    minimum: value >= minimum.
    above: value > above.
    maximum: value <= maximum.
    below: value < below.
    why: Appended to the message.

  Returns:
    float(value).

  Raises:
    ValueError: Naming `name`, the requirement and the value (a bool, a
      string or None is not a number).
  """
  parts = [f'{op} {bound:g}' for op, bound in (
      ('>=', minimum), ('>', above), ('<=', maximum), ('<', below))
           if bound is not None]
  requirement = 'a finite number' + (' ' + ' and '.join(parts) if parts
                                     else '')
  if is_real(value) and not is_number(value) and _finite64(value):
    requirement += ' (finite in float32: |x| <= 3.4e38)'
  ok = is_number(value)
  if ok:
    x = float(value)
    ok = ((minimum is None or x >= minimum) and
          (maximum is None or x <= maximum))
    # Strict bounds hold in the float32 core too (1e-40 > 0 in float64 is 0
    # there).
    strict = ((above is None or (x > above and core_float(x) > core_float(
        above))) and (below is None or (x < below and core_float(x) <
                                        core_float(below))))
    if ok and not strict and ((above is None or x > above) and
                              (below is None or x < below)):
      requirement += (' in float32 (|x| >= 1.2e-38: smaller is 0 in the '
                      'core)')
    ok = ok and strict
  require(ok, name, requirement, value, why)
  return float(value)


def _finite64(value: Any) -> bool:
  """Not NaN or inf (an int beyond float64, 10**400, is finite)."""
  try:
    return math.isfinite(float(value))
  except OverflowError:
    return True


def check_int(name: str, value: Any, *, minimum: int,
              maximum: int = 2**31 - 1) -> int:
  """An int (Python or NumPy, not bool) in [minimum, maximum], as int."""
  integer = (isinstance(value, (int, np.integer)) or (
      getattr(value, 'shape', None) == () and
      np.dtype(getattr(value, 'dtype', object)).kind in 'iu'))
  ok = (integer and not isinstance(value, (bool, np.bool_)) and
        minimum <= int(value) <= maximum)
  require(ok, name, f'an int in [{minimum}, {maximum}]', value)
  return int(value)


def check_bool(name: str, value: Any) -> bool:
  """A bool (Python or NumPy), as bool."""
  require(isinstance(value, (bool, np.bool_)), name, 'True or False', value)
  return bool(value)


# -- The reward's declared range (-inf, 1]: checks of its bindings. ----------
def check_penalties(**penalties: Any) -> None:
  """Resource penalties (`latex_reward.*`) must be finite and >= 0."""
  for name, value in penalties.items():
    _require(is_number(value) and value >= 0, f'latex_reward.{name}',
             'a finite number >= 0', value)


def check_reward_values(latex: Mapping[str, Any]) -> None:
  """Checks the reward's values (gin `latex_reward.*`).

  Args:
    latex: Values by `latex_reward` parameter: the penalties (finite,
      >= 0), `reward_dropoff` (in [0, 1]), `reward_halflife_km` (> 0) and
      `reward_tanh_scale_km` (>= 0), each where present.

  Raises:
    ValueError: Naming the first gin binding that breaks the contract.
  """
  check_penalties(**{k: v for k, v in latex.items()
                     if k.endswith('_penalty_per_mol') or
                     k.endswith('_penalty_per_kg')})
  prefix = 'latex_reward.'
  if 'reward_halflife_km' in latex:
    value = latex['reward_halflife_km']
    _require(is_positive(value), prefix + 'reward_halflife_km',
             'a finite number > 0 in float32 (>= 1.2e-38)', value)
  if 'reward_tanh_scale_km' in latex:
    value = latex['reward_tanh_scale_km']
    _require(is_number(value) and (value == 0 or is_positive(value)),
             prefix + 'reward_tanh_scale_km',
             '0 (off) or a finite number > 0 in float32 (>= 1.2e-38)', value)
  if 'reward_dropoff' in latex:
    value = latex['reward_dropoff']
    _require(is_number(value) and 0 <= value <= 1, prefix + 'reward_dropoff',
             'in [0, 1]', value)
