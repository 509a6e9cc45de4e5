# coding=utf-8
"""The altitudes a flight can reach: the band a wind file must cover.

The one home of that band (issue 64): the flight system's altitude-band
guard, [`AltitudeController.band_low_m`, `band_high_m`] (`flight.params`;
13-22 km by default), outside which the controller floats the balloon back
(`flight.controller.band_guard`), as bound in gin when a file is read. A
real source (a GFS grid, GRIB2, a sounding) is accepted when its winds span
it (`analysis.check_flight_band` by pressure, US Standard Atmosphere 1976;
`sounding.read` by the sounding's own heights); above a sounding's top the
wind is held at its top, and the record says so (`era5.Era5Data.
description`).
"""

from typing import Tuple

from ble_latex.flight import params as flight_params_lib


def flight_band_m() -> Tuple[float, float]:
  """(lowest, highest) altitude the balloon flies in. # [m]

  gin's `AltitudeController.band_low_m` / `band_high_m` (the flight
  system's defaults, `flight.params.DEFAULTS`, where unbound).
  """
  controller = flight_params_lib.controller()
  return float(controller['band_low_m']), float(controller['band_high_m'])


def band_text(band_m: Tuple[float, float]) -> str:
  """E.g. 'the flight band 13-22 km (AltitudeController.band_low_m/
  band_high_m)'."""
  return (f'the flight band {band_m[0] / 1000:g}-{band_m[1] / 1000:g} km '
          '(AltitudeController.band_low_m/band_high_m)')
