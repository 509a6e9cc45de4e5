# coding=utf-8
"""The operator's figures: flight tracks on a map and a flight over time.

  * `plot_track_map`    tracks in latitude/longitude with coastlines, each
                        flight's launch, end, station and station-keeping
                        circle.
  * `plot_flight_time`  altitude, sand, helium and distance from the station
                        against time since launch.

Both take `tracks.Track`s (`tracks.track` of eval records) and write a PNG
with matplotlib's Agg canvas (`figures.save_png`). Coastlines come from the
`landmetrics` package, which ships GSHHG's distance to the coast on a 0.1 deg
grid (nothing is downloaded: the bundled grid only); the coast is that
distance's zero contour, good to about 10 km. Without the package the map
is drawn without coastlines, and says so.
"""

import math
from typing import Optional, Sequence, Tuple

import matplotlib
from matplotlib import figure as mpl_figure
import numpy as np

from ble_latex.plots import figures
from ble_latex.run import tracks as tracks_lib

# [deg] Spacing of the coastline's grid (landmetrics' bundled grid: 0.1).
COAST_STEP_DEG = 0.05
COAST_POINTS = 600  # The most coastline grid points per side.
# [deg] The least half-width of the map around the tracks.
MIN_HALF_WIDTH_DEG = 1.0


def _colors(n: int) -> np.ndarray:
  """n distinct colours (tab10, repeating)."""
  return matplotlib.colormaps['tab10'](np.arange(n) % 10)


def coast_distance_km(lat: np.ndarray, lon: np.ndarray
                      ) -> Optional[np.ndarray]:
  """Signed distance to the coast at each point (negative on land), or None.

  landmetrics' bundled GSHHG grid (`open_distance_to_land(download=False)`);
  None if the package (or its grid) is not there. # [km]
  """
  try:
    import landmetrics  # pylint: disable=g-import-not-at-top
  except ImportError:
    return None
  try:
    grid = landmetrics.open_distance_to_land(download=False)
  except (OSError, ValueError):  # GridNotFoundError is a FileNotFoundError.
    return None
  try:
    return np.asarray(grid.query(np.ravel(lat), np.ravel(lon)),
                      dtype=float).reshape(np.shape(lat))
  finally:
    grid.close()


def _extent(flights: Sequence[tracks_lib.Track], lon_ref: float,
            radius_km: float) -> Tuple[float, float, float, float]:
  """(lon0, lon1, lat0, lat1) around every track and station circle."""
  lats = np.concatenate([np.r_[t.lat, t.station_lat] for t in flights])
  lons = np.concatenate([np.r_[t.lon, t.station_lon] for t in flights])
  lons = lon_ref + tracks_lib.wrap_longitude(lons - lon_ref)
  pad_lat = radius_km / 111.0 + 0.3
  mid = 0.5 * (lats.min() + lats.max())
  pad_lon = pad_lat / max(math.cos(math.radians(mid)), 0.1)
  lat0, lat1 = lats.min() - pad_lat, lats.max() + pad_lat
  lon0, lon1 = lons.min() - pad_lon, lons.max() + pad_lon
  widen = lambda lo, hi, half: (lo - max(half - 0.5 * (hi - lo), 0.0),
                                hi + max(half - 0.5 * (hi - lo), 0.0))
  lat0, lat1 = widen(lat0, lat1, MIN_HALF_WIDTH_DEG)
  lon0, lon1 = widen(lon0, lon1, MIN_HALF_WIDTH_DEG)
  # No long thin strip: the drawn width within 2/3..3/2 of the height.
  stretch = 1.0 / max(math.cos(math.radians(0.5 * (lat0 + lat1))), 0.1)
  height = (lat1 - lat0) * stretch
  lon0, lon1 = widen(lon0, lon1, height / 3.0)
  lat0, lat1 = widen(lat0, lat1, (lon1 - lon0) / 3.0 / stretch)
  return lon0, lon1, max(lat0, -90.0), min(lat1, 90.0)


def _circle(t: tracks_lib.Track, radius_km: float,
            lon_ref: float) -> Tuple[np.ndarray, np.ndarray]:
  """The station-keeping circle of a track's station, (lon, lat)."""
  theta = np.linspace(0.0, 2.0 * np.pi, 73)
  pairs = [tracks_lib.point_lat_lon(t.station_lat, t.station_lon,
                                    radius_km * math.cos(a),
                                    radius_km * math.sin(a)) for a in theta]
  lat = np.asarray([p[0] for p in pairs])
  lon = np.asarray([p[1] for p in pairs])
  return lon_ref + tracks_lib.wrap_longitude(lon - lon_ref), lat


def plot_track_map(flights: Sequence[tracks_lib.Track], path: str, *,
                   radius_km: float = figures.STATION_RADIUS_KM,
                   title: str = '') -> mpl_figure.Figure:
  """Tracks on a latitude/longitude map with coastlines.

  Each flight in its own colour: its path, launch (circle), end (cross),
  station (star) and station-keeping circle (dashed); land shaded and the
  coast drawn where landmetrics is installed. Longitudes near the first
  station's, unwrapped across the antimeridian.

  Args:
    flights: The tracks.
    path: Output PNG.
    radius_km: Station-keeping radius. # [km]
    title: The figure's title (the map's own notes follow it).

  Returns:
    The figure, written to `path`.
  """
  if not flights:
    raise ValueError('no flights to draw on the map')
  lon_ref = flights[0].station_lon
  lon0, lon1, lat0, lat1 = _extent(flights, lon_ref, radius_km)
  fig = mpl_figure.Figure(figsize=(8.0, 7.0), layout='constrained')
  ax = fig.subplots()
  # At most COAST_POINTS per side (a flight that crossed an ocean).
  step = max(COAST_STEP_DEG, (lat1 - lat0) / COAST_POINTS,
             (lon1 - lon0) / COAST_POINTS)
  grid_lat = np.arange(lat0, lat1 + step, step)
  grid_lon = np.arange(lon0, lon1 + step, step)
  mesh_lat, mesh_lon = np.meshgrid(grid_lat, grid_lon, indexing='ij')
  distance = coast_distance_km(mesh_lat,
                               tracks_lib.wrap_longitude(mesh_lon))
  notes = []
  if distance is None:
    notes.append('no coastlines (landmetrics not installed)')
  elif distance.min() < 0.0 < distance.max():
    ax.contourf(mesh_lon, mesh_lat, distance, levels=[-1e9, 0.0],
                colors=['#ece3cf'])
    ax.contour(mesh_lon, mesh_lat, distance, levels=[0.0], colors='0.35',
               linewidths=0.9)
  elif distance.max() <= 0.0:
    ax.set_facecolor('#ece3cf')
    notes.append('all land')
  else:
    notes.append('no coast in view')
  colors = _colors(len(flights))
  stations = set()
  for color, t in zip(colors, flights):
    lon = lon_ref + tracks_lib.wrap_longitude(t.lon - lon_ref)
    when = ('' if t.start_utc is None else
            f', {t.start_utc:%Y-%m-%d %H:%M}Z')
    ax.plot(lon, t.lat, color=color, lw=1.6,
            label=f'seed {t.seed}{when}, {t.t_s[-1] / 3600.0:.0f} h')
    # Above the stations' stars (a launch at the station stays visible).
    ax.plot(lon[0], t.lat[0], 'o', color=color, mec='k', ms=6, zorder=5)
    ax.plot(lon[-1], t.lat[-1], 'X', color=color, mec='k', ms=8, zorder=5)
    key = (round(t.station_lat, 4), round(t.station_lon, 4))
    if key not in stations:
      stations.add(key)
      circle_lon, circle_lat = _circle(t, radius_km, lon_ref)
      ax.plot(circle_lon, circle_lat, '--', color='k', lw=0.9)
      ax.plot(lon_ref + tracks_lib.wrap_longitude(t.station_lon - lon_ref),
              t.station_lat, '*', color='red', mec='k', ms=13)
  ax.plot([], [], 'o', color='0.6', mec='k', label='launch')
  ax.plot([], [], 'X', color='0.6', mec='k', label='end')
  ax.plot([], [], '*', color='red', mec='k', ms=11,
          label=f'station ({flights[0].station_source}), {radius_km:g} km')
  ax.set_xlim(lon0, lon1)
  ax.set_ylim(lat0, lat1)
  ax.set_aspect(1.0 / max(math.cos(math.radians(0.5 * (lat0 + lat1))), 0.1))
  ax.set_xlabel('longitude [deg E]')
  ax.set_ylabel('latitude [deg N]')
  ax.grid(alpha=0.3)
  ax.legend(fontsize=8, loc='best', framealpha=0.85)
  ax.set_title('\n'.join(s for s in (title, '; '.join(notes)) if s),
               fontsize=10)
  return figures.save_png(fig, path)


def plot_flight_time(flights: Sequence[tracks_lib.Track], path: str, *,
                     radius_km: float = figures.STATION_RADIUS_KM,
                     title: str = '') -> mpl_figure.Figure:
  """Altitude, sand, helium and distance from the station against time.

  Four panels sharing the time axis (hours since launch; each flight's UTC
  start in its legend label), one line per flight; the station-keeping
  radius dashed on the distance panel.

  Args:
    flights: The tracks.
    path: Output PNG.
    radius_km: Station-keeping radius. # [km]
    title: The figure's title.

  Returns:
    The figure, written to `path`.
  """
  if not flights:
    raise ValueError('no flights to draw over time')
  fig = mpl_figure.Figure(figsize=(9.0, 9.0), layout='constrained')
  axes = fig.subplots(4, 1, sharex=True)
  colors = _colors(len(flights))
  panels = (('altitude [km]', lambda t: t.altitude_m / 1000.0),
            ('sand [kg]', lambda t: t.sand_kg),
            ('helium [mol]', lambda t: t.helium_mols),
            ('distance from the station [km]', lambda t: t.distance_km))
  for color, t in zip(colors, flights):
    hours = t.t_s / 3600.0
    when = ('' if t.start_utc is None else
            f' (launch {t.start_utc:%Y-%m-%d %H:%M}Z)')
    for ax, (_, value) in zip(axes, panels):
      ax.plot(hours, value(t), color=color, lw=1.4,
              label=f'seed {t.seed}{when}')
  for ax, (label, _) in zip(axes, panels):
    ax.set_ylabel(label)
    ax.grid(alpha=0.3)
  axes[-1].axhline(radius_km, color='k', ls='--', lw=1.0,
                   label=f'{radius_km:g} km')
  axes[-1].set_ylim(bottom=0.0)
  axes[-1].set_xlabel('time since launch [h]')
  axes[-1].legend(handles=axes[-1].get_lines()[-1:], fontsize=8,
                  loc='upper left')
  fig.legend(handles=axes[0].get_lines(), loc='outside lower center',
             ncols=min(len(flights), 3), fontsize=8)
  if title:
    fig.suptitle(title, fontsize=10)
  return figures.save_png(fig, path)
