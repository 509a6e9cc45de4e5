# coding=utf-8
"""What the balloon measures of the sun and its gas: the observation options.

Two options of the observation (gin `latex_observation.*`, `EnvParams`),
both off by default (the paper's 71 features), each appending features after
index 70 (`jax_features.option_features`, its index map):

- `sun`: the sun's elevation at the balloon and its rate of change. A
  balloon knows its time and place (GPS), so it can compute both; together
  they tell how soon the sun sets or rises (the helium's temperature, hence
  its lift, follows the sun: `flight.thermal`). The elevation is NOAA's
  (`flight.solar.sun_elevation_deg`) at the balloon's own position
  (`flight.thermal.position_lat_lon`: the station's place plus its offsets)
  on the flight's own clock (`env_types.sun_params_of`: the start drawn at
  reset, BLE's date or the flight's start in the ERA5 data), the same sun
  the realistic physics heats the helium with; under the paper's physics
  the sun exists all the same (the flight has a start date and a place) and
  merely does not heat the gas. The rate is the central difference of the
  elevation over +-`RATE_HALF_STEP_S`.
- `gas_temperature`: the helium's temperature minus the air's at the
  balloon (a thermistor in the gas and one outside), the helium's as the
  flight physics has it (`flight.envelope.of_state`: the state T_g under
  `gas_state`, the air's plus the lagged solar forcing under
  `gas_superheat` alone, the air's, hence 0, under the paper's physics).

Pure functions of the env state (jittable, vmappable); the env calls
`features` where it observes (`jax_env.observation_of_column`).
"""

from typing import Tuple

import jax
import jax.numpy as jnp

from ble_latex.envs import env_types
from ble_latex.envs import jax_features
from ble_latex.flight import envelope
from ble_latex.flight import solar
from ble_latex.flight import thermal

Array = jax.Array

# Half the step of the elevation's central difference: the rate is the
# mean over 10 minutes (the elevation changes by <= 2.5 deg in it). # [s]
RATE_HALF_STEP_S = 300.0


def sun(params: env_types.EnvParams,
        state: env_types.EnvState) -> Tuple[Array, Array]:
  """The sun's elevation at the balloon and its rate of change.

  Args:
    params: The env parameters (the place of the flight system).
    state: The env state (the balloon's position and flight time, the
      flight's start and station).

  Returns:
    (elevation [deg], d(elevation)/dt [deg/h]).
  """
  f = state.flight
  clock = env_types.sun_params_of(params, state)
  lat, lon = thermal.position_lat_lon(clock.latitude_deg,
                                      clock.longitude_deg, f.x_m, f.y_m)

  def elevation(time_s: Array) -> Array:
    return solar.sun_elevation_deg(clock.start_day_j2000,
                                   clock.start_second_of_day, time_s, lat,
                                   lon)

  step = jnp.asarray(RATE_HALF_STEP_S, f.time_s.dtype)
  rate = (elevation(f.time_s + step) - elevation(f.time_s - step)) / (
      2.0 * step) * 3600.0
  return elevation(f.time_s), rate


def gas_excess_k(params: env_types.EnvParams,
                 state: env_types.EnvState) -> Array:
  """T_gas - T: the helium's temperature minus the air's at the balloon. # [K]

  The helium's of the flight physics (`envelope.of_state` under the
  flight's own system, `env_types.flight_params_of`); 0 under the paper's.
  """
  f = state.flight
  gas = envelope.of_state(env_types.flight_params_of(params, state), f,
                          f.temperature_k, f.pressure_pa, f.time_s)
  return gas.temperature - f.temperature_k


def features(state: env_types.EnvState,
             params: env_types.EnvParams) -> Array:
  """The options' features of `state` (`jax_features.option_features`):
  float32 [0..3], empty with both options off."""
  elevation = rate = excess = None
  if params.sun:
    elevation, rate = sun(params, state)
  if params.gas_temperature:
    excess = gas_excess_k(params, state)
  return jax_features.option_features(sun_elevation_deg=elevation,
                                      sun_rate_deg_per_h=rate,
                                      gas_excess_k=excess)
