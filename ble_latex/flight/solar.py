# coding=utf-8
"""The sun's elevation over a flight, in JAX (pure, jittable, vmappable).

The NOAA solar calculator as BLE 1.0.1 implements it
(`balloon_learning_environment/env/balloon/solar.py`, `solar_calculator`,
lines 43-157 of the installed 1.0.1), re-written for JAX on the flight
core's clock: the flight's start is given as the Julian date of 0h UTC of
its day minus 2451545.0 (`start_day_j2000`) and the second of that day
(`start_second_of_day`), so the time of day keeps full precision in float32
(a Unix time in float32 would be off by minutes).

Differences from BLE: no atmospheric refraction correction (< 0.6 deg, and
only near the horizon; the gas-temperature model spreads the sunset over
-16..24 deg anyway) and no azimuth or flux. tests/flight/test_physics_realistic.py
checks the elevation against BLE's `solar_calculator` (< 0.7 deg).
"""

import datetime as dt
from typing import Any, Tuple

import jax
import jax.numpy as jnp

from ble_latex import gin_values

Array = jax.Array

SECONDS_PER_DAY = 86_400.0  # [s]
DAYS_PER_JULIAN_CENTURY = 36_525.0  # [day]


def _rad(deg):
  return deg * (jnp.pi / 180.0)


def sun_elevation_deg(start_day_j2000: Array, start_second_of_day: Array,
                      time_s: Array, latitude_deg: Array,
                      longitude_deg: Array) -> Array:
  """Sun elevation above the horizon (NOAA, without refraction). # [deg]

  Args:
    start_day_j2000: Julian date of 0h UTC of the start day - 2451545.0.
      # [day]
    start_second_of_day: UTC second of that day at time_s = 0. # [s]
    time_s: Time since the start. # [s]
    latitude_deg: Latitude. # [deg]
    longitude_deg: Longitude, east positive. # [deg]

  Returns:
    The elevation. # [deg]
  """
  seconds = start_second_of_day + time_s
  whole_days = jnp.floor(seconds / SECONDS_PER_DAY)
  fraction_of_day = (seconds - whole_days * SECONDS_PER_DAY) / SECONDS_PER_DAY
  # Julian centuries since J2000.0 (BLE solar.py: julian_century).
  century = (start_day_j2000 + whole_days + fraction_of_day) / (
      DAYS_PER_JULIAN_CENTURY)
  # Geometric mean longitude and anomaly of the sun. # [rad]
  mean_long = _rad(jnp.mod(280.46646 + century * (36000.76983 +
                                                   century * 0.0003032),
                           360.0))
  mean_anomaly = _rad(jnp.mod(357.52911 + century * (35999.05029 -
                                                      0.0001537 * century),
                              360.0))
  # Obliquity of the ecliptic, corrected. # [rad]
  mean_obliquity = _rad(23.0 + (26.0 + (21.448 - century * (
      46.815 + century * (0.00059 - century * 0.001813))) / 60.0) / 60.0)
  omega = _rad(125.04 - 1934.136 * century)
  obliquity = mean_obliquity + _rad(0.00256 * jnp.cos(omega))
  eccentricity = 0.016708634 - century * (0.000042037 +
                                          0.0000001267 * century)
  # Equation of time. # [min]
  y = jnp.tan(0.5 * obliquity)**2
  eot_rad = (y * jnp.sin(2.0 * mean_long) -
             2.0 * eccentricity * jnp.sin(mean_anomaly) +
             4.0 * eccentricity * y * jnp.sin(mean_anomaly) *
             jnp.cos(2.0 * mean_long) -
             0.5 * y * y * jnp.sin(4.0 * mean_long) -
             1.25 * eccentricity * eccentricity * jnp.sin(2.0 * mean_anomaly))
  eot_min = 4.0 * eot_rad * (180.0 / jnp.pi)
  # Hour angle from the true solar time. # [rad]
  true_solar_min = jnp.mod(1440.0 * fraction_of_day + eot_min +
                           4.0 * longitude_deg, 1440.0)
  hour_angle = _rad(true_solar_min / 4.0 - 180.0)
  # Declination from the apparent longitude. # [rad]
  center = _rad(jnp.sin(mean_anomaly) * (1.914602 - century * (
      0.004817 + 0.000014 * century)) + jnp.sin(2.0 * mean_anomaly) * (
          0.019993 - 0.000101 * century) + jnp.sin(3.0 * mean_anomaly) *
                0.000289)
  apparent_long = mean_long + center - _rad(0.00569 + 0.00478 *
                                            jnp.sin(omega))
  declination = jnp.arcsin(jnp.sin(obliquity) * jnp.sin(apparent_long))
  lat = _rad(latitude_deg)
  cos_zenith = (jnp.sin(lat) * jnp.sin(declination) +
                jnp.cos(lat) * jnp.cos(declination) * jnp.cos(hour_angle))
  return 90.0 - jnp.degrees(jnp.arccos(jnp.clip(cos_zenith, -1.0, 1.0)))


# J2000.0 (the epoch of `start_day_j2000`), 2000-01-01 12:00 UTC.
J2000 = dt.datetime(2000, 1, 1, 12, tzinfo=dt.timezone.utc)


def solar_clock(start_time: Any, name: str) -> Tuple[float, float]:
  """(start_day_j2000 [day], start_second_of_day [s]) of a UTC start time.

  Args:
    start_time: A `datetime.datetime` (naive = UTC) or an ISO 8601 string
      ('2022-11-01T00:00:00').
    name: What it is in the message.

  Returns:
    The Julian date of 0h UTC of the start day minus 2451545.0, and the
    second of that day.

  Raises:
    ValueError: Naming `name` (not a date).
  """
  value = start_time
  if isinstance(value, str):
    try:
      value = dt.datetime.fromisoformat(value)
    except ValueError:
      value = None
  gin_values.require(isinstance(value, dt.datetime), name,
                     "a UTC date, e.g. '2022-11-01T00:00:00'", start_time)
  if value.tzinfo is None:
    value = value.replace(tzinfo=dt.timezone.utc)
  value = value.astimezone(dt.timezone.utc)
  midnight = value.replace(hour=0, minute=0, second=0, microsecond=0)
  return ((midnight - J2000).total_seconds() / 86400.0,
          (value - midnight).total_seconds())
