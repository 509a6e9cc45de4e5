# coding=utf-8
"""The launch map: expected TW50 over the launch box, the best launches'
flight paths, the station and its circle (matplotlib; returns the Figure)."""

from typing import Any, Dict, List, Optional

import matplotlib
from matplotlib import figure as figure_lib
import numpy as np

from ble_latex.launch import scoring


def launch_map(scores: scoring.Scores, shape: Any, radius_km: float,
               best: List[Dict[str, Any]],
               paths: Optional[np.ndarray] = None,
               title: str = '', *,
               delay_panel: bool = True) -> figure_lib.Figure:
  """The map and (winds that vary in time) expected TW50 against delay.

  Left: each site's expected TW50 at its best delay (and altitude), the
  station (star) and its radius (dashed), the best launches (each named in
  the legend with its rank, delay and score) and their flight paths (draw
  0). Right: the best site's and the station's
  expected TW50 per delay, with +- one standard error; drawn only with
  `delay_panel` (a time-invariant snapshot, e.g. a sounding, flies the same
  winds at every delay: only the sun's clock would differ).

  Args:
    scores: The dense grid's scores (`scoring.grid(space, *shape)` order).
    shape: (n_east, n_north, n_hours[, n_altitudes]).
    radius_km: The station-keeping radius. # [km]
    best: The best launches' records (`scoring.ranked`), best first.
    paths: [len(best), strides + 1, 2] their paths (east, north) [km].
      Records from the ground (`scoring.with_ascent`) also draw the way up
      (dotted, to the float point or the landing), the float phase from the
      float point, and the axes take them in.
    title: The figure's title.
    delay_panel: Draw the right panel (False: the map alone).
  """
  n_east, n_north, n_hours = (list(shape) + [1, 1])[:3]
  n_alt = len(scores.launches) // (n_east * n_north * n_hours)
  # Index ((a * n_hours + t) * n_north + j) * n_east + k.
  mean = scores.mean.reshape(n_alt, n_hours, n_north, n_east)
  stderr = scores.stderr.reshape(n_alt, n_hours, n_north, n_east)
  east = scores.launches.east_km[:n_east]
  north = scores.launches.north_km[::n_east][:n_north]
  hours = scores.launches.hours[::n_east * n_north][:n_hours]
  if delay_panel:
    fig = figure_lib.Figure(figsize=(12.5, 5.5))
    ax, side = fig.subplots(1, 2, gridspec_kw={'width_ratios': [1.25, 1]})
  else:
    fig = figure_lib.Figure(figsize=(7.0, 5.5))
    ax, side = fig.subplots(), None
  site = mean.max(axis=(0, 1))
  image = ax.pcolormesh(east, north, site, shading='nearest', cmap='viridis',
                        vmin=0.0, vmax=max(float(site.max()), 1e-6))
  fig.colorbar(image, ax=ax, label='expected TW50 at the best delay')
  theta = np.linspace(0.0, 2.0 * np.pi, 200)
  ax.plot(radius_km * np.cos(theta), radius_km * np.sin(theta), 'w--', lw=1.2,
          label=f'{radius_km:g} km')
  ax.plot([0.0], [0.0], marker='*', color='red', ms=14, ls='',
          label='station')
  colors = matplotlib.colormaps['autumn'](np.linspace(0.0, 0.8,
                                                      max(len(best), 1)))
  drawn = []  # From the ground: the paths the axes take in.
  for i, record in enumerate(best):
    if paths is not None:
      path, leg = paths[i], record.get('ascent')
      if leg and leg['floats'] and leg.get('float_east_km') is not None:
        # From the ground: the float phase from where the ascent ends.
        path = np.concatenate([[[leg['float_east_km'],
                                 leg['float_north_km']]], path[1:]])
      elif leg:
        path = path[:1]  # It never floats.
      ax.plot(path[:, 0], path[:, 1], color=colors[i], lw=1.0)
      if leg:
        drawn.append(path)
    # Named in the legend, not beside the marker: on a fine grid the best
    # launches are neighbours and their labels overlapped.
    ax.plot(record['east_km'], record['north_km'], 'o', mfc=colors[i],
            mec='k', ms=7, ls='',
            label=(f"{record['rank']}: +{record['hours']:g} h, TW50 "
                   f"{record['tw50_mean']:.2f}"))
  low, high = [east.min(), north.min()], [east.max(), north.max()]
  for i, record in enumerate(best):  # From the ground: the way up.
    leg = record.get('ascent')
    if not leg:
      continue
    end = 'float' if leg['floats'] else 'landing'
    if leg.get(f'{end}_east_km') is None:
      continue
    x, y = leg[f'{end}_east_km'], leg[f'{end}_north_km']
    ax.plot([record['east_km'], x], [record['north_km'], y], ':',
            color=colors[i], lw=1.5)
    ax.plot(x, y, '^' if leg['floats'] else 'v', mfc=colors[i], mec='k',
            ms=7, ls='', label=(f"{record['rank']}: reaches float "
                                f"({leg['ascent_min']:.0f} min)"
                                if leg['floats'] else
                                f"{record['rank']}: bursts, lands"))
    low = [min(low[0], x), min(low[1], y)]
    high = [max(high[0], x), max(high[1], y)]
  for path in drawn:
    low = [min(low[0], path[:, 0].min()), min(low[1], path[:, 1].min())]
    high = [max(high[0], path[:, 0].max()), max(high[1], path[:, 1].max())]
  if any(record.get('ascent') for record in best):  # Show the drift.
    pad = 0.05 * max(high[0] - low[0], high[1] - low[1], 1.0)
    ax.set_xlim(low[0] - pad, high[0] + pad)
    ax.set_ylim(low[1] - pad, high[1] + pad)
  else:
    ax.set_xlim(east.min(), east.max())
    ax.set_ylim(north.min(), north.max())
  ax.set_aspect('equal')
  ax.set_xlabel('launch east of the station [km]')
  ax.set_ylabel('launch north of the station [km]')
  ax.legend(loc='lower left', fontsize=8)
  if side is not None:
    _delay_panel(side, mean, stderr, east, north, hours, best)
  fig.suptitle(title)
  fig.tight_layout()
  return fig


def _delay_panel(side: Any, mean: np.ndarray, stderr: np.ndarray,
                 east: np.ndarray, north: np.ndarray, hours: np.ndarray,
                 best: List[Dict[str, Any]]) -> None:
  """Expected TW50 per delay at the best site and at the station."""
  k, j = (np.argmin(np.abs(east - best[0]['east_km'])),
          np.argmin(np.abs(north - best[0]['north_km']))) if best else (0, 0)
  a = int(np.argmax(mean[:, :, j, k].max(axis=1)))
  for label, (jj, kk) in (('best site', (j, k)),
                          ('station', (np.argmin(np.abs(north)),
                                       np.argmin(np.abs(east))))):
    side.errorbar(hours, mean[a, :, jj, kk], yerr=stderr[a, :, jj, kk],
                  marker='o', capsize=3,
                  label=f'{label} ({east[kk]:g}, {north[jj]:g}) km')
  side.set_xlabel('launch delay [h]')
  side.set_ylabel('expected TW50 (+- standard error)')
  side.set_ylim(-0.02, 1.02)
  side.grid(alpha=0.3)
  side.legend(fontsize=8)
