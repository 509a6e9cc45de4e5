# coding=utf-8
"""What the Gymnasium envs draw: the flight so far as an RGB image.

`flight_values` / `flight_point` read a `FlightState`'s host copy,
`draw_flight` draws a path and the station circle (with an inset around
the station once the path is far away), `figure_rgb` rasterizes it; the
continuous and the discrete env render with them (`render_mode='rgb_array'`).
matplotlib is imported only when a frame is drawn.
"""

from typing import Any, Dict, Mapping, Optional, Sequence, Tuple

import numpy as np


def check_render_mode(env: Any, render_mode: Optional[str]) -> None:
  """Raises ValueError unless `render_mode` is None or in the env's metadata."""
  if render_mode is not None and render_mode not in env.metadata[
      'render_modes']:
    raise ValueError(f'render_mode must be None or one of '
                     f'{env.metadata["render_modes"]}, got {render_mode!r}')


def flight_values(flight: Any) -> Dict[str, np.ndarray]:
  """A `FlightState` (host or device values) as NumPy values by field name."""
  return {name: np.asarray(getattr(flight, name))
          for name in flight.__dataclass_fields__}


def flight_point(flight: Mapping[str, Any]) -> Tuple[float, float, float,
                                                     float]:
  """t [h], x [km], y [km], altitude [km] of a `FlightState`'s values."""
  return (float(flight['time_s']) / 3600.0, float(flight['x_m']) / 1000.0,
          float(flight['y_m']) / 1000.0, float(flight['altitude_m']) / 1000.0)


# `draw_flight` adds an inset around the station when the x/y view is wider
# than this many station radii, spanning +-_INSET_HALF radii.
_INSET_ABOVE = 6.0
_INSET_HALF = 3.0


def draw_flight(figure: Any, path: Sequence[Tuple[float, float, float, float]],
                radius_km: float) -> Any:
  """Draws a flight path (`flight_point`s) and the station circle.

  When the path spans more than `_INSET_ABOVE` station radii, an inset
  zoomed on the station (+-`_INSET_HALF` radii) keeps the circle visible.

  Args:
    figure: A matplotlib Figure to draw on, or None for a new one.
    path: (t [h], x [km], y [km], altitude [km]) points.
    radius_km: The station-keeping circle's radius. # [km]

  Returns:
    The figure (x/y path with the circle, altitude vs time).
  """
  # pylint: disable=g-import-not-at-top
  from matplotlib import figure as mpl_figure
  from matplotlib import patches as mpl_patches
  from matplotlib.backends import backend_agg
  # pylint: enable=g-import-not-at-top
  if figure is None:
    figure = mpl_figure.Figure(figsize=(8.0, 4.0), dpi=80,
                               layout='constrained')
    backend_agg.FigureCanvasAgg(figure)
  figure.clear()
  ax_xy, ax_alt = figure.subplots(1, 2, width_ratios=(1.0, 1.4))
  t, x, y, alt = (np.array(c, dtype=float).reshape(-1)
                  for c in zip(*path)) if path else (np.zeros(0),) * 4

  def draw_path(ax, half, lw, ms):  # Station circle and path, +-half km.
    ax.add_patch(mpl_patches.Circle((0.0, 0.0), radius_km, fill=False,
                                    color='k', ls='--', lw=1.0))
    ax.plot(0.0, 0.0, marker='+', color='k')
    if len(x):
      ax.plot(x, y, color='tab:blue', lw=lw)
      ax.plot(x[-1], y[-1], marker='o', color='tab:red', ms=ms)
    ax.set_xlim(-half, half)
    ax.set_ylim(-half, half)
    ax.set_aspect('equal')

  half = max(np.abs(np.concatenate([x, y])).max() if len(x) else 0.0,
             radius_km) * 1.1
  draw_path(ax_xy, half, lw=1.5, ms=5)
  ax_xy.set_xlabel('x [km]')
  ax_xy.set_ylabel('y [km]')
  ax_xy.set_title(f'{radius_km:g} km station', fontsize=9)
  if half > _INSET_ABOVE * radius_km:
    # The circle would be a few pixels: an inset zoomed on the station.
    zoom = _INSET_HALF * radius_km
    inset = ax_xy.inset_axes((0.62, 0.62, 0.36, 0.36))
    draw_path(inset, zoom, lw=1.0, ms=3)
    inset.set_xticks([])
    inset.set_yticks([])
    inset.set_title(f'+-{zoom:g} km', fontsize=7, pad=2)
    ax_xy.indicate_inset_zoom(inset, edgecolor='0.5')
  if len(t):
    ax_alt.plot(t, alt, color='tab:blue', lw=1.5)
  ax_alt.set_xlabel('time [h]')
  ax_alt.set_ylabel('altitude [km]')
  ax_alt.grid(alpha=0.3)
  return figure


def figure_rgb(figure: Any) -> np.ndarray:
  """A drawn figure as an (H, W, 3) uint8 image."""
  figure.canvas.draw()
  return np.asarray(figure.canvas.buffer_rgba())[:, :, :3].copy()
