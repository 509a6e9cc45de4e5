# coding=utf-8
"""A wind file's gin bindings, the one home of their text.

A wind file (ERA5, a GFS grid or series, a sounding: `wind.gridded.load`)
flies through gin: `latex_episode.wind_field_factory = @GriddedWindField`
and `GriddedWindField.*` (`wind.gridded.Era5Settings`). The commands'
--wind_file, --era5_dates and --station_lat/--station_lon (`era5_bindings`,
`station_bindings`; a bad value is an `errors.UsageError`, exit 2) and the
real-winds scripts' cells (`wind.sources`, `benchmarks/real_winds.py`) build
their bindings here, so each binding is written once.

A real-winds cell (a record's settings) places its station by 'station_mode'
(`sources.STATION_MODES`): 'center' records 'station_lat_lon', 'per_seed'
records its 'station_bindings' (`PER_SEED` first).
"""

import os
from typing import Any, Dict, List, Mapping, Optional, Sequence

from ble_latex import errors
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


# -- The commands' --wind_file (alias --era5_path) / --era5_dates. ----------
def station_bindings(lat: Optional[float], lon: Optional[float]
                     ) -> List[str]:
  """The gin bindings of --station_lat / --station_lon (a fixed station).

  Raises:
    errors.UsageError: one without the other, or a value out of range.
  """
  if lat is None and lon is None:
    return []
  if lat is None or lon is None:
    raise errors.UsageError('--station_lat and --station_lon go together')
  if not (-90.0 <= lat <= 90.0 and -360.0 <= lon <= 360.0):
    raise errors.UsageError(
        f'--station_lat={lat:g} --station_lon={lon:g}: expected a latitude '
        'in [-90, 90] and a longitude in [-360, 360] [deg]')
  return fixed_station(lat, lon)


def era5_bindings(path: Optional[str], dates: Optional[str],
                  default_dates: str, station: Sequence[str] = ()
                  ) -> List[str]:
  """The gin bindings of --wind_file / --era5_dates (after `bind_gin`).

  Call after the user's gin is bound: ERA5 is on with `path`, or when gin
  binds `latex_episode.wind_field_factory = @GriddedWindField`. The start
  range is `dates`, else a `GriddedWindField.start_dates` the user bound,
  else `default_dates` (the command's split).

  Args:
    path: --wind_file (--era5_path), or None.
    dates: --era5_dates, or None.
    default_dates: The command's split (train: 'train'; eval: the suite's).
    station: `station_bindings` of --station_lat/--station_lon (they
      replace `file_defaults`).

  Returns:
    Bindings to add after the user's (empty without ERA5).

  Raises:
    errors.UsageError: --era5_dates or a station without ERA5, or a bad
      range.
  """
  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import env_params
  from ble_latex.envs import winds
  # pylint: enable=g-import-not-at-top
  bindings = []
  if path is not None:
    if not path.strip():
      raise errors.UsageError('--wind_file is empty')
    if dates is not None:  # A usage error before the file is read.
      era5_dates_value(dates)
    # Absolute (the Ray workers' working directory may differ).
    path = os.path.abspath(os.path.expandvars(os.path.expanduser(path)))
    bindings += file_bindings(path) + (list(station) or file_defaults(path))
  elif not winds.is_era5(env_params.episode()['wind_field_factory']):
    for flag, given in (('--era5_dates', dates is not None),
                        ('--station_lat/--station_lon', bool(station))):
      if given:
        raise errors.UsageError(
            f'{flag} needs ERA5 winds: --wind_file, or a gin file binding '
            'latex_episode.wind_field_factory = @GriddedWindField')
    return []
  else:
    bindings += list(station)
  if dates is None:
    if 'start_dates' in winds.bound_settings():
      return bindings  # The user's gin chose the range.
    if not _is_era5_file(path):
      return bindings  # Another source: flights start anywhere in it.
    dates = default_dates
  value = era5_dates_value(dates)
  return bindings + [start_dates(value)]


def _is_era5_file(path: Optional[str]) -> bool:
  """Whether the wind file (`path`, else gin's `GriddedWindField.path`) is
  ERA5, whose dates the commands' default splits (`gridded.DATE_SPLITS`) are;
  a GFS series, forecast or sounding is not split by them. Unreadable: True
  (the reader reports it when the env starts)."""
  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import winds
  from ble_latex.wind import gridded
  # pylint: enable=g-import-not-at-top
  try:
    path = path or winds.bound_settings()['path']
    return gridded.load(path).source == gridded.ERA5.label
  except (KeyError, OSError, ValueError):  # A BadFileError is a ValueError.
    return True


def file_defaults(path: str) -> List[str]:
  """The station bindings --wind_file implies, where the user bound none.

  `stations.file_defaults` (per-seed stations on a gridded snapshot other
  than ERA5: eval seed s flies station s; a sounding's named site), unless
  `GriddedWindField.stations`, `center_lat` or `center_lon` is bound.

  Raises:
    FileNotFoundError, errors.BadFileError: as `gridded.load`.
  """
  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import winds
  from ble_latex.wind import gridded
  from ble_latex.wind import stations
  # pylint: enable=g-import-not-at-top
  if {'stations', 'center_lat', 'center_lon'} & set(winds.bound_settings()):
    return []
  return settings(stations.file_defaults(gridded.load(path)))


def era5_dates_value(dates: str) -> Any:
  """`GriddedWindField.start_dates` of an --era5_dates value (checked).

  Raises:
    errors.UsageError: not a split, 'all' or FIRST,END.
  """
  from ble_latex.wind import gridded  # pylint: disable=g-import-not-at-top
  if dates == 'all':
    return None
  value = dates if dates in gridded.DATE_SPLITS else tuple(
      d.strip() for d in dates.split(','))
  try:
    gridded.start_dates_range(value, '--era5_dates')
  except errors.ConfigError as e:
    raise errors.UsageError(str(e)) from e
  return value
