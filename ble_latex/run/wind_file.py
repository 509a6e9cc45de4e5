# coding=utf-8
"""A wind file's gin bindings, the one home of their text.

A wind file (ERA5, a GFS grid or series, a sounding: `wind.gridded.load`)
flies through gin: `latex_episode.wind_field_factory = @GriddedWindField`
and `GriddedWindField.*` (`wind.gridded.Era5Settings`). The commands'
--wind_file, --era5_dates and --station_lat/--station_lon (`cli/common.py`) and the
real-winds scripts' cells (`wind.sources`, `benchmarks/real_winds.py`) build
their bindings here, so each binding is written once.

A real-winds cell (a record's settings) places its station by 'station_mode'
(`sources.STATION_MODES`): 'center' records 'station_lat_lon', 'per_seed'
records its 'station_bindings' (`PER_SEED` first).
"""

import os
from typing import Any, Dict, List, Mapping, Sequence

from ble_latex import gin_aliases

# Per-seed stations: seed s flies station s of the domain (`wind.stations`).
PER_SEED = "GriddedWindField.stations = 'per_seed'"


def file_bindings(path: str) -> List[str]:
  """Flies the wind file `path` (as given: make it absolute first)."""
  return ['latex_episode.wind_field_factory = @GriddedWindField',
          f'GriddedWindField.path = {path!r}']


def start_dates(value: Any) -> str:
  """Flights start in `value` (`GriddedWindField.start_dates`: a split name,
  a (first, last) range, or None for the whole file)."""
  return f'GriddedWindField.start_dates = {value!r}'


def settings(values: Mapping[str, Any]) -> List[str]:
  """`GriddedWindField.NAME = value` of each of `values` (e.g.
  `stations.file_defaults`)."""
  return [f'GriddedWindField.{name} = {value!r}'
          for name, value in values.items()]


def center(lat: float, lon: float) -> List[str]:
  """The station's place (lat [deg N], lon [deg E]) in 'fixed' mode."""
  return settings({'center_lat': float(lat), 'center_lon': float(lon)})


def fixed_station(lat: float, lon: float) -> List[str]:
  """Every flight keeps station at (lat, lon) [deg]."""
  return ["GriddedWindField.stations = 'fixed'", *center(lat, lon)]


def station_settings(name: str, file: str, mode: str,
                     extra_bindings: Sequence[str] = ()) -> Dict[str, Any]:
  """A real-winds cell's station part: its mode and (lat, lon) or bindings.

  Args:
    name: A source of `wind.sources.SOURCES`.
    file: Its file (a grid's is read in 'center' mode).
    mode: 'center' or 'per_seed'.
    extra_bindings: More bindings of 'per_seed' (e.g.
      `GriddedWindField.station_margin_km = 400`).
  """
  if mode == 'center':
    from ble_latex.wind import sources  # pylint: disable=g-import-not-at-top
    lat, lon = sources.center(name, file)
    return {'station_mode': mode,
            'station_lat_lon': [round(lat, 4), round(lon, 4)]}
  return {'station_mode': mode,
          'station_bindings': [PER_SEED, *extra_bindings]}


def canonical(cell: Mapping[str, Any]) -> Dict[str, Any]:
  """A cell's settings with its station bindings under today's gin names
  (`gin_aliases.current`), so a cell recorded before a rename (e.g.
  `Era5WindField.stations`) compares equal to the same cell written now."""
  from ble_latex.wind import gridded  # pylint: disable=g-import-not-at-top,unused-import  # Its aliases.
  out = dict(cell)
  if 'station_bindings' in out:
    out['station_bindings'] = [gin_aliases.current(b)
                               for b in out['station_bindings']]
  return out


def differing(recorded: Mapping[str, Any],
              cell: Mapping[str, Any]) -> List[str]:
  """The settings in which a recorded cell differs from `cell`, compared
  under today's gin names (`canonical`); empty: the same cell."""
  a, b = canonical(recorded), canonical(cell)
  return sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))


def cell_station_bindings(cell: Mapping[str, Any]) -> List[str]:
  """The station bindings of a cell's `station_settings`."""
  if cell['station_mode'] == 'center':
    return center(*cell['station_lat_lon'])
  return list(cell['station_bindings'])


def cell_bindings(cell: Mapping[str, Any], file: str) -> List[str]:
  """The gin bindings that fly a cell's suite ('suite', its ERA5 split's
  start dates) and station on the wind file `file`."""
  from ble_latex.run import suites  # pylint: disable=g-import-not-at-top
  return [*file_bindings(os.path.abspath(file)),
          start_dates(suites.era5_dates(cell['suite'])),
          *cell_station_bindings(cell)]
