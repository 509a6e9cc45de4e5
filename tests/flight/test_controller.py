# coding=utf-8
"""Tests of the action check and Eq. fullcontroller (NumPy oracle)."""

import datetime as dt

from balloon_learning_environment.utils import units
from hypothesis import assume
from hypothesis import given
from hypothesis import settings
from hypothesis import strategies as st
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex.envs import gymnasium_env
from ble_latex.envs import jax_env
from ble_latex.flight import controller
from ble_latex.flight import params as params_lib
from ble_latex.flight import state as state_lib
# The retired NumPy controller, the oracle of the core (oracle_cases.py).
from tests.reference import numpy_controller as controller_lib
from tests.reference import numpy_physics as physics

from tests.flight import oracle_cases as cases

_SETTINGS = settings(max_examples=40, deadline=None)
PAYLOAD = 2.2  # [kg]
SAND = 2.0  # [kg]
C_D = 0.25
Decision = controller_lib.Decision


def _ambient(atmosphere, h):
  a = atmosphere.at_height(units.Distance(m=h))
  return dict(temperature=float(a.temperature), pressure=float(a.pressure))


def _steady(atmosphere, h, rate, sand=SAND):
  """Keyword state of a balloon in steady motion at `rate` at altitude h."""
  amb = _ambient(atmosphere, h)
  n = physics.vent_target_mols(PAYLOAD, sand, rate, C_D, **amb)
  return dict(altitude_m=h, ascent_rate_mps=rate, helium_mols=n,
              sand_kg=sand, payload_kg=PAYLOAD, drag_coefficient=C_D, **amb)


def _apply(state, act):
  n = state['helium_mols'] - act.vent_mols
  sand = state['sand_kg'] - act.drop_kg
  return n, sand


@pytest.mark.parametrize('action', [
    [14_000, 1, -1], [21_000, 5, 1], (17_500.0, 2.5, 0.0),
    np.array([15_000, 3, 0.3], dtype=np.float32)])
def test_validate_action_accepts_in_range(action):
  a = gymnasium_env.validate_actions(action, None, jax_env.ACTION_LOW,
                                     jax_env.ACTION_HIGH)
  assert a.dtype == np.float64 and a.shape == (3,)


@pytest.mark.parametrize('action,match', [
    ([float('nan'), 1, 0], 'a0'),
    ([17_000, float('inf'), 0], 'a1'),
    ([17_000, 1, float('-inf')], 'a2'),
    ([13_999, 1, 0], r'a0 .*\[14000, 21000\]'),
    ([21_001, 1, 0], 'a0'),
    ([17_000, 0.5, 0], 'a1'),
    ([17_000, 5.1, 0], 'a1'),
    ([17_000, 1, 1.5], 'a2'),
    ([17_000, 1], r'shape \(3,\)'),
    ([[17_000, 1, 0, 0]], r'shape \(3,\)'),
    ([[17_000, 1, 0]], r'shape \(3,\)'),
    ('abc', 'numbers'),
    (None, 'numbers'),
])
def test_validate_action_rejects_bad(action, match):
  with pytest.raises(ValueError, match=match):
    gymnasium_env.validate_actions(action, None, jax_env.ACTION_LOW,
                                     jax_env.ACTION_HIGH)


def test_action_bounds_match_paper():
  np.testing.assert_array_equal(jax_env.ACTION_LOW, [14_000, 1, -1])
  np.testing.assert_array_equal(jax_env.ACTION_HIGH, [21_000, 5, 1])


def test_desired_ascent_rate_formula():
  c = controller_lib.AltitudeController()
  assert c.desired_ascent_rate(17_000.0, 18_200.0, 2.0) == pytest.approx(
      1_200.0 / (2.0 * 1_200.0))


@pytest.mark.parametrize('kwargs', [
    dict(min_vent_mols=-1.0), dict(min_drop_kg=float('nan')),
    dict(band_low_m=22_000.0, band_high_m=13_000.0),
    dict(stride=dt.timedelta(0))])
def test_constructor_rejects_bad_values(kwargs):
  with pytest.raises(ValueError):
    controller_lib.AltitudeController(**kwargs)


def test_float_takes_precedence_and_reaches_neutral(atmosphere):
  c = controller_lib.AltitudeController()
  # Rising with free lift: float vents to neutral, a0/a1 ignored.
  state = _steady(atmosphere, 17_000.0, 1.0)
  act = c.decide([14_000, 1, 0.5], **state)
  assert act.decision == Decision.FLOAT and act.drop_kg == 0.0
  n, sand = _apply(state, act)
  assert physics.free_lift(n, PAYLOAD, sand) == pytest.approx(0.0, abs=1e-12)
  # Sinking: float drops sand to neutral.
  state = _steady(atmosphere, 17_000.0, -1.0)
  act = c.decide([21_000, 5, 1.0], **state)
  assert act.decision == Decision.FLOAT and act.vent_mols == 0.0
  n, sand = _apply(state, act)
  assert physics.free_lift(n, PAYLOAD, sand) == pytest.approx(0.0, abs=1e-12)


@_SETTINGS
@given(h=st.floats(14_000.0, 21_000.0), v=st.floats(-3.0, 3.0),
       a0=st.floats(14_000.0, 21_000.0), a1=st.floats(1.0, 5.0))
def test_vent_or_ballast_solution_has_zero_force_residual(atmosphere, h, v,
                                                          a0, a1):
  c = controller_lib.AltitudeController()
  state = _steady(atmosphere, h, v)
  act = c.decide([a0, a1, -1.0], **state)
  rate = c.desired_ascent_rate(h, a0, a1)
  assert act.desired_ascent_rate == pytest.approx(rate)
  if act.decision == Decision.NOTHING:
    return
  assert act.decision == (Decision.BALLAST if rate > v else Decision.VENT)
  n, sand = _apply(state, act)
  assume(sand > 0.0)  # Reachable without running out of sand.
  residual = physics.force_balance_residual(
      rate, n, PAYLOAD, sand, C_D, state['temperature'], state['pressure'])
  assert abs(residual) <= 1e-9 * physics.weight_force(PAYLOAD, sand, n)


@_SETTINGS
@given(h=st.floats(13_000.0, 22_000.0), v=st.floats(-6.0, 6.0),
       sand=st.floats(0.0, 0.2), a0=st.floats(14_000.0, 21_000.0),
       a1=st.floats(1.0, 5.0), a2=st.floats(-1.0, 1.0))
def test_never_more_than_aboard(atmosphere, h, v, sand, a0, a1, a2):
  c = controller_lib.AltitudeController()
  state = _steady(atmosphere, h, v, sand=sand)
  act = c.decide([a0, a1, a2], **state)
  assert 0.0 <= act.vent_mols <= state['helium_mols']
  assert 0.0 <= act.drop_kg <= sand
  assert act.vent_mols == 0.0 or act.drop_kg == 0.0


def test_below_thresholds_do_nothing(atmosphere):
  c = controller_lib.AltitudeController()
  state = _steady(atmosphere, 17_000.0, 0.0)
  # 100 m in 5 strides: 0.017 m/s needs ~0.01 g of sand.
  for a0 in (17_100.0, 16_900.0):
    act = c.decide([a0, 5.0, -1.0], **state)
    assert act.decision == Decision.NOTHING
    assert act.vent_mols == 0.0 and act.drop_kg == 0.0
  # The same command with huge thresholds, and a real one with default ones.
  big = controller_lib.AltitudeController(min_vent_mols=50.0, min_drop_kg=1.0)
  assert big.decide([19_000, 1, -1], **state).decision == Decision.NOTHING
  assert big.decide([15_000, 1, -1], **state).decision == Decision.NOTHING
  assert c.decide([19_000, 1, -1], **state).decision == Decision.BALLAST
  assert c.decide([15_000, 1, -1], **state).decision == Decision.VENT


def test_threshold_edges(atmosphere):
  state = _steady(atmosphere, 17_000.0, 0.0)
  act = controller_lib.AltitudeController().decide([18_000, 1, -1], **state)
  exact = controller_lib.AltitudeController(min_drop_kg=act.drop_kg)
  assert exact.decide([18_000, 1, -1], **state).decision == Decision.BALLAST
  above = controller_lib.AltitudeController(min_drop_kg=act.drop_kg * 1.001)
  assert above.decide([18_000, 1, -1], **state).decision == Decision.NOTHING


@pytest.mark.parametrize('h,v,expect_guard', [
    (12_900.0, -0.3, True),   # below the band, sinking, command too weak
    (12_900.0, 0.0, True),    # below the band, floating
    (12_900.0, 0.3, False),   # below the band but already rising
    (22_100.0, 0.3, True),    # above the band, rising
    (22_100.0, -0.3, False),  # above the band but already sinking
    (13_000.0, -0.3, False),  # at the edge: inside
    (22_000.0, 0.3, False),   # at the edge: inside
])
def test_band_guard_when_doing_nothing(atmosphere, h, v, expect_guard):
  c = controller_lib.AltitudeController(min_vent_mols=1e3, min_drop_kg=1e3)
  state = _steady(atmosphere, h, v)
  act = c.decide([17_000, 5, -1], **state)  # Thresholds: always "nothing".
  assert act.guarded == expect_guard
  assert act.decision == (Decision.FLOAT if expect_guard else Decision.NOTHING)
  if expect_guard:
    n, sand = _apply(state, act)
    assert physics.free_lift(n, PAYLOAD, sand) == pytest.approx(0.0,
                                                                abs=1e-12)


def test_band_guard_lets_moves_back_into_band(atmosphere):
  c = controller_lib.AltitudeController()
  below = _steady(atmosphere, 12_800.0, -0.5)
  act = c.decide([15_000, 1, -1], **below)
  assert act.decision == Decision.BALLAST and not act.guarded
  above = _steady(atmosphere, 22_300.0, 0.5)
  act = c.decide([20_000, 1, -1], **above)
  assert act.decision == Decision.VENT and not act.guarded


@pytest.mark.parametrize('field', ['altitude_m', 'ascent_rate_mps',
                                   'helium_mols', 'temperature'])
def test_decide_rejects_non_finite_state(atmosphere, field):
  state = _steady(atmosphere, 17_000.0, 0.0)
  state[field] = float('nan')
  with pytest.raises(ValueError, match=field):
    controller_lib.AltitudeController().decide([17_000, 1, -1], **state)


_KINDS = st.sampled_from(['finite', 'nan', 'inf', '-inf'])


@settings(max_examples=40, deadline=None, derandomize=True)
@given(kinds=st.tuples(_KINDS, _KINDS, _KINDS), action=cases.ACTION,
       h=cases.f32(0.0, 40_000.0))
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


def _check_actuation(got, ref, x64, params=cases.PARAMS):
  assert int(got.decision) == list(cases.Decision).index(ref.decision)
  assert bool(got.guarded) == ref.guarded
  assert abs(float(got.desired_ascent_rate) - ref.desired_ascent_rate) <= (
      1e-12 if x64 else 1e-5)
  assert abs(float(got.vent_mols) - ref.vent_mols) <= (1e-9 if x64 else 2e-5)
  assert abs(float(got.drop_kg) - ref.drop_kg) <= (1e-11 if x64 else 1e-6)
  del params


@cases.PRECISIONS
@cases.SETTINGS
@given(k=cases.KEY, h=cases.ALTITUDE, v=cases.RATE, n=cases.HELIUM, s=cases.SAND, action=cases.ACTION)
def test_decide_matches_numpy(x64, k, h, v, n, s, action):
  if not x64:
    assume(not cases.near_threshold(cases.PARAMS, k, h, v, n, s, action))
  ref = cases.np_decide(cases.PARAMS, k, h, v, n, s, action)
  t, p = cases.ambient(k, h)
  dtype = cases.dtype(x64)
  with jax.enable_x64(x64):
    state = cases.jax_state(cases.PARAMS, k, h, v, n, s)
    got = cases.decide(cases.PARAMS, state, jnp.asarray(action, dtype),
                  jnp.asarray(t, dtype), jnp.asarray(p, dtype))
  _check_actuation(got, ref, x64)
  # The target lift is the lift once the amounts are released.
  after = physics.free_lift(n - ref.vent_mols, cases.PAYLOAD, s - ref.drop_kg)
  assert abs(float(got.lift_after_kg) - after) <= (1e-12 if x64 else 1e-6)


@cases.PRECISIONS
@cases.SETTINGS
@given(k=cases.KEY, h=st.one_of(cases.f32(11_000.0, 12_999.0), cases.f32(22_001.0, 24_000.0)),
       v=cases.RATE, n=cases.HELIUM, s=cases.SAND, action=cases.ACTION)
def test_band_guard_matches_numpy_outside_the_band(x64, k, h, v, n, s,
                                                   action):
  if not x64:
    assume(not cases.near_threshold(cases.PARAMS, k, h, v, n, s, action))
  ref = cases.np_decide(cases.PARAMS, k, h, v, n, s, action)
  t, p = cases.ambient(k, h)
  dtype = cases.dtype(x64)
  with jax.enable_x64(x64):
    state = cases.jax_state(cases.PARAMS, k, h, v, n, s)
    got = cases.decide(cases.PARAMS, state, jnp.asarray(action, dtype),
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
    state = cases.jax_state(cases.PARAMS, k, h, v, n, s)
    act = controller.Actuation(
        decision=jnp.int32(decision), desired_ascent_rate=jnp.float32(rate),
        vent_mols=jnp.float32(0.5), drop_kg=jnp.float32(0.0),
        guarded=jnp.bool_(False), lift_after_kg=jnp.float32(0.1))
    out = controller.band_guard(cases.PARAMS, state, act)
    if stands:
      assert int(out.decision) == decision and not bool(out.guarded)
    else:
      ref = cases.np_controller(cases.PARAMS).float_actuation(
          helium_mols=n, sand_kg=s, payload_kg=cases.PAYLOAD, guarded=True)
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
  amount = cases.np_decide(free, k, h, v, n, s, action)
  amount = amount.vent_mols if which == 'vent' else amount.drop_kg
  assert amount > 0.0
  t, p = cases.ambient(k, h)
  with jax.enable_x64(True):
    for factor, acts in ((1.0 + 1e-9, False), (1.0 - 1e-9, True)):
      key = 'min_vent_mols' if which == 'vent' else 'min_drop_kg'
      params = params_lib.make_flight_params(**{key: amount * factor})
      ref = cases.np_decide(params, k, h, v, n, s, action)
      got = cases.decide(params, cases.jax_state(params, k, h, v, n, s),
                    jnp.asarray(action), t, p)
      assert (ref.decision != cases.Decision.NOTHING) == acts
      _check_actuation(got, ref, True)
