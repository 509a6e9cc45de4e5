# coding=utf-8
"""GFS forecast downloads from NOAA NOMADS' GRIB filter (`ble-latex-download-gfs`).

NOMADS' public GRIB filter (`NOMADS_FILTER_URL`, no account) cuts one file of
a GFS run, `gfs.tHHz.pgrb2.0p25.fFFF` in `/gfs.YYYYMMDD/HH/atmos`, to the
variables, pressure levels and lat/lon box asked for
(https://nomads.ncep.noaa.gov/txt_descriptions/grib_filter_doc.shtml). One
request per forecast hour:

  - `build_files`: the requests (`GfsFile`: forecast hour, URL, local name)
    for a run, its forecast hours, a box and a pressure range;
  - `download`: fetches the missing ones into a folder. Resumable: a file
    already there and complete (a GRIB2 file: `GRIB` ... `7777`) is skipped;
    each download is held in memory up to `max_bytes` and written with
    `safe_io.atomic_write` (a temporary name, renamed), so a killed or failed
    download leaves no file under the final name.

Only the winds are fetched (`UGRD`, `VGRD`): `gridded.load` reads GRIB2 u and v
on isobaric levels (`analysis.open_dataset`) and nothing else. The files of
one run load together as one forecast (`gridded.load('DIR/gfs_RUN_f*.grib2')`,
`--wind_file`), joined along their valid times.

NOMADS keeps about the last 10 days of runs and asks users to stay under
about 120 requests a minute: `download` pauses between requests.
"""

import dataclasses
import datetime as dt
import http.client
import math
import os
import re
import time
import urllib.error
import urllib.parse
import urllib.request
from typing import Callable, List, Optional, Sequence, Tuple

from ble_latex import safe_io

NOMADS_FILTER_URL = 'https://nomads.ncep.noaa.gov/cgi-bin/filter_gfs_0p25.pl'
# The isobaric levels of GFS's pgrb2.0p25 files (GFS v16, from 2021). # [hPa]
GFS_LEVELS_HPA = (1, 2, 3, 5, 7, 10, 15, 20, 30, 40, 50, 70, 100, 150, 200,
                  250, 300, 350, 400, 450, 500, 550, 600, 650, 700, 750, 800,
                  850, 900, 925, 950, 975, 1000)
VARIABLES = ('UGRD', 'VGRD')  # The winds `gridded.load` reads.
CYCLES = (0, 6, 12, 18)  # Run hours. # [h UTC]
HOURLY_UNTIL = 120  # Forecast hours are hourly to +120 h. # [h]
THREE_HOURLY_UNTIL = 384  # Then 3-hourly to +384 h. # [h]
# From the ground (1000 hPa) to above the float band (10 hPa ~ 31 km). # [hPa]
DEFAULT_MIN_PRESSURE_HPA = 10.0  # [hPa]
DEFAULT_MAX_PRESSURE_HPA = 1000.0  # [hPa]
DEFAULT_HALF_WIDTH_DEG = 5.0  # [deg]
DEFAULT_HOURS = '0-24/3'
# Bounds: a command never asks NOMADS for more than this unless told.
DEFAULT_MAX_FILES = 100
DEFAULT_MAX_MB = 50.0  # One file; a 20 deg box is < 1 MB (estimate). # [MB]
DEFAULT_TIMEOUT_S = 60.0  # [s]
DEFAULT_PAUSE_S = 1.0  # [s] Between requests (NOMADS' ~120 hits/min).
_GRIB_START = b'GRIB'
_GRIB_END = b'7777'


class DownloadError(OSError):
  """A request failed (HTTP, network, not a GRIB2 file): one line."""


@dataclasses.dataclass(frozen=True)
class GfsFile:
  """One forecast hour's request.

  Attributes:
    hour: The forecast hour (lead time). # [h]
    valid: Its valid time, naive UTC.
    url: The GRIB filter's URL.
    name: The local file name (`file_name`).
  """
  hour: int
  valid: dt.datetime
  url: str
  name: str


def parse_run(text: str) -> dt.datetime:
  """A run's start from '2026-12-05T06Z', '2026-12-05T06', '2026120506'.

  Raises:
    ValueError: another form, or an hour that is not a GFS cycle.
  """
  match = (re.fullmatch(r'(\d{4})-(\d{2})-(\d{2})[T ](\d{2})(?::00)?Z?',
                        text.strip()) or
           re.fullmatch(r'(\d{4})(\d{2})(\d{2})(\d{2})Z?', text.strip()))
  if not match:
    raise ValueError(f'expected a run as YYYY-MM-DDTHHZ (e.g. '
                     f'2026-12-05T06Z), got {text!r}')
  year, month, day, hour = (int(g) for g in match.groups())
  try:
    run = dt.datetime(year, month, day, hour)
  except ValueError as error:
    raise ValueError(f'{text!r} is not a date and hour ({error})') from error
  if hour not in CYCLES:
    raise ValueError(f'GFS runs start at {", ".join(f"{c:02d}Z" for c in CYCLES)}'
                     f'; got {hour:02d}Z')
  return run


def is_forecast_hour(hour: int) -> bool:
  """Whether GFS 0.25 deg has the lead `hour` (hourly to 120, then 3-hourly)."""
  return (0 <= hour <= HOURLY_UNTIL or
          (HOURLY_UNTIL < hour <= THREE_HOURLY_UNTIL and hour % 3 == 0))


def parse_hours(text: str) -> List[int]:
  """Forecast hours from '0-24/3', '0,6,12' or a mix ('0-12/6,24'). # [h]

  Raises:
    ValueError: a malformed item, or an hour GFS does not have.
  """
  hours = set()
  for item in text.split(','):
    item = item.strip()
    match = re.fullmatch(r'(\d+)(?:-(\d+)(?:/(\d+))?)?', item)
    if not match:
      raise ValueError(f'expected hours such as 0-24/3 or 0,6,12, got '
                       f'{item!r}')
    first = int(match.group(1))
    last = int(match.group(2)) if match.group(2) else first
    step = int(match.group(3)) if match.group(3) else 1
    if last < first or step < 1:
      raise ValueError(f'{item!r}: expected FIRST-LAST/STEP with LAST >= '
                       'FIRST and STEP >= 1')
    hours.update(range(first, last + 1, step))
  bad = sorted(h for h in hours if not is_forecast_hour(h))
  if bad:
    raise ValueError(f'GFS 0.25 deg has no forecast hour {bad[0]} (hourly '
                     f'to {HOURLY_UNTIL}, then every 3 h to '
                     f'{THREE_HOURLY_UNTIL})')
  return sorted(hours)


def levels_hpa(min_hpa: float = DEFAULT_MIN_PRESSURE_HPA,
               max_hpa: float = DEFAULT_MAX_PRESSURE_HPA) -> List[int]:
  """GFS's isobaric levels within [min_hpa, max_hpa], ascending. # [hPa]

  Raises:
    ValueError: fewer than 2 levels in the range (the loader interpolates
      between levels).
  """
  levels = [p for p in GFS_LEVELS_HPA if min_hpa <= p <= max_hpa]
  if len(levels) < 2:
    raise ValueError(f'{len(levels)} GFS pressure level(s) in [{min_hpa:g}, '
                     f'{max_hpa:g}] hPa; at least 2 are needed (levels: '
                     f'{", ".join(str(p) for p in GFS_LEVELS_HPA)})')
  return levels


def box(center_lat: float, center_lon: float,
        half_width_deg: float = DEFAULT_HALF_WIDTH_DEG
        ) -> Tuple[float, float, float, float]:
  """(south, north, west, east) of center +- half width. # [deg]

  West in -180..180 and east = west + 2 half widths, so a box across the
  antimeridian runs past 180 (170..190) rather than wrapping.

  Raises:
    ValueError: a non-finite or out-of-range value.
  """
  for name, value in (('center_lat', center_lat), ('center_lon', center_lon),
                      ('half_width_deg', half_width_deg)):
    if not math.isfinite(value):
      raise ValueError(f'{name} must be finite, got {value}')
  if not -90.0 <= center_lat <= 90.0:
    raise ValueError(f'center_lat must be in [-90, 90], got {center_lat:g}')
  if not 0.0 < half_width_deg < 90.0:
    raise ValueError(f'half_width_deg must be in (0, 90), got '
                     f'{half_width_deg:g}')

  west = (center_lon - half_width_deg + 180.0) % 360.0 - 180.0
  return (max(center_lat - half_width_deg, -90.0),
          min(center_lat + half_width_deg, 90.0),
          west, west + 2.0 * half_width_deg)


def file_name(run: dt.datetime, hour: int) -> str:
  """The local name of a run's forecast hour: 'gfs_20261205T06Z_f003.grib2'."""
  return f'gfs_{run:%Y%m%dT%H}Z_f{hour:03d}.grib2'


def run_glob(run: dt.datetime) -> str:
  """The glob of a run's files, for `--wind_file`: 'gfs_20261205T06Z_f*.grib2'."""
  return f'gfs_{run:%Y%m%dT%H}Z_f*.grib2'


def build_files(*, run: dt.datetime, hours: Sequence[int],
                south: float, north: float, west: float, east: float,
                min_pressure_hpa: float = DEFAULT_MIN_PRESSURE_HPA,
                max_pressure_hpa: float = DEFAULT_MAX_PRESSURE_HPA,
                base_url: str = NOMADS_FILTER_URL) -> List[GfsFile]:
  """The GRIB filter's requests of a run's forecast hours in a box.

  Args:
    run: The run's start (a cycle: 00, 06, 12 or 18 UTC), naive UTC.
    hours: Forecast hours (`parse_hours`). # [h]
    south: The box's southern edge. # [deg N]
    north: Its northern edge. # [deg N]
    west: Its western edge. # [deg E]
    east: Its eastern edge, east of `west` (may pass 180). # [deg E]
    min_pressure_hpa: Lowest pressure (highest level) wanted. # [hPa]
    max_pressure_hpa: Highest pressure (lowest level) wanted. # [hPa]
    base_url: The filter script (a local stand-in in tests).

  Returns:
    One `GfsFile` per hour, in hour order.

  Raises:
    ValueError: no hours, a run that is not a cycle, too few levels, an
      empty box.
  """
  if not hours:
    raise ValueError('no forecast hours')
  if run.hour not in CYCLES or run.minute or run.second:
    raise ValueError(f'{run:%Y-%m-%dT%H:%M} is not a GFS run (cycles '
                     f'{CYCLES} UTC)')
  if not south < north or not west < east <= west + 360.0:
    raise ValueError(f'empty box: lat {south:g}..{north:g}, lon {west:g}..'
                     f'{east:g} (south < north, west < east)')
  levels = levels_hpa(min_pressure_hpa, max_pressure_hpa)
  files = []
  for hour in sorted(set(hours)):
    if not is_forecast_hour(hour):
      raise ValueError(f'GFS 0.25 deg has no forecast hour {hour}')
    query = [('dir', f'/gfs.{run:%Y%m%d}/{run:%H}/atmos'),
             ('file', f'gfs.t{run:%H}z.pgrb2.0p25.f{hour:03d}')]
    query += [(f'var_{v}', 'on') for v in VARIABLES]
    query += [(f'lev_{p}_mb', 'on') for p in levels]
    query += [('subregion', ''), ('leftlon', f'{west:g}'),
              ('rightlon', f'{east:g}'), ('toplat', f'{north:g}'),
              ('bottomlat', f'{south:g}')]
    url = f'{base_url}?{urllib.parse.urlencode(query)}'
    files.append(GfsFile(hour, run + dt.timedelta(hours=hour), url,
                         file_name(run, hour)))
  return files


def is_complete(path: str) -> bool:
  """Whether `path` is a whole GRIB file (starts `GRIB`, ends `7777`)."""
  try:
    size = os.path.getsize(path)
    if not os.path.isfile(path) or size < 8:
      return False
    with open(path, 'rb') as f:
      head = f.read(4)
      f.seek(size - 4)
      return head == _GRIB_START and f.read(4) == _GRIB_END
  except OSError:
    return False


def _first_text_line(body: bytes) -> str:
  """The first non-empty line of a (HTML) reply, tags dropped, short."""
  text = re.sub(r'<[^>]*>', ' ', body[:2000].decode('utf-8', 'replace'))
  lines = [' '.join(l.split()) for l in text.splitlines()]
  line = next((l for l in lines if l), '(empty reply)')
  return line[:160]


def fetch(url: str, *, timeout_s: float = DEFAULT_TIMEOUT_S,
          max_bytes: int = int(DEFAULT_MAX_MB * 1e6)) -> bytes:
  """One GRIB2 file from the filter, whole and checked.

  Args:
    url: The request (`GfsFile.url`).
    timeout_s: Network timeout of each read. # [s]
    max_bytes: Refuse a larger reply (a bound on what one request writes).

  Returns:
    The file's bytes: a GRIB2 file (`GRIB` ... `7777`).

  Raises:
    DownloadError: an HTTP error, an unreachable host, a timeout, a reply
      cut short, larger than `max_bytes`, or not GRIB2 (NOMADS answers a
      missing run or file with a page of text, named in the message).
  """
  request = urllib.request.Request(url, headers={
      'User-Agent': 'ble_latex (ble-latex-download-gfs)'})
  try:
    with urllib.request.urlopen(request, timeout=timeout_s) as reply:
      announced = reply.headers.get('Content-Length')
      body = reply.read(max_bytes + 1)
  except urllib.error.HTTPError as error:
    detail = _first_text_line(error.read() or b'') if error.fp else ''
    raise DownloadError(f'HTTP {error.code} {error.reason}'
                        f'{": " + detail if detail else ""}') from error
  except urllib.error.URLError as error:
    raise DownloadError(f'cannot reach {urllib.parse.urlsplit(url).netloc} '
                        f'({error.reason})') from error
  except http.client.IncompleteRead as error:
    raise DownloadError(f'the reply was cut short ({len(error.partial)} '
                        'bytes read)') from error
  except (OSError, http.client.HTTPException) as error:
    raise DownloadError(f'{type(error).__name__}: {error}') from error
  if (announced is not None and announced.strip().isdigit() and
      len(body) < int(announced) and len(body) <= max_bytes):
    raise DownloadError(f'the reply was cut short ({len(body)} of '
                        f'{int(announced)} bytes)')
  if len(body) > max_bytes:
    raise DownloadError(f'the reply is over {max_bytes / 1e6:g} MB (raise '
                        '--max_mb, or ask for a smaller box or fewer levels)')
  if not body.startswith(_GRIB_START):
    raise DownloadError(f'not a GRIB2 file: {_first_text_line(body)}')
  if not body.endswith(_GRIB_END):
    raise DownloadError(f'the GRIB2 file is truncated ({len(body)} bytes, no '
                        'end marker 7777)')
  return body


def download(files: Sequence[GfsFile], output_dir: str, *,
             overwrite: bool = False, timeout_s: float = DEFAULT_TIMEOUT_S,
             max_bytes: int = int(DEFAULT_MAX_MB * 1e6),
             pause_s: float = DEFAULT_PAUSE_S,
             log: Optional[Callable[[str], None]] = None) -> List[str]:
  """Downloads the files not already in `output_dir` (resumable).

  Args:
    files: The requests (`build_files`).
    output_dir: The folder (created if missing).
    overwrite: Download complete files again.
    timeout_s: Network timeout. # [s]
    max_bytes: The largest file accepted.
    pause_s: Pause between two requests (NOMADS' rate limit). # [s]
    log: Called with one line per file ('have ...', 'fetching ...').

  Returns:
    The paths of all `files`, in order.

  Raises:
    DownloadError: a request failed; its message names the file and URL.
      Files fetched before stay (a rerun skips them).
    OSError: the folder cannot be written.
  """
  log = log or (lambda line: None)
  os.makedirs(output_dir, exist_ok=True)
  safe_io.remove_stale_temporaries(output_dir, 'gfs_')  # A killed run's.
  paths, fetched = [], 0
  for gfs_file in files:
    path = os.path.join(output_dir, gfs_file.name)
    paths.append(path)
    if not overwrite and is_complete(path):
      log(f'have {path}')
      continue
    if fetched and pause_s > 0:
      time.sleep(pause_s)
    log(f'fetching +{gfs_file.hour} h (valid {gfs_file.valid:%Y-%m-%d %H:%M} '
        f'UTC) -> {path}')
    try:
      body = fetch(gfs_file.url, timeout_s=timeout_s, max_bytes=max_bytes)
    except DownloadError as error:
      raise DownloadError(f'{gfs_file.name}: {error} (URL {gfs_file.url})'
                          ) from error
    fetched += 1
    safe_io.atomic_write(path, body)
  return paths
