# coding=utf-8
"""BLE's standard atmosphere in JAX (pure, jittable, vmappable).

Re-implements `balloon_learning_environment.env.balloon.standard_atmosphere`
(BLE's seven layers with its random lapse-rate blend: a tropical profile,
300 K at -610 m and the tropopause at 17 km, not the US Standard Atmosphere
1976 that BLE's docstring names):

  * `reset(key)` draws the blend exactly as BLE's `Atmosphere.reset(key)`,
    alpha = jax.random.uniform(key) (float32, so the same key gives the same
    alpha as BLE in any precision scope); lapse rates
    L = (1 - alpha) L_low + alpha L_high; the layer-base temperatures
    T_{i+1} = T_i + L_i (H_{i+1} - H_i) from T_0 = 300 K and pressures from
    the hydrostatic equation from P_0 = 108870.8213 Pa.
  * `at_height(params, h)`: in layer i (H_i <= h < H_{i+1})
      T = T_i + L_i (h - H_i),
      P = P_i (T / T_i)^(-g / (R_a L_i))      (L_i != 0),
      P = P_i exp(-g (h - H_i) / (R_a T))     (L_i == 0),
      rho = P / (R_a T).
  * `at_pressure(params, P)`: the inverse (height, temperature, density).

The power laws are evaluated as exp(e log1p(x)) / expm1 of the small
relative temperature change, which keeps float32 within ~1e-6 of BLE's
float64 values (BLE's `T / T_i` loses ~1e-7 that an exponent of up to 34
would amplify). Heights outside BLE's [-610 m, 85 km) are extrapolated with
the edge layers (BLE asserts); `ble_latex.flight.dynamics` clamps as
`LatexBalloon` does.
"""

from typing import NamedTuple

from balloon_learning_environment.utils import constants
from flax import struct
import jax
import jax.numpy as jnp
import numpy as np

GRAVITY = constants.GRAVITY  # [m/s^2]
# Specific gas constant of dry air R_a = R / M_air. # [J/(kg K)]
DRY_AIR_SPECIFIC_GAS_CONSTANT = constants.DRY_AIR_SPECIFIC_GAS_CONSTANT

# Layer boundaries H_0..H_7 (BLE's _HEIGHT_TRANSITIONS). # [m]
HEIGHT_TRANSITIONS_M = (-610.0, 17000.0, 21000.0, 32000.0, 47000.0, 51000.0,
                        71000.0, 85000.0)
# Lapse rates of the 7 layers for alpha = 0 and alpha = 1. # [K/m]
LAPSE_RATES_LOW = (-0.007, 0.006, 0.001, 0.0028, 0.0, -0.0028, -0.002)
LAPSE_RATES_HIGH = (-0.0058, 0.005, 0.001, 0.0028, 0.0, -0.0028, -0.002)
BASE_TEMPERATURE_K = 300.0  # [K] at H_0
BASE_PRESSURE_PA = 108870.8213  # [Pa] at H_0
NUM_LAYERS = len(LAPSE_RATES_LOW)

Array = jax.Array


@struct.dataclass
class AtmosphereParams:
  """One sampled atmosphere (the state of BLE's `Atmosphere` after reset).

  Attributes:
    alpha: Lapse-rate blend in [0, 1). # [.]
    lapse_rates: L_i of the 7 layers, shape (7,). # [K/m]
    temperature_transitions: T_i at H_0..H_7, shape (8,). # [K]
    pressure_transitions: P_i at H_0..H_7, shape (8,). # [Pa]
  """
  alpha: Array
  lapse_rates: Array
  temperature_transitions: Array
  pressure_transitions: Array


class Ambient(NamedTuple):
  """Atmosphere at a height (BLE's AtmosphericValues without the height)."""
  temperature: Array  # [K]
  pressure: Array  # [Pa]
  density: Array  # [kg/m^3]


class AmbientAtPressure(NamedTuple):
  """Atmosphere at a pressure level."""
  height: Array  # [m]
  temperature: Array  # [K]
  density: Array  # [kg/m^3]


def _float_dtype():
  """JAX's current default float (float32, or float64 in an x64 scope)."""
  return jnp.asarray(0.0).dtype


def _pow_ratio(x: Array, exponent: Array) -> Array:
  """(1 + x)^exponent for 1 + x > 0, accurate when |x| is small."""
  return jnp.exp(exponent * jnp.log1p(x))


def reset(key: Array) -> AtmosphereParams:
  """Samples an atmosphere exactly as BLE's `Atmosphere.reset(key)`.

  BLE draws alpha = jax.random.uniform(key) in float32 (JAX's default); it is
  drawn in float32 here too, then used in the current default precision, so
  `reset(key).alpha == Atmosphere(key)`'s alpha in float32 and float64.

  Args:
    key: A PRNG key (one per atmosphere; split it yourself).

  Returns:
    The atmosphere's parameters.
  """
  alpha = jax.random.uniform(key, dtype=jnp.float32)
  return params_from_alpha(alpha.astype(_float_dtype()))


def params_from_alpha(alpha: Array) -> AtmosphereParams:
  """Builds the layer tables for a lapse-rate blend alpha (BLE's reset).

  Args:
    alpha: Blend between BLE's low and high lapse rates. # [.]

  Returns:
    The atmosphere's parameters.
  """
  dtype = _float_dtype()
  alpha = jnp.asarray(alpha, dtype)
  low = jnp.asarray(LAPSE_RATES_LOW, dtype)
  high = jnp.asarray(LAPSE_RATES_HIGH, dtype)
  lapse = (1 - alpha) * low + alpha * high  # [K/m]
  heights = np.asarray(HEIGHT_TRANSITIONS_M)
  temps = [jnp.asarray(BASE_TEMPERATURE_K, dtype)]
  pressures = [jnp.asarray(BASE_PRESSURE_PA, dtype)]
  for i in range(NUM_LAYERS):
    dh = float(heights[i + 1] - heights[i])  # [m]
    t_next = temps[-1] + lapse[i] * dh
    constant = lapse[i] == 0.0
    safe_lapse = jnp.where(constant, 1.0, lapse[i])
    p_linear = pressures[-1] * _pow_ratio(
        safe_lapse * dh / temps[-1],
        -GRAVITY / (DRY_AIR_SPECIFIC_GAS_CONSTANT * safe_lapse))
    p_constant = pressures[-1] * jnp.exp(
        -(GRAVITY * dh) / (DRY_AIR_SPECIFIC_GAS_CONSTANT * t_next))
    pressures.append(jnp.where(constant, p_constant, p_linear))
    temps.append(t_next)
  return AtmosphereParams(alpha=alpha, lapse_rates=lapse,
                          temperature_transitions=jnp.stack(temps),
                          pressure_transitions=jnp.stack(pressures))


def _layer_below(values: Array, boundaries: Array, descending: bool) -> Array:
  """Index i of the layer holding `values` (edge layers extrapolate)."""
  inner = boundaries[1:-1]
  if descending:
    i = jnp.sum(values[..., None] <= inner, axis=-1)
  else:
    i = jnp.sum(values[..., None] >= inner, axis=-1)
  return jnp.clip(i, 0, NUM_LAYERS - 1)


def at_height(params: AtmosphereParams, height_m: Array) -> Ambient:
  """Temperature, pressure and density at a geopotential height.

  BLE's `Atmosphere.at_height`; see the module docstring for the equations.

  Args:
    params: The atmosphere.
    height_m: Height h (any shape). # [m]

  Returns:
    Ambient(temperature [K], pressure [Pa], density [kg/m^3]).
  """
  h = jnp.asarray(height_m, _float_dtype())
  heights = jnp.asarray(HEIGHT_TRANSITIONS_M, h.dtype)
  i = _layer_below(h, heights, descending=False)
  h_i = heights[i]
  t_i = params.temperature_transitions[i]
  p_i = params.pressure_transitions[i]
  lapse = params.lapse_rates[i]
  temperature = t_i + lapse * (h - h_i)
  constant = lapse == 0.0
  safe_lapse = jnp.where(constant, 1.0, lapse)
  p_linear = p_i * _pow_ratio(
      safe_lapse * (h - h_i) / t_i,
      -GRAVITY / (DRY_AIR_SPECIFIC_GAS_CONSTANT * safe_lapse))
  p_constant = p_i * jnp.exp(-(GRAVITY * (h - h_i)) /
                             (DRY_AIR_SPECIFIC_GAS_CONSTANT * temperature))
  pressure = jnp.where(constant, p_constant, p_linear)
  density = pressure / (DRY_AIR_SPECIFIC_GAS_CONSTANT * temperature)
  return Ambient(temperature, pressure, density)


def at_pressure(params: AtmosphereParams,
                pressure_pa: Array) -> AmbientAtPressure:
  """Height, temperature and density at a pressure (BLE's `at_pressure`).

  In layer i (P_{i+1} < P <= P_i):
    h = H_i + T_i / L_i ((P / P_i)^(-R_a L_i / g) - 1)   (L_i != 0),
    h = H_i - R_a T_i / g log(P / P_i)                  (L_i == 0),
    T = T_i + L_i (h - H_i), rho = P / (R_a T).

  Args:
    params: The atmosphere.
    pressure_pa: Pressure P (any shape), > 0. # [Pa]

  Returns:
    AmbientAtPressure(height [m], temperature [K], density [kg/m^3]).
  """
  p = jnp.asarray(pressure_pa, _float_dtype())
  heights = jnp.asarray(HEIGHT_TRANSITIONS_M, p.dtype)
  i = _layer_below(p, params.pressure_transitions, descending=True)
  h_i = heights[i]
  t_i = params.temperature_transitions[i]
  p_i = params.pressure_transitions[i]
  lapse = params.lapse_rates[i]
  log_ratio = jnp.log(p / p_i)
  constant = lapse == 0.0
  safe_lapse = jnp.where(constant, 1.0, lapse)
  h_linear = jnp.expm1(-DRY_AIR_SPECIFIC_GAS_CONSTANT * safe_lapse / GRAVITY *
                       log_ratio) * t_i / safe_lapse + h_i
  h_constant = (-DRY_AIR_SPECIFIC_GAS_CONSTANT * t_i / GRAVITY) * log_ratio + (
      h_i)
  height = jnp.where(constant, h_constant, h_linear)
  temperature = t_i + lapse * (height - h_i)
  density = p / (DRY_AIR_SPECIFIC_GAS_CONSTANT * temperature)
  return AmbientAtPressure(height, temperature, density)
