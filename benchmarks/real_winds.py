r"""Agents flown on the real wind sources (issue 45 item 6): the record.

  nice -n 10 python benchmarks/real_winds.py \
      [--sources=gfs_namerica,gfs_global,boise,hilo] \
      [--agents=sac_pretrained,latex_station_seeker,latex_random] \
      [--seeds=100 | --seeds=gfs_namerica:100,boise:20] \
      [--station_mode=center] [--json=benchmarks/records/real_winds.json]

Each (source, agent, station mode) is one cell: the suite's (--suite,
default latex_small) first N seeds flown by `eval_lib.evaluate` (the
batched path, `run/batch_eval.py`, for the JAX-core agents; the one-at-a-
time path for `latex_random`, whose one random stream runs through the
seeds in order, and for `ble_station_seeker_discrete`, BLE's
`station_seeker` on `LatexBalloonDiscrete-v0`; the planners by
`run/planner_batch.py`'s `fly_planner`, batched without BLE's gym env), on
the source's and the station's gin bindings (`run/wind_file.py`,
`cell_bindings`). The sources: `ble_latex.wind.sources.SOURCES`. Every
real source here is one time step: it flies time-invariant, the analysis
(or the sounding's column) being the forecast the agents see, the truth the
same plus BLE's simplex noise; the seeds draw the noise (and on a sounding
nothing else).

Stations (--station_mode, recorded in each cell):
  * `center`: a GFS grid's station is the file's fixed centre (the middle of
    its latitudes and longitudes: every seed flies the same station); a
    sounding's is its launch site (`SOURCES`; a sounding is the same column
    everywhere, the site only places the sun; `wind.sources.center`);
  * `per_seed` (GFS grids only): seed s at station s of the domain (issue 45
    item 4): binds `GriddedWindField.stations = 'per_seed'`, plus any
    --station_bindings (e.g. `GriddedWindField.station_margin_km = 400`); the
    bindings are recorded. The per-seed stations were being added to envs/
    and wind/gridded* when this script was written: until they land this mode
    fails on the unknown binding.

The record (--json) holds one entry per cell under 'cells': its settings,
the seeds' compact records (no flight paths), their summary
(`metrics.summarize`) and the runs that flew them (command, date, machine,
load average before/after, wall seconds). Resumable: a cell whose settings
match flies only the seeds it lacks and merges them; a cell flown with other
settings is refused (name the difference) unless --overwrite. The file is
rewritten after every --chunk seeds of a cell (default 25), so a run cut
short keeps its finished chunks (a planner's cell on 2 CPU cores takes
long enough to span sessions). Each write rereads the record under its lock
(`.real_winds.json.lock`), so runs on other cells (one source per core) may
share one record. `docs/hooks/tables.py` ('real-winds') renders the table
from it.
"""

import datetime as dt
import json
import math
import os
import platform
import sys
from typing import Any, Dict, List, Optional, Sequence, Tuple

from absl import flags

import ble_latex  # pylint: disable=unused-import  # Fixes first.
from ble_latex import errors
from ble_latex import safe_io
from ble_latex.cli import common as cli
from ble_latex.run import episode_log
from ble_latex.run import provenance
from ble_latex.run import real_cells
from ble_latex.run import wind_file
from ble_latex.wind import sources

_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SOURCES = sources.SOURCES
# How long a chunk's write waits for another run's write of the record. # [s]
RECORD_WAIT_S = 60.0
AGENTS = ('sac_pretrained', 'latex_station_seeker', 'latex_random',
          'latex_mpc', 'latex_mpc_oracle', 'ble_station_seeker_discrete')
CHEAP_AGENTS = AGENTS[:3]

FLAGS = flags.FlagValues()
flags.DEFINE_list('sources', list(SOURCES), f'Sources flown, of {list(SOURCES)}.',
                  flag_values=FLAGS)
flags.DEFINE_list('agents', list(CHEAP_AGENTS), f'Agents flown, of '
                  f'{list(AGENTS)} (the planners are slow on a CPU).',
                  flag_values=FLAGS)
flags.DEFINE_list('seeds', ['100'], 'Seeds per source: N for every source, or '
                  'SOURCE:N entries (sources not named: 100).',
                  flag_values=FLAGS)
flags.DEFINE_string('suite', 'latex_small', 'Suite whose first seeds fly.',
                    flag_values=FLAGS)
flags.DEFINE_enum('station_mode', 'center', sources.STATION_MODES,
                  'Where the station is (see the module).',
                  flag_values=FLAGS)
flags.DEFINE_multi_string('station_bindings', [], 'More gin bindings of '
                          '--station_mode=per_seed.', flag_values=FLAGS)
flags.DEFINE_string('realdata_dir', sources.REALDATA_DIR,
                    'Folder of the real files (PROVENANCE.md).',
                    flag_values=FLAGS)
flags.DEFINE_string('json', str(episode_log.RECORDS_DIR / 'real_winds.json'),
                    'The record (merged).', flag_values=FLAGS)
flags.DEFINE_integer('max_episode_length', None, 'Cap on the strides (a '
                     'smoke test; default the suite\'s).', lower_bound=1,
                     flag_values=FLAGS)
flags.DEFINE_multi_string(
    'source_copy', [], 'NAME=PATH@SHA256: fly source NAME from PATH, a NetCDF '
    'copy of its GRIB2 (benchmarks/gpu/decode_grib.py, for a machine '
    'without eccodes), refused unless the copy reads to arrays of that '
    'SHA-256 (decode_grib.py prints the original\'s); the run records it.',
    flag_values=FLAGS)
flags.DEFINE_integer('chunk', 25, 'Seeds flown between two writes of the '
                     'record (a cut run keeps its finished chunks).',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_boolean('overwrite', False, 'Re-fly cells flown with other '
                     'settings.', flag_values=FLAGS)


def settings(name: str, agent: str, path: str) -> Dict[str, Any]:
  """What a cell's records depend on (a resume must match all of it).

  The truth's noise scale too (`wind.forecast_error`, the file's default):
  cells flown before it was recorded (at scale 1) are refused on resume.
  """
  # pylint: disable=g-import-not-at-top
  from ble_latex.wind import forecast_error
  from ble_latex.wind import gridded
  # pylint: enable=g-import-not-at-top
  scale = forecast_error.noise_scale(None, gridded.load(path).source)
  return {'source': name, 'file': os.path.relpath(path, FLAGS.realdata_dir),
          'agent': agent, 'suite': FLAGS.suite,
          'max_steps': FLAGS.max_episode_length,
          'noise_scale': round(scale, 4),
          **wind_file.station_settings(name, path, FLAGS.station_mode,
                                       FLAGS.station_bindings)}


def load_record(path: str) -> Dict[str, Any]:
  """The record at `path` ({'cells': {}} if none); one line if unreadable."""
  if not os.path.exists(path):
    return {'cells': {}}
  try:
    with open(path, encoding='utf-8') as f:
      record = json.load(f)
  except (json.JSONDecodeError, UnicodeDecodeError) as e:
    raise cli.CommandFailure(f'{path}: truncated or not JSON ({e}); fix or '
                             'move it, or give another --json') from e
  if not isinstance(record, dict) or not isinstance(record.get('cells'),
                                                    dict):
    raise cli.CommandUsageError(f'{path}: not a real_winds record (no '
                                "'cells')")
  return record


# What a compact flight's fields may hold: (type check, range) by field.
_UNIT = (0.0, 1.0)
_NON_NEGATIVE = (0.0, math.inf)
_FLIGHT_FIELDS = {'tw50': _UNIT, 'tw50_window': _UNIT,
                  'helium_vented_mols': _NON_NEGATIVE,
                  'sand_dropped_kg': _NON_NEGATIVE,
                  'final_distance_km': _NON_NEGATIVE,
                  'reward': (-math.inf, math.inf)}


def checked_cell(record: Dict[str, Any], key: str, path: str,
                 suite_seeds: Sequence[int]) -> Optional[Dict[str, Any]]:
  """The record's cell `key`, its flights checked before they are merged.

  Raises:
    cli.CommandFailure: One line naming the file, cell, flight and field:
      a cell without settings, runs or flights; a flight of a seed outside
      the suite or flown twice, a TW50 outside [0, 1], a negative or
      non-finite amount, a count that is no integer >= 0.
  """
  cell = record['cells'].get(key)
  if cell is None:
    return None
  where = f'{path}: cell {key}'

  def bad(what: str) -> cli.CommandFailure:
    return cli.CommandFailure(f'{where}: {what} (not a real_winds record; '
                              '--overwrite re-flies the cell)')

  if not (isinstance(cell, dict) and isinstance(cell.get('settings'), dict)
          and isinstance(cell.get('flights'), list) and
          isinstance(cell.get('runs', []), list)):
    raise bad('needs settings (object), flights and runs (lists)')
  allowed, seen = set(suite_seeds), set()
  for i, flight in enumerate(cell['flights']):
    if not isinstance(flight, dict) or any(k not in flight for k in real_cells.KEPT):
      raise bad(f'flight {i} lacks fields of {list(real_cells.KEPT)}')
    seed = flight['seed']
    if isinstance(seed, bool) or not isinstance(seed, int) or (
        seed not in allowed):
      raise bad(f'flight {i}: seed {seed!r} is not a seed of suite '
                f'{cell["settings"].get("suite")!r}')
    if seed in seen:
      raise bad(f'seed {seed} flown twice')
    seen.add(seed)
    for field, (low, high) in _FLIGHT_FIELDS.items():
      value = flight[field]
      if (isinstance(value, bool) or not isinstance(value, (int, float)) or
          not math.isfinite(value) or not low <= value <= high):
        raise bad(f'seed {seed}: {field} {value!r} is not a finite number '
                  f'in [{low:g}, {high:g}]')
    for field in ('steps', 'window_steps'):
      value = flight[field]
      if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise bad(f'seed {seed}: {field} {value!r} is not an integer >= 0')
    if not isinstance(flight['terminal_reason'], str):
      raise bad(f'seed {seed}: terminal_reason {flight["terminal_reason"]!r}'
                ' is not a string')
  return cell


def source_copies(entries: Sequence[str]) -> Dict[str, Tuple[str, str]]:
  """--source_copy: {name: (copy path, arrays' SHA-256)}, each checked
  (`sources.checked_copy`)."""
  copies = {}
  for entry in entries:
    name, _, rest = entry.partition('=')
    path, _, sha = rest.rpartition('@')
    if name not in SOURCES or not path or len(sha) != 64:
      raise cli.CommandUsageError(f'--source_copy: {entry!r} is not '
                                  'NAME=PATH@SHA256 with NAME among '
                                  f'{list(SOURCES)}')
    try:
      sources.checked_copy(path, sha)
    except FileNotFoundError as e:
      raise cli.CommandUsageError(f'--source_copy: {e}') from e
    except errors.BadFileError as e:
      raise cli.CommandFailure(f'--source_copy: {e}') from e
    copies[name] = (path, sha)
  return copies


def _main(argv: Sequence[str]) -> None:
  del argv
  version = provenance.code_version()  # Before the first import of the flight code.
  # pylint: disable=g-import-not-at-top
  from ble_latex.run import metrics
  from ble_latex.run import suites
  # pylint: enable=g-import-not-at-top
  unknown = [s for s in FLAGS.sources if s not in SOURCES]
  if unknown:
    raise cli.CommandUsageError(f'--sources: unknown {unknown} (known: '
                                f'{list(SOURCES)})')
  unknown = [a for a in FLAGS.agents if a not in AGENTS]
  if unknown:
    raise cli.CommandUsageError(f'--agents: unknown {unknown} (known: '
                                f'{list(AGENTS)})')
  soundings = [s for s in FLAGS.sources if sources.is_sounding(s)]
  if FLAGS.station_mode == 'per_seed' and soundings:
    raise cli.CommandUsageError(
        f'--station_mode=per_seed is for GFS grids: {soundings} are soundings '
        '(one column everywhere; they fly at their site, --station_mode='
        'center)')
  if FLAGS.station_bindings and FLAGS.station_mode != 'per_seed':
    raise cli.CommandUsageError('--station_bindings needs '
                                '--station_mode=per_seed')
  try:
    counts = real_cells.seeds_per_source(FLAGS.seeds, FLAGS.sources)
  except ValueError as e:
    raise cli.CommandUsageError(f'--seeds: {e}') from e
  suite_seeds = list(suites.get_eval_suite(FLAGS.suite).seeds)
  command = ' '.join(['python', 'benchmarks/real_winds.py', *sys.argv[1:]])
  # The record's folder, before anything is flown.
  cli.prepare_output_dir(os.path.dirname(os.path.abspath(FLAGS.json)),
                         '--json')
  record = load_record(FLAGS.json)
  copies = source_copies(FLAGS.source_copy)
  for name in FLAGS.sources:
    path = sources.path(name, FLAGS.realdata_dir)
    if not os.path.isfile(path):
      raise cli.CommandUsageError(f'{path}: no such file (--realdata_dir)')
    wanted = suite_seeds[:counts[name]]
    for agent in FLAGS.agents:
      cell = settings(name, agent, path)
      key = f'{name}/{agent}/{FLAGS.station_mode}'
      old = checked_cell(record, key, FLAGS.json, suite_seeds)
      differ = ([] if old is None else
                wind_file.differing(old['settings'], cell))
      if differ:
        if not FLAGS.overwrite:
          raise cli.CommandUsageError(
              f'{FLAGS.json}: cell {key} was flown with other settings '
              f'({", ".join(differ)}); --overwrite re-flies it')
        old = None
      flown = {r['seed']: r for r in (old or {}).get('flights', [])}
      todo = [s for s in wanted if s not in flown]
      if not todo:
        print(f'{key}: {len(wanted)} seeds already flown', file=sys.stderr)
        continue
      copy = copies.get(name)
      # A chunk of seeds at a time, the record rewritten after each: a run
      # cut short (a planner on a CPU takes hours) keeps its finished chunks.
      for at in range(0, len(todo), FLAGS.chunk):
        chunk = todo[at:at + FLAGS.chunk]
        load_before = [round(x, 2) for x in os.getloadavg()]
        date = dt.datetime.now(dt.timezone.utc).isoformat(timespec='minutes')
        flights, source, batched, wall = real_cells.fly_cell(
            cell, copy[0] if copy else path, chunk)
        if copy:  # The copy reads as a plain NetCDF ('ERA5'): name the file.
          source = (f'GRIB2 (time-invariant): {[os.path.abspath(path)]}, '
                    f'flown from its decoded NetCDF copy '
                    f'{os.path.basename(copy[0])}')
        flown.update({r['seed']: r for r in flights})
        run = {
            'command': command, 'date_utc': date, 'host': platform.node(),
            'cpus': os.cpu_count(), 'loadavg_before': load_before,
            'loadavg_after': [round(x, 2) for x in os.getloadavg()],
            'seeds': len(chunk), 'fly_s': round(wall, 1),
            'batched': batched, **version,
            **({'flown_from_copy': os.path.basename(copy[0]),
                'arrays_sha256': copy[1]} if copy else {})}
        # Another run (other cells, e.g. one per source on two cores, or
        # this cell restarted while it still runs) may have written: reread
        # and merge by seed under the record's lock, never replace.
        with safe_io.locked_file(FLAGS.json, what='real_winds record',
                                 wait_s=RECORD_WAIT_S):
          record = load_record(FLAGS.json)
          current = checked_cell(record, key, FLAGS.json, suite_seeds)
          runs = [run]
          if current is not None and not wind_file.differing(
              current['settings'], cell):
            flown.update({r['seed']: r for r in current['flights']
                          if r['seed'] not in flown})
            runs = current.get('runs', []) + runs
          elif old is not None:  # --overwrite of a cell flown before.
            runs = [*old.get('runs', []), run]
          merged = [flown[s] for s in sorted(flown)]
          old = record['cells'][key] = {
              'settings': cell, 'label': SOURCES[name].label,
              'wind_source': source, 'summary': metrics.summarize(merged),
              'runs': runs, 'flights': merged}
          record['about'] = (
              'benchmarks/real_winds.py: agents on real wind sources (time-'
              'invariant snapshots; truth = snapshot + BLE simplex noise). '
              'Files and licences: shared/realdata/PROVENANCE.md.')
          safe_io.atomic_write(FLAGS.json,
                               json.dumps(record, indent=1) + '\n')
        s = old['summary']
        print(json.dumps({'cell': key, 'seeds': s['episodes'],
                          'tw50_window_mean': round(s['tw50_window_mean'], 4),
                          'out_of_resources_pct': s['out_of_resources_pct'],
                          'fly_s': round(wall, 1), 'batched': batched}),
              flush=True)


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'real_winds.py', FLAGS, argv, doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
