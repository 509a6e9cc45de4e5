# coding=utf-8
"""The real wind sources the benchmarks fly: their files, labels and sites.

`SOURCES` names each real file beside the checkout
(`../shared/realdata/`, its PROVENANCE.md gives where each came from and
its licence) with its label and, for a sounding, its launch site. Every real
source is one time step: flown time-invariant, the analysis (or the
sounding's column) being the forecast the agents see.

Where a source's flights keep station (`STATION_MODES`):

- 'center': a GFS grid's station is the file's fixed centre (`center`:
  the middle of its latitudes and longitudes, every seed the same station);
  a sounding's is its launch site (a sounding is the same column
  everywhere, the site only places the sun);
- 'per_seed' (grids only): seed s flies station s of the domain
  (`wind.stations`).

The real-winds table flies a sounding at its site and a grid per seed
(`table_station_mode`). A GRIB2 source may fly from a NetCDF copy
(`grib_copy`), checked by its arrays' SHA-256 (`checked_copy`).
Scripts: `benchmarks/real_winds.py`, `real_winds_paths.py`,
`wind_compare.py`, `reward_shape.py`; their gin bindings:
`run/wind_file.py`.
"""

import os
from typing import Dict, NamedTuple, Optional, Sequence, Tuple

from ble_latex import errors


class Source(NamedTuple):
  """A real wind source.

  Attributes:
    file: Its path under the real-data folder (`REALDATA_DIR`).
    label: What it is, for tables and figures.
    site: A sounding's launch site (lat [deg N], lon [deg E]; University of
      Wyoming's station list), None for a grid.
  """
  file: str
  label: str
  site: Optional[Tuple[float, float]]


# The real files beside the checkout (../shared/realdata/PROVENANCE.md).
REALDATA_DIR = os.path.join(
    os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(
        __file__)))), '..', 'shared', 'realdata')
SOURCES: Dict[str, Source] = {
    'gfs_namerica': Source(
        'winds/gfs_2010-10-26T12Z_namerica_1deg.nc',
        'GFS analysis 2010-10-26 12Z, N. America 1° (NetCDF)', None),
    'gfs_global': Source(
        'winds/gfs_2011-10-08T00Z_f072_global_2p5deg.grib2',
        'GFS +72 h, valid 2011-10-11 00Z, global 2.5° (GRIB2)', None),
    'boise': Source('soundings/BOI-Boise_2010-12-09T12Z_uwyo.txt',
                    'sounding Boise 2010-12-09 12Z', (43.56, -116.21)),
    'hilo': Source('soundings/PHTO-Hilo_2023-11-01T00Z_uwyo.csv',
                   'sounding Hilo 2023-11-01 00Z', (19.72, -155.07)),
}
# The gridded sources (a sounding has a site).
GRIDS = tuple(name for name, s in SOURCES.items() if s.site is None)
STATION_MODES = ('center', 'per_seed')


def unknown(names: Sequence[str]) -> list:
  """The names of `names` that are no source of `SOURCES`, in order."""
  return [n for n in names if n not in SOURCES]


def path(name: str, realdata_dir: str = REALDATA_DIR) -> str:
  """Source `name`'s file under `realdata_dir`."""
  return os.path.join(realdata_dir, SOURCES[name].file)


def is_sounding(name: str) -> bool:
  return SOURCES[name].site is not None


def center(name: str, file: str) -> Tuple[float, float]:
  """(lat, lon) [deg] of 'center' mode: a grid's centre, a sounding's site.

  A grid's centre is the middle of the file's first and last latitudes and
  longitudes, the longitude wrapped into [-180, 180).

  Args:
    name: A source of `SOURCES`.
    file: Its file (read only for a grid).
  """
  site = SOURCES[name].site
  if site is not None:
    return site
  from ble_latex.wind import gridded  # pylint: disable=g-import-not-at-top
  data = gridded.load(file)
  lat = 0.5 * (data.latitude[0] + data.latitude[-1])
  lon = 0.5 * (data.longitude[0] + data.longitude[-1])
  return float(lat), float((lon + 180.0) % 360.0 - 180.0)


def table_station_mode(name: str) -> str:
  """The real-winds table's stations: a sounding at its site ('center'),
  a grid's seed s at station s ('per_seed')."""
  return 'center' if is_sounding(name) else 'per_seed'


def checked_copy(file: str, sha256: str) -> None:
  """Refuses a NetCDF copy of a GRIB2 source unless its arrays' `digest`
  (`grib_copy.digest` of `gridded.read_source`'s arrays) is `sha256`.

  Raises:
    FileNotFoundError: No file `file`.
    errors.BadFileError: Its arrays have another SHA-256 (one line naming
      both).
  """
  # pylint: disable=g-import-not-at-top
  from ble_latex.wind import grib_copy
  from ble_latex.wind import gridded
  # pylint: enable=g-import-not-at-top
  if not os.path.isfile(file):
    raise FileNotFoundError(f'{file}: no such file')
  got = grib_copy.digest(gridded.read_source(file)[1])
  if got != sha256:
    raise errors.BadFileError(f'{file} reads to arrays of SHA-256 {got}, '
                              f'not {sha256}')
