# coding=utf-8
# The retired NumPy float64 model (ble_latex before the JAX flight core,
# commit dcfa0e1), kept only as an independent oracle for the tests
# (the core's tests in tests/flight compare the core against it, setup in
# oracle_cases.py; test_physics.py and test_controller.py also keep the oracle
# honest). Not part of the package;
# gin registrations removed (the package owns those names).
"""Vertical physics of a zero-superpressure latex balloon.

Paper section "Equations of Motion".

Pure functions of the paper's equations (numpy, scalar-friendly; no state).
Helium is at ambient temperature and pressure (V = nRT/P), so buoyancy
rho*V*g = n*M_air*g exactly and the free lift

  L = n (M_air - M_He) - m_p - m_s                                   # [kg]

does not depend on altitude. Between two actuations only the drag factor
k(h) = 1/2 rho c_d A, proportional to (P/T)^(1/3), changes with altitude.

| paper equation                          | function                          |
|-----------------------------------------|-----------------------------------|
| ideal gas V = nRT/P                     | `volume`                          |
| rho = P M_a / (R T)                     | `air_density`                     |
| A = pi (3V / 4 pi)^(2/3)                | `drag_area`                       |
| F_b = rho V g                           | `buoyancy_force`                  |
| F_d = 1/2 rho c_d A abs(hdot) hdot      | `drag_force`                      |
| F_w = (m_p + m_h + m_s) g               | `total_mass`, `weight_force`      |
| Eq. fullN2L (hddot)                     | `acceleration`                    |
| Eq. fullN2L, exact for frozen k         | `relax`                           |
| Eq. fullN2L, k(h) re-evaluated          | `integrate_vertical`              |
| Eq. fullN2L, fine-step reference        | `rk4_vertical`                    |
| Eq. fullN2L = 0 (steady-state residual) | `force_balance_residual`          |
| vent polynomial (Eq. vent)              | `vent_polynomial`,                |
|                                         | `vent_target_mols`                |
| ballast equation (Eq. ballast)          | `ballast_target_sand`             |
| float case equations (Eq. float)        | `neutral_helium_mols`,            |
|                                         | `neutral_sand_kg`                 |

The printed vent and ballast equations have typos (see README): they are
derived here from the force balance (buoyancy = n M_air g; the ballast drag
term has rho).
"""

import math
from typing import Callable, Tuple, Union

from balloon_learning_environment.utils import constants
import numpy as np

ArrayLike = Union[float, np.ndarray]

GRAVITY = constants.GRAVITY  # [m/s^2]
GAS_CONSTANT = constants.UNIVERSAL_GAS_CONSTANT  # [J/(mol K)]
AIR_MOLAR_MASS = constants.DRY_AIR_MOLAR_MASS  # [kg/mol]
HELIUM_MOLAR_MASS = constants.HE_MOLAR_MASS  # [kg/mol]
# Net lift of one mol of helium at ambient T and P: M_air - M_He. # [kg/mol]
LIFT_PER_MOL = AIR_MOLAR_MASS - HELIUM_MOLAR_MASS

# Below this magnitude the free lift is treated as exactly zero. # [N]
_ZERO_LIFT_N = 1e-12


def volume(helium_mols: ArrayLike, temperature: ArrayLike,
           pressure: ArrayLike) -> ArrayLike:
  """Envelope volume from the ideal gas law, V = nRT/P. # [m^3]

  Args:
    helium_mols: Helium in the envelope. # [mol]
    temperature: Ambient (= helium) temperature. # [K]
    pressure: Ambient (= helium) pressure. # [Pa]
  """
  return helium_mols * GAS_CONSTANT * temperature / pressure


def air_density(temperature: ArrayLike, pressure: ArrayLike) -> ArrayLike:
  """Dry-air density rho = P M_a / (R T). # [kg/m^3]"""
  return pressure * AIR_MOLAR_MASS / (GAS_CONSTANT * temperature)


def drag_area(envelope_volume: ArrayLike) -> ArrayLike:
  """Cross-section of a spherical envelope, A = pi (3V / 4pi)^(2/3). # [m^2]"""
  return np.pi * (3.0 * envelope_volume / (4.0 * np.pi))**(2.0 / 3.0)


def buoyancy_force(density: ArrayLike, envelope_volume: ArrayLike) -> ArrayLike:
  """F_b = rho V g. # [N]"""
  return density * envelope_volume * GRAVITY


def drag_force(density: ArrayLike, drag_coefficient: ArrayLike,
               area: ArrayLike, ascent_rate: ArrayLike) -> ArrayLike:
  """F_d = 1/2 rho c_d A |hdot| hdot (opposes the motion). # [N]"""
  return 0.5 * density * drag_coefficient * area * np.abs(
      ascent_rate) * ascent_rate


def total_mass(payload_kg: ArrayLike, sand_kg: ArrayLike,
               helium_mols: ArrayLike) -> ArrayLike:
  """m = m_p + m_s + n M_He (payload includes the envelope). # [kg]"""
  return payload_kg + sand_kg + helium_mols * HELIUM_MOLAR_MASS


def weight_force(payload_kg: ArrayLike, sand_kg: ArrayLike,
                 helium_mols: ArrayLike) -> ArrayLike:
  """F_w = (m_p + m_h + m_s) g. # [N]"""
  return total_mass(payload_kg, sand_kg, helium_mols) * GRAVITY


def free_lift(helium_mols: ArrayLike, payload_kg: ArrayLike,
              sand_kg: ArrayLike) -> ArrayLike:
  """Free lift L = n (M_air - M_He) - m_p - m_s, altitude independent. # [kg]

  (F_b - F_w) / g, using rho V = n M_air for helium at ambient T and P.
  """
  return helium_mols * LIFT_PER_MOL - payload_kg - sand_kg


def drag_factor(helium_mols: ArrayLike, drag_coefficient: ArrayLike,
                temperature: ArrayLike, pressure: ArrayLike) -> ArrayLike:
  """k = 1/2 rho c_d A, so that F_d = k |hdot| hdot. # [kg/m]"""
  v = volume(helium_mols, temperature, pressure)
  return 0.5 * air_density(temperature, pressure) * drag_coefficient * (
      drag_area(v))


def acceleration(ascent_rate: ArrayLike, helium_mols: ArrayLike,
                 payload_kg: ArrayLike, sand_kg: ArrayLike,
                 drag_coefficient: ArrayLike, temperature: ArrayLike,
                 pressure: ArrayLike) -> ArrayLike:
  """Implements Eq. fullN2L.

  hddot = (rho V g - 1/2 rho c_d A |hdot| hdot - m g) / m.

  Args:
    ascent_rate: hdot. # [m/s]
    helium_mols: n. # [mol]
    payload_kg: m_p, including the envelope. # [kg]
    sand_kg: m_s. # [kg]
    drag_coefficient: c_d. # [.]
    temperature: Ambient temperature T. # [K]
    pressure: Ambient pressure P. # [Pa]

  Returns:
    hddot. # [m/s^2]
  """
  rho = air_density(temperature, pressure)
  v = volume(helium_mols, temperature, pressure)
  m = total_mass(payload_kg, sand_kg, helium_mols)
  return (buoyancy_force(rho, v) -
          drag_force(rho, drag_coefficient, drag_area(v), ascent_rate) -
          m * GRAVITY) / m


def force_balance_residual(ascent_rate: ArrayLike, helium_mols: ArrayLike,
                           payload_kg: ArrayLike, sand_kg: ArrayLike,
                           drag_coefficient: ArrayLike, temperature: ArrayLike,
                           pressure: ArrayLike) -> ArrayLike:
  """Net force m * hddot of Eq. fullN2L; 0 at steady state. # [N]"""
  m = total_mass(payload_kg, sand_kg, helium_mols)
  return m * acceleration(ascent_rate, helium_mols, payload_kg, sand_kg,
                          drag_coefficient, temperature, pressure)


def terminal_velocity(lift_force: float, drag_k: float) -> float:
  """Steady ascent rate of Eq. fullN2L, sign(L) sqrt(|L g| / k). # [m/s]

  Args:
    lift_force: Free lift force L g = F_b - F_w. # [N]
    drag_k: Drag factor k = 1/2 rho c_d A. # [kg/m]
  """
  return math.copysign(math.sqrt(abs(lift_force) / drag_k), lift_force)


def _log_cosh(s: float) -> float:
  """log(cosh(s)) for s >= 0 without overflow."""
  return s + math.log1p(math.exp(-2.0 * s)) - math.log(2.0)


def relax(ascent_rate: float, duration: float, *, lift_force: float,
          mass: float, drag_k: float) -> Tuple[float, float]:
  """Exact solution of Eq. fullN2L over `duration` with the drag factor frozen.

  Solves m hddot = F - k |hdot| hdot with constant F (free lift force), m and
  k in closed form; stiff-safe for any duration. With w = sign(F) hdot,
  v_t = sqrt(|F|/k), tau = m / sqrt(|F| k), u0 = w0 / v_t, s = t / tau:
    * w0 >= 0 (moving with the lift or at rest): tanh/coth relaxation,
      w = v_t (u0 + tanh s) / (1 + u0 tanh s),
      dh = v_t tau [log cosh s + log(1 + u0 tanh s)];
    * w0 < 0 (moving against the lift): tan-phase deceleration,
      w = v_t (u0 + tan s) / (1 - u0 tan s),
      dh = -v_t tau log(cos s - u0 sin s), until w = 0 at s = atan(-u0),
      then the first case from rest;
    * F = 0: w = w0 / (1 + k |w0| t / m), dh = sign(w0) (m/k) log(1 + k|w0|t/m);
    * k = 0 (no envelope): uniform acceleration F/m.

  Args:
    ascent_rate: Initial hdot. # [m/s]
    duration: Time to advance, >= 0. # [s]
    lift_force: F = F_b - F_w. # [N]
    mass: m = m_p + m_s + n M_He. # [kg]
    drag_k: k = 1/2 rho c_d A, >= 0. # [kg/m]

  Returns:
    (altitude change [m], final ascent rate [m/s]).
  """
  t = float(duration)
  v0 = float(ascent_rate)
  if t <= 0.0:
    return 0.0, v0
  if drag_k <= 0.0:
    acc = lift_force / mass
    return v0 * t + 0.5 * acc * t * t, v0 + acc * t
  if abs(lift_force) < _ZERO_LIFT_N:
    if v0 == 0.0:
      return 0.0, 0.0
    c = drag_k * abs(v0) / mass  # [1/s]
    return (math.copysign(mass / drag_k * math.log1p(c * t), v0),
            v0 / (1.0 + c * t))
  sign = 1.0 if lift_force > 0.0 else -1.0
  f = abs(lift_force)
  v_t = math.sqrt(f / drag_k)  # [m/s]
  tau = mass / math.sqrt(f * drag_k)  # [s]
  w0 = sign * v0
  s = t / tau
  dh = 0.0
  if w0 < 0.0:
    u0 = w0 / v_t
    s_stop = math.atan(-u0)
    if s < s_stop:
      tan_s = math.tan(s)
      w = v_t * (u0 + tan_s) / (1.0 - u0 * tan_s)
      dh = -v_t * tau * math.log(math.cos(s) - u0 * math.sin(s))
      return sign * dh, sign * w
    dh = v_t * tau * math.log(math.cos(s_stop))
    s -= s_stop
    w0 = 0.0
  u0 = w0 / v_t
  tanh_s = math.tanh(s)
  w = v_t * (u0 + tanh_s) / (1.0 + u0 * tanh_s)
  dh += v_t * tau * (_log_cosh(s) + math.log1p(u0 * tanh_s))
  return sign * dh, sign * w


def integrate_vertical(
    altitude: float, ascent_rate: float, duration: float, *,
    lift_force: float, mass: float, drag_k_at: Callable[[float], float],
    max_step: float = 60.0) -> Tuple[float, float]:
  """Integrates Eq. fullN2L with k(h) varying along the path.

  Steps of at most `max_step` seconds, each solved exactly by `relax` (so the
  stiff relaxation to terminal velocity is exact and unconditionally
  stable). Per step: a predictor with k at the start altitude, the altitude
  change with k frozen at the predicted midpoint altitude, and the new
  ascent rate with k at the new altitude (the rate relaxes within seconds to
  the terminal velocity of where the balloon is). Against a dt = 0.05 s RK4
  over 20-minute strides at up to 5.8 m/s: altitude within 0.04 %, ascent
  rate within 0.05 % (tests/flight/test_physics.py).

  Args:
    altitude: Initial h. # [m]
    ascent_rate: Initial hdot. # [m/s]
    duration: Time to advance. # [s]
    lift_force: F_b - F_w, constant between actuations. # [N]
    mass: Total mass. # [kg]
    drag_k_at: h -> k(h) = 1/2 rho(h) c_d A(h). # [kg/m]
    max_step: Longest exactly-solved step. # [s]

  Returns:
    (final altitude [m], final ascent rate [m/s]).
  """
  if duration <= 0.0:
    return float(altitude), float(ascent_rate)
  n = max(1, int(math.ceil(duration / max_step - 1e-9)))
  dt = duration / n
  h, v = float(altitude), float(ascent_rate)
  for _ in range(n):
    dh_pred, _ = relax(v, dt, lift_force=lift_force, mass=mass,
                       drag_k=drag_k_at(h))
    dh, _ = relax(v, dt, lift_force=lift_force, mass=mass,
                  drag_k=drag_k_at(h + 0.5 * dh_pred))
    # The velocity relaxes within seconds to the terminal velocity of the
    # current altitude, so it is taken with k at the end of the step.
    _, v = relax(v, dt, lift_force=lift_force, mass=mass,
                 drag_k=drag_k_at(h + dh))
    h += dh
  return h, v


def rk4_vertical(
    altitude: float, ascent_rate: float, duration: float, *,
    lift_force: float, mass: float, drag_k_at: Callable[[float], float],
    dt: float = 0.05) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
  """Fine-step classical RK4 of Eq. fullN2L; the reference for tests/validation.

  Args:
    altitude: Initial h. # [m]
    ascent_rate: Initial hdot. # [m/s]
    duration: Time to advance. # [s]
    lift_force: F_b - F_w. # [N]
    mass: Total mass. # [kg]
    drag_k_at: h -> k(h). # [kg/m]
    dt: RK4 step. # [s]

  Returns:
    (times [s], altitudes [m], ascent rates [m/s]), including t = 0.
  """
  n = max(1, int(math.ceil(duration / dt - 1e-9)))
  step = duration / n
  ts = np.linspace(0.0, duration, n + 1)
  hs = np.empty(n + 1)
  vs = np.empty(n + 1)
  h, v = float(altitude), float(ascent_rate)
  hs[0], vs[0] = h, v

  def acc(hh: float, vv: float) -> float:
    return (lift_force - drag_k_at(hh) * abs(vv) * vv) / mass

  for i in range(n):
    k1h, k1v = v, acc(h, v)
    k2h, k2v = v + 0.5 * step * k1v, acc(h + 0.5 * step * k1h,
                                         v + 0.5 * step * k1v)
    k3h, k3v = v + 0.5 * step * k2v, acc(h + 0.5 * step * k2h,
                                         v + 0.5 * step * k2v)
    k4h, k4v = v + step * k3v, acc(h + step * k3h, v + step * k3v)
    h += step / 6.0 * (k1h + 2.0 * k2h + 2.0 * k3h + k4h)
    v += step / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v)
    hs[i + 1], vs[i + 1] = h, v
  return ts, hs, vs


def vent_polynomial(payload_kg: float, sand_kg: float, ascent_rate: float,
                    drag_coefficient: float, temperature: float,
                    pressure: float) -> np.ndarray:
  """Coefficients of the vent polynomial in s = n^(1/3) (Eq. vent).

  Steady state of Eq. fullN2L with V = nRT/P:
    g (M_air - M_He) s^3 - b s^2 - (m_p + m_s) g = 0,
    b = 1/2 rho c_d pi (3RT / (4 pi P))^(2/3) |hdot| hdot.

  Returns:
    [a3, a2, a1, a0] for numpy.roots (highest power first).
  """
  rho = air_density(temperature, pressure)
  b = 0.5 * rho * drag_coefficient * np.pi * (
      3.0 * GAS_CONSTANT * temperature / (4.0 * np.pi * pressure))**(
          2.0 / 3.0) * abs(ascent_rate) * ascent_rate
  return np.array([GRAVITY * LIFT_PER_MOL, -b, 0.0,
                   -(payload_kg + sand_kg) * GRAVITY])


def vent_target_mols(payload_kg: float, sand_kg: float, ascent_rate: float,
                     drag_coefficient: float, temperature: float,
                     pressure: float) -> float:
  """Implements Eq. vent: helium n_calc with steady ascent rate `ascent_rate`.

  The vent polynomial (`vent_polynomial`) has exactly one positive real
  root s (its value at 0 is negative, it grows to +inf and has at most one
  interior minimum for s > 0); n_calc = s^3. The root from numpy.roots is
  polished by Newton steps. Scalars only.

  Args:
    payload_kg: m_p. # [kg]
    sand_kg: m_s aboard (unchanged by venting). # [kg]
    ascent_rate: Desired steady hdot. # [m/s]
    drag_coefficient: c_d. # [.]
    temperature: T at the balloon. # [K]
    pressure: P at the balloon. # [Pa]

  Returns:
    Target helium n_calc. # [mol]

  Raises:
    ValueError: non-finite or non-physical inputs.
  """
  _check_finite(payload_kg=payload_kg, sand_kg=sand_kg,
                ascent_rate=ascent_rate, drag_coefficient=drag_coefficient,
                temperature=temperature, pressure=pressure)
  if payload_kg + sand_kg <= 0.0 or temperature <= 0.0 or pressure <= 0.0:
    raise ValueError('vent_target_mols needs m_p + m_s > 0, T > 0, P > 0; got '
                     f'm_p={payload_kg}, m_s={sand_kg}, T={temperature}, '
                     f'P={pressure}')
  coeffs = vent_polynomial(payload_kg, sand_kg, ascent_rate, drag_coefficient,
                           temperature, pressure)
  roots = np.roots(coeffs)
  real = roots[np.abs(roots.imag) <= 1e-7 * np.maximum(1.0, np.abs(roots))]
  positive = real.real[real.real > 0.0]
  if positive.size == 0:  # Not expected; fall back to the neutral root.
    s = ((payload_kg + sand_kg) / LIFT_PER_MOL)**(1.0 / 3.0)
  else:
    s = float(np.max(positive))
  a3, a2, _, a0 = coeffs
  for _ in range(3):
    f = (a3 * s + a2) * s * s + a0
    df = (3.0 * a3 * s + 2.0 * a2) * s
    if df <= 0.0:
      break
    s -= f / df
  return float(s**3)


def ballast_target_sand(helium_mols: float, payload_kg: float,
                        ascent_rate: float, drag_coefficient: float,
                        temperature: float, pressure: float) -> float:
  """Implements Eq. ballast: sand m_s_calc with steady rate `ascent_rate`.

  m_s_calc = rho V - rho c_d A |hdot| hdot / (2 g) - m_p - n M_He
  (the printed equation lacks the rho in the drag term). May be negative
  when the rate cannot be reached even with all sand dropped.

  Returns:
    Target sand mass. # [kg]
  """
  _check_finite(helium_mols=helium_mols, payload_kg=payload_kg,
                ascent_rate=ascent_rate, drag_coefficient=drag_coefficient,
                temperature=temperature, pressure=pressure)
  rho = air_density(temperature, pressure)
  v = volume(helium_mols, temperature, pressure)
  return float(rho * v - rho * drag_coefficient * drag_area(v) *
               abs(ascent_rate) * ascent_rate / (2.0 * GRAVITY) - payload_kg -
               helium_mols * HELIUM_MOLAR_MASS)


def neutral_helium_mols(payload_kg: ArrayLike, sand_kg: ArrayLike) -> ArrayLike:
  """Eq. float (vent case): n_calc = (m_s + m_p) / (M_air - M_He). # [mol]"""
  return (payload_kg + sand_kg) / LIFT_PER_MOL


def neutral_sand_kg(helium_mols: ArrayLike, payload_kg: ArrayLike) -> ArrayLike:
  """Eq. float (ballast case). # [kg]

  m_s_calc = rho V - m_p - m_h = n (M_air - M_He) - m_p.
  """
  return helium_mols * LIFT_PER_MOL - payload_kg


def _check_finite(**values: float) -> None:
  for name, value in values.items():
    if not np.all(np.isfinite(value)):
      raise ValueError(f'{name} must be finite, got {value!r}')
