# coding=utf-8
"""Tests for ble_latex.flight: the JAX flight core against the NumPy oracle.

Each JAX function is compared with its twin in the retired NumPy float64
model the core replaced (tests/reference: numpy_physics, numpy_controller,
numpy_balloon.LatexBalloon.simulate_step) and with BLE's standard
atmosphere over hypothesis-generated states in realistic ranges, in
JAX's default float32 and in float64 inside a local `jax.enable_x64(True)`
scope. Inputs are drawn float32-representable so both sides see the same
numbers. BLE atmospheres are always built outside the x64 scope (BLE draws
its lapse-rate blend in the default precision).
"""

import datetime as dt
import functools
import math

from balloon_learning_environment.env import wind_field
from balloon_learning_environment.env.balloon import standard_atmosphere
from balloon_learning_environment.utils import units
from hypothesis import HealthCheck, assume
from hypothesis import given
from hypothesis import settings
from hypothesis import strategies as st
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import s2sphere as s2

from ble_latex.flight import atmosphere
from ble_latex.flight import controller
from ble_latex.flight import dynamics
from ble_latex.flight import params as params_lib
from ble_latex.flight import physics
from ble_latex.flight import state as state_lib
# The retired NumPy float64 model as the oracle.
from tests.reference import numpy_balloon as balloon_lib
from tests.reference import numpy_controller as controller_lib
from tests.reference import numpy_physics as np_physics

_SETTINGS = settings(max_examples=30, deadline=None, derandomize=True)
_FEW = settings(max_examples=15, deadline=None, derandomize=True)
PRECISIONS = pytest.mark.parametrize('x64', [False, True],
                                     ids=['float32', 'float64'])
Status = balloon_lib.LatexBalloonStatus
Decision = controller_lib.Decision
PARAMS = params_lib.FlightParams()
PAYLOAD = PARAMS.payload_kg  # [kg]
C_D = PARAMS.drag_coefficient  # [.]
LPM = np_physics.LIFT_PER_MOL  # [kg/mol]

# Realistic ranges (float32-representable draws).


def _f32(low: float, high: float):
  """float32-representable floats in [low, high] (bounds rounded)."""
  return st.floats(float(np.float32(low)), float(np.float32(high)), width=32,
                   allow_subnormal=False)

ALTITUDE = _f32(13_000.0, 22_000.0)  # [m]
RATE = _f32(-6.0, 6.0)  # [m/s]
HELIUM = _f32(88.0, 200.0)  # [mol]
SAND = _f32(0.0, 2.0)  # [kg]
ACTION = st.tuples(_f32(14_000.0, 21_000.0), _f32(1.0, 5.0), _f32(-1.0, 1.0))
KEY = st.integers(0, 2**20)


# --- helpers -----------------------------------------------------------------


@functools.lru_cache(maxsize=None)
def _ble_atmosphere(k: int) -> standard_atmosphere.Atmosphere:
  with jax.enable_x64(False):
    return standard_atmosphere.Atmosphere(jax.random.PRNGKey(k))


def _atm_params(k: int) -> atmosphere.AtmosphereParams:
  return _reset(jax.random.PRNGKey(k))


def _ambient(k: int, h: float):
  """BLE's (T [K], P [Pa]) at h."""
  a = _ble_atmosphere(k).at_height(units.Distance(m=h))
  return float(a.temperature), float(a.pressure)


def _dtype(x64: bool):
  return np.float64 if x64 else np.float32


_BATCH = 16  # Hypothesis' height lists, padded: one compile per precision.


def _padded(values, dtype) -> jnp.ndarray:
  """`values` padded to `_BATCH` with its last value (a fixed shape, so the
  jitted function compiles once, not once per list length)."""
  values = list(values)
  return jnp.asarray(values + values[-1:] * (_BATCH - len(values)), dtype)


def _rel(a, b) -> float:
  return abs(float(a) / float(b) - 1.0)


def _np_state(k, h, v, n, s, *, x=0.0, y=0.0, **kwargs):
  return balloon_lib.create_state(
      center_latlng=s2.LatLng.from_degrees(1.0, -113.0),
      date_time=dt.datetime(2022, 11, 1, tzinfo=dt.timezone.utc),
      atmosphere=_ble_atmosphere(k), altitude_m=h, ascent_rate_mps=v,
      helium_mols=n, sand_kg=s, x=units.Distance(m=x),
      y=units.Distance(m=y), **kwargs)


def _jax_state(params, k, h, v, n, s, *, x=0.0, y=0.0):
  return state_lib.initial_state(params, h, x, y, atm_params=_atm_params(k),
                                 ascent_rate_mps=v, helium_mols=n, sand_kg=s)


def _np_controller(params) -> controller_lib.AltitudeController:
  return controller_lib.AltitudeController(
      min_vent_mols=params.min_vent_mols, min_drop_kg=params.min_drop_kg,
      band_low_m=params.band_low_m, band_high_m=params.band_high_m)


def _np_decide(params, k, h, v, n, s, action):
  t, p = _ambient(k, h)
  return _np_controller(params).decide(
      np.asarray(action, np.float64), altitude_m=h, ascent_rate_mps=v,
      helium_mols=n, sand_kg=s, payload_kg=params.payload_kg,
      drag_coefficient=params.drag_coefficient, temperature=t, pressure=p)


def _near_threshold(params, k, h, v, n, s, action) -> bool:
  """The controller's choice is within float32 rounding of a threshold."""
  a0, a1, a2 = action
  if a2 > 0.0:
    return abs(np_physics.free_lift(n, params.payload_kg, s)) < 1e-5
  t, p = _ambient(k, h)
  rate = (a0 - h) / (a1 * params.stride_s)
  if abs(rate - v) < 1e-4:
    return True
  vent = n - np_physics.vent_target_mols(params.payload_kg, s, rate,
                                         params.drag_coefficient, t, p)
  drop = s - np_physics.ballast_target_sand(n, params.payload_kg, rate,
                                            params.drag_coefficient, t, p)
  return (min(abs(vent - params.min_vent_mols), abs(vent)) < 2e-4 or
          min(abs(drop - params.min_drop_kg), abs(drop)) < 1e-5 or
          min(abs(h - params.band_low_m), abs(h - params.band_high_m)) < 0.01)


def _const_wind(x, y, p, t):
  del y, p, t
  return 3.0 + 0.0 * x, -2.0 + 0.0 * x


CONST_WIND_NP = wind_field.WindVector(units.Velocity(mps=3.0),
                                      units.Velocity(mps=-2.0))


def _analytic_wind(x, y, p, t):
  """A smooth wind varying with position, pressure and time. # [m/s]"""
  u = 4.0 + 1e-4 * y + 1e-3 * (p - 8000.0) + 2.0 * jnp.sin(t / 3000.0)
  v = -3.0 + 2e-4 * x - 5e-4 * (p - 8000.0) + jnp.cos(t / 5000.0)
  return u, v


def _analytic_wind_np(x, y, pressure, time_elapsed):
  x, y, t = x.meters, y.meters, time_elapsed.total_seconds()
  u = 4.0 + 1e-4 * y + 1e-3 * (pressure - 8000.0) + 2.0 * math.sin(t / 3000.0)
  v = -3.0 + 2e-4 * x - 5e-4 * (pressure - 8000.0) + math.cos(t / 5000.0)
  return wind_field.WindVector(units.Velocity(mps=u), units.Velocity(mps=v))


# Jitted once per module (and retraced once per precision).
_reset = jax.jit(atmosphere.reset)
_at_height = jax.jit(atmosphere.at_height)
_at_pressure = jax.jit(atmosphere.at_pressure)
_relax = jax.jit(lambda v0, t, f, m, k: physics.relax(
    v0, t, lift_force=f, mass=m, drag_k=k))
_decide = jax.jit(controller.decide)
_vent_target = jax.jit(physics.vent_target_mols)
_vent_lift = jax.jit(physics.vent_target_lift_kg)
_STEP_CONST = dynamics.make_step(_const_wind)
_STEP_ANALYTIC = dynamics.make_step(_analytic_wind)


def _integrate_fn(num_steps):

  @jax.jit
  def run(atm, h, v, duration, lift, mass, n):

    def drag_k_at(hh):
      amb = atmosphere.at_height(atm, hh)
      return physics.drag_factor(n, C_D, amb.temperature, amb.pressure)

    return physics.integrate_vertical(h, v, duration, lift_force=lift,
                                      mass=mass, drag_k_at=drag_k_at,
                                      num_steps=num_steps)

  return run


_INTEGRATE = {n: _integrate_fn(n) for n in (1, 20)}


def _np_step(k, h, v, n, s, action, wind, balloon_kwargs=None,
             state_kwargs=None):
  state = _np_state(k, h, v, n, s, **(state_kwargs or {}))
  b = balloon_lib.LatexBalloon(state, **(balloon_kwargs or {}))
  b.simulate_step(wind, _ble_atmosphere(k), np.asarray(action, np.float64),
                  dt.timedelta(minutes=20))
  return b.state


def _assert_step_matches(js, ns, x64, *, check_guard=True, finite=False):
  """One stride's JAX state `js` against NumPy's `ns`.

  With finite rates, float32 helium and sand are sums of ~100 release pieces
  (each rounded to ~1e-7 relative), hence res_tol 1e-5 there.
  """
  alt_tol, pos_tol, res_tol = (1e-6, 1e-6, 1e-12) if x64 else (
      0.5, 5.0, 1e-5 if finite else 1e-6)
  if int(js.status) != ns.latex_status.value:
    # n (M_air - M_He) = m_p exactly (floated with no sand left): NumPy's
    # rounding picks either side; the JAX core (L + m_s = 0) is not out of
    # helium.
    tie = abs(ns.helium_mols * LPM - ns.payload_kg) < (1e-9 if x64 else 1e-5)
    assert tie and ns.latex_status == Status.OUT_OF_HELIUM
    assert int(js.status) == Status.OUT_OF_SAND.value
  assert int(js.last_decision) == list(Decision).index(ns.last_decision)
  assert abs(float(js.altitude_m) - ns.altitude_m) <= alt_tol
  assert abs(float(js.ascent_rate_mps) - ns.ascent_rate_mps) <= (
      1e-9 if x64 else 1e-2)
  assert abs(float(js.x_m) - ns.x.meters) <= pos_tol
  assert abs(float(js.y_m) - ns.y.meters) <= pos_tol
  assert abs(float(js.helium_mols) - ns.helium_mols) <= res_tol * (
      ns.helium_mols)
  assert abs(float(js.sand_kg) - ns.sand_kg) <= res_tol * max(ns.sand_kg,
                                                             1.0)
  assert abs(float(js.helium_vented_mols) - ns.helium_vented_mols) <= (
      res_tol * 200.0)
  assert abs(float(js.sand_dropped_kg) - ns.sand_dropped_kg) <= res_tol * 2
  assert abs(float(js.pending_vent_mols) - ns.pending_vent_mols) <= (
      res_tol * 200.0)
  assert abs(float(js.pending_drop_kg) - ns.pending_drop_kg) <= res_tol * 2
  assert float(js.time_s) == pytest.approx(ns.time_elapsed.total_seconds(),
                                           abs=1e-3)
  assert abs(float(js.desired_ascent_rate_mps) -
             ns.desired_ascent_rate_mps) <= (1e-9 if x64 else 1e-5)
  assert abs(float(js.pressure_pa) / ns.pressure - 1.0) <= (
      1e-9 if x64 else 1e-4)
  if check_guard and bool(js.guard_engaged) != ns.guard_engaged:
    # NumPy recomputes L = n (M_air - M_He) - m_p - m_s, so a floated balloon
    # has |L| ~ 1e-16 kg and its in-stride guard may "engage" with a vent or
    # drop of ~1e-15; the JAX state is exactly neutral (L = 0): nothing to do.
    outside = not (PARAMS.band_low_m <= ns.altitude_m <= PARAMS.band_high_m)
    assert ns.guard_engaged and outside and abs(ns.free_lift_kg) < 1e-9


def _end_near_boundary(params, ns) -> bool:
  """NumPy's end state is within float32 rounding of a status boundary."""
  volume = ns.envelope_volume
  return (abs(ns.helium_mols * LPM - params.payload_kg) < 1e-4 or
          abs(ns.sand_kg - params.min_drop_kg) < 1e-5 or
          abs(volume / params.burst_volume_m3 - 1.0) < 1e-4 or
          abs(ns.altitude_m) < 1.0)


_KINDS = st.sampled_from(['finite', 'nan', 'inf', '-inf'])


@settings(max_examples=40, deadline=None, derandomize=True)
@given(kinds=st.tuples(_KINDS, _KINDS, _KINDS), action=ACTION,
       h=_f32(0.0, 40_000.0))
def test_float_if_nan_replaces_an_action_with_any_nan(kinds, action, h):
  """Any NaN component: the whole action is the float action (clip(h), 1,
  1); +-inf and finite values pass unchanged (clipped later)."""
  a = np.array(action, np.float32)
  for i, kind in enumerate(kinds):
    a[i] = {'finite': a[i], 'nan': np.nan, 'inf': np.inf,
            '-inf': -np.inf}[kind]
  out, invalid = controller.float_if_nan(jnp.asarray(a), jnp.float32(h))
  out = np.asarray(out)
  if 'nan' in kinds:
    assert bool(invalid)
    np.testing.assert_array_equal(
        out, [np.clip(np.float32(h), 14_000.0, 21_000.0), 1.0, 1.0])
  else:
    assert not bool(invalid)
    np.testing.assert_array_equal(out, a)


# --- atmosphere --------------------------------------------------------------


@PRECISIONS
@_SETTINGS
@given(k=KEY, heights=st.lists(_f32(-600.0, 84_000.0), min_size=1,
                               max_size=_BATCH))
def test_atmosphere_matches_ble(x64, k, heights):
  ble = _ble_atmosphere(k)
  with jax.enable_x64(x64):
    params = _atm_params(k)
    # Same key -> same blend (BLE draws alpha in float32).
    np.testing.assert_allclose(np.asarray(params.lapse_rates, np.float64),
                               ble._lapse_rates, rtol=1e-15 if x64 else 1e-7)
    got = _at_height(params, _padded(heights, _dtype(x64)))
  for i, h in enumerate(heights):
    ref = ble.at_height(units.Distance(m=h))
    rtol_t = 1e-12 if x64 else 1e-6
    # float32: ~1e-6 up to 40 km, 3e-6 above (power laws with exponents up
    # to 34 of float32 layer tables).
    rtol_p = 1e-12 if x64 else (1e-6 if h < 40_000.0 else 3e-6)
    assert _rel(got.temperature[i], ref.temperature) <= rtol_t
    assert _rel(got.pressure[i], ref.pressure) <= rtol_p
    assert _rel(got.density[i], ref.density) <= rtol_p


@PRECISIONS
@_FEW
@given(k=KEY, heights=st.lists(_f32(-600.0, 84_000.0), min_size=1,
                               max_size=_BATCH))
def test_at_pressure_matches_ble(x64, k, heights):
  ble = _ble_atmosphere(k)
  pressures = np.array(
      [ble.at_height(units.Distance(m=h)).pressure for h in heights])
  pressures = pressures.astype(_dtype(x64)).astype(np.float64)
  with jax.enable_x64(x64):
    got = _at_pressure(_atm_params(k), _padded(pressures, _dtype(x64)))
  for i, p in enumerate(pressures):
    ref = ble.at_pressure(p)
    assert abs(float(got.height[i]) - ref.height.meters) <= (
        1e-7 if x64 else 0.05)
    assert _rel(got.temperature[i], ref.temperature) <= (
        1e-12 if x64 else 1e-6)
    assert _rel(got.density[i], ref.density) <= (1e-12 if x64 else 3e-6)


def test_atmosphere_vmaps_over_keys():
  keys = jax.random.split(jax.random.PRNGKey(7), 8)
  params = jax.vmap(atmosphere.reset)(keys)
  amb = jax.vmap(atmosphere.at_height, in_axes=(0, None))(params, 17_000.0)
  for i in range(8):
    with jax.enable_x64(False):
      ble = standard_atmosphere.Atmosphere(keys[i])
    ref = ble.at_height(units.Distance(m=17_000.0))
    assert _rel(amb.pressure[i], ref.pressure) < 1e-6


# --- physics -----------------------------------------------------------------


@PRECISIONS
@_SETTINGS
@given(k=KEY, h=ALTITUDE, v=RATE, n=HELIUM, s=SAND)
def test_physics_equations_match_numpy(x64, k, h, v, n, s):
  t, p = _ambient(k, h)
  args = dict(
      volume=(n, t, p), air_density=(t, p), drag_area=(30.0 * n / 168.0,),
      buoyancy_force=(0.1, 30.0), drag_force=(0.1, C_D, 11.0, v),
      total_mass=(PAYLOAD, s, n), weight_force=(PAYLOAD, s, n),
      free_lift=(n, PAYLOAD, s), drag_factor=(n, C_D, t, p),
      acceleration=(v, n, PAYLOAD, s, C_D, t, p),
      force_balance_residual=(v, n, PAYLOAD, s, C_D, t, p),
      ballast_target_sand=(n, PAYLOAD, v, C_D, t, p),
      neutral_helium_mols=(PAYLOAD, s), neutral_sand_kg=(n, PAYLOAD))
  scale = dict(acceleration=10.0, force_balance_residual=50.0,
               free_lift=5.0, ballast_target_sand=5.0, neutral_sand_kg=5.0)
  dtype = _dtype(x64)
  with jax.enable_x64(x64):
    for name, a in args.items():
      ref = getattr(np_physics, name)(*a)
      got = getattr(physics, name)(*(jnp.asarray(x, dtype) for x in a))
      tol = (1e-12 if x64 else 2e-6) * max(abs(ref), scale.get(name, 0.0),
                                           1e-30)
      assert abs(float(got) - ref) <= tol, name


@PRECISIONS
@_SETTINGS
@given(v0=RATE, t=_f32(0.0, 1200.0),
       lift=st.one_of(st.just(0.0), _f32(-3.0, 3.0), _f32(-1e-6, 1e-6)),
       m=_f32(3.0, 8.0), k=st.one_of(st.just(0.0), _f32(0.02, 0.8)))
def test_relax_matches_numpy(x64, v0, t, lift, m, k):
  f = lift * np_physics.GRAVITY
  ref_dh, ref_v = np_physics.relax(v0, t, lift_force=f, mass=m, drag_k=k)
  dtype = _dtype(x64)
  with jax.enable_x64(x64):
    dh, v = _relax(*(jnp.asarray(x, dtype) for x in (v0, t, f, m, k)))
  if x64:
    assert abs(float(dh) - ref_dh) <= 1e-10 * max(1.0, abs(ref_dh))
    assert abs(float(v) - ref_v) <= 1e-11 * max(1.0, abs(ref_v))
  else:
    assert abs(float(dh) - ref_dh) <= 1e-5 * (abs(ref_dh) + abs(v0) * t + 1)
    assert abs(float(v) - ref_v) <= 1e-5 * (abs(ref_v) + abs(v0) + 0.01)


def test_relax_is_finite_with_finite_gradients_at_singular_points():
  cases = [  # (v0, t, F, m, k)
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
      lambda x: jnp.stack(physics.relax(x[0], x[1], lift_force=x[2],
                                        mass=x[3], drag_k=x[4]))))
  rev = jax.jit(jax.grad(lambda x: sum(physics.relax(
      x[0], x[1], lift_force=x[2], mass=x[3], drag_k=x[4]))))
  for case in cases:
    x = jnp.asarray(case)
    out = _relax(*x)
    ref = np_physics.relax(case[0], case[1], lift_force=case[2],
                           mass=case[3], drag_k=case[4])
    np.testing.assert_allclose(np.asarray(out, np.float64), ref, rtol=1e-5,
                               atol=1e-5)
    assert np.all(np.isfinite(np.asarray(grad(x)))), case
    assert np.all(np.isfinite(np.asarray(rev(x)))), case


@PRECISIONS
# Most random (helium, sand) pairs leave the balloon far from neutral, so
# many draws climb out of the atmosphere and are filtered out by `assume`.
@settings(_FEW, suppress_health_check=[HealthCheck.filter_too_much])
@given(k=KEY, h=ALTITUDE, v=RATE, n=HELIUM, s=SAND,
       duration=_f32(1.0, 1200.0))
def test_integrate_vertical_matches_numpy(x64, k, h, v, n, s, duration):
  ble = _ble_atmosphere(k)
  lift = np_physics.free_lift(n, PAYLOAD, s) * np_physics.GRAVITY
  mass = np_physics.total_mass(PAYLOAD, s, n)

  def drag_k_at(hh):
    hh = min(max(hh, -600.0), 84_000.0)
    a = ble.at_height(units.Distance(m=hh))
    return float(np_physics.drag_factor(n, C_D, a.temperature, a.pressure))

  steps = physics.num_vertical_steps(duration)
  assume(steps in _INTEGRATE)
  ref_h, ref_v = np_physics.integrate_vertical(
      h, v, duration, lift_force=lift, mass=mass, drag_k_at=drag_k_at)
  assume(ref_h > 0.0 and ref_h < 80_000.0)
  dtype = _dtype(x64)
  with jax.enable_x64(x64):
    got_h, got_v = _INTEGRATE[steps](
        _atm_params(k), *(jnp.asarray(x, dtype)
                          for x in (h, v, duration, lift, mass, n)))
  assert abs(float(got_h) - ref_h) <= (1e-7 if x64 else 0.05 + 2e-6 *
                                       abs(ref_h - h))
  assert abs(float(got_v) - ref_v) <= (1e-10 if x64 else 1e-3)


@PRECISIONS
@_SETTINGS
@given(k=KEY, h=ALTITUDE, rate=_f32(-8.0, 8.0), s=SAND)
def test_vent_solve_matches_numpy(x64, k, h, rate, s):
  t, p = _ambient(k, h)
  ref = np_physics.vent_target_mols(PAYLOAD, s, rate, C_D, t, p)
  ref_lift = np_physics.free_lift(ref, PAYLOAD, s)
  dtype = _dtype(x64)
  with jax.enable_x64(x64):
    args = [jnp.asarray(x, dtype) for x in (PAYLOAD, s, rate, C_D, t, p)]
    got = _vent_target(*args)
    got_lift = _vent_lift(*args)
  assert _rel(got, ref) <= (1e-13 if x64 else 1e-6)
  assert abs(float(got_lift) - ref_lift) <= (1e-13 if x64 else 1e-6) * max(
      abs(ref_lift), 1.0 if x64 else 1e-3) + (1e-14 if x64 else 0.0) * 5


def test_vent_newton_converges_for_any_beta():
  """The cubic depends on beta = b / (a3 r) only (physics.vent_root)."""
  with jax.enable_x64(True):
    beta = jnp.linspace(-200.0, 200.0, 40_001)
    s = physics.vent_root(1.0, beta, 1.0)
    residual = jnp.abs((s - beta) * s * s - 1.0) / (1.0 + jnp.abs(beta) * s *
                                                    s)
    assert float(residual.max()) < 1e-14
    assert bool(jnp.all(s > jnp.maximum(2.0 * beta / 3.0, 0.0)))
    # Realistic range: converged with iterations to spare.
    small = physics.vent_root(1.0, jnp.linspace(-5.0, 5.0, 1001), 1.0,
                              iterations=6)
    big = physics.vent_root(1.0, jnp.linspace(-5.0, 5.0, 1001), 1.0)
    np.testing.assert_allclose(small, big, rtol=1e-15)
  # float32 over the flight envelope (13-22 km, |rate| <= 7 m/s).
  t, p = _ambient(0, 13_000.0)
  rates = jnp.linspace(-7.0, 7.0, 101)
  s32 = physics.vent_root(*physics.vent_coefficients(
      PAYLOAD, 0.0, rates, C_D, t, p))
  for rate, si in zip(np.asarray(rates), np.asarray(s32)):
    ref = np_physics.vent_target_mols(PAYLOAD, 0.0, float(rate), C_D, t, p)
    assert _rel(float(si)**3, ref) < 1e-6


@PRECISIONS
@_SETTINGS
@given(k=KEY, h=ALTITUDE, rate=_f32(-8.0, 8.0), n=HELIUM)
def test_ballast_solve_matches_numpy(x64, k, h, rate, n):
  t, p = _ambient(k, h)
  ref = np_physics.ballast_target_sand(n, PAYLOAD, rate, C_D, t, p)
  ref_lift = np_physics.free_lift(n, PAYLOAD, ref)
  dtype = _dtype(x64)
  with jax.enable_x64(x64):
    got = physics.ballast_target_sand(
        *(jnp.asarray(x, dtype) for x in (n, PAYLOAD, rate, C_D, t, p)))
    got_lift = physics.ballast_target_lift_kg(
        *(jnp.asarray(x, dtype) for x in (n, rate, C_D, t, p)))
  assert abs(float(got) - ref) <= (1e-12 if x64 else 1e-6) * 5.0
  assert abs(float(got_lift) - ref_lift) <= (1e-12 if x64 else 2e-6) * max(
      abs(ref_lift), 1.0 if x64 else 1e-2)


# --- controller --------------------------------------------------------------


def _check_actuation(got, ref, x64, params=PARAMS):
  assert int(got.decision) == list(Decision).index(ref.decision)
  assert bool(got.guarded) == ref.guarded
  assert abs(float(got.desired_ascent_rate) - ref.desired_ascent_rate) <= (
      1e-12 if x64 else 1e-5)
  assert abs(float(got.vent_mols) - ref.vent_mols) <= (1e-9 if x64 else 2e-5)
  assert abs(float(got.drop_kg) - ref.drop_kg) <= (1e-11 if x64 else 1e-6)
  del params


@PRECISIONS
@_SETTINGS
@given(k=KEY, h=ALTITUDE, v=RATE, n=HELIUM, s=SAND, action=ACTION)
def test_decide_matches_numpy(x64, k, h, v, n, s, action):
  if not x64:
    assume(not _near_threshold(PARAMS, k, h, v, n, s, action))
  ref = _np_decide(PARAMS, k, h, v, n, s, action)
  t, p = _ambient(k, h)
  dtype = _dtype(x64)
  with jax.enable_x64(x64):
    state = _jax_state(PARAMS, k, h, v, n, s)
    got = _decide(PARAMS, state, jnp.asarray(action, dtype),
                  jnp.asarray(t, dtype), jnp.asarray(p, dtype))
  _check_actuation(got, ref, x64)
  # The target lift is the lift once the amounts are released.
  after = np_physics.free_lift(n - ref.vent_mols, PAYLOAD, s - ref.drop_kg)
  assert abs(float(got.lift_after_kg) - after) <= (1e-12 if x64 else 1e-6)


@PRECISIONS
@_SETTINGS
@given(k=KEY, h=st.one_of(_f32(11_000.0, 12_999.0), _f32(22_001.0, 24_000.0)),
       v=RATE, n=HELIUM, s=SAND, action=ACTION)
def test_band_guard_matches_numpy_outside_the_band(x64, k, h, v, n, s,
                                                   action):
  if not x64:
    assume(not _near_threshold(PARAMS, k, h, v, n, s, action))
  ref = _np_decide(PARAMS, k, h, v, n, s, action)
  t, p = _ambient(k, h)
  dtype = _dtype(x64)
  with jax.enable_x64(x64):
    state = _jax_state(PARAMS, k, h, v, n, s)
    got = _decide(PARAMS, state, jnp.asarray(action, dtype),
                  jnp.asarray(t, dtype), jnp.asarray(p, dtype))
  _check_actuation(got, ref, x64)


def test_band_guard_is_an_action_filter():
  k, n, s = 0, 170.0, 1.0
  for h, v, rate, decision, stands in [
      (12_500.0, -1.0, -2.0, state_lib.DecisionCode.VENT, False),
      (12_500.0, -1.0, 1.0, state_lib.DecisionCode.BALLAST, True),
      (12_500.0, -1.0, 0.0, state_lib.DecisionCode.NOTHING, False),
      (12_500.0, 1.0, 0.0, state_lib.DecisionCode.NOTHING, True),
      (22_500.0, 1.0, 2.0, state_lib.DecisionCode.BALLAST, False),
      (22_500.0, 1.0, -2.0, state_lib.DecisionCode.VENT, True),
      (17_000.0, 1.0, 3.0, state_lib.DecisionCode.BALLAST, True),
  ]:
    state = _jax_state(PARAMS, k, h, v, n, s)
    act = controller.Actuation(
        decision=jnp.int32(decision), desired_ascent_rate=jnp.float32(rate),
        vent_mols=jnp.float32(0.5), drop_kg=jnp.float32(0.0),
        guarded=jnp.bool_(False), lift_after_kg=jnp.float32(0.1))
    out = controller.band_guard(PARAMS, state, act)
    if stands:
      assert int(out.decision) == decision and not bool(out.guarded)
    else:
      ref = _np_controller(PARAMS).float_actuation(
          helium_mols=n, sand_kg=s, payload_kg=PAYLOAD, guarded=True)
      assert int(out.decision) == state_lib.DecisionCode.FLOAT
      assert bool(out.guarded)
      assert float(out.vent_mols) == pytest.approx(ref.vent_mols, rel=1e-6)
      assert float(out.lift_after_kg) == 0.0


@pytest.mark.parametrize('which', ['vent', 'ballast'])
def test_thresholds_match_numpy(which):
  """n_min and m_s_min: just above the amount -> nothing, just below -> act."""
  k, h, s = 3, 17_000.0, 1.0
  n = 170.0 if which == 'vent' else 120.0  # free lift +1.04 / -0.20 kg
  action = (15_000.0, 2.0, -1.0) if which == 'vent' else (20_000.0, 1.0,
                                                            -1.0)
  v = 0.0
  free = params_lib.make_flight_params(min_vent_mols=0.0, min_drop_kg=0.0)
  amount = _np_decide(free, k, h, v, n, s, action)
  amount = amount.vent_mols if which == 'vent' else amount.drop_kg
  assert amount > 0.0
  t, p = _ambient(k, h)
  with jax.enable_x64(True):
    for factor, acts in ((1.0 + 1e-9, False), (1.0 - 1e-9, True)):
      key = 'min_vent_mols' if which == 'vent' else 'min_drop_kg'
      params = params_lib.make_flight_params(**{key: amount * factor})
      ref = _np_decide(params, k, h, v, n, s, action)
      got = _decide(params, _jax_state(params, k, h, v, n, s),
                    jnp.asarray(action), t, p)
      assert (ref.decision != Decision.NOTHING) == acts
      _check_actuation(got, ref, True)


# --- dynamics: one stride against LatexBalloon.simulate_step -----------------


def _compare_stride(x64, k, h, v, n, s, action, *, analytic, x=0.0, y=0.0):
  wind_np = _analytic_wind_np if analytic else CONST_WIND_NP
  step = _STEP_ANALYTIC if analytic else _STEP_CONST
  ns = _np_step(k, h, v, n, s, action, wind_np, state_kwargs=dict(x=x, y=y))
  if not x64:
    assume(not _end_near_boundary(PARAMS, ns))
  with jax.enable_x64(x64):
    state = _jax_state(PARAMS, k, h, v, n, s, x=x, y=y)
    js = step(PARAMS, _atm_params(k), state,
              jnp.asarray(action, _dtype(x64)))
  _assert_step_matches(js, ns, x64)
  return js, ns


@PRECISIONS
@_SETTINGS
@given(k=KEY, h=ALTITUDE, v=RATE, n=HELIUM, s=SAND, action=ACTION)
def test_step_matches_numpy_constant_wind(x64, k, h, v, n, s, action):
  if not x64:
    assume(not _near_threshold(PARAMS, k, h, v, n, s, action))
  _compare_stride(x64, k, h, v, n, s, action, analytic=False)


@PRECISIONS
@_FEW
@given(k=KEY, h=ALTITUDE, v=RATE, n=HELIUM, s=SAND, action=ACTION,
       x=_f32(-200_000.0, 200_000.0), y=_f32(-200_000.0, 200_000.0))
def test_step_matches_numpy_analytic_wind(x64, k, h, v, n, s, action, x, y):
  if not x64:
    assume(not _near_threshold(PARAMS, k, h, v, n, s, action))
  _compare_stride(x64, k, h, v, n, s, action, analytic=True, x=x, y=y)


FINITE = dict(valve_flow_mols_per_s=0.1, ballast_rate_kg_per_s=0.002)
_FINITE_PARAMS = params_lib.make_flight_params(**FINITE)
_STEP_FINITE = _STEP_CONST  # The static params fields retrace it.


@PRECISIONS
@_FEW
@given(k=KEY, h=ALTITUDE, v=RATE, n=HELIUM, s=SAND, action=ACTION)
def test_step_matches_numpy_finite_rates(x64, k, h, v, n, s, action):
  if not x64:
    assume(not _near_threshold(_FINITE_PARAMS, k, h, v, n, s, action))
  ns = _np_step(k, h, v, n, s, action, CONST_WIND_NP, balloon_kwargs=FINITE)
  if not x64:
    assume(not _end_near_boundary(_FINITE_PARAMS, ns))
  with jax.enable_x64(x64):
    js = _STEP_FINITE(_FINITE_PARAMS, _atm_params(k),
                      _jax_state(_FINITE_PARAMS, k, h, v, n, s),
                      jnp.asarray(action, _dtype(x64)))
  _assert_step_matches(js, ns, x64, finite=True)


@PRECISIONS
@pytest.mark.parametrize('case', [
    # (name, k, h, v, n, s, action, state kwargs, expected status)
    ('burst', 1, 18_000.0, 2.0, 180.0, 1.0, (21_000.0, 1.0, -1.0),
     dict(burst_volume_m3=60.0), Status.BURST),
    ('out_of_sand', 2, 17_000.0, 0.0, None, 0.004, (17_000.0, 1.0, 1.0), {},
     Status.OUT_OF_SAND),
    ('out_of_helium', 3, 17_000.0, 0.0, 87.0, 0.0, (17_000.0, 1.0, 1.0), {},
     Status.OUT_OF_HELIUM),
    ('grounded', 4, 1_500.0, -5.0, 85.0, 0.0, (14_000.0, 1.0, -1.0), {},
     Status.GROUNDED),
    ('guard_floats', 5, 12_900.0, -3.0, 160.0, 1.5, (14_000.0, 5.0, -1.0),
     {}, Status.OK),
])
def test_terminal_cases_match_numpy(x64, case):
  _, k, h, v, n, s, action, kwargs, expected = case
  if n is None:
    n = np_physics.neutral_helium_mols(PAYLOAD, s)
  ns = _np_step(k, h, v, n, s, action, CONST_WIND_NP, state_kwargs=kwargs)
  assert ns.latex_status == expected
  params = PARAMS.replace(**{
      'burst_volume_m3': kwargs['burst_volume_m3']} if kwargs else {})
  with jax.enable_x64(x64):
    state = _jax_state(params, k, h, v, n, s)
    js = _STEP_CONST(params, _atm_params(k), state,
                     jnp.asarray(action, _dtype(x64)))
    _assert_step_matches(js, ns, x64)
    if expected != Status.OK:
      # A terminal state is frozen (NumPy refuses to step it).
      again = _STEP_CONST(params, _atm_params(k), js,
                          jnp.asarray((15_000.0, 1.0, -1.0), _dtype(x64)))
      for a, b in zip(jax.tree.leaves(again), jax.tree.leaves(js)):
        np.testing.assert_array_equal(a, b)
  if case[0] == 'burst':
    assert ns.time_elapsed < dt.timedelta(minutes=20)
  if case[0] == 'guard_floats':
    assert ns.guard_engaged


def test_neutral_balloon_stays_put_in_float32():
  """The carried lift keeps a float exactly neutral (no float32 drift)."""
  atm = _atm_params(0)
  state = state_lib.initial_state(PARAMS, 17_000.0, atm_params=atm)
  assert float(state.free_lift_kg) == 0.0
  for _ in range(3):
    state = _STEP_CONST(PARAMS, atm, state, jnp.asarray((17_000.0, 1.0, 1.0)))
  assert float(state.altitude_m) == 17_000.0
  assert float(state.ascent_rate_mps) == 0.0
  # A float after a climb leaves exactly zero lift.
  state = _jax_state(PARAMS, 0, 17_000.0, 2.0, 175.0, 1.0)
  state = _STEP_CONST(PARAMS, atm, state, jnp.asarray((17_000.0, 1.0, 1.0)))
  assert float(state.free_lift_kg) == 0.0


# --- jit, vmap and gradients -------------------------------------------------


def _random_batch(rng, size, params=PARAMS):
  h = rng.uniform(13_000.0, 22_000.0, size)
  v = rng.uniform(-6.0, 6.0, size)
  n = rng.uniform(88.0, 200.0, size)
  s = rng.uniform(0.0, 2.0, size)
  actions = np.stack([rng.uniform(14_000.0, 21_000.0, size),
                      rng.uniform(1.0, 5.0, size),
                      rng.uniform(-1.0, 1.0, size)], axis=-1)
  keys = jax.random.split(jax.random.PRNGKey(11), size)
  atms = jax.vmap(atmosphere.reset)(keys)
  states = jax.vmap(lambda a, hh, vv, nn, ss: state_lib.initial_state(
      params, hh, atm_params=a, ascent_rate_mps=vv, helium_mols=nn,
      sand_kg=ss))(atms, h, v, n, s)
  return atms, states, jnp.asarray(actions, jnp.float32)


def test_vmap_equals_loop_of_single_steps():
  rng = np.random.default_rng(0)
  atms, states, actions = _random_batch(rng, 256)
  batched = jax.jit(jax.vmap(_STEP_ANALYTIC, in_axes=(None, 0, 0, 0)))(
      PARAMS, atms, states, actions)
  statuses = set()
  for i in range(256):
    one = jax.tree.map(lambda a, i=i: a[i], (atms, states, actions))
    single = _STEP_ANALYTIC(PARAMS, *one)
    for name in ('status', 'last_decision', 'guard_engaged'):
      assert int(getattr(single, name)) == int(getattr(batched, name)[i])
    for name in ('altitude_m', 'x_m', 'y_m', 'helium_mols', 'sand_kg',
                 'ascent_rate_mps', 'time_s'):
      a, b = float(getattr(single, name)), float(getattr(batched, name)[i])
      assert abs(a - b) <= 1e-5 * max(abs(a), 1.0), (i, name, a, b)
    statuses.add(int(single.status))
  assert len(statuses) > 1  # the batch covers terminal statuses too


def test_step_traces_once():
  """Different states and actions reuse one compiled stride."""
  rng = np.random.default_rng(1)
  atms, states, actions = _random_batch(rng, 3)
  before = _STEP_CONST._cache_size()
  for i in range(3):
    one = jax.tree.map(lambda a, i=i: a[i], (atms, states, actions))
    _STEP_CONST(PARAMS, *one)
  compiled = _STEP_CONST._cache_size()
  assert compiled - before <= 1
  _STEP_CONST(PARAMS.replace(payload_kg=2.5, burst_volume_m3=300.0),
              *jax.tree.map(lambda a: a[0], (atms, states, actions)))
  assert _STEP_CONST._cache_size() == compiled


def test_step_derivative_is_finite():
  """d(final altitude)/d(a0) through a whole stride (forward mode)."""
  atm = _atm_params(0)
  state = _jax_state(PARAMS, 0, 17_000.0, 0.5, 172.0, 1.5)

  def final_altitude(a0):
    out = dynamics.step(PARAMS, atm, state, jnp.stack([a0, 2.0, -1.0]),
                        _const_wind)
    return out.altitude_m

  derivative = jax.jit(lambda a0: jax.jvp(final_altitude, (a0,),
                                          (jnp.ones_like(a0),))[1])
  d = float(derivative(jnp.float32(15_000.0)))  # a vent decision
  assert np.isfinite(d) and 0.0 < d < 1.0


_STEP_SCHEDULED = dynamics.make_scheduled_step(_analytic_wind)


@pytest.mark.slow
@pytest.mark.ci
@pytest.mark.parametrize('finite', [False, True])
def test_scheduled_step_equals_static_step_and_compiles_once(finite):
  """A traced `padded_schedule` flies the static stride.

  Bit for bit but the position, which XLA may round once differently
  (x + u dt fused otherwise; <= 1 ulp).

  Strides of other lengths with the same padded shape (5 to 8 sub-steps)
  reuse one compiled step; the static `time_delta_s` compiles per length.
  """
  params = _FINITE_PARAMS if finite else PARAMS
  rng = np.random.default_rng(2)
  atms, states, actions = _random_batch(rng, 4, params)
  before = _STEP_SCHEDULED._cache_size()
  for i, time_delta_s in enumerate((1200.0, 901.0, 1.44e3 - 1e-3)):
    grid = dynamics.padded_schedule(time_delta_s, params.max_substep_s,
                                    params.vertical_step_s)
    assert grid.valid.shape == (8,) and grid.chunks.shape == (8, 4)
    one = jax.tree.map(lambda a, i=i: a[i], (atms, states, actions))
    static = dynamics.make_step(_analytic_wind, time_delta_s)(params, *one)
    traced = _STEP_SCHEDULED(params, *one, grid)
    for name, a in static.__dict__.items():
      if name in ('x_m', 'y_m'):  # XLA may fuse x + u dt differently.
        np.testing.assert_allclose(np.asarray(getattr(traced, name)),
                                   np.asarray(a), rtol=2.5e-7, err_msg=name)
      else:
        np.testing.assert_array_equal(np.asarray(getattr(traced, name)),
                                      np.asarray(a), err_msg=name)
  assert _STEP_SCHEDULED._cache_size() - before == 1
