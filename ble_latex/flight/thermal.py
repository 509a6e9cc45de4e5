# coding=utf-8
"""The helium's temperature relative to the air: the diurnal cycle, in JAX.

What the observation shows. ValBal's sunset table (stanford-ssi/
balloons-VALBAL `src/Utils.h`, used in `src/Utils.cpp`, a fit to 10 real
sunsets) gives the LIFT lost per degree of sun elevation over -16..24 deg,
and the ballast ValBal dropped around its sunsets (0.2-0.7 kg, mean ~0.45
kg) is that lift. A neutral balloon whose helium is at the air's temperature
loses no lift when the air cools (lift n (M_air T_gas/T - M_He) does not
depend on T when T_gas = T), so what the observation measures is the
gas-air temperature difference dT = T_gas - T: solar superheat by day,
radiative cooling of the film and gas at night. The air's own diurnal cycle
at 13-20 km (~1 K) moves both alike and is not modelled.

The model (pure, jittable, vmappable):

  * forcing f(el) = -night + (day + night) smoothstep((el - el_night) /
    (el_day - el_night)), the smoothstep 3x^2 - 2x^3, the window -16..24 deg
    that of ValBal's table (`src/Utils.h:147-150`) (`gas_temperature_offset`);
  * el the sun's elevation at the balloon's own position (`position_lat_lon`:
    the station's latitude/longitude plus the balloon's offsets east/north
    on a sphere of the Earth's mean radius) and time (`solar`);
  * a first-order thermal lag d(dT)/dt = (f - dT) / tau (tau =
    `FlightParams.gas_thermal_lag_s`; a latex film and its gas exchange heat
    in minutes), started in the infinite past, so
    dT(t) = int_0^inf f(t - tau u) e^-u du, evaluated by an
    `LAG_NODES`-point Gauss-Laguerre quadrature (`lagged`): exact for
    forcings polynomial of degree < 2 LAG_NODES in the lag, without a state
    variable, and a balloon launched at any time starts on the lagged
    curve (tau = 0: no lag, dT = f).
"""

from typing import Callable

import jax
import jax.numpy as jnp
import numpy as np

from ble_latex.flight import solar

Array = jax.Array

# Mean radius of the Earth (IUGG). # [m]
EARTH_RADIUS_M = 6_371_008.8
# Gauss-Laguerre nodes of the lag integral (static).
LAG_NODES = 6
_LAG_U, _LAG_W = np.polynomial.laguerre.laggauss(LAG_NODES)


def gas_temperature_offset(sun_elevation_deg: Array, *, day_k: Array,
                           night_k: Array, night_deg: Array,
                           day_deg: Array) -> Array:
  """Forcing of T_gas - T: solar superheat / radiative cooling. # [K]

  -night_k at and below a sun elevation of night_deg, +day_k at and above
  day_deg, a smoothstep 3x^2 - 2x^3 between. The window -16..24 deg is that
  of ValBal's sunset lift-loss table (stanford-ssi/balloons-VALBAL
  src/Utils.h:147-150, used in src/Utils.cpp:245-248), which integrates to
  0.43 kg of lift per sunset; the swing day_k + night_k is calibrated to it
  in `flight.params.REALISTIC` (docs/physics.md).

  Args:
    sun_elevation_deg: Sun elevation. # [deg]
    day_k: Superheat by day. # [K]
    night_k: Cooling at night (>= 0). # [K]
    night_deg: Elevation of full night. # [deg]
    day_deg: Elevation of full day. # [deg]
  """
  x = jnp.clip((sun_elevation_deg - night_deg) / (day_deg - night_deg), 0.0,
               1.0)
  return -night_k + (day_k + night_k) * x * x * (3.0 - 2.0 * x)


def lagged(forcing: Callable[[Array], Array], time_s: Array,
           lag_s: Array) -> Array:
  """First-order lag of `forcing`, started in the infinite past.

  y' = (f - y) / tau has y(t) = int_0^inf f(t - tau u) e^-u du; the
  integral by Gauss-Laguerre quadrature (`LAG_NODES` points). tau = 0
  gives f(t) (the weights sum to 1).

  Args:
    forcing: Pure, vectorised time [s] -> value.
    time_s: Time. # [s]
    lag_s: Time constant tau >= 0. # [s]

  Returns:
    The lagged value y(t), in the forcing's unit.
  """
  time_s = jnp.asarray(time_s)
  u = jnp.asarray(_LAG_U, time_s.dtype)
  w = jnp.asarray(_LAG_W, time_s.dtype)
  times = time_s[..., None] - jnp.asarray(lag_s, time_s.dtype)[..., None] * u
  return jnp.sum(w * forcing(times), axis=-1)


def position_lat_lon(latitude_deg: Array, longitude_deg: Array, x_m: Array,
                     y_m: Array):
  """(latitude, longitude) of a balloon at offsets (x east, y north). # [deg]

  On a sphere of `EARTH_RADIUS_M`: dlat = y / R, dlon = x / (R cos lat0)
  (the station-keeping offsets are <~ 500 km, where this is good to ~1 %
  of the offset). The latitude is clipped to [-90, 90].

  Args:
    latitude_deg: The station's latitude. # [deg]
    longitude_deg: The station's longitude, east positive. # [deg]
    x_m: Offset east of the station. # [m]
    y_m: Offset north of the station. # [m]
  """
  to_deg = 180.0 / jnp.pi
  cos_lat = jnp.maximum(jnp.cos(latitude_deg / to_deg), 1e-6)
  lat = jnp.clip(latitude_deg + to_deg * y_m / EARTH_RADIUS_M, -90.0, 90.0)
  return lat, longitude_deg + to_deg * x_m / (EARTH_RADIUS_M * cos_lat)


def forcing_at(params, time_s: Array, latitude_deg: Array,
               longitude_deg: Array) -> Array:
  """f: `gas_temperature_offset` of the sun at a place and time, unlagged. # [K]

  Args:
    params: The flight system (sun clock, superheat and its window).
    time_s: Flight time since the start. # [s]
    latitude_deg: Where (`position_lat_lon`). # [deg]
    longitude_deg: Where, east positive. # [deg]
  """
  return gas_temperature_offset(
      solar.sun_elevation_deg(params.start_day_j2000,
                              params.start_second_of_day, time_s,
                              latitude_deg, longitude_deg),
      day_k=params.superheat_day_k, night_k=params.cooling_night_k,
      night_deg=params.sun_elevation_night_deg,
      day_deg=params.sun_elevation_day_deg)


def gas_excess_k(params, time_s: Array, x_m: Array = 0.0,
                 y_m: Array = 0.0) -> Array:
  """T_gas - T of a balloon at (x, y) at flight time `time_s`. # [K]

  The lagged (`params.gas_thermal_lag_s`) forcing `gas_temperature_offset`
  of the sun's elevation at the balloon's position (`position_lat_lon`).

  Args:
    params: The flight system (`FlightParams`: sun clock, station,
      superheat_day_k, cooling_night_k, the elevation window, the lag).
    time_s: Flight time since the start. # [s]
    x_m: Offset east of the station. # [m]
    y_m: Offset north of the station. # [m]
  """
  lat, lon = position_lat_lon(params.latitude_deg, params.longitude_deg,
                              x_m, y_m)
  lat, lon = lat[..., None], lon[..., None]

  def forcing(t):
    return forcing_at(params, t, lat, lon)

  time_s = jnp.asarray(time_s) + jnp.zeros_like(jnp.asarray(x_m) + y_m)
  return lagged(forcing, time_s, params.gas_thermal_lag_s)
