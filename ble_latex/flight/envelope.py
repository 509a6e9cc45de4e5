# coding=utf-8
"""The envelope's gas, lift and drag under the flight system's switches.

Where `physics` holds the equations, this module picks them by the static
switches of `FlightParams` (pure, jittable, vmappable), so that the
integrator (`dynamics`) and the controller (`controller`) use the same gas
temperature, gas pressure, lift and drag:

| quantity        | paper model (default)      | realistic switch                 |
|-----------------|----------------------------|----------------------------------|
| helium T        | ambient T                  | gas_superheat: T + dT(sun, lag)  |
|                 |                            | gas_state: the state T_g (`gas`) |
| helium P        | ambient P                  | latex_overpressure: P + dP       |
| free lift       | n (M_air - M_He) - m_p - m_s | n (M_air beta - M_He) - m_p - m_s + W |
| c_d             | drag_coefficient           | drag_model: ASTRA's c_d(Re)      |
| burst volume    | burst_volume_m3            | burst_spread: pi d^3 / 6, d drawn |

beta = (T_gas / T) (P / P_gas) (`physics.buoyant_lift_per_mol`), W the
free-lift disturbance carried in `FlightState.lift_walk_kg` (`disturbance`),
dT the lagged solar forcing at the balloon's position (`thermal`). Under
`gas_state` the helium's temperature is the flight's state T_g (`gas`:
adiabatic compression and relaxation toward T + f(sun) + dT_h), and the
controller's targets are taken at the temperature the gas settles at under
the commanded rate (`settled`: T + f(sun) - `gas.steady_lag_k`), which the
balloon can compute from the air's temperature, the sun and its command.

The state carries the paper's lift ledger L_paper = n (M_air - M_He) - m_p
- m_s (`FlightState.free_lift_kg`, exact in float32); the realistic free lift
is L_paper + n M_air (beta - 1) + W (`free_lift_kg`).
"""

from typing import NamedTuple

import jax
import jax.numpy as jnp

from ble_latex.flight import gas as gas_lib
from ble_latex.flight import params as params_lib
from ble_latex.flight import physics
from ble_latex.flight import solar
from ble_latex.flight import thermal

Array = jax.Array


class Gas(NamedTuple):
  """The helium's temperature and pressure (and the air's)."""
  air_temperature: Array  # [K]
  air_pressure: Array  # [Pa]
  temperature: Array  # [K]
  pressure: Array  # [Pa]


def sun_elevation_deg(params: params_lib.FlightParams,
                      time_s: Array) -> Array:
  """The sun's elevation at the flight's place and time. # [deg]

  Args:
    params: The flight system (start day and second of day, latitude and
      longitude).
    time_s: Flight time since the start. # [s]

  Returns:
    The sun's elevation above the horizon. # [deg]
  """
  return solar.sun_elevation_deg(params.start_day_j2000,
                                 params.start_second_of_day, time_s,
                                 params.latitude_deg, params.longitude_deg)


def gas(params: params_lib.FlightParams, air_temperature: Array,
        air_pressure: Array, time_s: Array, x_m: Array = 0.0,
        y_m: Array = 0.0, gas_temperature: Array = None) -> Gas:
  """The helium's T and P around a balloon in air at (T, P) at `time_s`.

  Args:
    params: The flight system (gas_superheat, latex_overpressure,
      gas_state).
    air_temperature: Ambient T. # [K]
    air_pressure: Ambient P. # [Pa]
    time_s: Flight time (for the sun). # [s]
    x_m: The balloon's offset east of the station (for the sun). # [m]
    y_m: The balloon's offset north of the station (for the sun). # [m]
    gas_temperature: The state T_g (`FlightState.gas_temperature_k`), used
      under `gas_state`; None = a gas at rest (the air's plus the lagged
      solar forcing, as without gas_state). # [K]
  """
  temperature = air_temperature
  if params.gas_state and gas_temperature is not None:
    temperature = jnp.asarray(gas_temperature).astype(
        jnp.result_type(air_temperature)) + jnp.zeros_like(air_temperature)
  elif params.gas_superheat:
    temperature = air_temperature + thermal.gas_excess_k(
        params, time_s, x_m, y_m).astype(jnp.result_type(air_temperature))
  pressure = air_pressure
  if params.latex_overpressure:
    pressure = air_pressure + params.overpressure_pa
  return Gas(air_temperature, air_pressure, temperature, pressure)


def of_state(params: params_lib.FlightParams, state, air_temperature: Array,
             air_pressure: Array, time_s: Array) -> Gas:
  """`gas` of a flight state: its T_g under gas_state, else the model's.

  Args:
    params: The flight system.
    state: The flight state (position, gas_temperature_k).
    air_temperature: Ambient T at the balloon. # [K]
    air_pressure: Ambient P at the balloon. # [Pa]
    time_s: Flight time (for the sun without gas_state). # [s]
  """
  return gas(params, air_temperature, air_pressure, time_s, state.x_m,
             state.y_m, state.gas_temperature_k)


def forcing_k(params: params_lib.FlightParams, time_s: Array,
              x_m: Array = 0.0, y_m: Array = 0.0) -> Array:
  """f(sun): T_eq - T of the gas's relaxation at the balloon, unlagged. # [K]

  `thermal.gas_temperature_offset` of the sun's elevation at the balloon's
  position (`thermal.position_lat_lon`) and time; 0 without gas_superheat.

  Args:
    params: The flight system (sun clock, station, superheat window).
    time_s: Flight time. # [s]
    x_m: Offset east of the station. # [m]
    y_m: Offset north of the station. # [m]
  """
  shape = jnp.zeros_like(jnp.asarray(time_s) + jnp.asarray(x_m) + y_m)
  if not params.gas_superheat:
    return shape
  lat, lon = thermal.position_lat_lon(params.latitude_deg,
                                      params.longitude_deg, x_m, y_m)
  return shape + thermal.forcing_at(params, time_s, lat, lon).astype(
      shape.dtype)


def settled(params: params_lib.FlightParams, g: Gas, forcing: Array,
            rate: Array) -> Gas:
  """The gas as it settles at a steady `rate` (the controller's targets).

  Under gas_state: T_g = T + f - `gas.steady_lag_k` (T_g below its target
  by the adiabatic cooling a steady rise keeps up against the relaxation);
  without it, `g` itself (the lagged forcing has no rate in it).

  Args:
    params: The flight system (gas_state, gas_thermal_lag_s).
    g: The gas now (the air's T and P, the gas's P).
    forcing: f(sun) at the balloon (`forcing_k`). # [K]
    rate: The steady ascent rate. # [m/s]
  """
  if not params.gas_state:
    return g
  target = g.air_temperature + forcing
  rho = physics.air_density(g.air_temperature, g.air_pressure)
  lag = gas_lib.steady_lag_k(target, g.pressure, rho, rate,
                             params.gas_thermal_lag_s)
  return g._replace(temperature=target - lag)


def lift_per_mol(params: params_lib.FlightParams, g: Gas) -> Array:
  """Net lift of a mol of helium, M_air beta - M_He. # [kg/mol]

  Args:
    params: The flight system (gas_superheat, latex_overpressure).
    g: The helium's and the air's T and P (`gas`).

  Returns:
    Net lift per mol; `physics.LIFT_PER_MOL` when neither switch is on.
    # [kg/mol]
  """
  if not (params.gas_superheat or params.latex_overpressure or
          params.gas_state):
    return jnp.asarray(physics.LIFT_PER_MOL, g.air_temperature.dtype)
  return physics.buoyant_lift_per_mol(g.air_temperature, g.air_pressure,
                                      g.temperature, g.pressure)


def free_lift_kg(params: params_lib.FlightParams, state, g: Gas) -> Array:
  """The free lift (F_b - F_w) / g of `state` in gas `g`. # [kg]

  L_paper + n (M_air beta - M_He - (M_air - M_He)) + W; the paper's ledger
  `state.free_lift_kg` itself when no lift switch is on.

  Args:
    params: The flight system (gas_superheat, latex_overpressure,
      lift_walk).
    state: The flight state (free_lift_kg, helium_mols, lift_walk_kg).
    g: The helium's and the air's T and P (`gas`).

  Returns:
    The free lift. # [kg]
  """
  lift = state.free_lift_kg
  if params.gas_superheat or params.latex_overpressure or params.gas_state:
    lift = lift + state.helium_mols * (lift_per_mol(params, g) -
                                       physics.LIFT_PER_MOL)
  if params.lift_walk:
    lift = lift + state.lift_walk_kg
  return lift


def volume(helium_mols: Array, g: Gas) -> Array:
  """Envelope volume n R T_gas / P_gas. # [m^3]

  Args:
    helium_mols: Helium in the envelope n. # [mol]
    g: The helium's and the air's T and P (`gas`).

  Returns:
    The envelope volume. # [m^3]
  """
  return physics.gas_volume(helium_mols, g.temperature, g.pressure)


def drag_coefficient(params: params_lib.FlightParams, helium_mols: Array,
                     g: Gas, speed: Array) -> Array:
  """c_d of `params.drag_model` at `speed` through the air. # [.]

  Args:
    params: The flight system (drag_model and its coefficients).
    helium_mols: Helium in the envelope n (sets the diameter). # [mol]
    g: The helium's and the air's T and P (`gas`).
    speed: Speed through the air (sign ignored). # [m/s]

  Returns:
    The drag coefficient c_d; `params.drag_coefficient` for the
    'constant' model. # [.]
  """
  if params.drag_model == 'constant':
    return jnp.asarray(params.drag_coefficient)
  rho = physics.air_density(g.air_temperature, g.air_pressure)
  reynolds = physics.reynolds_number(
      rho, speed, physics.envelope_diameter(volume(helium_mols, g)),
      physics.air_viscosity(g.air_temperature))
  return physics.drag_coefficient_of_reynolds(
      reynolds, subcritical=params.drag_coefficient_subcritical,
      supercritical=params.drag_coefficient_supercritical,
      transition=params.reynolds_transition, band=params.reynolds_band,
      smooth=params.drag_model == 'smooth')


def drag_factor(params: params_lib.FlightParams, helium_mols: Array, g: Gas,
                speed: Array) -> Array:
  """k = 1/2 rho c_d(Re) A(V), F_d = k |hdot| hdot at `speed`. # [kg/m]

  Args:
    params: The flight system (drag_model and its coefficients).
    helium_mols: Helium in the envelope n. # [mol]
    g: The helium's and the air's T and P (`gas`).
    speed: Speed through the air (sign ignored). # [m/s]

  Returns:
    The drag factor k. # [kg/m]
  """
  rho = physics.air_density(g.air_temperature, g.air_pressure)
  return 0.5 * rho * drag_coefficient(params, helium_mols, g, speed) * (
      physics.drag_area(volume(helium_mols, g)))


def steady_lift_kg(params: params_lib.FlightParams, helium_mols: Array,
                   g: Gas, rate: Array) -> Array:
  """Free lift for a steady rate: k(n, rate) |rate| rate / g. # [kg]

  Args:
    params: The flight system (drag_model and its coefficients).
    helium_mols: Helium in the envelope n. # [mol]
    g: The helium's and the air's T and P (`gas`).
    rate: Steady ascent rate hdot. # [m/s]

  Returns:
    The free lift that holds `rate` steady. # [kg]
  """
  return drag_factor(params, helium_mols, g, rate) * jnp.abs(rate) * rate / (
      physics.GRAVITY)


def vent_target(params: params_lib.FlightParams, payload_kg: Array,
                sand_kg: Array, walk_kg: Array, helium_mols: Array, g: Gas,
                rate: Array, refinements: int = 2) -> Array:
  """Eq. vent with this gas and drag: the free lift after venting. # [kg]

  The helium n_calc = s^3 with a3 s^3 - b s^2 - c = 0, a3 = g (M_air beta -
  M_He), b = 1/2 rho c_d pi (3 R T_gas / (4 pi P_gas))^(2/3) |hdot| hdot,
  c = (m_p + m_s - W) g; c_d(Re) is taken at the current helium's diameter,
  then `refinements - 1` more times at n_calc's. Returns b s^2 / g (the
  steady lift, as `physics.vent_target_lift_kg`).

  Args:
    params: The flight system (lift and drag switches).
    payload_kg: m_p. # [kg]
    sand_kg: m_s aboard (unchanged by venting). # [kg]
    walk_kg: Free-lift random walk W. # [kg]
    helium_mols: Current helium n (first c_d(Re) estimate). # [mol]
    g: The helium's and the air's T and P (`gas`).
    rate: Desired steady ascent rate hdot. # [m/s]
    refinements: Evaluations of c_d(Re) (static; 1 for the 'constant'
      drag model).

  Returns:
    The free lift after venting to n_calc. # [kg]
  """
  rho = physics.air_density(g.air_temperature, g.air_pressure)
  a3 = physics.GRAVITY * lift_per_mol(params, g)
  shape = jnp.pi * (3.0 * physics.GAS_CONSTANT * g.temperature / (
      4.0 * jnp.pi * g.pressure))**(2.0 / 3.0)
  c = jnp.maximum(payload_kg + sand_kg - walk_kg, 1e-6) * physics.GRAVITY
  n = helium_mols
  lift = jnp.zeros_like(rate)
  for _ in range(refinements if params.drag_model != 'constant' else 1):
    c_d = drag_coefficient(params, n, g, rate)
    b = 0.5 * rho * c_d * shape * jnp.abs(rate) * rate
    s = physics.vent_root(a3 + jnp.zeros_like(b), b, c)
    n = s * s * s
    lift = b * s * s / physics.GRAVITY
  return lift


def burst_volume_m3(params: params_lib.FlightParams, state) -> Array:
  """The volume at which this flight's envelope bursts. # [m^3]

  Args:
    params: The flight system (burst_spread, burst_volume_m3).
    state: The flight state (its drawn burst_volume_m3 when burst_spread).

  Returns:
    The burst volume. # [m^3]
  """
  if params.burst_spread:
    return state.burst_volume_m3
  return params.burst_volume_m3
