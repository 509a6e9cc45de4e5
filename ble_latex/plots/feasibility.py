# coding=utf-8
"""Figures of the station-keeping feasibility map (`wind.feasibility`).

- `plot_map`: every column's margin (signed distance of zero to the hull
  of the reachable winds, m/s) on a latitude/longitude map, zero's contour
  (where holding station becomes possible) in black, coastlines where
  landmetrics is installed (`maps.coast_distance_km`);
- `plot_hodograph`: one column's reachable winds in the (u, v) plane,
  coloured by altitude or pressure, their hull and zero.
"""

import json
import os
from typing import Optional, Sequence

from matplotlib import axes as mpl_axes
from matplotlib import figure as mpl_figure
import numpy as np
import scipy.spatial

from ble_latex import errors
from ble_latex.plots import figures
from ble_latex.plots import maps
from ble_latex.wind import feasibility
from ble_latex.wind import gridded
from ble_latex.wind import reach

# Resolution of the figures' PNGs. # [dots per inch]
_DPI = 110
# Colour range of the margin. # [m/s]
MARGIN_RANGE_MPS = 10.0


def plot_map(fmap: feasibility.FeasibilityMap, path: str, title: str,
             sites: Sequence[Sequence[float]] = ()) -> str:
  """The margin of every column of `fmap` as a PNG at `path`.

  Args:
    fmap: The map.
    path: The PNG.
    title: Its first title line (e.g. the file).
    sites: (lat, lon) markers (e.g. the hodographs' sites). # [deg]

  Returns:
    A note on the coastlines ('' when drawn).
  """
  lon = (fmap.longitude + 180.0) % 360.0 - 180.0
  order = np.argsort(lon, kind='stable')
  lon, margin = lon[order], fmap.margin_mps[:, order]
  width = 11.0 if lon[-1] - lon[0] > 180.0 else 8.0
  fig = mpl_figure.Figure(figsize=(width, width * 0.55))
  ax = fig.subplots()
  mesh = ax.pcolormesh(lon, fmap.latitude, margin, shading='nearest',
                       cmap='RdBu', vmin=-MARGIN_RANGE_MPS,
                       vmax=MARGIN_RANGE_MPS)
  ax.contour(lon, fmap.latitude, margin, levels=[0.0], colors='k',
             linewidths=0.8)
  note = ''
  mesh_lat, mesh_lon = np.meshgrid(
      np.linspace(fmap.latitude[0], fmap.latitude[-1], 361),
      np.linspace(lon[0], lon[-1], 721), indexing='ij')
  coast = maps.coast_distance_km(mesh_lat, mesh_lon)
  if coast is None:
    note = 'no coastlines (landmetrics not installed)'
  else:
    ax.contour(mesh_lon, mesh_lat, coast, levels=[0.0], colors='0.35',
               linewidths=0.5)
  for lat_site, lon_site in sites:
    ax.plot((lon_site + 180.0) % 360.0 - 180.0, lat_site, marker='*',
            color='gold', markeredgecolor='k', markersize=12)
  fig.colorbar(mesh, ax=ax, label='zero inside the hull by [m/s] '
               '(< 0: outside)', shrink=0.85)
  summary = fmap.summary()
  ax.set_title(f'{title}\nflight band {fmap.band_m[0] / 1000:g}-'
               f'{fmap.band_m[1] / 1000:g} km ({fmap.band_pa[0] / 100:.0f}-'
               f'{fmap.band_pa[1] / 100:.0f} hPa), {fmap.time}: zero inside '
               f'the hull in {100 * summary["inside_fraction_area"]:.1f} % '
               'of the area', fontsize=9)
  ax.set_xlabel('longitude [deg E]')
  ax.set_ylabel('latitude [deg N]')
  ax.set_aspect('equal')
  fig.tight_layout()
  figures.save_png(fig, path, dpi=_DPI)
  return note


def plot_hodograph(winds: np.ndarray, levels: np.ndarray, label: str,
                   col: feasibility.Column, path: str, title: str,
                   ax: Optional[mpl_axes.Axes] = None) -> None:
  """One column's reachable winds, their hull and zero, as a PNG.

  Args:
    winds: [M, 2] the band's winds (`feasibility.band_winds`). # [m/s]
    levels: [M] their altitude [km] or pressure [hPa] (the colour).
    label: The colour bar's label.
    col: Their `feasibility.Column`.
    path: The PNG.
    title: The site's title line.
    ax: Draw there instead (no file written).
  """
  own = ax is None
  if own:
    fig = mpl_figure.Figure(figsize=(5.6, 5.0))
    ax = fig.subplots()
  else:
    fig = ax.figure
  ax.plot(winds[:, 0], winds[:, 1], color='0.6', linewidth=0.8, zorder=1)
  points = ax.scatter(winds[:, 0], winds[:, 1], c=levels, cmap='viridis',
                      s=18, zorder=2)
  try:
    hull = scipy.spatial.ConvexHull(winds)
    ring = np.append(hull.vertices, hull.vertices[0])
    ax.fill(winds[ring, 0], winds[ring, 1], color='tab:blue', alpha=0.12,
            zorder=0)
  except scipy.spatial.QhullError:
    pass
  ax.plot(0.0, 0.0, marker='+', color='red' if not col.inside else 'k',
          markersize=14, mew=2, zorder=3)
  ax.axhline(0.0, color='0.85', linewidth=0.5, zorder=0)
  ax.axvline(0.0, color='0.85', linewidth=0.5, zorder=0)
  fig.colorbar(points, ax=ax, label=label, shrink=0.85)
  ax.set_aspect('equal', adjustable='datalim')
  ax.set_xlabel('u (east) [m/s]')
  ax.set_ylabel('v (north) [m/s]')
  verdict = 'inside' if col.inside else 'outside'
  ax.set_title(f'{title}\nzero {verdict} the hull by '
               f'{abs(col.margin_mps):.2f} m/s; largest direction gap '
               f'{col.gap_deg:.0f} deg; weakest {col.weakest_mps:.1f} m/s',
               fontsize=8)
  if own:
    fig.tight_layout()
    figures.save_png(fig, path, dpi=_DPI)


MAP_PNG = 'feasibility_map.png'
MAP_JSON = 'feasibility.json'


def _site_name(lat: float, lon: float) -> str:
  return f'hodograph_{lat:+.2f}_{(lon + 180.0) % 360.0 - 180.0:+.2f}.png'


def write(path: str, output_dir: str,
          sites: Sequence[Sequence[float]] = (), time_index: int = 0
          ) -> dict:
  """The feasibility map of a wind file: PNGs and a JSON in `output_dir`.

  A grid: `feasibility_map.png` (every column), `feasibility.json` (the
  summary, the margin, gap and weakest wind of every column, rounded) and a
  hodograph per site (`hodograph_<lat>_<lon>.png`). A sounding: its one
  column (`hodograph.png`, the JSON); sites do not apply (one column).

  Args:
    path: The wind file (any `gridded.load` reads).
    output_dir: An existing folder.
    sites: (lat [deg N], lon [deg E]) of the grid's hodographs.
    time_index: Which of the file's times a grid maps.

  Returns:
    The JSON's content (also written).

  Raises:
    FileNotFoundError, errors.BadFileError: a bad file (`gridded.load`).
    errors.ConfigError: a time the file does not hold; sites on a sounding.
  """
  data = gridded.load(path)
  record = {'file': str(path), 'source': data.description,
            'about': 'station-keeping feasibility: zero inside the convex '
                     'hull of the winds reachable in the flight band '
                     '(ble_latex.wind.feasibility); margin_mps > 0 inside',
            'outputs': []}
  if data.source == 'sounding':
    if sites:
      raise errors.ConfigError('--feasibility_sites: a sounding is one '
                               'column (its site); give no sites')
    s = feasibility.sounding_column(path)
    out = os.path.join(output_dir, 'hodograph.png')
    plot_hodograph(s.winds, s.height_m / 1000.0, 'altitude [km]', s.column,
                   out, f'sounding {os.path.basename(str(path))}')
    record.update(column=s.column.as_dict(),
                  band_m=list(reach.flight_band_m()))
    record['outputs'].append(out)
  else:
    outside = [site for site in sites if not data.covers(*site)]
    if outside:  # Before anything is written.
      raise errors.ConfigError(f'--feasibility_sites: {outside[0][0]:g}, '
                               f'{outside[0][1]:g} is outside {path}')
    fmap = feasibility.grid_map(data, time_index)
    out = os.path.join(output_dir, MAP_PNG)
    note = plot_map(fmap, out, f'{os.path.basename(str(path))} '
                    f'({data.source})', sites)
    record.update(summary=fmap.summary(), coast_note=note,
                  latitude=fmap.latitude.round(4).tolist(),
                  longitude=fmap.longitude.round(4).tolist(),
                  margin_mps=fmap.margin_mps.round(3).tolist(),
                  gap_deg=fmap.gap_deg.round(1).tolist(),
                  weakest_mps=fmap.weakest_mps.round(3).tolist(), sites=[])
    record['outputs'].append(out)
    for lat, lon in sites:
      col, winds = feasibility.at(data, lat, lon,
                                  time_s=float(data.time_s[time_index]))
      levels = np.concatenate([[fmap.band_pa[0]], data.pressure[
          (data.pressure > fmap.band_pa[0]) &
          (data.pressure < fmap.band_pa[1])], [fmap.band_pa[1]]]) / 100.0
      site_png = os.path.join(output_dir, _site_name(lat, lon))
      plot_hodograph(winds, levels, 'pressure [hPa]', col, site_png,
                     f'{lat:.2f} N {lon:.2f} E, {fmap.time}')
      record['sites'].append({'lat': lat, 'lon': lon, **col.as_dict()})
      record['outputs'].append(site_png)
  json_path = os.path.join(output_dir, MAP_JSON)
  with open(json_path, 'w', encoding='utf-8') as f:
    json.dump(record, f)
  record['outputs'].append(json_path)
  return record
