# coding=utf-8
"""Radiosonde soundings as wind columns (University of Wyoming text and CSV).

A sounding is one column of the atmosphere over a launch site: pressure,
geopotential height and the wind measured by the radiosonde on its ascent.
`read` turns the University of Wyoming's two formats into a `Sounding`:

  * the fixed-width text of weather.uwyo.edu ("TEXT:LIST"): a dashed rule,
    a row of column names (PRES HGHT TEMP ... DRCT SKNT ...), a row of units
    (hPa m C ... deg knot ...), a rule, then one row per level, each column
    7 characters wide, blank where nothing was measured;
  * the CSV export: a header row of the same names, one row per level.

Units: PRES [hPa] -> [Pa]; HGHT [m]; SKNT [knot] -> [m/s] (1 knot = 1852 m /
3600 s exactly); DRCT [deg], the direction the wind blows FROM, clockwise
from north (the meteorological convention, WMO No. 306). The components are
u = -speed * sin(DRCT) (towards east) and v = -speed * cos(DRCT) (towards
north).

Only levels with pressure, height, direction and speed are kept; levels are
ordered by pressure, descending with height. Real files list a level twice
where a mandatory level is also a significant one (Boise 2010-12-09: 115 hPa
at 15 240 and 15 237 m): the first listed is kept. A height that does not
grow as pressure falls is refused (a file that is not a sounding). A column
that flies must cover the altitudes the balloon can reach
(`reach.flight_band_m`, 13-22 km by default); above its top the wind is held
(`Site.top_m`, named in the record).

The site and time are read from the file where it has them (`Site`,
`read_site`): the "Station information" lines of the TEXT:LIST page
(`Station identifier: BOI`, `Station number: 72681`, `Observation time:
101209/1200` as YYMMDD/HHMM UTC, `Station latitude: 43.56`, `Station
longitude: -116.21`), the same `key: value` lines above a CSV's header row
(a leading `#` allowed), or the page's title ("72681 BOI Boise Observations
at 12Z 09 Dec 2010"). A bare table (as both files in tests/data/realwinds)
has none: its site and time stay unknown.
"""

import csv
import dataclasses
import datetime as dt
import io
import os
import re
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from ble_latex import errors
from ble_latex.wind import gridded_checks
from ble_latex.wind import reach

KNOT_MPS = 1852.0 / 3600.0  # [m/s] One knot (exact).
HPA_PA = 100.0  # [Pa] One hectopascal.
MAX_FILE_BYTES = 4 * 1024 * 1024  # A sounding is ~10 kB; refuse anything big.
MIN_LEVELS = 2
_COLUMNS = ('PRES', 'HGHT', 'DRCT', 'SKNT')
_WIDTH = 7  # Characters per column of the fixed-width text.
# `key: value` lines of the UWyo page's station block (or above a CSV).
_META = re.compile(r'^[#\s]*(Station identifier|Station number|Observation '
                   r'time|Station latitude|Station longitude)\s*:\s*(.*?)\s*$',
                   re.IGNORECASE | re.MULTILINE)
# The page's title: "72681 BOI Boise Observations at 12Z 09 Dec 2010".
_TITLE = re.compile(r'(\d{5})?\s*([A-Z0-9]{3,4})?[^\n<>]*?Observations at '
                    r'(\d{1,2})Z (\d{1,2} [A-Za-z]{3} \d{4})')


@dataclasses.dataclass(frozen=True)
class Site:
  """Where and when a sounding was made, as its file says (None: unknown).

  Attributes:
    identifier: The station's letters (e.g. 'BOI').
    number: The WMO station number (e.g. '72681').
    time: The observation time, UTC (timezone-aware).
    latitude: The station's latitude. # [deg N]
    longitude: The station's longitude. # [deg E]
    top_m: The highest level with a wind: above it the wind is held at
      its value (set by the reader, `analysis.sounding_arrays`). # [m]
  """
  identifier: Optional[str] = None
  number: Optional[str] = None
  time: Optional[dt.datetime] = None
  latitude: Optional[float] = None
  longitude: Optional[float] = None
  top_m: Optional[float] = None

  @property
  def label(self) -> str:
    """E.g. 'BOI 72681 43.56N -116.21E 2010-12-09T12:00Z' (what is known)."""
    parts = [p for p in (self.identifier, self.number) if p]
    if self.latitude is not None and self.longitude is not None:
      parts.append(f'{self.latitude:g}N {self.longitude:g}E')
    if self.time is not None:
      parts.append(f'{self.time:%Y-%m-%dT%H:%M}Z')
    return ' '.join(parts)

  @property
  def notes(self) -> List[str]:
    """What a record says of the column: ['wind above its top, 22.5 km,
    held'] (nothing without `top_m`)."""
    if self.top_m is None:
      return []
    return [f'wind above its top, {self.top_m / 1000:.1f} km, held']


def _observation_time(value: str, path: str) -> dt.datetime:
  """UWyo's `YYMMDD/HHMM` or `HHZ DD Mon YYYY`, UTC."""
  value = value.strip()
  try:
    if re.fullmatch(r'\d{6}/\d{4}', value):
      year = int(value[:2])
      year += 1900 if year >= 70 else 2000  # UWyo's archive starts in 1973.
      when = dt.datetime.strptime(f'{year}{value[2:]}', '%Y%m%d/%H%M')
    else:
      hour, day = value.split('Z', 1)
      when = dt.datetime.strptime(day.strip(), '%d %b %Y').replace(
          hour=int(hour))
  except ValueError as e:
    raise errors.BadFileError(
        f'{path}: observation time {value!r} is not YYMMDD/HHMM or '
        '"HHZ DD Mon YYYY"') from e
  return when.replace(tzinfo=dt.timezone.utc)


def read_site(text: str, path: str) -> Site:
  """The site and time a sounding's text names (`Site`; None where not).

  Raises:
    errors.BadFileError: a station block value that does not parse (a
      latitude outside [-90, 90], a longitude outside [-180, 360], a time
      that is no date).
  """
  values = {}
  for key, value in _META.findall(text):
    values.setdefault(key.lower(), value)
  site = {}
  title = _TITLE.search(text)
  if title:
    number, identifier, hour, day = title.groups()
    site.update(number=number, identifier=identifier,
                time=_observation_time(f'{hour}Z {day}', path))
  if values.get('station identifier'):
    site['identifier'] = values['station identifier']
  if values.get('station number'):
    site['number'] = values['station number']
  if values.get('observation time'):
    site['time'] = _observation_time(values['observation time'], path)
  for key, name, bound in (('station latitude', 'latitude', 90.0),
                           ('station longitude', 'longitude', 360.0)):
    if key in values:
      try:
        number = float(values[key])
      except ValueError:
        number = float('nan')
      low = -90.0 if name == 'latitude' else -180.0
      if not low <= number <= bound:
        raise errors.BadFileError(
            f'{path}: {key} {values[key]!r} is not a number in [{low:g}, '
            f'{bound:g}]')
      site[name] = number
  return Site(**site)


@dataclasses.dataclass(frozen=True)
class Sounding:
  """One radiosonde column, ordered by pressure from the ground up.

  Attributes:
    pressure_pa: Pressure of each level, descending. # [Pa]
    height_m: Geopotential height of each level, ascending. # [m]
    u_mps: Wind towards east. # [m/s]
    v_mps: Wind towards north. # [m/s]
    source: The file read.
    site: Where and when, as the file says (`read_site`).
  """
  pressure_pa: np.ndarray
  height_m: np.ndarray
  u_mps: np.ndarray
  v_mps: np.ndarray
  source: str
  site: Site = Site()


def wind_components(direction_deg: np.ndarray, speed_mps: np.ndarray
                    ) -> Tuple[np.ndarray, np.ndarray]:
  """u, v of a wind blowing FROM `direction_deg` (clockwise from north).

  Args:
    direction_deg: Meteorological direction (0 = from the north). # [deg]
    speed_mps: Wind speed. # [m/s]

  Returns:
    (u towards east, v towards north). # [m/s]
  """
  radians = np.deg2rad(direction_deg)
  return -speed_mps * np.sin(radians), -speed_mps * np.cos(radians)


def _float(cell: str) -> float:
  cell = cell.strip()
  return float(cell) if cell else float('nan')


def _text_rows(lines: Sequence[str], path: str) -> List[Dict[str, float]]:
  """Rows of the fixed-width text (University of Wyoming TEXT:LIST)."""
  for i, line in enumerate(lines):
    names = line.split()
    if all(c in names for c in _COLUMNS):
      break
  else:
    raise errors.BadFileError(
        f'{path}: not a University of Wyoming sounding: no header row naming '
        f'{", ".join(_COLUMNS)}')
  header = lines[i]
  # Each name is right-aligned in its 7-character column.
  spans = {}
  for name in _COLUMNS:
    end = header.index(name) + len(name)
    spans[name] = (max(0, end - _WIDTH), end)
  rows = []
  for line in lines[i + 1:]:
    stripped = line.strip()
    if not stripped or set(stripped) <= set('-'):
      continue
    if not stripped[0].isdigit():
      if rows:  # The station's indices follow the levels.
        break
      continue  # The units row.
    try:
      rows.append({name: _float(line[a:b]) for name, (a, b) in spans.items()})
    except ValueError as e:
      raise errors.BadFileError(
          f'{path}: unreadable sounding row {stripped[:40]!r}') from e
  return rows


def _csv_rows(text: str, path: str) -> List[Dict[str, float]]:
  reader = csv.DictReader(io.StringIO(text))
  names = [n.strip() for n in (reader.fieldnames or [])]
  missing = [c for c in _COLUMNS if c not in names]
  if missing:
    raise errors.BadFileError(
        f'{path}: not a University of Wyoming sounding CSV: no column(s) '
        f'{", ".join(missing)}')
  rows = []
  for n, row in enumerate(reader, start=2):
    row = {k.strip(): v for k, v in row.items() if k is not None}
    try:
      rows.append({c: _float(row.get(c) or '') for c in _COLUMNS})
    except ValueError as e:
      raise errors.BadFileError(
          f'{path}: line {n}: a value that is not a number') from e
  return rows


def read(path: str) -> Sounding:
  """Reads a University of Wyoming sounding (text or CSV).

  Args:
    path: The file.

  Returns:
    The levels with a full wind measurement.

  Raises:
    errors.BadFileError: Not a sounding, unreadable, too big, levels out of
      order, or winds that do not cover `reach.flight_band_m` (one line
      naming the file).
  """
  gridded_checks.not_regular(path, 'sounding')  # A FIFO would block open().
  try:
    size = os.path.getsize(path)
    if size > MAX_FILE_BYTES:
      raise errors.BadFileError(
          f'{path}: {size} bytes is no sounding (at most {MAX_FILE_BYTES})')
    with open(path, 'rb') as f:
      raw = f.read()
  except OSError as e:
    raise errors.BadFileError(f'{path}: cannot read: {e.strerror or e}') from e
  try:
    text = raw.decode('utf-8-sig')  # Spreadsheets save a byte-order mark.
  except UnicodeDecodeError as e:
    raise errors.BadFileError(f'{path}: not a text file') from e
  lines = text.splitlines()
  header = next((i for i, l in enumerate(lines)
                 if all(c in l for c in _COLUMNS)), None)
  first = next((l for l in text.splitlines() if l.strip()), '')
  if ',' in (first if header is None else lines[header]):
    rows = _csv_rows('\n'.join(lines[header or 0:]), path)
  else:
    rows = _text_rows(lines, path)
  return dataclasses.replace(_column(rows, path), site=read_site(text, path))


# How far a level's pressure may lie from the US Standard Atmosphere 1976's
# at its height (`reach.pressure_of_height`): real columns stay within ~30 %
# up to 35 km; PRES in Pa (x100) or kPa (/10) does not. # [.]
MAX_PRESSURE_RATIO = 2.0


def check_pressure_units(pressure_hpa: np.ndarray, height_m: np.ndarray,
                         path: str) -> None:
  """Each level's PRES [hPa] within `MAX_PRESSURE_RATIO` of the standard
  atmosphere's at its HGHT [m].

  Raises:
    errors.BadFileError: One line naming the file and the first level that
      is not (a file whose PRES is in Pa, or whose heights are not metres).
  """
  with np.errstate(all='ignore'):
    standard = np.array([reach.pressure_of_height(float(h)) for h in
                         height_m]) / HPA_PA
    ratio = pressure_hpa / standard
  bad = ~((ratio >= 1 / MAX_PRESSURE_RATIO) & (ratio <= MAX_PRESSURE_RATIO))
  if np.any(bad):
    i = int(np.argmax(bad))
    raise errors.BadFileError(
        f'{path}: PRES {pressure_hpa[i]:g} hPa at HGHT {height_m[i]:g} m is '
        f'{ratio[i]:.3g} x the standard atmosphere\'s {standard[i]:.4g} hPa '
        f'there (more than {MAX_PRESSURE_RATIO:g}x off): PRES must be in hPa '
        'and HGHT in m')


def _column(rows: Sequence[Dict[str, float]], path: str) -> Sounding:
  table = np.array([[r[c] for c in _COLUMNS] for r in rows], np.float64)
  if table.size:
    table = table[np.all(np.isfinite(table), axis=1)]
  if len(table) < MIN_LEVELS:
    raise errors.BadFileError(
        f'{path}: {len(table)} level(s) with pressure, height and wind; a '
        f'column needs at least {MIN_LEVELS}')
  pressure_hpa, height_m, direction, speed_kt = table.T
  if np.any(pressure_hpa <= 0) or np.any(speed_kt < 0) or np.any(
      (direction < 0) | (direction > 360)):
    raise errors.BadFileError(
        f'{path}: a pressure <= 0, a negative speed or a direction outside '
        '0-360 deg')
  fastest = int(np.argmax(speed_kt))
  if speed_kt[fastest] * KNOT_MPS > gridded_checks.MAX_WIND_MPS:
    raise errors.BadFileError(
        f'{path}: a wind of {speed_kt[fastest]:g} knots at '
        f'{pressure_hpa[fastest]:g} hPa is above '
        f'{gridded_checks.MAX_WIND_MPS:g} m/s (corrupt data)')
  order = np.argsort(-pressure_hpa, kind='stable')
  # The first listed level of each pressure (a stable sort keeps file order).
  first = np.concatenate([[True], np.diff(pressure_hpa[order]) != 0])
  order = order[first]
  pressure_hpa, height_m = pressure_hpa[order], height_m[order]
  if np.any(np.diff(height_m) <= 0):
    raise errors.BadFileError(
        f'{path}: heights do not grow as pressure falls')
  check_pressure_units(pressure_hpa, height_m, path)
  low, high = reach.flight_band_m()
  if height_m[0] > low or height_m[-1] < high:
    raise errors.BadFileError(
        f'{path}: winds cover {height_m[0]:.0f}-{height_m[-1]:.0f} m; a '
        f'flight needs {reach.band_text((low, high))}')
  u, v = wind_components(direction[order], speed_kt[order] * KNOT_MPS)
  return Sounding(pressure_pa=pressure_hpa * HPA_PA, height_m=height_m,
                  u_mps=u, v_mps=v, source=str(path))
