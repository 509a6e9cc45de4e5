# coding=utf-8
"""Flight tracks as KML, GeoJSON and CSV (`ble-latex-plot --export`).

Each takes `tracks.Track`s (`tracks.track` of eval records) and returns the
file's text; the standard library writes them (xml.etree, json, csv), so
no GIS dependency is needed:

- KML 2.2 (Google Earth, QGIS): one folder per flight with its path
  (a LineString, altitude absolute, with a TimeSpan when the start is
  known), its launch and end points and its station.
- GeoJSON (RFC 7946): per flight a LineString feature ([lon, lat, altitude
  m] per point) whose properties hold the seed, station and each point's
  time, plus a Point feature for its station.
- CSV: one row per flight point (`CSV_COLUMNS`).
"""

import csv
import io
import json
from typing import Callable, Dict, List, Sequence, Tuple
from xml.etree import ElementTree

from ble_latex.run import tracks as tracks_lib

KML_NAMESPACE = 'http://www.opengis.net/kml/2.2'
# One row per flight point.
CSV_COLUMNS = ('seed', 't_s', 'utc', 'lat', 'lon', 'altitude_m', 'x_km',
               'y_km', 'distance_km', 'helium_mols', 'sand_kg',
               'station_lat', 'station_lon')


def _utc(track: tracks_lib.Track, i: int) -> str:
  when = track.utc(i)
  return '' if when is None else tracks_lib.utc_text(when)


def to_kml(flights: Sequence[tracks_lib.Track], name: str = 'flights') -> str:
  """KML 2.2 of the flights (the module's doc)."""
  ElementTree.register_namespace('', KML_NAMESPACE)
  q = lambda tag: f'{{{KML_NAMESPACE}}}{tag}'
  root = ElementTree.Element(q('kml'))
  document = ElementTree.SubElement(root, q('Document'))
  ElementTree.SubElement(document, q('name')).text = name
  style = ElementTree.SubElement(document, q('Style'), id='path')
  line = ElementTree.SubElement(style, q('LineStyle'))
  ElementTree.SubElement(line, q('color')).text = 'ff0000ff'  # aabbggrr
  ElementTree.SubElement(line, q('width')).text = '2'

  def placemark(parent, title, geometry, coordinates, description='',
                span=None, style=None):
    # KML 2.2's element order: name, description, TimeSpan, styleUrl,
    # then the geometry.
    mark = ElementTree.SubElement(parent, q('Placemark'))
    ElementTree.SubElement(mark, q('name')).text = title
    if description:
      ElementTree.SubElement(mark, q('description')).text = description
    if span is not None:
      when = ElementTree.SubElement(mark, q('TimeSpan'))
      ElementTree.SubElement(when, q('begin')).text = span[0]
      ElementTree.SubElement(when, q('end')).text = span[1]
    if style is not None:
      ElementTree.SubElement(mark, q('styleUrl')).text = style
    shape = ElementTree.SubElement(mark, q(geometry))
    if geometry == 'LineString':
      ElementTree.SubElement(shape, q('altitudeMode')).text = 'absolute'
    ElementTree.SubElement(shape, q('coordinates')).text = coordinates

  for t in flights:
    last = len(t.t_s) - 1
    folder = ElementTree.SubElement(document, q('Folder'))
    ElementTree.SubElement(folder, q('name')).text = f'seed {t.seed}'
    points = ' '.join(f'{lon:.6f},{lat:.6f},{alt:.1f}' for lon, lat, alt in
                      zip(t.lon, t.lat, t.altitude_m))
    placemark(folder, f'seed {t.seed} path', 'LineString', points,
              f'{last + 1} points, {t.t_s[-1] / 3600.0:.1f} h',
              span=(None if t.start_utc is None else
                    (_utc(t, 0), _utc(t, last))), style='#path')
    for label, i in (('launch', 0), ('end', last)):
      placemark(folder, f'seed {t.seed} {label}', 'Point',
                f'{t.lon[i]:.6f},{t.lat[i]:.6f},{t.altitude_m[i]:.1f}',
                _utc(t, i))
    placemark(folder, f'seed {t.seed} station', 'Point',
              f'{t.station_lon:.6f},{t.station_lat:.6f},0',
              f'station ({t.station_source})')
  ElementTree.indent(root)
  return ('<?xml version="1.0" encoding="UTF-8"?>\n' +
          ElementTree.tostring(root, encoding='unicode') + '\n')


def to_geojson(flights: Sequence[tracks_lib.Track]) -> str:
  """GeoJSON (RFC 7946) FeatureCollection of the flights."""
  features: List[Dict] = []
  for t in flights:
    n = len(t.t_s)
    features.append({
        'type': 'Feature',
        'geometry': {'type': 'LineString', 'coordinates': [
            [round(float(t.lon[i]), 6), round(float(t.lat[i]), 6),
             round(float(t.altitude_m[i]), 1)] for i in range(n)]},
        'properties': {
            'seed': t.seed, 'kind': 'path',
            'station_lat': t.station_lat, 'station_lon': t.station_lon,
            'station_source': t.station_source,
            'start_utc': None if t.start_utc is None else _utc(t, 0),
            't_s': [float(v) for v in t.t_s],
            'utc': None if t.start_utc is None else [_utc(t, i)
                                                     for i in range(n)]}})
    features.append({
        'type': 'Feature',
        'geometry': {'type': 'Point', 'coordinates': [t.station_lon,
                                                      t.station_lat]},
        'properties': {'seed': t.seed, 'kind': 'station',
                       'station_source': t.station_source}})
  return json.dumps({'type': 'FeatureCollection', 'features': features},
                    indent=1) + '\n'


def to_csv(flights: Sequence[tracks_lib.Track]) -> str:
  """CSV, one row per flight point (`CSV_COLUMNS`)."""
  out = io.StringIO()
  writer = csv.writer(out, lineterminator='\n')
  writer.writerow(CSV_COLUMNS)
  for t in flights:
    distance = t.distance_km
    for i in range(len(t.t_s)):
      writer.writerow([
          t.seed, f'{t.t_s[i]:g}', _utc(t, i), f'{t.lat[i]:.6f}',
          f'{t.lon[i]:.6f}', f'{t.altitude_m[i]:.1f}', f'{t.x_km[i]:.4f}',
          f'{t.y_km[i]:.4f}', f'{distance[i]:.4f}', f'{t.helium_mols[i]:.4f}',
          f'{t.sand_kg[i]:.4f}', f'{t.station_lat:.5f}',
          f'{t.station_lon:.5f}'])
  return out.getvalue()


# --export's formats: name -> (file name, writer).
Writer = Callable[[Sequence[tracks_lib.Track]], str]
FORMATS: Dict[str, Tuple[str, Writer]] = {
    'kml': ('tracks.kml', to_kml),
    'geojson': ('tracks.geojson', to_geojson),
    'csv': ('tracks.csv', to_csv),
}
