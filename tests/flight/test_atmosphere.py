"""The JAX atmosphere (ble_latex/flight/atmosphere.py) against BLE's standard
atmosphere, in float32 and float64 (setup: oracle_cases.py)."""

from balloon_learning_environment.env.balloon import standard_atmosphere
from balloon_learning_environment.utils import units
from hypothesis import given
from hypothesis import strategies as st
import jax
import numpy as np

from ble_latex.flight import atmosphere

from tests.flight import oracle_cases as cases


@cases.PRECISIONS
@cases.SETTINGS
@given(k=cases.KEY, heights=st.lists(cases.f32(-600.0, 84_000.0), min_size=1,
                               max_size=cases.BATCH))
def test_atmosphere_matches_ble(x64, k, heights):
  ble = cases.ble_atmosphere(k)
  with jax.enable_x64(x64):
    params = cases.atm_params(k)
    # Same key -> same blend (BLE draws alpha in float32).
    np.testing.assert_allclose(np.asarray(params.lapse_rates, np.float64),
                               ble._lapse_rates, rtol=1e-15 if x64 else 1e-7)
    got = cases.at_height(params, cases.padded(heights, cases.dtype(x64)))
  for i, h in enumerate(heights):
    ref = ble.at_height(units.Distance(m=h))
    rtol_t = 1e-12 if x64 else 1e-6
    # float32: ~1e-6 up to 40 km, 3e-6 above (power laws with exponents up
    # to 34 of float32 layer tables).
    rtol_p = 1e-12 if x64 else (1e-6 if h < 40_000.0 else 3e-6)
    assert cases.rel(got.temperature[i], ref.temperature) <= rtol_t
    assert cases.rel(got.pressure[i], ref.pressure) <= rtol_p
    assert cases.rel(got.density[i], ref.density) <= rtol_p


@cases.PRECISIONS
@cases.FEW
@given(k=cases.KEY, heights=st.lists(cases.f32(-600.0, 84_000.0), min_size=1,
                               max_size=cases.BATCH))
def test_at_pressure_matches_ble(x64, k, heights):
  ble = cases.ble_atmosphere(k)
  pressures = np.array(
      [ble.at_height(units.Distance(m=h)).pressure for h in heights])
  pressures = pressures.astype(cases.dtype(x64)).astype(np.float64)
  with jax.enable_x64(x64):
    got = cases.at_pressure(cases.atm_params(k), cases.padded(pressures, cases.dtype(x64)))
  for i, p in enumerate(pressures):
    ref = ble.at_pressure(p)
    assert abs(float(got.height[i]) - ref.height.meters) <= (
        1e-7 if x64 else 0.05)
    assert cases.rel(got.temperature[i], ref.temperature) <= (
        1e-12 if x64 else 1e-6)
    assert cases.rel(got.density[i], ref.density) <= (1e-12 if x64 else 3e-6)


def test_atmosphere_vmaps_over_keys():
  keys = jax.random.split(jax.random.PRNGKey(7), 8)
  params = jax.vmap(atmosphere.reset)(keys)
  amb = jax.vmap(atmosphere.at_height, in_axes=(0, None))(params, 17_000.0)
  for i in range(8):
    with jax.enable_x64(False):
      ble = standard_atmosphere.Atmosphere(keys[i])
    ref = ble.at_height(units.Distance(m=17_000.0))
    assert cases.rel(amb.pressure[i], ref.pressure) < 1e-6
