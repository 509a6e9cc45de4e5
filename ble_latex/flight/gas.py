# coding=utf-8
"""The helium's own temperature: adiabatic compression and thermal relaxation.

Under realistic physics with `FlightParams.gas_state` the helium's temperature
T_g is a state of the flight (`FlightState.gas_temperature_k`), carried
through the air's pressure field:

  dT_g/dt = kappa T_g (dP_g/dt) / P_g  +  (T_eq - T_g) / tau          (1)

  * the first term is the reversible adiabatic compression of an ideal gas,
    T P^(-kappa) = const with kappa = 1 - 1/gamma = 0.4 for helium (gamma =
    5/3, monatomic; Poisson's equation). With dP/dt = -rho g w (hydrostatic)
    a rising balloon's helium cools at kappa M_air g / R ~ 13.7 K/km while
    the lower stratosphere's air is near isothermal: the altitude stiffness
    of a gas balloon (field notes, round 5; zero-pressure balloon thermal
    models carry T_g as a state for this reason);
  * the second relaxes T_g toward T_eq = T_air + f(sun) + dT_h with the
    envelope's thermal time constant tau (`FlightParams.gas_thermal_lag_s`,
    the one home of tau, the same lag the sun's forcing had before): f the
    solar superheat / radiative cooling (`thermal.gas_temperature_offset`),
    dT_h the bounded heating disturbance (`heating_transition`).

In steady motion at speed w, (1) holds T_g below T_eq by
`steady_lag_k` = kappa T_g rho g w tau / P_g, a damping lift
c w = n M_air (T_eq - T_g) / T_air: 110-215 g/(m/s) for the default balloon
at 17 km (tau 300-600 s), which makes a manoeuvre cost 5-10x the drag alone.

The integrator (`dynamics`) solves (1) by splitting each vertical chunk:
relaxation for half the chunk (`relax`, exact for a fixed target), the
adiabatic part along the chunk's path inside the vertical step (`adiabatic`:
T_g(h) = T_g0 (P_g(h) / P_g0)^kappa, exact for any path), relaxation for the
other half at the chunk's end (Strang splitting, second order). The float64
reference (`reference.rk4_gas_reference`) integrates (1) and the motion as one
ODE by RK4.

Pure, jittable, vmappable functions; units in the docstrings.
"""

import jax
import jax.numpy as jnp

from ble_latex.flight import disturbance
from ble_latex.flight import physics

Array = jax.Array

# Ratio of specific heats of helium (monatomic ideal gas, c_p / c_v). # [.]
GAMMA_HELIUM = 5.0 / 3.0
# Poisson's exponent kappa = 1 - 1/gamma of T P^-kappa = const. # [.]
KAPPA_HELIUM = 1.0 - 1.0 / GAMMA_HELIUM


def adiabatic(temperature: Array, pressure_from: Array,
              pressure_to: Array) -> Array:
  """T_g after a reversible adiabatic change of pressure. # [K]

  Poisson's equation T_1 = T_0 (P_1 / P_0)^kappa, kappa = 1 - 1/gamma
  (`KAPPA_HELIUM`).

  Args:
    temperature: The gas's temperature before. # [K]
    pressure_from: The gas's pressure before. # [Pa]
    pressure_to: The gas's pressure after. # [Pa]
  """
  return temperature * (pressure_to / pressure_from) ** KAPPA_HELIUM


def relax(temperature: Array, target: Array, duration_s: Array,
          time_constant_s: Array) -> Array:
  """T_g after `duration_s` of dT/dt = (target - T) / tau, target fixed. # [K]

  Exact: target + (T - target) e^(-dt / tau); tau = 0 gives the target.

  Args:
    temperature: T_g now. # [K]
    target: The relaxation target T_eq. # [K]
    duration_s: dt >= 0. # [s]
    time_constant_s: tau >= 0. # [s]
  """
  tau = jnp.asarray(time_constant_s)
  safe = jnp.where(tau > 0.0, tau, 1.0)
  decay = jnp.where(tau > 0.0, jnp.exp(-duration_s / safe), 0.0)
  return target + (temperature - target) * decay


def steady_lag_k(temperature: Array, pressure: Array, air_density: Array,
                 rate: Array, time_constant_s: Array) -> Array:
  """T_eq - T_g of a gas moving steadily at `rate`. # [K]

  (1) with dT_g/dt = 0 and dP_g/dt = -rho g w: kappa T_g rho g w tau / P_g
  (positive rising: the gas is cooler than its target).

  Args:
    temperature: The gas's temperature T_g. # [K]
    pressure: The gas's pressure P_g. # [Pa]
    air_density: rho of the air. # [kg/m^3]
    rate: Ascent rate w. # [m/s]
    time_constant_s: tau. # [s]
  """
  return (KAPPA_HELIUM * temperature * air_density * physics.GRAVITY * rate *
          time_constant_s / pressure)


def damping_kg_per_mps(helium_mols: Array, air_temperature: Array,
                       air_pressure: Array, time_constant_s: Array) -> Array:
  """c of the damping lift c w of steady motion (gas at the air's T, P). # [kg/(m/s)]

  n M_air steady_lag_k / T_air per m/s = n M_air kappa rho g tau / P.

  Args:
    helium_mols: Helium n. # [mol]
    air_temperature: T. # [K]
    air_pressure: P. # [Pa]
    time_constant_s: tau. # [s]
  """
  rho = physics.air_density(air_temperature, air_pressure)
  return (helium_mols * physics.AIR_MOLAR_MASS *
          steady_lag_k(air_temperature, air_pressure, rho, 1.0,
                       time_constant_s) / air_temperature)


def heating_transition(heating_k: Array, duration_s: Array, *, rms_k: Array,
                       time_constant_s: Array, key: Array) -> Array:
  """dT_h after `duration_s`: an Ornstein-Uhlenbeck heating disturbance. # [K]

  d(dT_h) = -dT_h / tau_h dt + s dB with s = rms sqrt(2 / tau_h), so its
  stationary spread is `rms_k` and its correlation time tau_h: bounded, and
  (entering T_eq) a free lift n M_air dT_h / T_air that scales with the
  displaced air. The exact transition (`disturbance.transition`).

  Args:
    heating_k: dT_h now. # [K]
    duration_s: dt >= 0. # [s]
    rms_k: Stationary rms. # [K]
    time_constant_s: Correlation time tau_h > 0. # [s]
    key: PRNG key of this draw.
  """
  sigma = rms_k * jnp.sqrt(2.0 / time_constant_s)  # [K/sqrt(s)]
  return disturbance.transition(heating_k, duration_s, sigma=sigma,
                                time_constant_s=time_constant_s, key=key)
