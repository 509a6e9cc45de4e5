r"""Does the feasibility map predict flown TW50? (issue 64 item 5)

  nice -n 10 python benchmarks/feasibility_tw50.py [--json=benchmarks/records/feasibility_tw50.json]

For every per-seed cell of the committed record
`benchmarks/records/real_winds_noise1.json` (`real_winds.py`'s record as flown
before issue 64's seam and noise default, at BLE's noise scale 1 and kept
as it was; the two shared GFS files, 100 `latex_small` seeds per agent;
--record another), the station
each seed flew (`jax_env.flight_stations`, as the eval records name it) and
the feasibility of the winds there (`wind.feasibility.at`: bilinear column,
the flight band's reachable winds, the signed distance of zero to their hull
[m/s], > 0 inside). Prints and records, per file and agent, Spearman's rank
correlation (`scipy.stats.spearmanr`) of that margin with the flight's TW50
over the window (`tw50_window`, the table's TW50), its p-value, and the mean
TW50 of the stations with zero inside and outside the hull; and the same
pooled over both files.

The global GRIB2's cells were flown before global grids became seamless
(5b5995c): their stations were drawn in the old box, which kept the
per-seed margin (400 km) from the longitudes 0 and 357.5 as from an edge;
this script draws them in that box (`stations.station_box(...,
global_longitude=False)` over the file's own longitudes), so each seed's
station is the one it flew. No flight is flown.
"""

import argparse
import datetime as dt
import json
import os
import platform
import subprocess
import sys

import numpy as np
import scipy.stats

from ble_latex import safe_io
from ble_latex.run import episode_log

HERE = os.path.dirname(os.path.abspath(__file__))
REAL = os.path.join(HERE, '..', '..', 'shared', 'realdata')


def flown_stations(path: str, seeds, old_global_box: bool) -> np.ndarray:
  """[N, 2] (lat, lon) each seed flew on `path` with per-seed stations."""
  # pylint: disable=g-import-not-at-top
  import jax.numpy as jnp
  from ble_latex.envs import env_params
  from ble_latex.envs import jax_env
  from ble_latex.wind import gridded
  from ble_latex.wind import stations
  # pylint: enable=g-import-not-at-top
  params = env_params.params_from_gin(wind_file=path)
  if old_global_box:
    data = gridded.load(path)
    box = stations.station_box(data.latitude, data.longitude[:-1],
                               stations.DEFAULT_MARGIN_KM,
                               global_longitude=False)
    params = params.replace(wind_grid=params.wind_grid.replace(
        station_box=jnp.asarray(box, jnp.float32)))
  return np.asarray(jax_env.flight_stations(params, seeds), np.float64)


def correlate(margin, tw50):
  rho, p = scipy.stats.spearmanr(margin, tw50)
  inside = margin >= 0.0
  return {'n': int(len(margin)), 'spearman_rho': round(float(rho), 3),
          'p_value': float(f'{p:.2g}'),
          'inside_stations': int(inside.sum()),
          'tw50_mean_inside': (round(float(np.mean(tw50[inside])), 4)
                               if inside.any() else None),
          'tw50_mean_outside': (round(float(np.mean(tw50[~inside])), 4)
                                if (~inside).any() else None)}


def main():
  parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
  parser.add_argument('--json', default=str(episode_log.RECORDS_DIR / 'feasibility_tw50.json'))
  parser.add_argument('--record', default=str(episode_log.RECORDS_DIR / 'real_winds_noise1.json'))
  args = parser.parse_args()
  if safe_io.output_problem(args.json):
    parser.error(f'--json: {safe_io.output_problem(args.json)}')
  # pylint: disable=g-import-not-at-top
  from ble_latex.wind import feasibility
  from ble_latex.wind import gridded
  # pylint: enable=g-import-not-at-top
  cells = json.load(open(args.record, encoding='utf-8'))['cells']
  now = dt.datetime.now(dt.timezone.utc)
  commit = subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], cwd=HERE,
                          capture_output=True, text=True).stdout.strip()
  out = {'command': 'python benchmarks/feasibility_tw50.py',
         'date': f'{now:%Y-%m-%d %H:%M} UTC', 'commit': commit,
         'machine': f'{platform.node()} ({os.cpu_count()} cores)',
         'load': round(os.getloadavg()[0], 1),
         'about': __doc__.split('\n\n')[2].replace('\n', ' '),
         'sources': {}, 'pooled': {}}
  pooled = {}
  by_source = {}
  for key, cell in cells.items():
    source, agent, mode = key.split('/')
    if mode != 'per_seed':
      continue
    path = os.path.normpath(os.path.join(REAL, cell['settings']['file']))
    seeds = [f['seed'] for f in cell['flights']]
    if source not in by_source:
      data = gridded.load(path)
      station = flown_stations(path, seeds, data.global_longitude)
      margin = np.array([feasibility.at(data, lat, lon)[0].margin_mps
                         for lat, lon in station])
      by_source[source] = (seeds, station, margin)
      out['sources'][source] = {
          'file': cell['settings']['file'], 'wind_source': data.description,
          'stations_inside': int((margin >= 0).sum()), 'agents': {},
          'stations': [{'seed': s, 'lat': round(float(a), 4),
                        'lon': round(float(o), 4),
                        'margin_mps': round(float(m), 3)}
                       for s, (a, o), m in zip(seeds, station, margin)]}
    known, _, margin = by_source[source]
    if seeds != known:
      sys.exit(f'{key}: seeds differ from the first cell of {source}')
    tw50 = np.array([f['tw50_window'] for f in cell['flights']])
    result = correlate(margin, tw50)
    out['sources'][source]['agents'][agent] = result
    pooled.setdefault(agent, ([], []))
    pooled[agent][0].extend(margin)
    pooled[agent][1].extend(tw50)
    print(f'{source:13s} {agent:30s} rho {result["spearman_rho"]:+.3f} '
          f'(p {result["p_value"]:.2g}, n {result["n"]}); TW50 inside '
          f'{result["tw50_mean_inside"]} ({result["inside_stations"]}), '
          f'outside {result["tw50_mean_outside"]}')
  for agent, (margin, tw50) in pooled.items():
    result = correlate(np.array(margin), np.array(tw50))
    out['pooled'][agent] = result
    print(f'{"both files":13s} {agent:30s} rho {result["spearman_rho"]:+.3f} '
          f'(p {result["p_value"]:.2g}, n {result["n"]})')
  safe_io.atomic_write(args.json, json.dumps(out, indent=1))
  print(f'wrote {args.json} ({out["date"]}, {out["machine"]}, load '
        f'{out["load"]}, commit {commit})')


if __name__ == '__main__':
  main()
