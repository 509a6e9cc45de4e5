# coding=utf-8
"""Tests for ble_latex.physics: the paper's equations and the integrator."""

import math

from balloon_learning_environment.utils import units
from hypothesis import HealthCheck, assume
from hypothesis import given
from hypothesis import settings
from hypothesis import strategies as st
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex.flight import physics as flight_physics
# The retired NumPy model, the oracle of the core (tests/flight/oracle_cases.py).
from tests.reference import numpy_physics as physics

from tests.flight import oracle_cases as cases

_SETTINGS = settings(max_examples=40, deadline=None)
PAYLOAD = 2.2  # [kg]


def _ambient(atmosphere, h):
  a = atmosphere.at_height(units.Distance(m=h))
  return float(a.temperature), float(a.pressure)


def _drag_k_at(atmosphere, n, c_d=0.25):
  def f(h):
    t, p = _ambient(atmosphere, h)
    return float(physics.drag_factor(n, c_d, t, p))
  return f


@_SETTINGS
@given(n=st.floats(1.0, 500.0), t=st.floats(150.0, 320.0),
       p=st.floats(1_000.0, 101_325.0))
def test_buoyancy_is_n_times_air_molar_mass(n, t, p):
  rho = physics.air_density(t, p)
  v = physics.volume(n, t, p)
  assert physics.buoyancy_force(rho, v) == pytest.approx(
      n * physics.AIR_MOLAR_MASS * physics.GRAVITY, rel=1e-12)


def test_drag_area_of_sphere():
  r = 2.0  # [m]
  v = 4.0 / 3.0 * math.pi * r**3
  assert physics.drag_area(v) == pytest.approx(math.pi * r**2, rel=1e-12)


def test_functions_are_array_friendly():
  n = np.array([100.0, 150.0])
  t = np.array([200.0, 210.0])
  p = np.array([9000.0, 8000.0])
  assert physics.drag_factor(n, 0.25, t, p).shape == (2,)
  assert physics.acceleration(np.zeros(2), n, PAYLOAD, 2.0, 0.25, t,
                              p).shape == (2,)


def test_acceleration_is_full_n2l(atmosphere):
  t, p = _ambient(atmosphere, 17_000.0)
  n, sand, v = 170.0, 2.0, 1.3
  rho = physics.air_density(t, p)
  vol = physics.volume(n, t, p)
  m = PAYLOAD + sand + n * physics.HELIUM_MOLAR_MASS
  expected = (rho * vol * physics.GRAVITY - 0.5 * rho * 0.25 *
              physics.drag_area(vol) * abs(v) * v - m * physics.GRAVITY) / m
  assert physics.acceleration(v, n, PAYLOAD, sand, 0.25, t,
                              p) == pytest.approx(expected, rel=1e-12)


@_SETTINGS
@given(v0=st.floats(-8.0, 8.0),
       lift=st.one_of(st.floats(-10.0, 10.0), st.just(0.0),
                      st.floats(-1e-3, 1e-3)),
       mass=st.floats(1.0, 10.0), k=st.floats(0.02, 0.6),
       duration=st.floats(0.0, 60.0))
def test_relax_is_exact_for_frozen_drag(v0, lift, mass, k, duration):
  dh, v = physics.relax(v0, duration, lift_force=lift, mass=mass, drag_k=k)
  _, hs, vs = physics.rk4_vertical(0.0, v0, max(duration, 1e-9),
                                   lift_force=lift, mass=mass,
                                   drag_k_at=lambda h: k, dt=0.01)
  assert dh == pytest.approx(hs[-1], rel=1e-7, abs=1e-7)
  assert v == pytest.approx(vs[-1], rel=1e-7, abs=1e-8)


def test_relax_reaches_terminal_velocity_and_is_stiff_safe():
  lift, mass, k = 2.0, 5.0, 0.2
  v_t = physics.terminal_velocity(lift, k)
  for duration in (1e3, 1e6, 1e9):  # No overflow for huge steps.
    dh, v = physics.relax(-3.0, duration, lift_force=lift, mass=mass,
                          drag_k=k)
    assert v == pytest.approx(v_t, rel=1e-12)
    assert math.isfinite(dh)


def test_relax_against_lift_stops_then_reverses():
  lift, mass, k = -1.5, 4.0, 0.25
  dh, v = physics.relax(4.0, 300.0, lift_force=lift, mass=mass, drag_k=k)
  _, hs, vs = physics.rk4_vertical(0.0, 4.0, 300.0, lift_force=lift,
                                   mass=mass, drag_k_at=lambda h: k, dt=0.01)
  assert v < 0.0
  assert dh == pytest.approx(hs[-1], rel=1e-8)
  assert v == pytest.approx(vs[-1], rel=1e-8)


def test_relax_continuous_at_zero_lift():
  for v0 in (-2.0, 0.5):
    zero = physics.relax(v0, 100.0, lift_force=0.0, mass=5.0, drag_k=0.2)
    tiny = physics.relax(v0, 100.0, lift_force=1e-9, mass=5.0, drag_k=0.2)
    np.testing.assert_allclose(zero, tiny, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize('h0,v0,rate,sand', [
    (16_000.0, 0.0, 3.0, 2.0),   # fast climb through the 17 km lapse change
    (16_000.0, 0.0, 5.8, 2.0),   # fastest commandable climb
    (21_000.0, 0.0, -5.8, 2.0),  # fastest commandable descent
    (14_000.0, -2.0, 1.0, 1.0),  # reversal
    (17_000.0, 0.0, 0.2, 2.0),   # slow, long relaxation
])
def test_integrator_matches_fine_rk4_reference(atmosphere, h0, v0, rate,
                                               sand):
  """20 simulated minutes with k(h) varying, vs RK4 at dt = 0.05 s."""
  t, p = _ambient(atmosphere, h0)
  if rate > 0:
    n = physics.neutral_helium_mols(PAYLOAD, sand)
    sand = physics.ballast_target_sand(n, PAYLOAD, rate, 0.25, t, p)
  else:
    n = physics.vent_target_mols(PAYLOAD, sand, rate, 0.25, t, p)
  lift = float(physics.free_lift(n, PAYLOAD, sand)) * physics.GRAVITY
  mass = float(physics.total_mass(PAYLOAD, sand, n))
  k_at = _drag_k_at(atmosphere, n)
  h, v = physics.integrate_vertical(h0, v0, 1200.0, lift_force=lift,
                                    mass=mass, drag_k_at=k_at, max_step=60.0)
  _, hs, vs = physics.rk4_vertical(h0, v0, 1200.0, lift_force=lift, mass=mass,
                                   drag_k_at=k_at, dt=0.05)
  # Measured: <= 1.2 m (0.02 %) in altitude, <= 0.04 % in ascent rate.
  assert abs(h - hs[-1]) <= max(2.0, 5e-4 * abs(hs[-1] - h0))
  assert abs(v - vs[-1]) <= 1e-3 * abs(vs[-1])


@_SETTINGS
@given(h=st.floats(13_000.0, 22_000.0), rate=st.floats(-6.0, 6.0),
       sand=st.floats(0.0, 3.0), payload=st.floats(0.5, 5.0),
       c_d=st.floats(0.1, 0.5))
def test_vent_root_zeroes_the_force_balance(atmosphere, h, rate, sand,
                                            payload, c_d):
  t, p = _ambient(atmosphere, h)
  coeffs = physics.vent_polynomial(payload, sand, rate, c_d, t, p)
  roots = np.roots(coeffs)
  positive_real = [r for r in roots
                   if abs(r.imag) < 1e-7 * max(1, abs(r)) and r.real > 0]
  assert len(positive_real) == 1
  n = physics.vent_target_mols(payload, sand, rate, c_d, t, p)
  residual = physics.force_balance_residual(rate, n, payload, sand, c_d, t, p)
  weight = physics.weight_force(payload, sand, n)
  assert abs(residual) <= 1e-9 * weight
  assert physics.terminal_velocity(
      float(physics.free_lift(n, payload, sand)) * physics.GRAVITY,
      float(physics.drag_factor(n, c_d, t, p))) == pytest.approx(
          rate, rel=1e-6, abs=1e-6)  # sqrt amplifies the residual at 0.


@_SETTINGS
@given(h=st.floats(13_000.0, 22_000.0), rate=st.floats(-6.0, 6.0),
       n=st.floats(80.0, 250.0), c_d=st.floats(0.1, 0.5))
def test_ballast_zeroes_the_force_balance(atmosphere, h, rate, n, c_d):
  t, p = _ambient(atmosphere, h)
  sand = physics.ballast_target_sand(n, PAYLOAD, rate, c_d, t, p)
  residual = physics.force_balance_residual(rate, n, PAYLOAD, sand, c_d, t, p)
  assert abs(residual) <= 1e-9 * physics.weight_force(PAYLOAD, abs(sand), n)


@_SETTINGS
@given(h=st.floats(13_000.0, 22_000.0), sand=st.floats(0.0, 3.0),
       n=st.floats(80.0, 250.0))
def test_float_equations_give_neutral_buoyancy(atmosphere, h, sand, n):
  t, p = _ambient(atmosphere, h)
  n_float = physics.neutral_helium_mols(PAYLOAD, sand)
  assert physics.acceleration(0.0, n_float, PAYLOAD, sand, 0.25, t,
                              p) == pytest.approx(0.0, abs=1e-12)
  sand_float = physics.neutral_sand_kg(n, PAYLOAD)
  assert physics.acceleration(0.0, n, PAYLOAD, sand_float, 0.25, t,
                              p) == pytest.approx(0.0, abs=1e-12)


def test_free_lift_does_not_depend_on_altitude(atmosphere):
  n, sand = 170.0, 2.0
  for h in (13_000.0, 17_000.0, 22_000.0):
    t, p = _ambient(atmosphere, h)
    net = (physics.buoyancy_force(physics.air_density(t, p),
                                  physics.volume(n, t, p)) -
           physics.weight_force(PAYLOAD, sand, n)) / physics.GRAVITY
    assert net == pytest.approx(physics.free_lift(n, PAYLOAD, sand),
                                abs=1e-12)


@pytest.mark.parametrize('bad', [float('nan'), float('inf')])
def test_solvers_reject_non_finite_inputs(bad):
  with pytest.raises(ValueError, match='ascent_rate'):
    physics.vent_target_mols(PAYLOAD, 2.0, bad, 0.25, 200.0, 9000.0)
  with pytest.raises(ValueError, match='helium_mols'):
    physics.ballast_target_sand(bad, PAYLOAD, 1.0, 0.25, 200.0, 9000.0)
  with pytest.raises(ValueError, match='P > 0'):
    physics.vent_target_mols(PAYLOAD, 2.0, 1.0, 0.25, 200.0, -1.0)


@cases.PRECISIONS
@cases.SETTINGS
@given(k=cases.KEY, h=cases.ALTITUDE, v=cases.RATE, n=cases.HELIUM, s=cases.SAND)
def test_physics_equations_match_numpy(x64, k, h, v, n, s):
  t, p = cases.ambient(k, h)
  args = dict(
      volume=(n, t, p), air_density=(t, p), drag_area=(30.0 * n / 168.0,),
      buoyancy_force=(0.1, 30.0), drag_force=(0.1, cases.C_D, 11.0, v),
      total_mass=(cases.PAYLOAD, s, n), weight_force=(cases.PAYLOAD, s, n),
      free_lift=(n, cases.PAYLOAD, s), drag_factor=(n, cases.C_D, t, p),
      acceleration=(v, n, cases.PAYLOAD, s, cases.C_D, t, p),
      force_balance_residual=(v, n, cases.PAYLOAD, s, cases.C_D, t, p),
      ballast_target_sand=(n, cases.PAYLOAD, v, cases.C_D, t, p),
      neutral_helium_mols=(cases.PAYLOAD, s), neutral_sand_kg=(n, cases.PAYLOAD))
  scale = dict(acceleration=10.0, force_balance_residual=50.0,
               free_lift=5.0, ballast_target_sand=5.0, neutral_sand_kg=5.0)
  dtype = cases.dtype(x64)
  with jax.enable_x64(x64):
    for name, a in args.items():
      ref = getattr(physics, name)(*a)
      got = getattr(flight_physics, name)(*(jnp.asarray(x, dtype) for x in a))
      tol = (1e-12 if x64 else 2e-6) * max(abs(ref), scale.get(name, 0.0),
                                           1e-30)
      assert abs(float(got) - ref) <= tol, name


@cases.PRECISIONS
@cases.SETTINGS
@given(v0=cases.RATE, t=cases.f32(0.0, 1200.0),
       lift=st.one_of(st.just(0.0), cases.f32(-3.0, 3.0), cases.f32(-1e-6, 1e-6)),
       m=cases.f32(3.0, 8.0), k=st.one_of(st.just(0.0), cases.f32(0.02, 0.8)))
def test_relax_matches_numpy(x64, v0, t, lift, m, k):
  f = lift * physics.GRAVITY
  ref_dh, ref_v = physics.relax(v0, t, lift_force=f, mass=m, drag_k=k)
  dtype = cases.dtype(x64)
  with jax.enable_x64(x64):
    dh, v = cases.relax(*(jnp.asarray(x, dtype) for x in (v0, t, f, m, k)))
  if x64:
    assert abs(float(dh) - ref_dh) <= 1e-10 * max(1.0, abs(ref_dh))
    assert abs(float(v) - ref_v) <= 1e-11 * max(1.0, abs(ref_v))
  else:
    assert abs(float(dh) - ref_dh) <= 1e-5 * (abs(ref_dh) + abs(v0) * t + 1)
    assert abs(float(v) - ref_v) <= 1e-5 * (abs(ref_v) + abs(v0) + 0.01)


def test_relax_is_finite_with_finite_gradients_at_singular_points():
  singular = [  # (v0, t, F, m, k)
      (0.0, 60.0, 0.0, 4.2, 0.2),  # no lift, at rest
      (2.0, 60.0, 0.0, 4.2, 0.2),  # no lift, moving
      (0.0, 60.0, 1.0, 4.2, 0.2),  # at rest, lift
      (-3.0, 60.0, 1.0, 4.2, 0.2),  # against the lift, stops inside
      (-3.0, 1.0, 1.0, 4.2, 0.2),  # against the lift, tan phase
      (3.0, 60.0, 1e-13, 4.2, 0.2),  # below the zero-lift threshold
      (3.0, 60.0, 1e-9, 4.2, 0.2),  # tiny lift
      (1.0, 60.0, 1.0, 4.2, 0.0),  # no drag
      (1.0, 0.0, 1.0, 4.2, 0.2),  # zero duration
      (1.0, 1e6, -1.0, 4.2, 0.2),  # very long
  ]
  grad = jax.jit(jax.jacfwd(
      lambda x: jnp.stack(flight_physics.relax(x[0], x[1], lift_force=x[2],
                                        mass=x[3], drag_k=x[4]))))
  rev = jax.jit(jax.grad(lambda x: sum(flight_physics.relax(
      x[0], x[1], lift_force=x[2], mass=x[3], drag_k=x[4]))))
  for case in singular:
    x = jnp.asarray(case)
    out = cases.relax(*x)
    ref = physics.relax(case[0], case[1], lift_force=case[2],
                           mass=case[3], drag_k=case[4])
    np.testing.assert_allclose(np.asarray(out, np.float64), ref, rtol=1e-5,
                               atol=1e-5)
    assert np.all(np.isfinite(np.asarray(grad(x)))), case
    assert np.all(np.isfinite(np.asarray(rev(x)))), case


@cases.PRECISIONS
# Most random (helium, sand) pairs leave the balloon far from neutral, so
# many draws climb out of the atmosphere and are filtered out by `assume`.
@settings(cases.FEW, suppress_health_check=[HealthCheck.filter_too_much])
@given(k=cases.KEY, h=cases.ALTITUDE, v=cases.RATE, n=cases.HELIUM, s=cases.SAND,
       duration=cases.f32(1.0, 1200.0))
def test_integrate_vertical_matches_numpy(x64, k, h, v, n, s, duration):
  ble = cases.ble_atmosphere(k)
  lift = physics.free_lift(n, cases.PAYLOAD, s) * physics.GRAVITY
  mass = physics.total_mass(cases.PAYLOAD, s, n)

  def drag_k_at(hh):
    hh = min(max(hh, -600.0), 84_000.0)
    a = ble.at_height(units.Distance(m=hh))
    return float(physics.drag_factor(n, cases.C_D, a.temperature, a.pressure))

  steps = flight_physics.num_vertical_steps(duration)
  assume(steps in cases.INTEGRATE)
  ref_h, ref_v = physics.integrate_vertical(
      h, v, duration, lift_force=lift, mass=mass, drag_k_at=drag_k_at)
  assume(ref_h > 0.0 and ref_h < 80_000.0)
  dtype = cases.dtype(x64)
  with jax.enable_x64(x64):
    got_h, got_v = cases.INTEGRATE[steps](
        cases.atm_params(k), *(jnp.asarray(x, dtype)
                          for x in (h, v, duration, lift, mass, n)))
  assert abs(float(got_h) - ref_h) <= (1e-7 if x64 else 0.05 + 2e-6 *
                                       abs(ref_h - h))
  assert abs(float(got_v) - ref_v) <= (1e-10 if x64 else 1e-3)


@cases.PRECISIONS
@cases.SETTINGS
@given(k=cases.KEY, h=cases.ALTITUDE, rate=cases.f32(-8.0, 8.0), s=cases.SAND)
def test_vent_solve_matches_numpy(x64, k, h, rate, s):
  t, p = cases.ambient(k, h)
  ref = physics.vent_target_mols(cases.PAYLOAD, s, rate, cases.C_D, t, p)
  ref_lift = physics.free_lift(ref, cases.PAYLOAD, s)
  dtype = cases.dtype(x64)
  with jax.enable_x64(x64):
    args = [jnp.asarray(x, dtype) for x in (cases.PAYLOAD, s, rate, cases.C_D, t, p)]
    got = cases.vent_target(*args)
    got_lift = cases.vent_lift(*args)
  assert cases.rel(got, ref) <= (1e-13 if x64 else 1e-6)
  assert abs(float(got_lift) - ref_lift) <= (1e-13 if x64 else 1e-6) * max(
      abs(ref_lift), 1.0 if x64 else 1e-3) + (1e-14 if x64 else 0.0) * 5


def test_vent_newton_converges_for_any_beta():
  """The cubic depends on beta = b / (a3 r) only (flight_physics.vent_root)."""
  with jax.enable_x64(True):
    beta = jnp.linspace(-200.0, 200.0, 40_001)
    s = flight_physics.vent_root(1.0, beta, 1.0)
    residual = jnp.abs((s - beta) * s * s - 1.0) / (1.0 + jnp.abs(beta) * s *
                                                    s)
    assert float(residual.max()) < 1e-14
    assert bool(jnp.all(s > jnp.maximum(2.0 * beta / 3.0, 0.0)))
    # Realistic range: converged with iterations to spare.
    small = flight_physics.vent_root(1.0, jnp.linspace(-5.0, 5.0, 1001), 1.0,
                              iterations=6)
    big = flight_physics.vent_root(1.0, jnp.linspace(-5.0, 5.0, 1001), 1.0)
    np.testing.assert_allclose(small, big, rtol=1e-15)
  # float32 over the flight envelope (13-22 km, |rate| <= 7 m/s).
  t, p = cases.ambient(0, 13_000.0)
  rates = jnp.linspace(-7.0, 7.0, 101)
  s32 = flight_physics.vent_root(*flight_physics.vent_coefficients(
      cases.PAYLOAD, 0.0, rates, cases.C_D, t, p))
  for rate, si in zip(np.asarray(rates), np.asarray(s32)):
    ref = physics.vent_target_mols(cases.PAYLOAD, 0.0, float(rate), cases.C_D, t, p)
    assert cases.rel(float(si)**3, ref) < 1e-6


@cases.PRECISIONS
@cases.SETTINGS
@given(k=cases.KEY, h=cases.ALTITUDE, rate=cases.f32(-8.0, 8.0), n=cases.HELIUM)
def test_ballast_solve_matches_numpy(x64, k, h, rate, n):
  t, p = cases.ambient(k, h)
  ref = physics.ballast_target_sand(n, cases.PAYLOAD, rate, cases.C_D, t, p)
  ref_lift = physics.free_lift(n, cases.PAYLOAD, ref)
  dtype = cases.dtype(x64)
  with jax.enable_x64(x64):
    got = flight_physics.ballast_target_sand(
        *(jnp.asarray(x, dtype) for x in (n, cases.PAYLOAD, rate, cases.C_D, t, p)))
    got_lift = flight_physics.ballast_target_lift_kg(
        *(jnp.asarray(x, dtype) for x in (n, rate, cases.C_D, t, p)))
  assert abs(float(got) - ref) <= (1e-12 if x64 else 1e-6) * 5.0
  assert abs(float(got_lift) - ref_lift) <= (1e-12 if x64 else 2e-6) * max(
      abs(ref_lift), 1.0 if x64 else 1e-2)
