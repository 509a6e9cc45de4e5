"""Tests for ble_latex.flight: the JAX flight core as a whole (jit, vmap,
gradients, the scheduled stride) against the NumPy oracle.

Each JAX function is compared with its twin in the retired NumPy float64
model the core replaced (tests/reference: numpy_physics, numpy_controller,
numpy_balloon.LatexBalloon.simulate_step) and with BLE's standard
atmosphere over hypothesis-generated states in realistic ranges, in
JAX's default float32 and in float64 inside a local `jax.enable_x64(True)`
scope. Inputs are drawn float32-representable so both sides see the same
numbers. BLE atmospheres are always built outside the x64 scope (BLE draws
its lapse-rate blend in the default precision).

The shared setup is tests/flight/oracle_cases.py; each module's own
comparisons are in test_{atmosphere,physics,controller,dynamics}.py.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex.flight import atmosphere
from ble_latex.flight import dynamics
from ble_latex.flight import state as state_lib

from tests.flight import oracle_cases as cases


def _random_batch(rng, size, params=cases.PARAMS):
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
  batched = jax.jit(jax.vmap(cases.STEP_ANALYTIC, in_axes=(None, 0, 0, 0)))(
      cases.PARAMS, atms, states, actions)
  statuses = set()
  for i in range(256):
    one = jax.tree.map(lambda a, i=i: a[i], (atms, states, actions))
    single = cases.STEP_ANALYTIC(cases.PARAMS, *one)
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
  before = cases.STEP_CONST._cache_size()
  for i in range(3):
    one = jax.tree.map(lambda a, i=i: a[i], (atms, states, actions))
    cases.STEP_CONST(cases.PARAMS, *one)
  compiled = cases.STEP_CONST._cache_size()
  assert compiled - before <= 1
  cases.STEP_CONST(cases.PARAMS.replace(payload_kg=2.5, burst_volume_m3=300.0),
              *jax.tree.map(lambda a: a[0], (atms, states, actions)))
  assert cases.STEP_CONST._cache_size() == compiled


def test_step_derivative_is_finite():
  """d(final altitude)/d(a0) through a whole stride (forward mode)."""
  atm = cases.atm_params(0)
  state = cases.jax_state(cases.PARAMS, 0, 17_000.0, 0.5, 172.0, 1.5)

  def final_altitude(a0):
    out = dynamics.step(cases.PARAMS, atm, state, jnp.stack([a0, 2.0, -1.0]),
                        cases.const_wind)
    return out.altitude_m

  derivative = jax.jit(lambda a0: jax.jvp(final_altitude, (a0,),
                                          (jnp.ones_like(a0),))[1])
  d = float(derivative(jnp.float32(15_000.0)))  # a vent decision
  assert np.isfinite(d) and 0.0 < d < 1.0


_STEP_SCHEDULED = dynamics.make_scheduled_step(cases.analytic_wind)


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
  params = cases.FINITE_PARAMS if finite else cases.PARAMS
  rng = np.random.default_rng(2)
  atms, states, actions = _random_batch(rng, 4, params)
  before = _STEP_SCHEDULED._cache_size()
  for i, time_delta_s in enumerate((1200.0, 901.0, 1.44e3 - 1e-3)):
    grid = dynamics.padded_schedule(time_delta_s, params.max_substep_s,
                                    params.vertical_step_s)
    assert grid.valid.shape == (8,) and grid.chunks.shape == (8, 4)
    one = jax.tree.map(lambda a, i=i: a[i], (atms, states, actions))
    static = dynamics.make_step(cases.analytic_wind, time_delta_s)(params, *one)
    traced = _STEP_SCHEDULED(params, *one, grid)
    for name, a in static.__dict__.items():
      if name in ('x_m', 'y_m'):  # XLA may fuse x + u dt differently.
        np.testing.assert_allclose(np.asarray(getattr(traced, name)),
                                   np.asarray(a), rtol=2.5e-7, err_msg=name)
      else:
        np.testing.assert_array_equal(np.asarray(getattr(traced, name)),
                                      np.asarray(a), err_msg=name)
  assert _STEP_SCHEDULED._cache_size() - before == 1
