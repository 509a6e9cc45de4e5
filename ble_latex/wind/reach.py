# coding=utf-8
"""The altitudes a flight can reach: the band a wind file must cover.

The one home of that band (issue 64): the flight system's altitude-band
guard, [`latex_controller.band_low_m`, `band_high_m`] (`flight.params`;
13-22 km by default), outside which the controller floats the balloon back
(`flight.controller.band_guard`), as bound in gin when a file is read. A
real source (a GFS grid, GRIB2, a sounding) is accepted when its winds span
it (`analysis.check_flight_band` by pressure, US Standard Atmosphere 1976;
`sounding.read` by the sounding's own heights); above a sounding's top the
wind is held at its top, and the record says so (`gridded.Era5Data.
description`).
"""

import math
from typing import Tuple

from ble_latex.flight import params as flight_params_lib


def flight_band_m() -> Tuple[float, float]:
  """(lowest, highest) altitude the balloon flies in. # [m]

  gin's `latex_controller.band_low_m` / `band_high_m` (the flight
  system's defaults, `flight.params.DEFAULTS`, where unbound).
  """
  controller = flight_params_lib.controller()
  return float(controller['band_low_m']), float(controller['band_high_m'])


def band_text(band_m: Tuple[float, float]) -> str:
  """E.g. 'the flight band 13-22 km (latex_controller.band_low_m/
  band_high_m)'."""
  return (f'the flight band {band_m[0] / 1000:g}-{band_m[1] / 1000:g} km '
          '(latex_controller.band_low_m/band_high_m)')


def pressure_of_height(height_m: float) -> float:
  """US Standard Atmosphere 1976 pressure at a geopotential height. # [Pa]

  Layers 0-11 km (lapse -6.5 K/km), 11-20 km (isothermal 216.65 K), 20-32 km
  (lapse +1 K/km): p = p_b (T_b / T)^(g0 M / (R L)) or p_b exp(-g0 M dh /
  (R T_b)) (NOAA/NASA/USAF, 1976, eq. 33a/33b).
  """
  g_m_r = 9.80665 * 0.0289644 / 8.3144598  # g0 M / R. # [K/m]
  layers = ((0.0, 288.15, -0.0065, 101325.0), (11_000.0, 216.65, 0.0, 22632.1),
            (20_000.0, 216.65, 0.001, 5474.89), (32_000.0, 228.65, 0.0028,
                                                 868.019))
  # Below sea level (a low-lying site): the lowest layer, extended down.
  base, temp, lapse, p_base = ([l for l in layers if l[0] <= height_m] or
                               layers[:1])[-1]
  dh = height_m - base
  if lapse == 0.0:
    return p_base * math.exp(-g_m_r * dh / temp)
  return p_base * (temp / (temp + lapse * dh)) ** (g_m_r / lapse)
