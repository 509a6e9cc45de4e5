# coding=utf-8
"""The forecast error of a real wind file: BLE's simplex noise, scaled (issue 64).

On a wind file the agents see the file (the forecast) and the balloon flies
in the truth = file + `noise_scale` x BLE's simplex noise
(`wind.simplex.wind_noise_uv`; `GriddedWindField.noise_scale`).

BLE's noise as ported is 1.05 m/s rms per component (`BLE_NOISE_RMS_MPS`:
1024 reset keys x 500 points, 40-165 hPa, +-300 km, 0-72 h;
`python benchmarks/noise_rms.py`), whatever the weather. BLE's own comment
(`simplex_wind_noise.NOISE_MAGNITUDE`) says it should match the 12-h CRMSE of
Loon's observations against the forecast, 3.5 m/s (a vector error: 2.5 m/s
per component), and it was left at ~1 m/s. Published stratospheric errors
are larger still than BLE's: Loon super-pressure balloons against
reanalyses in the lower stratosphere differ by a zonal-wind SD of 2.5-3.5 m/s
(Friedrich, L. S., McDonald, A. J., Bodeker, G. E., et al., "A comparison of
Loon balloon observations and stratospheric reanalysis products", Atmos.
Chem. Phys. 17, 855-866, 2017) - an analysis's error, before any forecast
lead.

`REAL_FILE_NOISE_RMS_MPS` = 2.5 m/s per component, the lower end of
Friedrich et al.'s range and BLE's 3.5 m/s vector CRMSE, is the default on
real files other than ERA5 (GFS analyses and forecasts, GRIB2, soundings):
`noise_scale` = 2.5 / 1.05 = 2.39. ERA5 files keep BLE's noise (scale 1),
the paper's setting. `GriddedWindField.noise_scale = X` chooses any scale
(0: the truth is the file).
"""

import math
from typing import Any, Optional

import numpy as np

from ble_latex import errors

# BLE's simplex noise, rms per component, measured by
# benchmarks/noise_rms.py (2026-12-05, 2-core build machine). # [m/s]
BLE_NOISE_RMS_MPS = 1.045
# The forecast error on real files other than ERA5, rms per component:
# Friedrich et al. 2017 (ACP 17, 855), 2.5-3.5 m/s zonal SD; BLE's 3.5 m/s
# vector 12-h CRMSE / sqrt(2). # [m/s]
REAL_FILE_NOISE_RMS_MPS = 2.5
# The sources whose default noise is BLE's own (the paper's ERA5 setting).
BLE_NOISE_SOURCES = ('ERA5',)


def check_scale(scale: Any) -> Optional[float]:
  """`GriddedWindField.noise_scale`, checked: None or a finite number >= 0."""
  if scale is None:
    return None
  if (isinstance(scale, bool) or not isinstance(scale, (int, float)) or
      not math.isfinite(scale) or scale < 0):
    raise errors.ConfigError(
        f'GriddedWindField.noise_scale = {scale!r}: expected None (the source '
        'decides) or a finite number >= 0 (x BLE\'s simplex noise)')
  return float(scale)


def noise_scale(setting: Any, source: str, two_source: bool = False) -> float:
  """The factor on BLE's simplex noise in a file's truth.

  Args:
    setting: `GriddedWindField.noise_scale` (None: the source decides).
    source: `gridded.Era5Data.source` ('ERA5', 'analysis', 'GRIB2',
      'sounding').
    two_source: The truth is a second file (`truth_on_forecast_grid`).

  Returns:
    The setting; else 0 with a truth file (its own winds are the error),
    1 on ERA5, REAL_FILE_NOISE_RMS_MPS / BLE_NOISE_RMS_MPS (2.39) on other
    files.
  """
  scale = check_scale(setting)
  if scale is not None:
    return scale
  if two_source:
    return 0.0
  if source in BLE_NOISE_SOURCES:
    return 1.0
  return REAL_FILE_NOISE_RMS_MPS / BLE_NOISE_RMS_MPS


def describe(scale: float) -> str:
  """E.g. 'truth = file + 2.39 x BLE noise (2.5 m/s rms per component)'."""
  return (f'truth = file + {scale:.3g} x BLE noise '
          f'({scale * BLE_NOISE_RMS_MPS:.2g} m/s rms per component)')


def truth_on_forecast_grid(forecast: Any, truth: Any) -> np.ndarray:
  """A second file's winds as the truth, on the forecast file's grid.

  The two-source mode (`GriddedWindField.truth_path`): the agents see the
  forecast (e.g. a forecast run's lead times), the balloon flies in the
  truth (e.g. analyses at the same valid times), each read by `gridded.load`.
  The truth is interpolated multi-linearly (`Era5Data.interpolate`) at every
  node of the forecast's grid (its times, levels, latitudes, longitudes), so
  the device grid interpolates both alike.

  Args:
    forecast: The forecast's `gridded.Era5Data`.
    truth: The truth's `gridded.Era5Data`.

  Returns:
    [time, pressure, lat, lon, 2] the truth's (u, v), float32. # [m/s]

  Raises:
    errors.ConfigError: a truth that does not hold the forecast's valid
      times or area (one line naming both files).
  """
  def label(data):
    return f'{data.description}: {list(data.paths)}'
  first, last = forecast.times[0], forecast.times[-1]
  if not (truth.times[0] <= first and last <= truth.times[-1]):
    raise errors.ConfigError(
        f'GriddedWindField.truth_path: the truth ({label(truth)}, '
        f'{truth.times[0]}..{truth.times[-1]}) does not hold the forecast\'s '
        f'valid times {first}..{last} ({label(forecast)})')
  corners = [(lat, lon) for lat in forecast.latitude[[0, -1]]
             for lon in forecast.longitude[[0, -1]]]
  outside = [c for c in corners if not truth.covers(*c)]
  if outside:
    raise errors.ConfigError(
        f'GriddedWindField.truth_path: the truth ({label(truth)}) does not '
        f'cover the forecast\'s area at (lat, lon) {outside[0]} '
        f'({label(forecast)})')
  time_s = (forecast.times - truth.times[0]) / np.timedelta64(1, 's')
  tt, pp, la, lo = np.meshgrid(time_s, forecast.pressure, forecast.latitude,
                               forecast.longitude, indexing='ij')
  return truth.interpolate(tt, pp, la, lo).astype(np.float32)
