# coding=utf-8
# The retired NumPy float64 model (ble_latex before the JAX flight core,
# commit dcfa0e1), kept only as an independent oracle for the tests
# (the core's tests in tests/flight compare the core against it, setup in
# oracle_cases.py; test_physics.py and test_controller.py also keep the oracle
# honest). Not part of the package;
# gin registrations removed (the package owns those names).
"""Vent/ballast altitude controller (Eq. fullcontroller).

Paper section "Altitude Controller".

The agent's action is (a0 desired altitude [m], a1 time factor [.], a2 float
flag [.]). Every stride (20 min) the controller turns it into an amount of
helium to vent or sand to drop:

  hdot_des = (a0 - h) / (a1 * stride)                       (Eq. hdot_des)

  Float      if a2 > 0                     -> neutral buoyancy (Eq. float)
  Do nothing if vent < n_min or drop < m_s_min
  Ballast    if hdot_des > hdot            -> sand from Eq. ballast
  Vent       if hdot_des < hdot            -> helium from Eq. vent

plus the altitude-band guard: outside [band_low_m, band_high_m] the
controller floats unless its decision moves the balloon back into the band.
Float takes precedence and is exact (no thresholds), as in the paper's case
order. Amounts never exceed what is aboard.
"""

import dataclasses
import datetime as dt
import enum
import math
from typing import Any

import numpy as np

from . import numpy_physics as physics

# Action bounds (a0 [m], a1 [.], a2 [.]), paper "Method".
ACTION_LOW = np.array([14_000.0, 1.0, -1.0], dtype=np.float32)
ACTION_HIGH = np.array([21_000.0, 5.0, 1.0], dtype=np.float32)
# Controller stride Delta t between actions.
STRIDE = dt.timedelta(minutes=20)

DEFAULT_MIN_VENT_MOLS = 0.2  # [mol] ~5 g of lift
DEFAULT_MIN_DROP_KG = 0.005  # [kg]
DEFAULT_BAND_LOW_M = 13_000.0  # [m]
DEFAULT_BAND_HIGH_M = 22_000.0  # [m]


class Decision(enum.Enum):
  """What the controller did at an action (values are the info strings)."""
  NOTHING = 'nothing'
  FLOAT = 'float'
  VENT = 'vent'
  BALLAST = 'ballast'


@dataclasses.dataclass(frozen=True)
class Actuation:
  """The controller's output for one action.

  Attributes:
    decision: Float / vent / ballast / nothing.
    desired_ascent_rate: hdot_des (0 for float). # [m/s]
    vent_mols: Helium to vent, 0 <= vent_mols <= helium aboard. # [mol]
    drop_kg: Sand to drop, 0 <= drop_kg <= sand aboard. # [kg]
    guarded: True when the altitude-band guard replaced the decision by float.
  """
  decision: Decision
  desired_ascent_rate: float
  vent_mols: float = 0.0
  drop_kg: float = 0.0
  guarded: bool = False


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


class AltitudeController:
  """Eq. fullcontroller: maps (a0, a1, a2) to a vent or ballast amount."""

  def __init__(self,
               *,
               stride: dt.timedelta = STRIDE,
               min_vent_mols: float = DEFAULT_MIN_VENT_MOLS,
               min_drop_kg: float = DEFAULT_MIN_DROP_KG,
               band_low_m: float = DEFAULT_BAND_LOW_M,
               band_high_m: float = DEFAULT_BAND_HIGH_M):
    """Constructor.

    Args:
      stride: Delta t in hdot_des = (a0 - h) / (a1 Delta t).
      min_vent_mols: n_min, smallest ventable helium. # [mol]
      min_drop_kg: m_s_min, smallest droppable sand; also the out-of-sand
        threshold. # [kg]
      band_low_m: Lower edge of the allowed altitude band. # [m]
      band_high_m: Upper edge of the allowed altitude band. # [m]

    Raises:
      ValueError: for non-finite, negative or inconsistent values.
    """
    if not isinstance(stride, dt.timedelta) or stride.total_seconds() <= 0:
      raise ValueError(f'stride must be a positive timedelta, got {stride!r}')
    for name, value in (('min_vent_mols', min_vent_mols),
                        ('min_drop_kg', min_drop_kg)):
      if not math.isfinite(value) or value < 0:
        raise ValueError(f'{name} must be finite and >= 0, got {value}')
    if not (math.isfinite(band_low_m) and math.isfinite(band_high_m) and
            band_low_m < band_high_m):
      raise ValueError(f'band must satisfy band_low_m < band_high_m (finite), '
                       f'got [{band_low_m}, {band_high_m}]')
    self.stride = stride
    self.min_vent_mols = float(min_vent_mols)
    self.min_drop_kg = float(min_drop_kg)
    self.band_low_m = float(band_low_m)
    self.band_high_m = float(band_high_m)

  def desired_ascent_rate(self, altitude_m: float, a0: float,
                          a1: float) -> float:
    """Implements Eq. hdot_des = (a0 - h) / (a1 Delta t). # [m/s]"""
    return (a0 - altitude_m) / (a1 * self.stride.total_seconds())

  def float_actuation(self, *, helium_mols: float, sand_kg: float,
                      payload_kg: float, guarded: bool = False) -> Actuation:
    """Implements Eq. float: vent or drop to neutral buoyancy (drag 0).

    If the buoyancy exceeds the weight, vents n - (m_p + m_s)/(M_air - M_He);
    otherwise drops m_s - (n (M_air - M_He) - m_p), capped at the sand aboard.
    """
    lift = physics.free_lift(helium_mols, payload_kg, sand_kg)  # [kg]
    vent, drop = 0.0, 0.0
    if lift > 0.0:
      vent = min(helium_mols - physics.neutral_helium_mols(payload_kg, sand_kg),
                 helium_mols)
    elif lift < 0.0:
      drop = min(sand_kg - physics.neutral_sand_kg(helium_mols, payload_kg),
                 sand_kg)
    return Actuation(Decision.FLOAT, 0.0, max(vent, 0.0), max(drop, 0.0),
                     guarded)

  def decide(self, action: Any, *, altitude_m: float, ascent_rate_mps: float,
             helium_mols: float, sand_kg: float, payload_kg: float,
             drag_coefficient: float, temperature: float,
             pressure: float) -> Actuation:
    """Implements Eq. fullcontroller for one action.

    Args:
      action: (a0, a1, a2); validated by `validate_action`.
      altitude_m: Current altitude h_t. # [m]
      ascent_rate_mps: Current ascent rate hdot_t. # [m/s]
      helium_mols: Helium aboard n. # [mol]
      sand_kg: Sand aboard m_s. # [kg]
      payload_kg: m_p, including the envelope. # [kg]
      drag_coefficient: c_d. # [.]
      temperature: Ambient T at the balloon. # [K]
      pressure: Ambient P at the balloon. # [Pa]

    Returns:
      The actuation (amounts already capped at what is aboard).

    Raises:
      ValueError: for a bad action or non-finite / non-physical state.
    """
    a0, a1, a2 = validate_action(action)
    values = dict(altitude_m=altitude_m, ascent_rate_mps=ascent_rate_mps,
                  helium_mols=helium_mols, sand_kg=sand_kg,
                  payload_kg=payload_kg, drag_coefficient=drag_coefficient,
                  temperature=temperature, pressure=pressure)
    for name, value in values.items():
      if not math.isfinite(value):
        raise ValueError(f'{name} must be finite, got {value}')
    for name in ('helium_mols', 'sand_kg', 'payload_kg'):
      if values[name] < 0:
        raise ValueError(f'{name} must be >= 0, got {values[name]}')
    for name in ('drag_coefficient', 'temperature', 'pressure'):
      if values[name] <= 0:
        raise ValueError(f'{name} must be > 0, got {values[name]}')

    if a2 > 0.0:
      return self.float_actuation(helium_mols=helium_mols, sand_kg=sand_kg,
                                  payload_kg=payload_kg)

    rate = self.desired_ascent_rate(altitude_m, a0, a1)
    actuation = Actuation(Decision.NOTHING, rate)
    if rate > ascent_rate_mps:
      target = physics.ballast_target_sand(helium_mols, payload_kg, rate,
                                           drag_coefficient, temperature,
                                           pressure)
      drop = min(sand_kg - target, sand_kg)
      if drop >= self.min_drop_kg and drop > 0.0:
        actuation = Actuation(Decision.BALLAST, rate, drop_kg=drop)
    elif rate < ascent_rate_mps:
      target = physics.vent_target_mols(payload_kg, sand_kg, rate,
                                        drag_coefficient, temperature,
                                        pressure)
      vent = min(helium_mols - target, helium_mols)
      if vent >= self.min_vent_mols and vent > 0.0:
        actuation = Actuation(Decision.VENT, rate, vent_mols=vent)

    if not self._moves_into_band(altitude_m, actuation, ascent_rate_mps):
      return self.float_actuation(helium_mols=helium_mols, sand_kg=sand_kg,
                                  payload_kg=payload_kg, guarded=True)
    return actuation

  def outside_band_moving_out(self, altitude_m: float,
                              ascent_rate_mps: float) -> bool:
    """True when h is outside the band and hdot does not point back in."""
    return ((altitude_m < self.band_low_m and ascent_rate_mps <= 0.0) or
            (altitude_m > self.band_high_m and ascent_rate_mps >= 0.0))

  def _moves_into_band(self, altitude_m: float, actuation: Actuation,
                       ascent_rate_mps: float) -> bool:
    """Altitude-band guard: may this decision stand at this altitude?"""
    if self.band_low_m <= altitude_m <= self.band_high_m:
      return True
    if actuation.decision == Decision.NOTHING:
      resulting_rate = ascent_rate_mps
    else:
      resulting_rate = actuation.desired_ascent_rate
    return not self.outside_band_moving_out(altitude_m, resulting_rate)
