# coding=utf-8
"""The launch fill: a balloon neutral under the physics it flies.

`state.initial_state` fills the envelope neutral for the paper's gas (helium
at the air's T and P). Under realistic physics the helium is warmer by day
and cooler at night (`thermal`) and may be over-pressured, so that fill is
~0.1 kg heavy at night and light by day, which the first float command pays
in sand or helium at once. `neutral_launch` refills it as a launch crew
does, to zero free lift in the gas of the bound physics at the balloon's
altitude, position and time:

  n = (m_p + m_s - W) / (M_air beta - M_He)      (Eq. float, realistic gas)

and keeps the paper's lift ledger consistent (`FlightState.free_lift_kg` =
n (M_air - M_He) - m_p - m_s). Under `gas_state` it also sets the helium's
temperature state to that of a gas at rest there (the air's plus the lagged
solar forcing of the flight's own sun clock). Pure, jittable, vmappable; the paper's model
(and an explicit `FlightParams.initial_helium_mols`) is returned unchanged.
"""

import jax
import jax.numpy as jnp

from ble_latex.flight import atmosphere as atmosphere_lib
from ble_latex.flight import envelope
from ble_latex.flight import params as params_lib
from ble_latex.flight import physics
from ble_latex.flight import state as state_lib

Array = jax.Array


def neutral_launch(params: params_lib.FlightParams,
                   atm_params: atmosphere_lib.AtmosphereParams,
                   state: state_lib.FlightState) -> state_lib.FlightState:
  """`state` refilled to zero free lift under `params`' gas (Eq. float).

  Args:
    params: The flight system as flown (its sun clock set to this flight's
      start, e.g. the env's `flight_params_of`).
    atm_params: The atmosphere.
    state: A new balloon (`state.initial_state`), nothing pending.

  Returns:
    The state with the helium that makes the realistic free lift 0 at its
    altitude, position and time, and the paper's ledger for that helium;
    `state` itself when no gas switch is on (`gas_superheat`,
    `latex_overpressure`) or the launch helium is given
    (`initial_helium_mols`).
  """
  if not (params.gas_superheat or params.latex_overpressure or
          params.gas_state):
    return state
  ambient = atmosphere_lib.at_height(atm_params, state.altitude_m)
  g = envelope.gas(params, ambient.temperature, ambient.pressure,
                   state.time_s, state.x_m, state.y_m)
  if params.gas_state:
    state = state.replace(gas_temperature_k=g.temperature.astype(
        state.gas_temperature_k.dtype))
  if params.initial_helium_mols is not None:
    return state
  per_mol = envelope.lift_per_mol(params, g)
  weight = params.payload_kg + state.sand_kg - state.lift_walk_kg  # [kg]
  helium = weight / per_mol
  # n (M_air - M_He) - m_p - m_s, formed without the cancellation.
  ledger = weight * (physics.LIFT_PER_MOL / per_mol - 1.0) - (
      state.lift_walk_kg)
  dtype = state.helium_mols.dtype
  return state.replace(helium_mols=jnp.asarray(helium, dtype),
                       settled_lift_kg=jnp.asarray(ledger, dtype))
