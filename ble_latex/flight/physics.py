# coding=utf-8
"""Vertical physics of a zero-superpressure latex balloon, in JAX.

Paper section "Equations of Motion" (docs/physics-model.md has the
derivations). The equations are written branch-free
(`jnp.where` on safe operands, so neither values nor gradients of an unused
branch can leak NaN/inf), jittable, vmappable and working in float32 or, in
a caller's `jax.enable_x64(True)` scope, float64.

| paper equation                          | function                          |
|-----------------------------------------|-----------------------------------|
| ideal gas V = nRT/P                     | `volume`                          |
| rho = P M_a / (R T)                     | `air_density`                     |
| A = pi (3V / 4 pi)^(2/3)                | `drag_area`                       |
| F_b = rho V g                           | `buoyancy_force`                  |
| F_d = 1/2 rho c_d A abs(hdot) hdot      | `drag_force`                      |
| F_w = (m_p + m_h + m_s) g               | `total_mass`, `weight_force`      |
| free lift (F_b - F_w) / g               | `free_lift`                       |
| k = 1/2 rho c_d A                       | `drag_factor`                     |
| Eq. fullN2L (hddot)                     | `acceleration`                    |
| Eq. fullN2L = 0 (steady-state residual) | `force_balance_residual`          |
| Eq. fullN2L, steady state               | `terminal_velocity`               |
| Eq. fullN2L, exact for frozen k         | `relax`                           |
| Eq. fullN2L, k(h) re-evaluated          | `vertical_step`,                  |
|                                         | `integrate_vertical`              |
| vent polynomial (Eq. vent)              | `vent_coefficients`, `vent_root`, |
|                                         | `vent_target_mols`,               |
|                                         | `vent_target_lift_kg`             |
| ballast equation (Eq. ballast)          | `ballast_target_sand`,            |
|                                         | `ballast_target_lift_kg`          |
| float case equations (Eq. float)        | `neutral_helium_mols`,            |
|                                         | `neutral_sand_kg`                 |

Helium is at ambient T and P, so the free lift L = n (M_air - M_He) - m_p -
m_s [kg] does not depend on altitude. In float32 that difference cancels to
~4e-7 kg (one ulp of n ~ 168 mol), i.e. a spurious ~4 mm/s terminal velocity
of a "neutral" balloon; the flight core therefore carries L in its state and
obtains it from the controller's targets directly (`vent_target_lift_kg`,
`ballast_target_lift_kg`: the steady-state lift k hdot |hdot| / g), which is
exact to float32 precision relative to L itself.
"""

import math
from typing import Callable, Optional, Tuple

from balloon_learning_environment.utils import constants
import jax
import jax.numpy as jnp

Array = jax.Array

GRAVITY = constants.GRAVITY  # [m/s^2]
GAS_CONSTANT = constants.UNIVERSAL_GAS_CONSTANT  # [J/(mol K)]
AIR_MOLAR_MASS = constants.DRY_AIR_MOLAR_MASS  # [kg/mol]
HELIUM_MOLAR_MASS = constants.HE_MOLAR_MASS  # [kg/mol]
# Net lift of one mol of helium at ambient T and P: M_air - M_He. # [kg/mol]
LIFT_PER_MOL = AIR_MOLAR_MASS - HELIUM_MOLAR_MASS

# Below this magnitude the free lift force is exactly zero (as NumPy). # [N]
ZERO_LIFT_N = 1e-12
# Newton iterations of the vent cubic (converged for any physical input;
# see `vent_root`).
VENT_NEWTON_ITERATIONS = 8


def volume(helium_mols: Array, temperature: Array, pressure: Array) -> Array:
  """Envelope volume from the ideal gas law, V = nRT/P. # [m^3]

  Args:
    helium_mols: Helium in the envelope n. # [mol]
    temperature: Ambient (= helium) temperature T. # [K]
    pressure: Ambient (= helium) pressure P. # [Pa]
  """
  return helium_mols * GAS_CONSTANT * temperature / pressure


def air_density(temperature: Array, pressure: Array) -> Array:
  """Dry-air density rho = P M_a / (R T). # [kg/m^3]

  Args:
    temperature: Air temperature T. # [K]
    pressure: Air pressure P. # [Pa]

  Returns:
    Air density rho. # [kg/m^3]
  """
  return pressure * AIR_MOLAR_MASS / (GAS_CONSTANT * temperature)


def drag_area(envelope_volume: Array) -> Array:
  """Cross-section of a spherical envelope, A = pi (3V / 4pi)^(2/3). # [m^2]"""
  return jnp.pi * (3.0 * envelope_volume / (4.0 * jnp.pi))**(2.0 / 3.0)


def buoyancy_force(density: Array, envelope_volume: Array) -> Array:
  """F_b = rho V g. # [N]

  Args:
    density: Air density rho. # [kg/m^3]
    envelope_volume: Envelope volume V. # [m^3]

  Returns:
    Buoyancy force F_b. # [N]
  """
  return density * envelope_volume * GRAVITY


def drag_force(density: Array, drag_coefficient: Array, area: Array,
               ascent_rate: Array) -> Array:
  """F_d = 1/2 rho c_d A |hdot| hdot (opposes the motion). # [N]

  Args:
    density: Air density rho. # [kg/m^3]
    drag_coefficient: c_d. # [.]
    area: Cross-section A. # [m^2]
    ascent_rate: hdot (positive upwards). # [m/s]

  Returns:
    Drag force F_d, with the sign of hdot. # [N]
  """
  return 0.5 * density * drag_coefficient * area * jnp.abs(
      ascent_rate) * ascent_rate


def total_mass(payload_kg: Array, sand_kg: Array, helium_mols: Array) -> Array:
  """F_w / g: m = m_p + m_s + n M_He (payload includes the envelope). # [kg]

  Args:
    payload_kg: m_p, including the envelope. # [kg]
    sand_kg: m_s. # [kg]
    helium_mols: n. # [mol]

  Returns:
    Total mass m. # [kg]
  """
  return payload_kg + sand_kg + helium_mols * HELIUM_MOLAR_MASS


def weight_force(payload_kg: Array, sand_kg: Array,
                 helium_mols: Array) -> Array:
  """F_w = (m_p + m_h + m_s) g. # [N]

  Args:
    payload_kg: m_p, including the envelope. # [kg]
    sand_kg: m_s. # [kg]
    helium_mols: n (m_h = n M_He). # [mol]

  Returns:
    Weight F_w. # [N]
  """
  return total_mass(payload_kg, sand_kg, helium_mols) * GRAVITY


def free_lift(helium_mols: Array, payload_kg: Array, sand_kg: Array) -> Array:
  """Free lift L = (F_b - F_w) / g = n (M_air - M_He) - m_p - m_s. # [kg]

  Args:
    helium_mols: n. # [mol]
    payload_kg: m_p, including the envelope. # [kg]
    sand_kg: m_s. # [kg]

  Returns:
    Free lift L (helium at ambient T and P). # [kg]
  """
  return helium_mols * LIFT_PER_MOL - payload_kg - sand_kg


def drag_factor(helium_mols: Array, drag_coefficient: Array,
                temperature: Array, pressure: Array) -> Array:
  """k = 1/2 rho c_d A, so that F_d = k |hdot| hdot. # [kg/m]

  Args:
    helium_mols: n. # [mol]
    drag_coefficient: c_d. # [.]
    temperature: Ambient (= helium) temperature T. # [K]
    pressure: Ambient (= helium) pressure P. # [Pa]

  Returns:
    Drag factor k. # [kg/m]
  """
  v = volume(helium_mols, temperature, pressure)
  return 0.5 * air_density(temperature, pressure) * drag_coefficient * (
      drag_area(v))


def acceleration(ascent_rate: Array, helium_mols: Array, payload_kg: Array,
                 sand_kg: Array, drag_coefficient: Array, temperature: Array,
                 pressure: Array) -> Array:
  """Implements Eq. fullN2L: hddot = (rho V g - F_d - m g) / m. # [m/s^2]

  Args:
    ascent_rate: hdot. # [m/s]
    helium_mols: n. # [mol]
    payload_kg: m_p, including the envelope. # [kg]
    sand_kg: m_s. # [kg]
    drag_coefficient: c_d. # [.]
    temperature: Ambient temperature T. # [K]
    pressure: Ambient pressure P. # [Pa]
  """
  rho = air_density(temperature, pressure)
  v = volume(helium_mols, temperature, pressure)
  m = total_mass(payload_kg, sand_kg, helium_mols)
  return (buoyancy_force(rho, v) -
          drag_force(rho, drag_coefficient, drag_area(v), ascent_rate) -
          m * GRAVITY) / m


def force_balance_residual(ascent_rate: Array, helium_mols: Array,
                           payload_kg: Array, sand_kg: Array,
                           drag_coefficient: Array, temperature: Array,
                           pressure: Array) -> Array:
  """Net force m hddot of Eq. fullN2L; 0 at steady state. # [N]

  Args:
    ascent_rate: hdot. # [m/s]
    helium_mols: n. # [mol]
    payload_kg: m_p, including the envelope. # [kg]
    sand_kg: m_s. # [kg]
    drag_coefficient: c_d. # [.]
    temperature: Ambient temperature T. # [K]
    pressure: Ambient pressure P. # [Pa]

  Returns:
    Net force F_b - F_d - F_w. # [N]
  """
  m = total_mass(payload_kg, sand_kg, helium_mols)
  return m * acceleration(ascent_rate, helium_mols, payload_kg, sand_kg,
                          drag_coefficient, temperature, pressure)


def terminal_velocity(lift_force: Array, drag_k: Array) -> Array:
  """Steady rate of Eq. fullN2L, sign(F) sqrt(|F| / k). # [m/s]

  Args:
    lift_force: Free lift force F = F_b - F_w. # [N]
    drag_k: Drag factor k > 0. # [kg/m]
  """
  return jnp.sign(lift_force) * jnp.sqrt(jnp.abs(lift_force) / drag_k)


def _log_cosh(s: Array) -> Array:
  """log(cosh(s)) for s >= 0, without overflow or cancellation.

  log1p(2 sinh(s/2)^2) below s = 1 (accurate as s -> 0, where the large-s
  form s + log1p(exp(-2s)) - log 2 cancels to ~1e-7 absolute in float32).
  """
  small = s < 1.0
  s_small = jnp.where(small, s, 0.0)
  sinh_half = jnp.sinh(0.5 * s_small)
  return jnp.where(small, jnp.log1p(2.0 * sinh_half * sinh_half),
                   s + jnp.log1p(jnp.exp(-2.0 * s)) - math.log(2.0))


def relax(ascent_rate: Array, duration: Array, *, lift_force: Array,
          mass: Array, drag_k: Array) -> Tuple[Array, Array]:
  """Eq. fullN2L solved exactly over `duration` with the drag factor frozen.

  m hddot = F - k |hdot| hdot with constant F, m, k (`physics.relax`). With
  w = sign(F) hdot, v_t = sqrt(|F|/k), tau = m / sqrt(|F| k), u0 = w0 / v_t,
  s = t / tau:
    * w0 >= 0: w = v_t (u0 + tanh s) / (1 + u0 tanh s),
      dh = v_t tau [log cosh s + log(1 + u0 tanh s)];
    * w0 < 0, s < s_stop = atan(-u0): w = v_t (u0 + tan s) / (1 - u0 tan s),
      dh = -v_t tau log(cos s - u0 sin s); after s_stop the first case from
      rest, plus dh_stop = v_t tau log cos s_stop = -v_t tau log1p(u0^2)/2;
    * |F| < 1e-12 N: w = w0 / (1 + k |w0| t / m),
      dh = sign(w0) (m / k) log(1 + k |w0| t / m) (0 for w0 = 0);
    * k <= 0: uniform acceleration F / m;
    * t <= 0: no change.
  All cases are evaluated on safe operands and selected with `jnp.where`, so
  the removable singularities (F = 0, v0 = 0, the stop of the tan phase) give
  neither NaN values nor NaN gradients.

  Args:
    ascent_rate: Initial hdot. # [m/s]
    duration: Time to advance t. # [s]
    lift_force: F = F_b - F_w. # [N]
    mass: m = m_p + m_s + n M_He, > 0. # [kg]
    drag_k: k = 1/2 rho c_d A, >= 0. # [kg/m]

  Returns:
    (altitude change [m], final ascent rate [m/s]).
  """
  v0 = jnp.asarray(ascent_rate)
  t = jnp.maximum(duration, 0.0)
  positive_t = duration > 0.0
  has_drag = drag_k > 0.0
  k = jnp.where(has_drag, drag_k, 1.0)
  zero_lift = jnp.abs(lift_force) < ZERO_LIFT_N

  # k = 0: uniform acceleration.
  acc = lift_force / mass
  dh_free = v0 * t + 0.5 * acc * t * t
  v_free = v0 + acc * t

  # F = 0: quadratic drag only.
  c = k * jnp.abs(v0) / mass  # [1/s]
  dh_zero = jnp.sign(v0) * (mass / k) * jnp.log1p(c * t)
  v_zero = v0 / (1.0 + c * t)

  # F != 0.
  sign = jnp.where(lift_force >= 0.0, 1.0, -1.0)
  f = jnp.where(zero_lift, 1.0, jnp.abs(lift_force))  # [N]
  v_t = jnp.sqrt(f / k)  # [m/s]
  tau = mass / jnp.sqrt(f * k)  # [s]
  length = mass / k  # v_t tau [m]
  w0 = sign * v0
  u0 = w0 / v_t
  s = t / tau
  against = w0 < 0.0
  u_neg = jnp.minimum(u0, 0.0)
  s_stop = jnp.arctan(-u_neg)
  in_tan = against & (s < s_stop)
  # Tan phase (still moving against the lift at t).
  s_tan = jnp.where(in_tan, s, 0.0)
  tan_s = jnp.tan(s_tan)
  w_tan = v_t * (u_neg + tan_s) / (1.0 - u_neg * tan_s)
  # log(cos s - u0 sin s) = log1p(-2 sin^2(s/2) - u0 sin s): no cancellation
  # for small s.
  sin_half = jnp.sin(0.5 * s_tan)
  dh_tan = -length * jnp.log1p(-2.0 * sin_half * sin_half -
                               u_neg * jnp.sin(s_tan))
  # Tanh phase (with the lift from the start, or from rest after the stop).
  # log cos(atan u0) = -log1p(u0^2) / 2 (-log|u0| where u0^2 would overflow).
  huge = u_neg < -1e15
  u_sq = jnp.square(jnp.where(huge, 0.0, u_neg))
  log_sec = jnp.where(huge, jnp.log(-jnp.where(huge, u_neg, -1.0)),
                      0.5 * jnp.log1p(u_sq))
  dh_stop = jnp.where(against, -length * log_sec, 0.0)
  s_rel = jnp.where(against, jnp.maximum(s - s_stop, 0.0), s)
  u_rel = jnp.where(against, 0.0, jnp.maximum(u0, 0.0))
  tanh_s = jnp.tanh(s_rel)
  w_tanh = v_t * (u_rel + tanh_s) / (1.0 + u_rel * tanh_s)
  dh_tanh = dh_stop + length * (_log_cosh(s_rel) + jnp.log1p(u_rel * tanh_s))
  dh_lift = sign * jnp.where(in_tan, dh_tan, dh_tanh)
  v_lift = sign * jnp.where(in_tan, w_tan, w_tanh)

  dh = jnp.where(~has_drag, dh_free, jnp.where(zero_lift, dh_zero, dh_lift))
  v = jnp.where(~has_drag, v_free, jnp.where(zero_lift, v_zero, v_lift))
  return jnp.where(positive_t, dh, 0.0), jnp.where(positive_t, v, v0)


def vertical_step(altitude: Array, ascent_rate: Array, duration: Array, *,
                  lift_force: Array, mass: Array,
                  drag_k_at: Callable[[Array], Array]) -> Tuple[Array, Array]:
  """One step of Eq. fullN2L with k(h) re-evaluated (`integrate_vertical`).

  A predictor with k at the start altitude, the altitude change with k frozen
  at the predicted midpoint altitude, the new rate with k at the new
  altitude, each solved exactly by `relax`.

  Args:
    altitude: Initial h. # [m]
    ascent_rate: Initial hdot. # [m/s]
    duration: Step length. # [s]
    lift_force: F_b - F_w. # [N]
    mass: Total mass. # [kg]
    drag_k_at: Pure h -> k(h) = 1/2 rho(h) c_d A(h). # [kg/m]

  Returns:
    (final altitude [m], final ascent rate [m/s]).
  """
  def solve(k):
    return relax(ascent_rate, duration, lift_force=lift_force, mass=mass,
                 drag_k=k)

  dh_pred, _ = solve(drag_k_at(altitude))
  dh, _ = solve(drag_k_at(altitude + 0.5 * dh_pred))
  _, v = solve(drag_k_at(altitude + dh))
  return altitude + dh, v


def vertical_step_varying(
    altitude: Array, ascent_rate: Array, duration: Array, *, mass: Array,
    forces_at: Callable[[Array, Array], Tuple[Array, Array]]
) -> Tuple[Array, Array]:
  """`vertical_step` with the lift too varying along the path (realistic).

  The lift force F(h) (helium over- or under-pressure and temperature) and
  the drag factor k(h, hdot) (c_d of the Reynolds number) are evaluated
  where `vertical_step` evaluates k: a predictor with (F, k) at the start,
  the altitude change with them at the predicted midpoint (altitude and
  mean rate), the new rate with them at the new altitude; each piece solved
  exactly by `relax` with F and k frozen.

  Args:
    altitude: Initial h. # [m]
    ascent_rate: Initial hdot. # [m/s]
    duration: Step length. # [s]
    mass: Total mass. # [kg]
    forces_at: Pure (h, hdot) -> (F_b - F_w [N], k [kg/m]).

  Returns:
    (final altitude [m], final ascent rate [m/s]).
  """
  def solve(forces):
    f, k = forces
    return relax(ascent_rate, duration, lift_force=f, mass=mass, drag_k=k)

  dh_pred, v_pred = solve(forces_at(altitude, ascent_rate))
  dh, v_mid = solve(forces_at(altitude + 0.5 * dh_pred,
                              0.5 * (ascent_rate + v_pred)))
  _, v = solve(forces_at(altitude + dh, v_mid))
  return altitude + dh, v


def num_vertical_steps(duration: float, max_step: float = 60.0) -> int:
  """Steps of `integrate_vertical` for a concrete duration (as NumPy).

  Args:
    duration: Time to advance (a concrete number, not traced). # [s]
    max_step: Longest step. # [s]

  Returns:
    ceil(duration / max_step), at least 1.
  """
  return max(1, int(math.ceil(float(duration) / max_step - 1e-9)))


def integrate_vertical(
    altitude: Array, ascent_rate: Array, duration: Array, *,
    lift_force: Array, mass: Array, drag_k_at: Callable[[Array], Array],
    max_step: float = 60.0,
    num_steps: Optional[int] = None) -> Tuple[Array, Array]:
  """Integrates Eq. fullN2L with k(h) varying along the path.

  `num_steps` equal `vertical_step`s (NumPy's `physics.integrate_vertical`).

  Args:
    altitude: Initial h. # [m]
    ascent_rate: Initial hdot. # [m/s]
    duration: Time to advance (traced if num_steps is given). # [s]
    lift_force: F_b - F_w, constant between actuations. # [N]
    mass: Total mass. # [kg]
    drag_k_at: Pure h -> k(h). # [kg/m]
    max_step: Longest step, used when num_steps is None (then `duration`
      must be a concrete number). # [s]
    num_steps: Static number of steps; None = ceil(duration / max_step).

  Returns:
    (final altitude [m], final ascent rate [m/s]).
  """
  if num_steps is None:
    num_steps = num_vertical_steps(duration, max_step)
  dt = jnp.maximum(duration, 0.0) / num_steps

  def body(_, hv):
    return vertical_step(hv[0], hv[1], dt, lift_force=lift_force, mass=mass,
                         drag_k_at=drag_k_at)

  h0 = jnp.asarray(altitude) + jnp.zeros_like(dt)
  v0 = jnp.asarray(ascent_rate) + jnp.zeros_like(dt)
  return jax.lax.fori_loop(0, num_steps, body, (h0, v0))


def vent_coefficients(payload_kg: Array, sand_kg: Array, ascent_rate: Array,
                      drag_coefficient: Array, temperature: Array,
                      pressure: Array) -> Tuple[Array, Array, Array]:
  """Eq. vent as a3 s^3 - b s^2 - c = 0 in s = n^(1/3).

  Steady state of Eq. fullN2L with V = nRT/P (`physics.vent_polynomial`
  = [a3, -b, 0, -c]):
    a3 = g (M_air - M_He),
    b = 1/2 rho c_d pi (3RT / (4 pi P))^(2/3) |hdot| hdot,
    c = (m_p + m_s) g.

  Args:
    payload_kg: m_p. # [kg]
    sand_kg: m_s aboard. # [kg]
    ascent_rate: Desired steady hdot. # [m/s]
    drag_coefficient: c_d. # [.]
    temperature: T at the balloon. # [K]
    pressure: P at the balloon. # [Pa]

  Returns:
    (a3 [N/mol], b [N/mol^(2/3)], c [N]).
  """
  rho = air_density(temperature, pressure)
  b = 0.5 * rho * drag_coefficient * jnp.pi * (
      3.0 * GAS_CONSTANT * temperature / (4.0 * jnp.pi * pressure))**(
          2.0 / 3.0) * jnp.abs(ascent_rate) * ascent_rate
  a3 = GRAVITY * LIFT_PER_MOL
  c = (payload_kg + sand_kg) * GRAVITY
  return a3 + jnp.zeros_like(b), b, c


def vent_root(a3: Array, b: Array, c: Array,
              iterations: int = VENT_NEWTON_ITERATIONS) -> Array:
  """The unique positive root s of p(s) = a3 s^3 - b s^2 - c (Eq. vent).

  For a3 > 0, c > 0: p(0) = -c < 0; p decreases on (0, 2b/(3 a3)) when
  b > 0 and increases beyond, so there is exactly one positive root s*, and
  s* > max(2b/(3 a3), 0). p is increasing and convex (p'' = 6 a3 s - 2b > 0)
  on [s*, inf). The start s0 = max(b, 0)/a3 + (c/a3)^(1/3) satisfies
  p(s0) = s0^2 (a3 s0 - b) - c >= r^2 a3 r - c = 0 (r = (c/a3)^(1/3), b > 0;
  for b <= 0, p(r) = -b r^2 >= 0), so s0 >= s*, and Newton's iterates
  from the right of the root of an increasing convex function decrease
  monotonically to it (quadratically). With s = r sigma the cubic is
  a3 r^3 (sigma^3 - beta sigma^2 - 1), beta = b / (a3 r), so the number of
  iterations needed depends on beta alone: 8 reach the root to a few ulp
  for |beta| <= 200 (float64; tests/flight/test_physics.py), while the flight
  envelope has |beta| < 1 (|hdot| <= 7 m/s above 13 km; beta grows as
  hdot^2 (P/T)^(1/3) / (m_p + m_s)^(1/3)).

  Args:
    a3: Cubic coefficient g (M_air - M_He), > 0. # [N/mol]
    b: Drag coefficient of the polynomial (any sign). # [N/mol^(2/3)]
    c: Weight (m_p + m_s) g, > 0. # [N]
    iterations: Fixed number of Newton steps (static).

  Returns:
    s* = n_calc^(1/3). # [mol^(1/3)]
  """
  s = jnp.maximum(b, 0.0) / a3 + jnp.cbrt(c / a3)

  def newton(_, s):
    p = (a3 * s - b) * s * s - c
    dp = (3.0 * a3 * s - 2.0 * b) * s
    ok = dp > 0.0
    return s - jnp.where(ok, p, 0.0) / jnp.where(ok, dp, 1.0)

  return jax.lax.fori_loop(0, iterations, newton, s)


def vent_target_mols(payload_kg: Array, sand_kg: Array, ascent_rate: Array,
                     drag_coefficient: Array, temperature: Array,
                     pressure: Array) -> Array:
  """Implements Eq. vent: helium n_calc = s*^3 with steady rate hdot. # [mol]

  Args:
    payload_kg: m_p. # [kg]
    sand_kg: m_s aboard (unchanged by venting). # [kg]
    ascent_rate: Desired steady hdot. # [m/s]
    drag_coefficient: c_d. # [.]
    temperature: T at the balloon. # [K]
    pressure: P at the balloon. # [Pa]
  """
  s = vent_root(*vent_coefficients(payload_kg, sand_kg, ascent_rate,
                                   drag_coefficient, temperature, pressure))
  return s * s * s


def vent_target_lift_kg(payload_kg: Array, sand_kg: Array, ascent_rate: Array,
                        drag_coefficient: Array, temperature: Array,
                        pressure: Array) -> Array:
  """Free lift after venting to Eq. vent's n_calc: b s*^2 / g. # [kg]

  From the cubic, g (M_air - M_He) n_calc - (m_p + m_s) g = b s*^2, i.e. the
  steady drag k(n_calc) hdot |hdot| / g; computed this way it keeps full
  relative precision (n_calc (M_air - M_He) - m_p - m_s cancels).

  Args:
    payload_kg: m_p. # [kg]
    sand_kg: m_s aboard (unchanged by venting). # [kg]
    ascent_rate: Desired steady hdot. # [m/s]
    drag_coefficient: c_d. # [.]
    temperature: T at the balloon. # [K]
    pressure: P at the balloon. # [Pa]

  Returns:
    Free lift L at n_calc. # [kg]
  """
  _, b, _ = coeffs = vent_coefficients(payload_kg, sand_kg, ascent_rate,
                                       drag_coefficient, temperature, pressure)
  s = vent_root(*coeffs)
  return b * s * s / GRAVITY


def ballast_target_sand(helium_mols: Array, payload_kg: Array,
                        ascent_rate: Array, drag_coefficient: Array,
                        temperature: Array, pressure: Array) -> Array:
  """Implements Eq. ballast: sand m_s_calc with steady rate hdot. # [kg]

  m_s_calc = rho V - rho c_d A |hdot| hdot / (2 g) - m_p - n M_He (may be
  negative when the rate cannot be reached even with all sand dropped).

  Args:
    helium_mols: n aboard (unchanged by dropping sand). # [mol]
    payload_kg: m_p. # [kg]
    ascent_rate: Desired steady hdot. # [m/s]
    drag_coefficient: c_d. # [.]
    temperature: T at the balloon. # [K]
    pressure: P at the balloon. # [Pa]

  Returns:
    m_s_calc (not clipped to the sand aboard). # [kg]
  """
  rho = air_density(temperature, pressure)
  v = volume(helium_mols, temperature, pressure)
  return (rho * v - rho * drag_coefficient * drag_area(v) *
          jnp.abs(ascent_rate) * ascent_rate / (2.0 * GRAVITY) - payload_kg -
          helium_mols * HELIUM_MOLAR_MASS)


def ballast_target_lift_kg(helium_mols: Array, ascent_rate: Array,
                           drag_coefficient: Array, temperature: Array,
                           pressure: Array) -> Array:
  """Free lift after dropping to Eq. ballast's m_s_calc. # [kg]

  n (M_air - M_He) - m_p - m_s_calc = k(n) |hdot| hdot / g (rho V = n M_air),
  without the cancellation of the difference.

  Args:
    helium_mols: n aboard. # [mol]
    ascent_rate: Desired steady hdot. # [m/s]
    drag_coefficient: c_d. # [.]
    temperature: T at the balloon. # [K]
    pressure: P at the balloon. # [Pa]

  Returns:
    Free lift L at m_s_calc. # [kg]
  """
  k = drag_factor(helium_mols, drag_coefficient, temperature, pressure)
  return k * jnp.abs(ascent_rate) * ascent_rate / GRAVITY


def neutral_helium_mols(payload_kg: Array, sand_kg: Array) -> Array:
  """Eq. float (vent case): n_calc = (m_s + m_p) / (M_air - M_He). # [mol]

  Args:
    payload_kg: m_p. # [kg]
    sand_kg: m_s. # [kg]

  Returns:
    Helium n_calc for zero free lift. # [mol]
  """
  return (payload_kg + sand_kg) / LIFT_PER_MOL


def neutral_sand_kg(helium_mols: Array, payload_kg: Array) -> Array:
  """Eq. float (ballast case): m_s_calc = n (M_air - M_He) - m_p. # [kg]

  Args:
    helium_mols: n. # [mol]
    payload_kg: m_p. # [kg]

  Returns:
    Sand m_s_calc for zero free lift (may be negative). # [kg]
  """
  return helium_mols * LIFT_PER_MOL - payload_kg


# -- Realistic latex physics (issue 28; off in the paper's model). ----------
# Each equation names its source; the code is this project's own.

# Sutherland's law for air as ASTRA uses it (sobester/astra_simulator
# astra/weather.py:551-553, 569-575: mu0 = 0.01827 cP at 15 C, C = 120, in
# Rankine; 0.555 T[R] = 0.999 T[K], so it is the kelvin form below).
SUTHERLAND_VISCOSITY_PA_S = 1.827e-5  # [Pa s] mu0 at T0
SUTHERLAND_REFERENCE_K = 288.15  # [K] T0 (15 C)
SUTHERLAND_CONSTANT_K = 120.0  # [K] C


def air_viscosity(temperature: Array) -> Array:
  """Sutherland's law mu = mu0 (T/T0)^(3/2) (T0 + C) / (T + C). # [Pa s]

  ASTRA weather.py:569-575 (constants at :551-553).

  Args:
    temperature: Air temperature T. # [K]
  """
  t = temperature / SUTHERLAND_REFERENCE_K
  return SUTHERLAND_VISCOSITY_PA_S * t * jnp.sqrt(t) * (
      SUTHERLAND_REFERENCE_K + SUTHERLAND_CONSTANT_K) / (
          temperature + SUTHERLAND_CONSTANT_K)


def envelope_diameter(envelope_volume: Array) -> Array:
  """Diameter of a spherical envelope d = (6V/pi)^(1/3). # [m]

  ASTRA simulator.py:1113.
  """
  return jnp.cbrt(6.0 * envelope_volume / jnp.pi)


def reynolds_number(density: Array, speed: Array, diameter: Array,
                    viscosity: Array) -> Array:
  """Re = rho |v| d / mu (ASTRA flight_tools.py:209). # [.]

  Args:
    density: Air density rho. # [kg/m^3]
    speed: Speed through the air (sign ignored). # [m/s]
    diameter: Envelope diameter d. # [m]
    viscosity: Air viscosity mu. # [Pa s]
  """
  return density * jnp.abs(speed) * diameter / viscosity


def drag_coefficient_of_reynolds(reynolds: Array, *, subcritical: Array,
                                 supercritical: Array, transition: Array,
                                 band: Array, smooth: bool) -> Array:
  """ASTRA's balloon c_d(Re) (flight_tools.py:211-218). # [.]

  c_d = subcritical (0.425) below Re_t = `transition` (3.296e5) and
  supercritical (0.225) above; `smooth` ramps linearly between them over
  [Re_t, Re_t + band] (ASTRA's own model, band = 0.363e5), else steps at Re_t
  (the two-regime form). Continuous and branch-free when smooth.

  Args:
    reynolds: Re. # [.]
    subcritical: c_d below the drag crisis. # [.]
    supercritical: c_d above it. # [.]
    transition: Re_t. # [.]
    band: Ramp width (smooth only). # [.]
    smooth: Ramp (static).
  """
  if not smooth:
    return jnp.where(reynolds < transition, subcritical, supercritical)
  x = jnp.clip((reynolds - transition) / jnp.maximum(band, 1e-9), 0.0, 1.0)
  return subcritical - (subcritical - supercritical) * x


def gas_volume(helium_mols: Array, gas_temperature: Array,
               gas_pressure: Array) -> Array:
  """V = n R T_gas / P_gas, the helium at its own T and P. # [m^3]

  P_gas = P + dP with a latex overpressure dP; T_gas = T + superheat
  (ASTRA simulator.py:1105-1112 with excessPressureCoeff = (P + dP) / P).

  Args:
    helium_mols: n. # [mol]
    gas_temperature: Helium temperature T_gas. # [K]
    gas_pressure: Helium pressure P_gas. # [Pa]

  Returns:
    Helium volume V. # [m^3]
  """
  return helium_mols * GAS_CONSTANT * gas_temperature / gas_pressure


def buoyant_lift_per_mol(air_temperature: Array, air_pressure: Array,
                         gas_temperature: Array,
                         gas_pressure: Array) -> Array:
  """Net lift of a mol of helium, M_air beta - M_He. # [kg/mol]

  The displaced air rho V = (P M_air / (R T)) (R T_gas / P_gas) per mol, so
  beta = (T_gas / T) (P / P_gas); beta = 1 (helium at ambient T and P) is
  the paper's LIFT_PER_MOL.

  Args:
    air_temperature: Ambient air temperature T. # [K]
    air_pressure: Ambient air pressure P. # [Pa]
    gas_temperature: Helium temperature T_gas. # [K]
    gas_pressure: Helium pressure P_gas. # [Pa]

  Returns:
    Net lift per mol of helium. # [kg/mol]
  """
  beta = (gas_temperature / air_temperature) * (air_pressure / gas_pressure)
  return AIR_MOLAR_MASS * beta - HELIUM_MOLAR_MASS


def burst_volume_of_diameter(diameter: Array) -> Array:
  """Burst volume of a sphere of the burst diameter, pi d^3 / 6. # [m^3]"""
  return jnp.pi * diameter * diameter * diameter / 6.0


def draw_burst_diameter(key: Array, scale: Array, shape: Array) -> Array:
  """A burst diameter from ASTRA's Weibull law (simulator.py:831-833). # [m]

  d = lambda W, W ~ Weibull(k): ASTRA's TA-1200 has lambda = 9.6758 m and
  k = 14.3577 (available_balloons_parachutes.py:32), mean lambda
  Gamma(1 + 1/k) = 9.33 m = 1.081 x the nominal 8.63 m (:62).

  Args:
    key: PRNG key (one per flight).
    scale: lambda. # [m]
    shape: k. # [.]
  """
  u = jax.random.uniform(key, jnp.shape(scale), jnp.result_type(scale, float),
                         minval=1e-12, maxval=1.0)
  # Inverse CDF: F(d) = 1 - exp(-(d/lambda)^k).
  return scale * (-jnp.log(u))**(1.0 / shape)
