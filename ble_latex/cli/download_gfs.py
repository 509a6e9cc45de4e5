# coding=utf-8
r"""`ble-latex-download-gfs`: a GFS run's forecast winds from NOAA NOMADS.

Fetches u and v (UGRD, VGRD) on GFS's 0.25 deg pressure levels for a box
around a station, one GRIB2 file per forecast hour, from NOMADS' public GRIB
filter (no account): `--output_dir/gfs_YYYYMMDDTHHZ_fFFF.grib2`. Resumable:
files already complete are skipped, a download is written under a temporary
name and renamed, so rerun the same command after a failure. The files of a
run then load as one forecast: `--wind_file='DIR/gfs_YYYYMMDDTHHZ_f*.grib2'`
(the command prints it). NOMADS keeps about the last 10 days of runs.

Usage:
  ble-latex-download-gfs --run=2026-12-05T00Z --hours=0-48/3 \
      --center_lat=40 --center_lon=-100 --output_dir=gfs
  ble-latex-download-gfs ... --dry_run       # prints the URLs; no network
"""

import sys
from typing import Optional, Sequence

from absl import flags

from ble_latex.cli import common as cli
from ble_latex.run import gin_binding
from ble_latex.wind import gfs_requests as gfs

_PROG = 'ble-latex-download-gfs'
# The command's own flags (`cli.run_absl`).
FLAGS = flags.FlagValues()
flags.DEFINE_string('output_dir', 'gfs', 'Folder of the GRIB2 files.',
                    flag_values=FLAGS)
flags.DEFINE_string('run', None, 'The run: YYYY-MM-DDTHHZ, HH one of 00, 06, '
                    '12, 18 (UTC).', flag_values=FLAGS)
flags.DEFINE_string('hours', gfs.DEFAULT_HOURS,
                    'Forecast hours: FIRST-LAST/STEP and/or a comma list '
                    f'(hourly to {gfs.HOURLY_UNTIL}, then 3-hourly to '
                    f'{gfs.THREE_HOURLY_UNTIL}).', flag_values=FLAGS)
flags.DEFINE_float('center_lat', None, 'The box\'s centre [deg N].',
                   flag_values=FLAGS)
flags.DEFINE_float('center_lon', None, 'The box\'s centre [deg E], '
                   '-180..180 or 0..360.', flag_values=FLAGS)
flags.DEFINE_float('half_width_deg', gfs.DEFAULT_HALF_WIDTH_DEG,
                   'Box = centre +- this [deg].', flag_values=FLAGS)
flags.DEFINE_float('min_pressure_hpa', gfs.DEFAULT_MIN_PRESSURE_HPA,
                   'Lowest pressure level [hPa].', flag_values=FLAGS)
flags.DEFINE_float('max_pressure_hpa', gfs.DEFAULT_MAX_PRESSURE_HPA,
                   'Highest pressure level [hPa] (1000: from the ground).',
                   flag_values=FLAGS)
flags.DEFINE_boolean('dry_run', False, 'Print the URLs; no network.',
                     flag_values=FLAGS)
flags.DEFINE_boolean('overwrite', False,
                     'Download files that are already complete.',
                     flag_values=FLAGS)
flags.DEFINE_integer('max_files', gfs.DEFAULT_MAX_FILES,
                     'Refuse to request more files than this.',
                     flag_values=FLAGS)
flags.DEFINE_float('max_mb', gfs.DEFAULT_MAX_MB,
                   'Refuse a file larger than this [MB].', flag_values=FLAGS)
flags.DEFINE_float('timeout_s', gfs.DEFAULT_TIMEOUT_S,
                   'Network timeout [s].', flag_values=FLAGS)
flags.DEFINE_float('pause_s', gfs.DEFAULT_PAUSE_S,
                   'Pause between requests [s] (NOMADS allows ~120 a minute).',
                   flag_values=FLAGS)
flags.DEFINE_string('base_url', gfs.NOMADS_FILTER_URL,
                    'The GRIB filter script (a mirror or a local stand-in).',
                    flag_values=FLAGS)


def _check() -> None:
  """Flag values that need no network (one-line usage errors)."""
  for name in ('run', 'center_lat', 'center_lon'):
    if FLAGS[name].value is None:
      raise cli.CommandUsageError(f'--{name} is required')
  for name in ('max_mb', 'timeout_s'):
    if not FLAGS[name].value > 0:
      raise cli.CommandUsageError(f'--{name} must be > 0, got '
                                  f'{FLAGS[name].value:g}')
  if FLAGS.pause_s < 0:
    raise cli.CommandUsageError(f'--pause_s must be >= 0, got '
                                f'{FLAGS.pause_s:g}')
  if FLAGS.max_files < 1:
    raise cli.CommandUsageError(f'--max_files must be >= 1, got '
                                f'{FLAGS.max_files}')
  if not FLAGS.base_url.startswith(('http://', 'https://')):
    raise cli.CommandUsageError(f'--base_url must be an http(s) URL, got '
                                f'{FLAGS.base_url!r}')


def _main(argv: Sequence[str]) -> int:
  """Prints (--dry_run) or downloads the files; returns the exit status."""
  del argv
  args = FLAGS
  try:
    run = gfs.parse_run(args.run)
  except ValueError as error:
    return cli.usage(_PROG, f'--run: {error}')
  try:
    hours = gfs.parse_hours(args.hours)
  except ValueError as error:
    return cli.usage(_PROG, f'--hours: {error}')
  if len(hours) > args.max_files:
    return cli.usage(_PROG, f'--hours asks for {len(hours)} files, over '
                     f'--max_files={args.max_files}')
  try:
    south, north, west, east = gfs.box(args.center_lat, args.center_lon,
                                       args.half_width_deg)
    files = gfs.build_files(
        run=run, hours=hours, south=south, north=north, west=west, east=east,
        min_pressure_hpa=args.min_pressure_hpa,
        max_pressure_hpa=args.max_pressure_hpa, base_url=args.base_url)
  except ValueError as error:
    return cli.usage(_PROG, str(error))
  if args.dry_run:
    for gfs_file in files:
      print(gfs_file.url)
    return 0
  try:
    paths = gfs.download(files, args.output_dir, overwrite=args.overwrite,
                         timeout_s=args.timeout_s,
                         max_bytes=int(args.max_mb * 1e6),
                         pause_s=args.pause_s,
                         log=lambda line: print(line, flush=True))
  except OSError as error:
    print(f'{_PROG}: {gin_binding.one_line(error)}', file=sys.stderr)
    return 1
  from ble_latex.wind import gridded  # pylint: disable=g-import-not-at-top
  try:  # The files must fly: load them as `--wind_file` would.
    data = gridded.load(paths)
  except (OSError, ValueError) as error:
    print(f'{_PROG}: the downloaded files do not load: '
          f'{gin_binding.one_line(error)}', file=sys.stderr)
    return 1
  pattern = f'{args.output_dir.rstrip("/")}/{gfs.run_glob(run)}'
  print(f'wrote {len(paths)} file(s): {data.description}, '
        f'valid {data.start:%Y-%m-%d %H:%M} to {data.end:%Y-%m-%d %H:%M} UTC, '
        f'{data.pressure.min() / 100:g}-{data.pressure.max() / 100:g} hPa, '
        f'lat {data.latitude[0]:g}..{data.latitude[-1]:g}, lon '
        f'{data.longitude[0]:g}..{data.longitude[-1]:g}')
  print(f"fly them with --wind_file='{pattern}'")
  return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
  """The command (`cli.run_absl`); returns the exit status."""
  return cli.run_absl(_main, _PROG, FLAGS, argv, doc=__doc__, check=_check)


if __name__ == '__main__':
  sys.exit(main())
