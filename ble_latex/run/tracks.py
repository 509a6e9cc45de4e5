# coding=utf-8
"""Where and when a flight was: lat/lon and UTC time of each flight point.

An eval record's `flight_path` holds the balloon's offset (x east, y north
[km]) from its flight's station. `locate` adds what an operator needs to put
the track on a map, on every wind source:

- `station_lat`, `station_lon` [deg]: on a wind file, the flight's station
  (`jax_env.flight_stations`: per seed on a gridded snapshot, else the fixed
  target); on BLE's generative winds, which have no place, the flight
  system's nominal position (`FlightParams.latitude_deg/longitude_deg`, gin
  `latex_flight.latitude_deg/longitude_deg`, 1 N 113 W by default: where the
  sun is computed, the paper's ERA5 region); and
  `station_source`: 'wind file' or 'nominal'.
- `start_utc`: the flight's start (ISO 8601, UTC): the env's draw
  (`EnvState.start_time_offset_s` after `env_types.START_EPOCH`): on a wind
  file a time in the file (none where the file names no time, e.g. a
  sounding without one); on BLE's winds the date BLE draws (it sets the
  sun's clock, not the winds).
- per flight point, `lat`, `lon` [deg, lon in -180..180] and `utc`: the
  point's offset from the station mapped as the winds read it (BLE's
  great-circle destination, `globe.latlng_of_offset`), and the start plus
  the point's `t_s`.

`path_lat_lon` and `circle_lat_lon` give a path's and a station-keeping
circle's lat/lon for drawing. `track` reads them back from any eval record (records written before these
fields get them computed the same way, a station-less record at the nominal
position). Nothing here draws or writes files.
"""

import dataclasses
import datetime as dt
from typing import Any, Dict, List, Mapping, Optional, Sequence

import jax
import numpy as np

from ble_latex.envs import env_types
from ble_latex.envs import jax_env
from ble_latex.flight import params as flight_params_lib
from ble_latex.wind import globe

STATION_FROM_WIND_FILE = 'wind file'
STATION_NOMINAL = 'nominal'
# Where a wind file names no time (a sounding without one) its flights fly
# at this time (`gridded_jax`, issue 64): not a date, so no times are written.
UNDATED_START = dt.datetime(1970, 1, 1, tzinfo=dt.timezone.utc)


def wrap_longitude(lon: Any) -> Any:
  """A longitude in -180..180 (180 maps to -180). # [deg E]"""
  return (np.asarray(lon, dtype=float) + 180.0) % 360.0 - 180.0


def lat_lon_text(lat: float, lon: float) -> str:
  """'39.9867 N 101.7607 W': a place as operators write it. # [deg]"""
  lon = float(wrap_longitude(lon))
  return (f'{abs(lat):.4f} {"N" if lat >= 0 else "S"} '
          f'{abs(lon):.4f} {"E" if lon >= 0 else "W"}')


def utc_text(when: dt.datetime) -> str:
  """ISO 8601 UTC with a 'Z' ('2010-10-26T12:00:00Z')."""
  return when.astimezone(dt.timezone.utc).strftime('%Y-%m-%dT%H:%M:%SZ')


def parse_utc(text: str, what: str) -> dt.datetime:
  """An ISO 8601 time (naive = UTC) as an aware UTC datetime.

  Raises:
    ValueError: naming `what`, if `text` is not an ISO time.
  """
  try:
    when = dt.datetime.fromisoformat(str(text).replace('Z', '+00:00'))
  except ValueError as e:
    raise ValueError(f'{what}: not an ISO 8601 time: {text!r}') from e
  if when.tzinfo is None:
    when = when.replace(tzinfo=dt.timezone.utc)
  return when.astimezone(dt.timezone.utc)


def start_times(params: env_types.EnvParams,
                seeds: Sequence[int]) -> List[Optional[dt.datetime]]:
  """The UTC start of each env seed's flight under `params`.

  `reset(PRNGKey(seed), params)`'s `start_time_offset_s` (the env's own
  draw; jitted, so the forecast the draw also makes is not computed).

  Args:
    params: The env params (their `wind_grid`, if any).
    seeds: Env seeds (ints in [0, 2**32)).

  Returns:
    One aware UTC datetime per seed (`known_start`: None where the wind
    file names no time).
  """
  env = jax_env.LatexBalloonJaxEnv()
  keys = jax.vmap(jax.random.PRNGKey)(np.asarray(seeds, np.uint32))
  offsets = jax.device_get(jax.jit(jax.vmap(
      lambda k: env.draw(jax_env.arena_key(k), params)[0].start_time_offset_s
  ))(keys))
  return [known_start(params, env_types.START_EPOCH +
                      dt.timedelta(seconds=int(s)))
          for s in np.asarray(offsets).reshape(-1)]


def known_start(params: env_types.EnvParams,
                start: dt.datetime) -> Optional[dt.datetime]:
  """`start`, or None where it is a wind file's `UNDATED_START`."""
  if params.wind_grid is not None and start == UNDATED_START:
    return None
  return start


def stations(params: env_types.EnvParams,
             seeds: Sequence[int]) -> 'tuple[np.ndarray, str]':
  """Each seed's station [N, 2] (lat, lon in -180..180) and its source.

  On a wind file `jax_env.flight_stations`; else the flight system's nominal
  position (`STATION_NOMINAL`).
  """
  found = jax_env.flight_stations(params, seeds)
  if found is not None:
    return np.asarray(found, np.float64), STATION_FROM_WIND_FILE
  flight = params.flight
  nominal = [float(flight.latitude_deg),
             float(wrap_longitude(flight.longitude_deg))]
  return np.tile(nominal, (len(seeds), 1)), STATION_NOMINAL


def point_lat_lon(station_lat: float, station_lon: float, x_km: float,
                  y_km: float) -> 'tuple[float, float]':
  """(lat, lon in -180..180) of an offset from the station. # [deg]

  `globe.latlng_of_offset` (BLE's great-circle destination, as the winds are
  read), with x east and y north in km.
  """
  lat, lon = globe.latlng_of_offset(station_lat, station_lon, x_km * 1000.0,
                                    y_km * 1000.0)
  return lat, float(wrap_longitude(lon))


def path_lat_lon(station_lat: float, station_lon: float,
                 flight_path: Sequence[Mapping[str, Any]]
                 ) -> 'tuple[List[float], List[float]]':
  """A flight path's (lats, lons in -180..180), from its station's frame.

  `point_lat_lon` of each point's `x_km`, `y_km` (east, north of the
  station). # [deg]
  """
  pairs = [point_lat_lon(station_lat, station_lon, p['x_km'], p['y_km'])
           for p in flight_path]
  return [a for a, _ in pairs], [b for _, b in pairs]


def circle_lat_lon(lat: float, lon: float, radius_km: float,
                   points: int = 73) -> 'tuple[List[float], List[float]]':
  """The circle `radius_km` [km] around (lat, lon): (lats, lons). # [deg]

  `points` points (the last the first again), clockwise from north:
  `point_lat_lon` of (r sin a, r cos a) for a in 0..2 pi.
  """
  pairs = [point_lat_lon(lat, lon, radius_km * np.sin(a),
                         radius_km * np.cos(a))
           for a in np.linspace(0.0, 2.0 * np.pi, points)]
  return [a for a, _ in pairs], [b for _, b in pairs]


def locate_record(record: Mapping[str, Any], station: Sequence[float],
                  station_source: str,
                  start: Optional[dt.datetime]) -> Dict[str, Any]:
  """`record` with its station, start and each point's lat/lon/utc.

  Args:
    record: An eval record (`records.EVAL_SCHEMA`).
    station: (lat [deg N], lon [deg E]).
    station_source: `STATION_FROM_WIND_FILE` or `STATION_NOMINAL`.
    start: The flight's UTC start, or None (no times).
  """
  lat0, lon0 = float(station[0]), float(wrap_longitude(station[1]))
  out = {**record, 'station_lat': round(lat0, 5), 'station_lon': round(lon0, 5),
         'station_source': station_source}
  if start is not None:
    out['start_utc'] = utc_text(start)
  path = []
  for point in record['flight_path']:
    lat, lon = point_lat_lon(lat0, lon0, point['x_km'], point['y_km'])
    located = {**point, 'lat': round(lat, 6), 'lon': round(lon, 6)}
    if start is not None:
      located['utc'] = utc_text(start + dt.timedelta(seconds=point['t_s']))
    path.append(located)
  out['flight_path'] = path
  return out


def locate(records: Sequence[Mapping[str, Any]],
           params: env_types.EnvParams) -> List[Dict[str, Any]]:
  """Eval records with lat/lon and UTC on every point (the module's doc).

  Args:
    records: Eval records (each with its `seed`), flown under `params`.
    params: The env params they were flown with.

  Returns:
    New records (`locate_record`).
  """
  seeds = [int(r['seed']) for r in records]
  if not seeds:
    return []
  where, source = stations(params, seeds)
  starts = start_times(params, seeds)
  return [locate_record(r, s, source, t)
          for r, s, t in zip(records, where, starts)]


@dataclasses.dataclass(frozen=True)
class Track:
  """One flight on the map (arrays along its flight points).

  Attributes:
    seed: The record's seed.
    station_lat: Its station's latitude. # [deg N]
    station_lon: Its station's longitude, -180..180. # [deg E]
    station_source: `STATION_FROM_WIND_FILE` or `STATION_NOMINAL`.
    start_utc: The flight's start, or None (a record without one).
    t_s: Flight time of each point. # [s]
    lat: Latitude. # [deg N]
    lon: Longitude, -180..180. # [deg E]
    x_km: Offset east of the station. # [km]
    y_km: Offset north of the station. # [km]
    altitude_m: Altitude. # [m]
    helium_mols: Helium. # [mol]
    sand_kg: Sand. # [kg]
  """
  seed: int
  station_lat: float
  station_lon: float
  station_source: str
  start_utc: Optional[dt.datetime]
  t_s: np.ndarray
  lat: np.ndarray
  lon: np.ndarray
  x_km: np.ndarray
  y_km: np.ndarray
  altitude_m: np.ndarray
  helium_mols: np.ndarray
  sand_kg: np.ndarray

  @property
  def distance_km(self) -> np.ndarray:
    """Distance from the station (in the plane of x, y). # [km]"""
    return np.hypot(self.x_km, self.y_km)

  def utc(self, i: int) -> Optional[dt.datetime]:
    """Point i's UTC time, or None."""
    if self.start_utc is None:
      return None
    return self.start_utc + dt.timedelta(seconds=float(self.t_s[i]))


def track(record: Mapping[str, Any], where: str = 'record') -> Track:
  """The `Track` of an eval record (validated by `records.load_eval`).

  Points' own lat/lon are used where every point has them; else (a record
  written before them) they are computed from the station (the nominal
  position if the record has none) as `locate` does.

  Raises:
    ValueError: naming `where`, for a start time that is not ISO 8601 (the
      other fields are checked by `records.EVAL_OPTIONAL`).
  """
  path = record['flight_path']
  column = lambda name: np.asarray([p[name] for p in path], dtype=float)
  if 'station_lat' in record and 'station_lon' in record:
    lat0, lon0 = record['station_lat'], record['station_lon']
    source = record.get('station_source', STATION_FROM_WIND_FILE)
  else:
    lat0 = flight_params_lib.DEFAULTS.latitude_deg
    lon0 = flight_params_lib.DEFAULTS.longitude_deg
    source = STATION_NOMINAL
  lon0 = float(wrap_longitude(lon0))
  start = record.get('start_utc')
  start = None if start is None else parse_utc(start, f'{where}: start_utc')
  if all('lat' in p and 'lon' in p for p in path):
    lat, lon = column('lat'), wrap_longitude(column('lon'))
  else:
    pairs = [point_lat_lon(lat0, lon0, p['x_km'], p['y_km']) for p in path]
    lat = np.asarray([a for a, _ in pairs])
    lon = np.asarray([b for _, b in pairs])
  return Track(
      seed=int(record['seed']), station_lat=float(lat0), station_lon=lon0,
      station_source=source, start_utc=start, t_s=column('t_s'), lat=lat,
      lon=lon, x_km=column('x_km'), y_km=column('y_km'),
      altitude_m=column('altitude_m'), helium_mols=column('helium_mols'),
      sand_kg=column('sand_kg'))
