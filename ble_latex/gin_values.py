# coding=utf-8
"""Reading gin bindings without importing the modules that declare them.

A gin binding can only exist for a configurable that is registered: gin
refuses to parse `LatexBalloonEnv.episode_steps = 10` unless the module
declaring `LatexBalloonEnv` was imported (and `skip_unknown=True` drops such
a binding for good). So a configurable whose module is not in `sys.modules`
has no bindings, and its keyword defaults are all there is. That lets the
JAX env (`jax_env.params_from_gin`) read the gym env's gin names
(`LatexBalloonEnv.*`, `LatexBalloonArena.*`, `latex_reward.*`,
`balloon_env.perciatelli_reward_function.*`) without importing BLE's
balloon/env modules and TensorFlow behind them.

Light on purpose: only gin, inspect and sys.
"""

import inspect
import math
import sys
from typing import Any, Callable, Dict, Mapping, Optional

import gin


def effective_bindings(function: Callable[..., Any]) -> Dict[str, Any]:
  """A gin configurable's keyword defaults overridden by its gin bindings."""
  target = inspect.unwrap(function)
  values = {name: p.default for name, p in
            inspect.signature(target).parameters.items()
            if p.default is not inspect.Parameter.empty}
  values.update(gin.get_bindings(function))
  return values


def imported_bindings(module: str, name: str,
                      defaults: Mapping[str, Any]) -> Dict[str, Any]:
  """`effective_bindings` of `module.name` if that module is imported.

  Args:
    module: The module declaring the configurable, e.g. 'ble_latex.envs.gym_env'.
    name: The configurable's attribute in that module.
    defaults: Values when the module is not imported (it then has no
      bindings): the configurable's keyword defaults, restated.

  Returns:
    `defaults` updated with the configurable's keyword defaults and gin
    bindings where `module` is in `sys.modules`, else `defaults`.
  """
  values = dict(defaults)
  loaded = sys.modules.get(module)
  if loaded is not None:
    values.update(effective_bindings(getattr(loaded, name)))
  return values


def registered_bindings(selector: str) -> Dict[str, Any]:
  """gin bindings of `selector`, or {} if no such configurable is registered."""
  try:
    return gin.get_bindings(selector)
  except ValueError:  # "Could not find ... in the Gin registry".
    return {}


def bound(module: str, name: str) -> Dict[str, Any]:
  """Only the gin-bound values of `module.name` ({} if not imported)."""
  loaded = sys.modules.get(module)
  return {} if loaded is None else gin.get_bindings(getattr(loaded, name))


# -- The reward's declared range (-inf, 1]: checks of its bindings. ----------
def _require(ok: bool, binding: str, requirement: str, value: Any) -> None:
  if not ok:
    raise ValueError(f'gin binding {binding} must be {requirement}, got '
                     f'{value!r}: the reward would leave its declared range '
                     '(-inf, 1]')


def is_number(value: Any) -> bool:
  return (isinstance(value, (int, float)) and not isinstance(value, bool) and
          math.isfinite(value))


def check_penalties(**penalties: Any) -> None:
  """Resource penalties (`latex_reward.*`) must be finite and >= 0."""
  for name, value in penalties.items():
    _require(is_number(value) and value >= 0, f'latex_reward.{name}',
             'a finite number >= 0', value)


def check_reward_values(latex: Mapping[str, Any],
                        perciatelli: Optional[Mapping[str, Any]]) -> None:
  """Checks `latex_reward.*` and `perciatelli_reward_function.*` values.

  Args:
    latex: `latex_reward`'s effective values (penalties are checked).
    perciatelli: BLE's `perciatelli_reward_function` effective values.

  Raises:
    ValueError: Naming the first gin binding that breaks the contract.
  """
  check_penalties(**{k: v for k, v in latex.items()
                     if k.endswith('_penalty_per_mol') or
                     k.endswith('_penalty_per_kg')})
  ble = perciatelli or {}
  prefix = 'perciatelli_reward_function.'
  for name in ('station_keeping_radius_km', 'reward_halflife'):
    if name in ble:
      _require(is_number(ble[name]) and ble[name] > 0, prefix + name,
               'a finite number > 0', ble[name])
  if 'reward_dropoff' in ble:
    value = ble['reward_dropoff']
    _require(is_number(value) and 0 <= value <= 1, prefix + 'reward_dropoff',
             'in [0, 1]', value)
