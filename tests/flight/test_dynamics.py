"""One stride of the JAX core (ble_latex/flight/dynamics.py) against the oracle's
LatexBalloon.simulate_step, in float32 and float64 (setup: oracle_cases.py)."""

import datetime as dt

from hypothesis import assume
from hypothesis import given
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex.flight import state as state_lib

from tests.reference import numpy_physics as np_physics
from tests.flight import oracle_cases as cases


def _compare_stride(x64, k, h, v, n, s, action, *, analytic, x=0.0, y=0.0):
  wind_np = cases.analytic_wind_np if analytic else cases.CONST_WIND_NP
  step = cases.STEP_ANALYTIC if analytic else cases.STEP_CONST
  ns = cases.np_step(k, h, v, n, s, action, wind_np, state_kwargs=dict(x=x, y=y))
  if not x64:
    assume(not cases.end_near_boundary(cases.PARAMS, ns))
  with jax.enable_x64(x64):
    state = cases.jax_state(cases.PARAMS, k, h, v, n, s, x=x, y=y)
    js = step(cases.PARAMS, cases.atm_params(k), state,
              jnp.asarray(action, cases.dtype(x64)))
  cases.assert_step_matches(js, ns, x64)
  return js, ns


@cases.PRECISIONS
@cases.SETTINGS
@given(k=cases.KEY, h=cases.ALTITUDE, v=cases.RATE, n=cases.HELIUM, s=cases.SAND, action=cases.ACTION)
def test_step_matches_numpy_constant_wind(x64, k, h, v, n, s, action):
  if not x64:
    assume(not cases.near_threshold(cases.PARAMS, k, h, v, n, s, action))
  _compare_stride(x64, k, h, v, n, s, action, analytic=False)


@cases.PRECISIONS
@cases.FEW
@given(k=cases.KEY, h=cases.ALTITUDE, v=cases.RATE, n=cases.HELIUM, s=cases.SAND, action=cases.ACTION,
       x=cases.f32(-200_000.0, 200_000.0), y=cases.f32(-200_000.0, 200_000.0))
def test_step_matches_numpy_analytic_wind(x64, k, h, v, n, s, action, x, y):
  if not x64:
    assume(not cases.near_threshold(cases.PARAMS, k, h, v, n, s, action))
  _compare_stride(x64, k, h, v, n, s, action, analytic=True, x=x, y=y)


_STEP_FINITE = cases.STEP_CONST  # The static params fields retrace it.


@cases.PRECISIONS
@cases.FEW
@given(k=cases.KEY, h=cases.ALTITUDE, v=cases.RATE, n=cases.HELIUM, s=cases.SAND, action=cases.ACTION)
def test_step_matches_numpy_finite_rates(x64, k, h, v, n, s, action):
  if not x64:
    assume(not cases.near_threshold(cases.FINITE_PARAMS, k, h, v, n, s, action))
  ns = cases.np_step(k, h, v, n, s, action, cases.CONST_WIND_NP, balloon_kwargs=cases.FINITE)
  if not x64:
    assume(not cases.end_near_boundary(cases.FINITE_PARAMS, ns))
  with jax.enable_x64(x64):
    js = _STEP_FINITE(cases.FINITE_PARAMS, cases.atm_params(k),
                      cases.jax_state(cases.FINITE_PARAMS, k, h, v, n, s),
                      jnp.asarray(action, cases.dtype(x64)))
  cases.assert_step_matches(js, ns, x64, finite=True)


@cases.PRECISIONS
@pytest.mark.parametrize('case', [
    # (name, k, h, v, n, s, action, state kwargs, expected status)
    ('burst', 1, 18_000.0, 2.0, 180.0, 1.0, (21_000.0, 1.0, -1.0),
     dict(burst_volume_m3=60.0), cases.Status.BURST),
    ('out_of_sand', 2, 17_000.0, 0.0, None, 0.004, (17_000.0, 1.0, 1.0), {},
     cases.Status.OUT_OF_SAND),
    ('out_of_helium', 3, 17_000.0, 0.0, 87.0, 0.0, (17_000.0, 1.0, 1.0), {},
     cases.Status.OUT_OF_HELIUM),
    ('grounded', 4, 1_500.0, -5.0, 85.0, 0.0, (14_000.0, 1.0, -1.0), {},
     cases.Status.GROUNDED),
    ('guard_floats', 5, 12_900.0, -3.0, 160.0, 1.5, (14_000.0, 5.0, -1.0),
     {}, cases.Status.OK),
])
def test_terminal_cases_match_numpy(x64, case):
  _, k, h, v, n, s, action, kwargs, expected = case
  if n is None:
    n = np_physics.neutral_helium_mols(cases.PAYLOAD, s)
  ns = cases.np_step(k, h, v, n, s, action, cases.CONST_WIND_NP, state_kwargs=kwargs)
  assert ns.latex_status == expected
  params = cases.PARAMS.replace(**{
      'burst_volume_m3': kwargs['burst_volume_m3']} if kwargs else {})
  with jax.enable_x64(x64):
    state = cases.jax_state(params, k, h, v, n, s)
    js = cases.STEP_CONST(params, cases.atm_params(k), state,
                     jnp.asarray(action, cases.dtype(x64)))
    cases.assert_step_matches(js, ns, x64)
    if expected != cases.Status.OK:
      # A terminal state is frozen (NumPy refuses to step it).
      again = cases.STEP_CONST(params, cases.atm_params(k), js,
                          jnp.asarray((15_000.0, 1.0, -1.0), cases.dtype(x64)))
      for a, b in zip(jax.tree.leaves(again), jax.tree.leaves(js)):
        np.testing.assert_array_equal(a, b)
  if case[0] == 'burst':
    assert ns.time_elapsed < dt.timedelta(minutes=20)
  if case[0] == 'guard_floats':
    assert ns.guard_engaged


def test_neutral_balloon_stays_put_in_float32():
  """The carried lift keeps a float exactly neutral (no float32 drift)."""
  atm = cases.atm_params(0)
  state = state_lib.initial_state(cases.PARAMS, 17_000.0, atm_params=atm)
  assert float(state.free_lift_kg) == 0.0
  for _ in range(3):
    state = cases.STEP_CONST(cases.PARAMS, atm, state, jnp.asarray((17_000.0, 1.0, 1.0)))
  assert float(state.altitude_m) == 17_000.0
  assert float(state.ascent_rate_mps) == 0.0
  # A float after a climb leaves exactly zero lift.
  state = cases.jax_state(cases.PARAMS, 0, 17_000.0, 2.0, 175.0, 1.0)
  state = cases.STEP_CONST(cases.PARAMS, atm, state, jnp.asarray((17_000.0, 1.0, 1.0)))
  assert float(state.free_lift_kg) == 0.0
