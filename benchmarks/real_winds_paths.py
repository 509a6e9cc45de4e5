r"""Flight paths of agents over a real GFS domain (issue 45 item 6): a figure.

  nice -n 10 python benchmarks/real_winds_paths.py \
      [--source=gfs_namerica] [--agents=sac_pretrained,latex_station_seeker] \
      [--seeds=8] [--png=docs/assets/real_winds_paths.png] \
      [--json=benchmarks/records/real_winds_paths.json]

Flies the suite's (--suite, default latex_small) first --seeds seeds of
each agent on a real source (`ble_latex.wind.sources.SOURCES`, a GFS grid)
as that script's `--station_mode=per_seed` does: `eval_lib.evaluate` (the
batched path for the JAX-core agents) on the `--wind_file` bindings
(`wind_file.era5_bindings`) plus `wind_file.cell_station_bindings` of a
per-seed cell (seed s at station s; --station_bindings adds bindings,
recorded), every
flight time-invariant (the snapshot is the forecast, the truth the snapshot
plus BLE's simplex noise). The eval records hold each flight's path in its
station's frame (x east, y north [km]); `jax_env.flight_stations` gives each
seed's station and `globe.latlng_of_offset` (BLE's great-circle offset, the
one the wind field reads the file with) turns the path into lat/lon.

The PNG (--png): one panel per agent, lat/lon axes over the file's domain
(the grid's extent drawn as a rectangle), each flight's track (a dot at its
launch, a cross where it ended), its station with the station-keeping
radius (50 km) circle; the title names the file and "time-invariant".
The JSON (--json): the command, date, machine, load average before/after,
the commit, settings and, per flight, its station, TW50 (window and flown),
terminal reason and final distance -- and, where `benchmarks/records/real_winds.json`
holds the same cell (same settings), the TW50 it recorded for that seed.
"""

import datetime as dt
import json
import os
import platform
import sys
import time
from typing import Any, Dict, List, Optional, Sequence, Tuple

from absl import flags

import ble_latex  # pylint: disable=unused-import  # Fixes first.
from ble_latex import safe_io
from ble_latex.cli import common as cli
from ble_latex.run import episode_log
from ble_latex.run import provenance
from ble_latex.run import wind_file
from ble_latex.wind import sources

_HERE = os.path.dirname(os.path.abspath(__file__))
_ROOT = os.path.dirname(_HERE)
DEFAULT_AGENTS = ('sac_pretrained', 'latex_station_seeker')
# The agents flown: `benchmarks/real_winds.py`'s of the same names.
AGENTS = ('sac_pretrained', 'latex_station_seeker', 'latex_random',
          'latex_mpc', 'latex_mpc_oracle', 'ble_station_seeker_discrete')

FLAGS = flags.FlagValues()
flags.DEFINE_enum('source', 'gfs_namerica', sources.GRIDS, 'The GFS grid '
                  'flown (ble_latex.wind.sources.SOURCES).',
                  flag_values=FLAGS)
flags.DEFINE_list('agents', list(DEFAULT_AGENTS), 'Agents flown (one panel '
                  f'each), of {list(AGENTS)}.', flag_values=FLAGS)
flags.DEFINE_integer('seeds', 8, "The suite's first N seeds.", lower_bound=1,
                     flag_values=FLAGS)
flags.DEFINE_string('suite', 'latex_small', 'Suite whose first seeds fly.',
                    flag_values=FLAGS)
flags.DEFINE_multi_string('station_bindings', [], 'More gin bindings of the '
                          'per-seed stations (as real_winds.py\'s).',
                          flag_values=FLAGS)
flags.DEFINE_string('realdata_dir', sources.REALDATA_DIR,
                    'Folder of the real files (PROVENANCE.md).',
                    flag_values=FLAGS)
flags.DEFINE_string('png', os.path.join(_ROOT, 'docs', 'assets',
                                        'real_winds_paths.png'),
                    'The figure.', flag_values=FLAGS)
flags.DEFINE_string('json', str(episode_log.RECORDS_DIR / 'real_winds_paths.json'),
                    'The record (rewritten).', flag_values=FLAGS)
flags.DEFINE_integer('max_episode_length', None, 'Cap on the strides (a '
                     'smoke test; default the suite\'s).', lower_bound=1,
                     flag_values=FLAGS)


def fly(path: str, agent: str, seeds: Sequence[int], suite: str,
        cell: Dict[str, Any], max_steps: int
        ) -> Tuple[List[Dict[str, Any]], Dict[str, Any]]:
  """Flies `seeds` of `agent` on the grid `path`: (records, about the run).

  The records are `eval_lib.evaluate`'s (with `flight_path`), each with its
  station's `station_lat`/`station_lon` [deg].
  """
  # pylint: disable=g-import-not-at-top
  import gin
  from ble_latex.envs import env_params
  from ble_latex.envs import jax_env
  from ble_latex.run import batch_eval
  from ble_latex.run import eval_lib
  from ble_latex.run import suites
  # pylint: enable=g-import-not-at-top
  gin.clear_config()  # `era5_bindings` reads what gin binds.
  bindings = (
      wind_file.era5_bindings(path, suites.era5_dates(suite), 'eval') +
      wind_file.cell_station_bindings(cell))
  agent_obj, env = eval_lib.build(eval_lib.EvalSpec(
      agent=agent, gin_bindings=tuple(bindings)))
  began = time.perf_counter()
  records = eval_lib.evaluate(agent_obj, env, seeds, max_steps,
                              description=f'{os.path.basename(path)} {agent}')
  wall = time.perf_counter() - began
  stations = jax_env.flight_stations(env_params.params_from_gin(),
                                     [r['seed'] for r in records])
  if stations is None:
    raise cli.CommandUsageError(f'{path}: no stations (not a wind file?)')
  records = [{**r, 'station_lat': float(lat), 'station_lon': float(lon)}
             for r, (lat, lon) in zip(records, stations)]
  # 'analysis (time-invariant): [paths]' -> its description (no paths).
  about = {'wind_source': env_params.wind_source().split(': [')[0],
           'radius_km': float(env.radius.kilometers),
           'batched': batch_eval.flies_batched(agent_obj, env),
           'fly_s': round(wall, 1)}
  return records, about


def draw(path: str, title: str, panels: Dict[str, List[Dict[str, Any]]],
         radius_km: float, png: str) -> None:
  """The figure: one panel per agent of its flights over the file's domain."""
  # pylint: disable=g-import-not-at-top
  from matplotlib import figure as mpl_figure
  from matplotlib import patches as mpl_patches
  from matplotlib.backends import backend_agg
  import numpy as np
  from ble_latex.run import tracks
  from ble_latex.wind import gridded
  # pylint: enable=g-import-not-at-top
  data = gridded.load(path)
  west, east = data.longitude[0], data.longitude[-1]
  west, east = (float((lon + 180.0) % 360.0 - 180.0) for lon in (west, east))
  south, north = sorted((float(data.latitude[0]), float(data.latitude[-1])))
  fig = mpl_figure.Figure(figsize=(6.0 * len(panels), 6.0),
                          layout='constrained')
  axes = np.atleast_1d(fig.subplots(1, len(panels), sharey=True))
  colors = [f'C{i % 10}' for i in range(10)]
  for ax, (agent, records) in zip(axes, panels.items()):
    ax.add_patch(mpl_patches.Rectangle(
        (west, south), east - west, north - south, fill=False, color='0.3',
        lw=1.2, ls='--', label='wind file domain'))
    for i, r in enumerate(records):
      color = colors[i % len(colors)]
      lats, lons = tracks.path_lat_lon(r['station_lat'], r['station_lon'],
                                       r['flight_path'])
      ax.plot(lons, lats, color=color, lw=1.0,
              label=f"seed {r['seed']}: TW50 {100 * r['tw50_window']:.0f} %")
      ax.plot(lons[0], lats[0], 'o', color=color, ms=3)
      ax.plot(lons[-1], lats[-1], 'x', color=color, ms=5)
      clats, clons = tracks.circle_lat_lon(r['station_lat'],
                                           r['station_lon'], radius_km)
      ax.plot(clons, clats, color=color, lw=0.8)
      ax.plot(r['station_lon'], r['station_lat'], '*', color=color, ms=7,
              mec='k', mew=0.4)
    mean = 100 * float(np.mean([r['tw50_window'] for r in records]))
    ax.set_title(f'{agent} ({len(records)} flights, TW50 window mean '
                 f'{mean:.1f} %)', fontsize=10)
    ax.set_xlabel('longitude [deg E]')
    pad_lon, pad_lat = 0.03 * (east - west), 0.03 * (north - south)
    ax.set_xlim(west - pad_lon, east + pad_lon)
    ax.set_ylim(south - pad_lat, north + pad_lat)
    # Degrees of longitude shrink by cos(latitude): equal km both ways.
    ax.set_aspect(1.0 / np.cos(np.radians(0.5 * (south + north))))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc='upper center', bbox_to_anchor=(0.5, -0.13),
              ncol=3)
  axes[0].set_ylabel('latitude [deg N]')
  fig.suptitle(f'{title}\nstar: station, circle: {radius_km:g} km, dot: '
               'launch, cross: end', fontsize=10)
  os.makedirs(os.path.dirname(os.path.abspath(png)), exist_ok=True)
  backend_agg.FigureCanvasAgg(fig)
  fig.savefig(png, dpi=110)


def recorded_tw50(source: str, agent: str, cell: Dict[str, Any],
                  record_path: str) -> Dict[int, float]:
  """seed -> tw50_window of benchmarks/records/real_winds.json's same cell, if any."""
  if not os.path.exists(record_path):
    return {}
  try:
    with open(record_path, encoding='utf-8') as f:
      cells = json.load(f)['cells']
  except (ValueError, KeyError, TypeError) as e:
    raise cli.CommandFailure(f'{record_path}: not a real_winds record '
                             f'({type(e).__name__}: {e})') from e
  old = cells.get(f'{source}/{agent}/per_seed')
  if not isinstance(old, dict) or wind_file.differing(
      old.get('settings') or {}, cell):
    return {}
  return {r['seed']: r['tw50_window'] for r in old['flights']}


def _shown(path: str) -> str:
  """`path` relative to the checkout when inside it, else absolute."""
  path = os.path.abspath(path)
  inside = os.path.commonpath([path, _ROOT]) == _ROOT
  return os.path.relpath(path, _ROOT) if inside else path


def run(*, source: str, path: str, agents: Sequence[str], seeds: int,
        suite: str, station_bindings: Sequence[str], png: str,
        json_path: str, max_steps: Optional[int], command: str,
        real_winds_json: Optional[str] = None) -> Dict[str, Any]:
  """Flies the agents, draws `png`, writes `json_path`; returns the record."""
  from ble_latex.run import suites  # pylint: disable=g-import-not-at-top
  version = provenance.code_version()
  suite_seeds = list(suites.get_eval_suite(suite).seeds)[:seeds]
  steps = max_steps or suites.get_eval_suite(suite).max_episode_length
  load_before = [round(x, 2) for x in os.getloadavg()]
  date = dt.datetime.now(dt.timezone.utc).isoformat(timespec='minutes')
  panels, flights, runs, radius_km, wind_source = {}, [], {}, None, None
  for agent in agents:
    # The cell `real_winds.py --station_mode=per_seed` records.
    cell = {'source': source, 'file': os.path.relpath(
        path, os.path.dirname(os.path.dirname(path))), 'agent': agent,
            'suite': suite, 'max_steps': max_steps,
            'station_mode': 'per_seed',
            **wind_file.station_settings(source, path, 'per_seed',
                                         station_bindings)}
    records, about = fly(path, agent, suite_seeds, suite, cell, steps)
    radius_km, wind_source = about.pop('radius_km'), about.pop('wind_source')
    runs[agent] = about
    panels[agent] = records
    before = (recorded_tw50(source, agent, cell, real_winds_json)
              if real_winds_json else {})
    for r in records:
      flights.append({
          'agent': agent, 'seed': r['seed'],
          'station_lat': round(r['station_lat'], 4),
          'station_lon': round(r['station_lon'], 4),
          **{k: r[k] for k in ('tw50_window', 'tw50', 'steps',
                               'terminal_reason', 'final_distance_km')},
          **({'real_winds_json_tw50_window': before[r['seed']]}
             if r['seed'] in before else {})})
  title = (f'{os.path.basename(path)}, {wind_source}: {len(suite_seeds)} '
           f'{suite} seeds at per-seed stations')
  draw(path, title, panels, radius_km, png)
  record = {
      'about': ('benchmarks/real_winds_paths.py: flight paths of agents over '
                'a real GFS domain (time-invariant snapshot; truth = snapshot '
                '+ BLE simplex noise); the figure is --png.'),
      'command': command, 'date_utc': date, 'host': platform.node(),
      'cpus': os.cpu_count(), 'loadavg_before': load_before,
      'loadavg_after': [round(x, 2) for x in os.getloadavg()], **version,
      'source': source, 'file': os.path.basename(path),
      'wind_source': wind_source, 'suite': suite, 'seeds': len(suite_seeds),
      'max_steps': max_steps, 'station_mode': 'per_seed',
      **wind_file.station_settings(source, path, 'per_seed',
                                   station_bindings),
      'track_coordinates': 'lat/lon (globe.latlng_of_offset of the station '
                           'frame)',
      'radius_km': radius_km, 'png': _shown(png),
      'runs': runs, 'flights': flights}
  safe_io.atomic_write(json_path, json.dumps(record, indent=1) + '\n')
  return record


def _main(argv: Sequence[str]) -> None:
  del argv
  unknown = [a for a in FLAGS.agents if a not in AGENTS]
  if unknown:
    raise cli.CommandUsageError(f'--agents: unknown {unknown} (known: '
                                f'{list(AGENTS)})')
  path = sources.path(FLAGS.source, FLAGS.realdata_dir)
  if not os.path.isfile(path):
    raise cli.CommandUsageError(f'{path}: no such file (--realdata_dir)')
  command = ' '.join(['python', 'benchmarks/real_winds_paths.py',
                      *sys.argv[1:]])
  record = run(source=FLAGS.source, path=path, agents=FLAGS.agents,
               seeds=FLAGS.seeds, suite=FLAGS.suite,
               station_bindings=FLAGS.station_bindings, png=FLAGS.png,
               json_path=FLAGS.json, max_steps=FLAGS.max_episode_length,
               command=command,
               real_winds_json=str(episode_log.RECORDS_DIR / 'real_winds.json'))
  for agent, about in record['runs'].items():
    tw = [f['tw50_window'] for f in record['flights'] if f['agent'] == agent]
    print(json.dumps({'agent': agent, 'tw50_window': [round(t, 4) for t in tw],
                      **about}), flush=True)


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'real_winds_paths.py', FLAGS, argv, doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
