# coding=utf-8
"""The intermittent lift disturbance (issue 44, item 1): calm / gusty spells.

`flight.disturbance.switch` / `intermittent_transition`, their FlightParams
fields and gin bindings, and the stride that flies them. Statistical checks
use fixed keys.
"""

import gin
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex import configs
from ble_latex.flight import atmosphere as atmosphere_lib
from ble_latex.flight import disturbance
from ble_latex.flight import dynamics
from ble_latex.flight import params as params_lib
from ble_latex.flight import state as state_lib

INTERMITTENT = params_lib.make_flight_params(
    **{**params_lib.REALISTIC, **params_lib.LIFT_WALK_INTERMITTENT})
SUBSTEP_S = 200.0  # [s] six to a 20-minute stride
PER_STRIDE = 6


def _calm(x_m, y_m, pressure_pa, t_s):
  del y_m, pressure_pa, t_s
  return jnp.zeros_like(x_m), jnp.zeros_like(x_m)


def _paths(p: params_lib.FlightParams, intermittent: bool, *, paths: int,
           substeps: int):
  """[paths, substeps] W and regime from 0, calm, with fixed keys."""
  def run(key):
    def body(carry, k):
      w, g = carry
      if intermittent:
        w, g = disturbance.intermittent_transition(
            w, g, SUBSTEP_S, sigma=p.lift_walk_kg_per_sqrt_s,
            calm_sigma=p.lift_walk_calm_kg_per_sqrt_s,
            time_constant_s=0.0, calm_mean_s=p.lift_walk_calm_mean_s,
            gusty_mean_s=p.lift_walk_gusty_mean_s, key=k)
      else:
        w = disturbance.transition(w, SUBSTEP_S,
                                   sigma=p.lift_walk_kg_per_sqrt_s,
                                   time_constant_s=0.0, key=k)
      return (w, g), (w, g)
    return jax.lax.scan(body, (jnp.float32(0.0), jnp.zeros((), bool)),
                        jax.random.split(key, substeps))[1]
  keys = jax.random.split(jax.random.PRNGKey(44), paths)
  return jax.device_get(jax.jit(jax.vmap(run))(keys))


def _excess_kurtosis(x: np.ndarray) -> float:
  x = x - x.mean()
  return float((x**4).mean() / (x**2).mean()**2 - 3.0)


def test_intermittent_setting_keeps_the_calibrated_long_run_rate():
  p = INTERMITTENT
  assert p.lift_walk_intermittent and p.lift_walk
  assert disturbance.mean_sigma(
      p.lift_walk_kg_per_sqrt_s, p.lift_walk_calm_kg_per_sqrt_s,
      p.lift_walk_calm_mean_s, p.lift_walk_gusty_mean_s) == pytest.approx(
          params_lib.LIFT_WALK_RANDOM['lift_walk_kg_per_sqrt_s'], rel=0.01)
  assert not params_lib.make_flight_params(
      **params_lib.REALISTIC).lift_walk_intermittent  # Off by default.


def test_spells_make_stride_increments_heavy_tailed():
  # Two days in 200 s sub-steps; the 20-minute increments after the first
  # 12 h (a flight starts calm). One regime: Gaussian increments (excess
  # kurtosis 0). Calm / gusty spells: a mixture of Gaussians (excess ~7.7
  # for the setting), with the long-run variance rate of 0.35 g/sqrt(s)
  # and the gusty share tau_g / (tau_c + tau_g).
  substeps, skip = 864, 216
  p = INTERMITTENT
  walk, gusty = _paths(p, True, paths=1000, substeps=substeps)
  increments = np.diff(walk[:, skip::PER_STRIDE], axis=1).ravel()
  rate = increments.var() / (PER_STRIDE * SUBSTEP_S)  # [kg^2/s]
  assert np.sqrt(rate) == pytest.approx(0.35e-3, rel=0.1)
  assert _excess_kurtosis(increments) > 3.0
  share = p.lift_walk_gusty_mean_s / (p.lift_walk_calm_mean_s +
                                      p.lift_walk_gusty_mean_s)
  assert gusty[:, skip:].mean() == pytest.approx(share, abs=0.03)
  # The regime persists for hours: far fewer changes than sub-steps.
  changes = np.abs(np.diff(gusty[:, skip:].astype(int), axis=1)).sum(axis=1)
  expected = (substeps - skip) * SUBSTEP_S * 2.0 / (
      p.lift_walk_calm_mean_s + p.lift_walk_gusty_mean_s)
  assert changes.mean() == pytest.approx(expected, rel=0.1)

  plain = params_lib.make_flight_params(**params_lib.REALISTIC,
                                       **params_lib.LIFT_WALK_RANDOM)
  walk, _ = _paths(plain, False, paths=1000, substeps=substeps)
  increments = np.diff(walk[:, skip::PER_STRIDE], axis=1).ravel()
  assert abs(_excess_kurtosis(increments)) < 0.3


def test_gin_binds_the_intermittent_option():
  gin.clear_config()
  try:
    gin.parse_config_files_and_bindings(
        [configs.gin_file('latex_physics.gin'),
         configs.gin_file('latex_realistic.gin')],
        ['latex_flight.lift_walk_kg_per_sqrt_s = 0.67e-3',
         'latex_flight.lift_walk_calm_kg_per_sqrt_s = 0.07e-3'])
    assert params_lib.flight_params_from_gin() == INTERMITTENT
    # The paper's model switches it off with the walk.
    assert not params_lib.paper_flight_params().lift_walk_intermittent
  finally:
    gin.clear_config()


@pytest.mark.parametrize('bindings, match', [
    (['latex_flight.lift_walk_kg_per_sqrt_s = None',
      'latex_flight.lift_walk_calm_kg_per_sqrt_s = 0.07e-3'],
     'lift_walk_calm_kg_per_sqrt_s.*lift_walk_kg_per_sqrt_s'),
    (['latex_flight.lift_walk_calm_kg_per_sqrt_s = -1e-4'],
     'lift_walk_calm_kg_per_sqrt_s'),
    (['latex_flight.lift_walk_calm_kg_per_sqrt_s = 0.07e-3',
      'latex_flight.lift_walk_gusty_mean_s = 0.0'], 'lift_walk_gusty_mean_s'),
])
def test_bad_intermittent_bindings_name_their_binding(bindings, match):
  gin.clear_config()
  try:
    gin.parse_config_files_and_bindings(
        [configs.gin_file('latex_realistic.gin')], bindings)
    with pytest.raises(ValueError, match=match):
      params_lib.flight_params_from_gin()
  finally:
    gin.clear_config()


@pytest.mark.slow  # One stride compiled: ~5 s idle, 15 s on a loaded machine.
def test_a_stride_flies_the_calm_regime():
  # Calm sigma 0 and a calm spell far longer than a stride: the stride's
  # free lift does not walk (the flight starts calm). Flown at the gusty
  # sigma (intermittency ignored), it would walk.
  atm = atmosphere_lib.params_from_alpha(0.5)
  still = INTERMITTENT.replace(lift_walk_calm_kg_per_sqrt_s=0.0,
                               lift_walk_calm_mean_s=864_000.0)
  burst_key, walk_key = jax.random.split(jax.random.PRNGKey(7))
  start = state_lib.initial_state(still, 17_000.0, atm_params=atm,
                                  key=burst_key)
  hold = jnp.array([17_000.0, 1.0, 1.0], jnp.float32)
  end = jax.device_get(dynamics.step(still, atm, start, hold, _calm,
                                     key=walk_key))
  assert end.lift_walk_kg == 0.0 and not end.lift_walk_gusty
  assert end.status == state_lib.FlightStatus.OK
