"""The flight core's tests against the NumPy oracle: what they share.

The hypothesis settings and realistic ranges, the BLE atmospheres, states built
on both sides, the winds, the core's functions jitted once, and the oracle's
stride with the check that a JAX stride matches it (used by test_core.py,
test_atmosphere.py, test_physics.py, test_controller.py, test_dynamics.py)."""

import datetime as dt
import functools
import math

from balloon_learning_environment.env import wind_field
from balloon_learning_environment.env.balloon import standard_atmosphere
from balloon_learning_environment.utils import units
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


SETTINGS = settings(max_examples=30, deadline=None, derandomize=True)
FEW = settings(max_examples=15, deadline=None, derandomize=True)
PRECISIONS = pytest.mark.parametrize('x64', [False, True],
                                     ids=['float32', 'float64'])
Status = balloon_lib.LatexBalloonStatus
Decision = controller_lib.Decision
PARAMS = params_lib.FlightParams()
PAYLOAD = PARAMS.payload_kg  # [kg]
C_D = PARAMS.drag_coefficient  # [.]
LPM = np_physics.LIFT_PER_MOL  # [kg/mol]


def f32(low: float, high: float):
  """float32-representable floats in [low, high] (bounds rounded)."""
  return st.floats(float(np.float32(low)), float(np.float32(high)), width=32,
                   allow_subnormal=False)


ALTITUDE = f32(13_000.0, 22_000.0)  # [m]
RATE = f32(-6.0, 6.0)  # [m/s]
HELIUM = f32(88.0, 200.0)  # [mol]
SAND = f32(0.0, 2.0)  # [kg]
ACTION = st.tuples(f32(14_000.0, 21_000.0), f32(1.0, 5.0), f32(-1.0, 1.0))
KEY = st.integers(0, 2**20)


@functools.lru_cache(maxsize=None)
def ble_atmosphere(k: int) -> standard_atmosphere.Atmosphere:
  with jax.enable_x64(False):
    return standard_atmosphere.Atmosphere(jax.random.PRNGKey(k))


def atm_params(k: int) -> atmosphere.AtmosphereParams:
  return reset(jax.random.PRNGKey(k))


def ambient(k: int, h: float):
  """BLE's (T [K], P [Pa]) at h."""
  a = ble_atmosphere(k).at_height(units.Distance(m=h))
  return float(a.temperature), float(a.pressure)


def dtype(x64: bool):
  return np.float64 if x64 else np.float32


BATCH = 16  # Hypothesis' height lists, padded: one compile per precision.


def padded(values, dtype) -> jnp.ndarray:
  """`values` padded to `BATCH` with its last value (a fixed shape, so the
  jitted function compiles once, not once per list length)."""
  values = list(values)
  return jnp.asarray(values + values[-1:] * (BATCH - len(values)), dtype)


def rel(a, b) -> float:
  return abs(float(a) / float(b) - 1.0)


def np_state(k, h, v, n, s, *, x=0.0, y=0.0, **kwargs):
  return balloon_lib.create_state(
      center_latlng=s2.LatLng.from_degrees(1.0, -113.0),
      date_time=dt.datetime(2022, 11, 1, tzinfo=dt.timezone.utc),
      atmosphere=ble_atmosphere(k), altitude_m=h, ascent_rate_mps=v,
      helium_mols=n, sand_kg=s, x=units.Distance(m=x),
      y=units.Distance(m=y), **kwargs)


def jax_state(params, k, h, v, n, s, *, x=0.0, y=0.0):
  return state_lib.initial_state(params, h, x, y, atm_params=atm_params(k),
                                 ascent_rate_mps=v, helium_mols=n, sand_kg=s)


def np_controller(params) -> controller_lib.AltitudeController:
  return controller_lib.AltitudeController(
      min_vent_mols=params.min_vent_mols, min_drop_kg=params.min_drop_kg,
      band_low_m=params.band_low_m, band_high_m=params.band_high_m)


def np_decide(params, k, h, v, n, s, action):
  t, p = ambient(k, h)
  return np_controller(params).decide(
      np.asarray(action, np.float64), altitude_m=h, ascent_rate_mps=v,
      helium_mols=n, sand_kg=s, payload_kg=params.payload_kg,
      drag_coefficient=params.drag_coefficient, temperature=t, pressure=p)


def near_threshold(params, k, h, v, n, s, action) -> bool:
  """The controller's choice is within float32 rounding of a threshold."""
  a0, a1, a2 = action
  if a2 > 0.0:
    return abs(np_physics.free_lift(n, params.payload_kg, s)) < 1e-5
  t, p = ambient(k, h)
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


def const_wind(x, y, p, t):
  del y, p, t
  return 3.0 + 0.0 * x, -2.0 + 0.0 * x


CONST_WIND_NP = wind_field.WindVector(units.Velocity(mps=3.0),
                                      units.Velocity(mps=-2.0))


def analytic_wind(x, y, p, t):
  """A smooth wind varying with position, pressure and time. # [m/s]"""
  u = 4.0 + 1e-4 * y + 1e-3 * (p - 8000.0) + 2.0 * jnp.sin(t / 3000.0)
  v = -3.0 + 2e-4 * x - 5e-4 * (p - 8000.0) + jnp.cos(t / 5000.0)
  return u, v


def analytic_wind_np(x, y, pressure, time_elapsed):
  x, y, t = x.meters, y.meters, time_elapsed.total_seconds()
  u = 4.0 + 1e-4 * y + 1e-3 * (pressure - 8000.0) + 2.0 * math.sin(t / 3000.0)
  v = -3.0 + 2e-4 * x - 5e-4 * (pressure - 8000.0) + math.cos(t / 5000.0)
  return wind_field.WindVector(units.Velocity(mps=u), units.Velocity(mps=v))


# Jitted once (and retraced once per precision).
reset = jax.jit(atmosphere.reset)
at_height = jax.jit(atmosphere.at_height)
at_pressure = jax.jit(atmosphere.at_pressure)
relax = jax.jit(lambda v0, t, f, m, k: physics.relax(
    v0, t, lift_force=f, mass=m, drag_k=k))
decide = jax.jit(controller.decide)
vent_target = jax.jit(physics.vent_target_mols)
vent_lift = jax.jit(physics.vent_target_lift_kg)
STEP_CONST = dynamics.make_step(const_wind)
STEP_ANALYTIC = dynamics.make_step(analytic_wind)


def integrate_fn(num_steps):

  @jax.jit
  def run(atm, h, v, duration, lift, mass, n):

    def drag_k_at(hh):
      amb = atmosphere.at_height(atm, hh)
      return physics.drag_factor(n, C_D, amb.temperature, amb.pressure)

    return physics.integrate_vertical(h, v, duration, lift_force=lift,
                                      mass=mass, drag_k_at=drag_k_at,
                                      num_steps=num_steps)

  return run


INTEGRATE = {n: integrate_fn(n) for n in (1, 20)}


def np_step(k, h, v, n, s, action, wind, balloon_kwargs=None,
             state_kwargs=None):
  state = np_state(k, h, v, n, s, **(state_kwargs or {}))
  b = balloon_lib.LatexBalloon(state, **(balloon_kwargs or {}))
  b.simulate_step(wind, ble_atmosphere(k), np.asarray(action, np.float64),
                  dt.timedelta(minutes=20))
  return b.state


def assert_step_matches(js, ns, x64, *, check_guard=True, finite=False):
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


def end_near_boundary(params, ns) -> bool:
  """NumPy's end state is within float32 rounding of a status boundary."""
  volume = ns.envelope_volume
  return (abs(ns.helium_mols * LPM - params.payload_kg) < 1e-4 or
          abs(ns.sand_kg - params.min_drop_kg) < 1e-5 or
          abs(volume / params.burst_volume_m3 - 1.0) < 1e-4 or
          abs(ns.altitude_m) < 1.0)


FINITE = dict(valve_flow_mols_per_s=0.1, ballast_rate_kg_per_s=0.002)
FINITE_PARAMS = params_lib.make_flight_params(**FINITE)
