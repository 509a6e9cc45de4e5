# coding=utf-8
"""The CDS requests for the paper's ERA5 files (`ble-latex-download-era5`).

`build_requests` builds the exact `cdsapi` requests of the dataset
`reanalysis-era5-pressure-levels` (u, v around a target, one request per
calendar month) whose NetCDF files `gridded.load` reads;
`ble_latex.cli.download_era5` fetches them (or, with `--source=arco`,
`era5_arco` cuts the same selection from Google's ARCO-ERA5 store). The
defaults are the paper's data (Saunders et al. 2023, "RL problem", Wind).
"""

import calendar
import datetime as dt
import math
from typing import Any, Dict, List, Sequence, Tuple

from ble_latex.wind import gridded
from ble_latex.wind import gridded_checks

DATASET = 'reanalysis-era5-pressure-levels'
PAPER_START_DATE = dt.date(2022, 11, 1)
PAPER_END_DATE = dt.date(2023, 1, 31)
PAPER_MIN_PRESSURE_HPA = 20.0  # [hPa] = 2000 Pa
PAPER_MAX_PRESSURE_HPA = 175.0  # [hPa] = 17 500 Pa
PAPER_GRID_DEG = 0.4  # [deg]
PAPER_TIMES = ('00:00', '06:00', '12:00', '18:00')
# Covers the 200 km start radius and the 500 km the balloon may drift.
DEFAULT_HALF_WIDTH_DEG = 5.0  # [deg]
# ERA5's native grid is 0.25 deg; CDS only interpolates finer, and a grid
# finer than this asks for an area of (2 x half width / grid)^2 points that
# no request can return. # [deg]
MIN_GRID_DEG = 0.05


def pressure_levels_hpa(min_hpa: float = PAPER_MIN_PRESSURE_HPA,
                        max_hpa: float = PAPER_MAX_PRESSURE_HPA) -> List[int]:
  """ERA5's standard pressure levels within [min_hpa, max_hpa]. # [hPa]

  Args:
    min_hpa: Lowest pressure wanted (the paper's 20 hPa). # [hPa]
    max_hpa: Highest pressure wanted (the paper's 175 hPa). # [hPa]

  Returns:
    The levels, ascending. # [hPa]

  Raises:
    ValueError: If no ERA5 level lies in the range.
  """
  levels = [p for p in gridded_checks.ERA5_PRESSURE_LEVELS_HPA
            if min_hpa <= p <= max_hpa]
  if not levels:
    raise ValueError(
        f'No ERA5 pressure level in [{min_hpa}, {max_hpa}] hPa '
        f'(levels: {list(gridded_checks.ERA5_PRESSURE_LEVELS_HPA)})')
  return levels


def build_requests(
    *,
    center_lat: float = gridded.PAPER_CENTER_LAT,  # [deg N]
    center_lon: float = gridded.PAPER_CENTER_LON,  # [deg E]
    start_date: dt.date = PAPER_START_DATE,
    end_date: dt.date = PAPER_END_DATE,
    half_width_deg: float = DEFAULT_HALF_WIDTH_DEG,  # [deg]
    grid_deg: float = PAPER_GRID_DEG,  # [deg]
    min_pressure_hpa: float = PAPER_MIN_PRESSURE_HPA,  # [hPa]
    max_pressure_hpa: float = PAPER_MAX_PRESSURE_HPA,  # [hPa]
    times: Sequence[str] = PAPER_TIMES,
) -> List[Tuple[str, Dict[str, Any]]]:
  """CDS requests for ERA5 u, v around a target, one per calendar month.

  One request per month because CDS takes the Cartesian product of the
  year, month and day lists (a single request for Nov 2022 - Jan 2023 would
  also fetch Jan 2022 and Nov-Dec 2023) and to stay within CDS's size limits.
  The defaults are the paper's data.

  Args:
    center_lat: Target latitude. # [deg N]
    center_lon: Target longitude. # [deg E]
    start_date: First day (inclusive).
    end_date: Last day (inclusive).
    half_width_deg: The area is the target +- this. # [deg]
    grid_deg: Grid spacing CDS interpolates to. # [deg]
    min_pressure_hpa: Lowest pressure level. # [hPa]
    max_pressure_hpa: Highest pressure level. # [hPa]
    times: Hours of the day ('HH:MM').

  Returns:
    A list of (month 'YYYY-MM', request dict) for
    `cdsapi.Client().retrieve(DATASET, request, target)`.

  Raises:
    ValueError: on an empty date range or a bad area.
  """
  if end_date < start_date:
    raise ValueError(f'end_date {end_date} is before start_date {start_date}')
  for name, value in (('center_lat', center_lat), ('center_lon', center_lon),
                      ('half_width_deg', half_width_deg),
                      ('grid_deg', grid_deg)):
    if not math.isfinite(value):
      raise ValueError(f'{name} must be finite, got {value}')
  if not 0 < half_width_deg <= 90 or not grid_deg > 0:
    raise ValueError(f'half_width_deg must be in (0, 90] and grid_deg > 0, '
                     f'got {half_width_deg}, {grid_deg}')
  if not MIN_GRID_DEG <= grid_deg <= 2 * half_width_deg:
    raise ValueError(
        f'grid_deg must be in [{MIN_GRID_DEG:g}, 2 x half_width_deg = '
        f'{2 * half_width_deg:g}] deg (ERA5\'s native grid is 0.25 deg; at '
        f'least two points across the area), got {grid_deg:g}')
  north = min(center_lat + half_width_deg, 90.0)
  south = max(center_lat - half_width_deg, -90.0)
  if north <= south:
    raise ValueError(f'Empty area around lat {center_lat}')
  area = [north, center_lon - half_width_deg, south,
          center_lon + half_width_deg]
  levels = [str(p) for p in pressure_levels_hpa(min_pressure_hpa,
                                                max_pressure_hpa)]
  requests = []
  year, month = start_date.year, start_date.month
  while (year, month) <= (end_date.year, end_date.month):
    first = max(start_date, dt.date(year, month, 1))
    last = min(end_date,
               dt.date(year, month, calendar.monthrange(year, month)[1]))
    requests.append((f'{year:04d}-{month:02d}', {
        'product_type': ['reanalysis'],
        'variable': ['u_component_of_wind', 'v_component_of_wind'],
        'year': [f'{year:04d}'],
        'month': [f'{month:02d}'],
        'day': [f'{d:02d}' for d in range(first.day, last.day + 1)],
        'time': list(times),
        'pressure_level': levels,
        'area': area,
        'grid': [grid_deg, grid_deg],
        'data_format': 'netcdf',
        'download_format': 'unarchived',
    }))
    year, month = (year + 1, 1) if month == 12 else (year, month + 1)
  return requests
