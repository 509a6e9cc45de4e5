# coding=utf-8
r"""`ble-latex-download-era5`: fetches the paper's ERA5 winds (CDS or ARCO).

Downloads ERA5 u, v on pressure levels (CDS dataset
`reanalysis-era5-pressure-levels`) around the station-keeping target, one
request and file per calendar month (`<output stem>_YYYY-MM.nc`, skipped when
already there), then joins the months into `--output` for
`GriddedWindField.path` (gin_configs/paper_era5.gin). Defaults are the paper's
data: 1 Nov 2022 - 31 Jan 2023, lat 1, lon -113 +- 5 deg, 0.4 deg grid,
levels 20-175 hPa, 00/06/12/18 UTC (~16 MB of float32 winds).

Needs a CDS account: put your token in ~/.cdsapirc (or set CDSAPI_URL and
CDSAPI_KEY), see https://cds.climate.copernicus.eu/how-to-api, and accept the
ERA5 licence on the dataset's page.

--source=arco reads the same area, levels, days and hours from Google's
public ARCO-ERA5 Zarr store instead (`--store`, default
gs://gcp-public-data-arco-era5/ar/full_37-1h-0p25deg-chunk-1.zarr-v3):
anonymous, no account or queue, one file `--output` on the store's native
0.25 deg grid (`--grid_deg` does not apply); needs
`pip install 'ble_latex[arco]'` (zarr, gcsfs).

Usage:
  ble-latex-download-era5 --output era5_paper.nc
  ble-latex-download-era5 --source=arco --output era5_paper.nc
  ble-latex-download-era5 --dry_run          # prints the requests as JSON
  python -m ble_latex.cli.download_era5 --start_date 2022-12-01 \
      --end_date 2022-12-31 --output era5_dec.nc
"""

import datetime as dt
import json
import os
import sys
from typing import Any, List, Optional, Sequence, Tuple

from absl import flags

from ble_latex import quiet
from ble_latex.cli import common as cli

with quiet.third_party_noise():
  # pylint: disable=g-import-not-at-top
  import numpy as np
  import xarray as xr

  from ble_latex.wind import era5_arco
  from ble_latex.wind import era5_requests
  from ble_latex.wind import gridded
  from ble_latex.wind import gridded_checks
  # pylint: enable=g-import-not-at-top


def monthly_path(output: str, month: str) -> str:
  """Path of one month's file: `<output stem>_YYYY-MM<ext>`."""
  stem, ext = os.path.splitext(output)
  return f'{stem}_{month}{ext or ".nc"}'


def merge_files(paths: Sequence[str], output: str) -> str:
  """Joins ERA5 files (e.g. monthly) along time into one NetCDF file.

  The layout (old or new CDS) is kept; times are sorted and duplicates
  dropped; packing is dropped (months packed with different scale factors
  would not share one), the winds are written as compressed float32.

  Args:
    paths: ERA5 files on the same grid.
    output: The joined file (written atomically).

  Returns:
    `output`.

  Raises:
    FileNotFoundError: a file is missing.
    IsADirectoryError: a path is a directory.
    OSError: `output` cannot be written (no partial file is left).
    ValueError: a file is not NetCDF, is truncated or has no time dimension.
  """
  datasets = []
  try:
    time_dim = None
    for path in paths:
      gridded_checks.check_file(path)
      try:
        dataset = xr.open_dataset(path)
      except Exception as error:  # pylint: disable=broad-except
        raise ValueError(f'ERA5 file {path} is not a readable NetCDF file '
                         f'({type(error).__name__}: {error})') from error
      datasets.append(dataset)
      dim = gridded.find_time_dim(dataset)
      if dim is None or (time_dim is not None and dim != time_dim):
        raise ValueError(
            f'ERA5 file {path} has no time dimension {time_dim or ""} '
            f'(expected one of {list(gridded.TIME_DIMS)}; found dims '
            f'{sorted(str(d) for d in dataset.dims)})')
      time_dim = dim
    merged = xr.concat(datasets, dim=time_dim, data_vars='minimal',
                       coords='minimal', compat='override', join='exact')
    merged = merged.sortby(time_dim).drop_duplicates(time_dim).load()
  finally:
    for dataset in datasets:
      dataset.close()
  encoding = {}
  for name in merged.variables:
    merged[name].encoding = {}
  for name in merged.data_vars:
    if np.issubdtype(merged[name].dtype, np.floating):
      encoding[name] = {'dtype': 'float32', 'zlib': True, 'complevel': 4}
  partial = output + '.part'
  try:
    merged.to_netcdf(partial, encoding=encoding)
    os.replace(partial, output)
  except OSError as error:
    raise OSError(f'could not write {output} ({type(error).__name__}: '
                  f'{error})') from error
  finally:
    _remove_partial(partial)
  return output


def _remove_partial(path: str) -> None:
  """Removes a partial download or write, if there is one (best effort)."""
  try:
    os.remove(path)
  except OSError:
    pass


def _output_error(output: str,
                  jobs: Sequence[Tuple[str, Any, str]]) -> Optional[str]:
  """Why `--output` or a monthly file cannot be written there, or None.

  Args:
    output: The joined file.
    jobs: (month, request, monthly file) of each request.

  Returns:
    A one-line error, or None when the paths are usable.
  """
  separators = tuple(s for s in (os.sep, os.altsep, '/') if s)
  if output.endswith(separators) or os.path.isdir(output):
    return (f'--output {output} is a directory; give a file name such as '
            f'{os.path.join(output, "era5_paper.nc")}')
  parent = os.path.dirname(os.path.abspath(output))
  while not os.path.exists(parent):  # Created later: check what exists.
    parent = os.path.dirname(parent)
  if not os.path.isdir(parent):
    return f'--output {output}: {parent} is not a directory'
  for month, _, target in jobs:
    if os.path.isdir(target):
      return f'{target} (the file for {month}) is a directory'
  return None


def _credentials_error() -> Optional[str]:
  """Why cdsapi would have no credentials, or None if it has some."""
  if os.environ.get('CDSAPI_URL') and os.environ.get('CDSAPI_KEY'):
    return None
  rc = os.environ.get('CDSAPI_RC', os.path.expanduser('~/.cdsapirc'))
  if os.path.isfile(rc):
    return None
  return (f'no CDS API credentials: {rc} does not exist and CDSAPI_URL / '
          'CDSAPI_KEY are not set. Create a CDS account, then write\n'
          '  url: https://cds.climate.copernicus.eu/api\n'
          '  key: <your personal access token>\n'
          f'to {rc} (see https://cds.climate.copernicus.eu/how-to-api) and '
          'accept the ERA5 licence on the dataset page.')


_PROG = 'ble-latex-download-era5'
# The command's own flags (`cli.run_absl`).
FLAGS = flags.FlagValues()
flags.DEFINE_string('output', 'era5_paper.nc',
                    'Joined NetCDF file (monthly files go beside it).',
                    flag_values=FLAGS)
flags.DEFINE_float('center_lat', gridded.PAPER_CENTER_LAT,
                   'Target latitude [deg N].', flag_values=FLAGS)
flags.DEFINE_float('center_lon', gridded.PAPER_CENTER_LON,
                   'Target longitude [deg E].', flag_values=FLAGS)
flags.DEFINE_string('start_date', era5_requests.PAPER_START_DATE.isoformat(),
                    'First day, YYYY-MM-DD (inclusive).', flag_values=FLAGS)
flags.DEFINE_string('end_date', era5_requests.PAPER_END_DATE.isoformat(),
                    'Last day, YYYY-MM-DD (inclusive).', flag_values=FLAGS)
flags.DEFINE_float('half_width_deg', era5_requests.DEFAULT_HALF_WIDTH_DEG,
                   'Area = target +- this [deg].', flag_values=FLAGS)
flags.DEFINE_float('grid_deg', era5_requests.PAPER_GRID_DEG,
                   'Grid spacing [deg].', flag_values=FLAGS)
flags.DEFINE_float('min_pressure_hpa', era5_requests.PAPER_MIN_PRESSURE_HPA,
                   'Lowest pressure level [hPa].', flag_values=FLAGS)
flags.DEFINE_float('max_pressure_hpa', era5_requests.PAPER_MAX_PRESSURE_HPA,
                   'Highest pressure level [hPa].', flag_values=FLAGS)
flags.DEFINE_boolean('dry_run', False,
                     'Print the CDS requests as JSON; no network.',
                     flag_values=FLAGS)
flags.DEFINE_boolean('overwrite', False,
                     'Download months whose file already exists.',
                     flag_values=FLAGS)
flags.DEFINE_enum('source', 'cds', ['cds', 'arco'],
                  'cds: the Copernicus Climate Data Store (account, queue, '
                  'regridded to --grid_deg); arco: Google\'s public ARCO-ERA5 '
                  'Zarr store (anonymous, native 0.25 deg grid; needs '
                  f"{era5_arco.EXTRA}).", flag_values=FLAGS)
flags.DEFINE_string('store', era5_arco.DEFAULT_STORE,
                    'The Zarr store --source=arco reads (path or URL).',
                    flag_values=FLAGS)
flags.DEFINE_boolean('no_merge', False,
                     'Keep the monthly files only (use a glob such as '
                     "'era5_paper_*.nc' as GriddedWindField.path).",
                     flag_values=FLAGS)


def _date(name: str) -> dt.date:
  """The date flag `name`, parsed."""
  text = FLAGS[name].value
  try:
    return dt.date.fromisoformat(text)
  except ValueError as error:
    raise cli.CommandUsageError(
        f'--{name}: expected a date YYYY-MM-DD, got {text!r}') from error


# ERA5 reaches back to 1940 (Hersbach et al. 2020, with the back extension).
_FIRST_YEAR = 1940


def _check() -> None:
  for name in ('start_date', 'end_date'):
    year = _date(name).year
    if not _FIRST_YEAR <= year <= dt.date.today().year + 1:
      raise cli.CommandUsageError(
          f'--{name}: ERA5 covers {_FIRST_YEAR} to now, got year {year}')
  if not -90.0 <= FLAGS.center_lat <= 90.0:
    raise cli.CommandUsageError(
        f'--center_lat must be in [-90, 90] deg, got {FLAGS.center_lat:g}')
  if FLAGS.source == 'arco':
    for name, why in (('grid_deg', "ARCO-ERA5 keeps the store's native grid "
                       '(0.25 deg)'),
                      ('no_merge', '--source=arco writes one file'),
                      ('overwrite', '--source=arco always writes --output')):
      if FLAGS[name].present:
        raise cli.CommandUsageError(f'--{name} is for --source=cds only: '
                                    f'{why}')
  elif FLAGS['store'].present:
    raise cli.CommandUsageError('--store is for --source=arco only')


def _main(argv: Sequence[str]) -> int:
  """Downloads (or, --dry_run, prints) the requests; returns the status."""
  args = FLAGS
  try:
    requests = era5_requests.build_requests(
        center_lat=args.center_lat, center_lon=args.center_lon,
        start_date=_date('start_date'), end_date=_date('end_date'),
        half_width_deg=args.half_width_deg, grid_deg=args.grid_deg,
        min_pressure_hpa=args.min_pressure_hpa,
        max_pressure_hpa=args.max_pressure_hpa)
  except ValueError as error:
    print(f'{_PROG}: error: {error}', file=sys.stderr)
    return 2
  if args.source == 'arco':
    return _arco_main(requests)
  jobs = [(month, request, monthly_path(args.output, month))
          for month, request in requests]
  problem = _output_error(args.output, jobs)
  if problem:
    print(f'{_PROG}: error: {problem}', file=sys.stderr)
    return 2
  if args.dry_run:
    print(json.dumps({
        'dataset': era5_requests.DATASET,
        'output': None if args.no_merge else args.output,
        'requests': [{'month': month, 'target': target, 'request': request}
                     for month, request, target in jobs]}, indent=2))
    return 0

  todo = [job for job in jobs if args.overwrite or not os.path.isfile(job[2])]
  if todo:
    problem = _credentials_error()
    if problem:
      print(f'{_PROG}: error: {problem}', file=sys.stderr)
      return 2
    import cdsapi  # pylint: disable=g-import-not-at-top
    client = cdsapi.Client()
    for month, request, target in todo:
      print(f'requesting {era5_requests.DATASET} {month} -> {target}',
            flush=True)
      os.makedirs(os.path.dirname(os.path.abspath(target)), exist_ok=True)
      partial = target + '.part'
      try:  # No partial download is left behind, whatever happens.
        try:
          client.retrieve(era5_requests.DATASET, request, partial)
        except Exception as error:  # pylint: disable=broad-except
          print(f'{_PROG}: error: CDS request for {month} failed '
                f'({type(error).__name__}: {error}). Check your token in '
                '~/.cdsapirc and that you accepted the ERA5 licence on the '
                'dataset page.', file=sys.stderr)
          return 1
        os.replace(partial, target)
      finally:
        _remove_partial(partial)
  targets: List[str] = [target for _, _, target in jobs]
  try:
    if args.no_merge:
      data = gridded.load(targets)
    else:
      merge_files(targets, args.output)
      data = gridded.load(args.output)
  except (OSError, ValueError) as error:
    print(f'{_PROG}: error: {error}', file=sys.stderr)
    return 1
  _print_written(args.output if not args.no_merge else targets, data)
  return 0


def _print_written(what: Any, data: gridded.Era5Data) -> None:
  """Prints what was written and the data's extent."""
  print(f'wrote {what}: '
        f'{data.times.size} times {data.start:%Y-%m-%d %H:%M} to '
        f'{data.end:%Y-%m-%d %H:%M} UTC, pressure {data.pressure.min():.0f}-'
        f'{data.pressure.max():.0f} Pa, lat {data.latitude[0]:g}..'
        f'{data.latitude[-1]:g}, lon {data.longitude[0]:g}..'
        f'{data.longitude[-1]:g}')


def _arco_main(requests: Sequence[Tuple[str, Any]]) -> int:
  """--source=arco: the requests' winds from the Zarr store, one file.

  Args:
    requests: `era5_requests.build_requests` output (its grid is not used).

  Returns:
    The exit status: 0, 1 (the store cannot be read or lacks the data, the
    output cannot be written), 2 (usage: --output, zarr/gcsfs missing).
  """
  args = FLAGS
  problem = _output_error(args.output, [])
  if problem:
    return cli.usage(_PROG, problem)
  if args.dry_run:
    print(json.dumps({'source': 'arco', 'output': args.output,
                      **era5_arco.describe(requests, args.store)}, indent=2))
    return 0
  try:
    era5_arco.require_packages(args.store)
  except era5_arco.ArcoUnavailableError as error:
    return cli.usage(_PROG, str(error))
  print(f'reading ARCO-ERA5 {args.store} -> {args.output}', flush=True)
  try:
    era5_arco.fetch(requests, args.output, store=args.store)
    data = gridded.load(args.output)
  except (OSError, ValueError) as error:
    print(f'{_PROG}: error: {error}', file=sys.stderr)
    return 1
  _print_written(args.output, data)
  return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
  """The command (`cli.run_absl`); returns the exit status."""
  return cli.run_absl(_main, _PROG, FLAGS, argv,
                      doc=__doc__, check=_check)


if __name__ == '__main__':
  sys.exit(main())
