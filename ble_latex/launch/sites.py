# coding=utf-8
"""Launch planning skips hopeless sites (issue 64 item 5).

A station whose column has zero outside the hull of the winds the balloon
can reach (`wind.feasibility`) cannot be held by steering in altitude over
that snapshot, whatever the launch: `feasible_stations` says which candidate
stations of a wind file are worth scoring, `ble-latex-launch
--min_hull_margin_mps` skips a station below the margin before any launch
is flown.
"""

from typing import Any, Dict, List, Sequence, Tuple

from ble_latex.wind import feasibility
from ble_latex.wind import gridded


def feasible_stations(path: Any, stations: Sequence[Tuple[float, float]],
                      min_margin_mps: float = 0.0) -> List[Dict[str, Any]]:
  """Each candidate station's margin and whether it is kept.

  Args:
    path: Wind file(s) (`gridded.load`).
    stations: (lat [deg N], lon [deg E]) candidates.
    min_margin_mps: The least margin of zero inside the hull kept (0: zero
      inside or on it). # [m/s]

  Returns:
    [{'lat', 'lon', 'margin_mps', 'keep'}] in the candidates' order.

  Raises:
    FileNotFoundError, errors.BadFileError: as `gridded.load`.
    errors.ConfigError: a margin that is no finite number.
  """
  keep, margin = feasibility.sites_feasible(gridded.load(path), stations,
                                            min_margin_mps)
  return [{'lat': float(lat), 'lon': float(lon),
           'margin_mps': round(float(m), 4), 'keep': bool(k)}
          for (lat, lon), m, k in zip(stations, margin, keep)]

