r"""BLE's VAE winds against each real wind source (issue 45 item 7).

  nice -n 10 python benchmarks/wind_compare.py \
      [--json=benchmarks/records/wind_compare.json] \
      [--figure=docs/assets/wind_compare.png]

One run samples BLE's generative (VAE) forecast (`stats.sample_vae`:
--fields keys x --points places and times, 50-200 km from the station, 48 h)
and each real source of `ble_latex.wind.sources.SOURCES` (a GFS grid:
--samples columns uniform over its whole area, `region='domain'`; a
sounding: its one column, a single sample, said so in the record), and
records per source (`ble_latex.wind.stats`):
  * `own`: its profile in the flight band 15-25 km (US Standard Atmosphere
    1976: 2511-12045 Pa) at its own levels (the VAE: its grid's 8 levels in
    50-120 hPa, i.e. 15.2-20.6 km, the most of the band it reaches; GFS: 30,
    50, 70, 100 hPa; a sounding: every level it reports) -- speed quantiles
    per level, the fraction of columns with two levels >= 90 and >= 135 deg
    apart, vertical shear and each column's spread;
  * `common`: the same at --common_pressures_pa (default 50, 70, 100 hPa:
    the levels every source holds), where sources can be compared level for
    level (shear and direction diversity depend on how many levels there
    are and how close);
  * `vs_vae`: `stats.compare` with the VAE at the common levels
    (1-Wasserstein distances of u and v, per level and pooled).
Writes --json with the command, date, machine and load average, and the
figure (`plots.plot_wind_compare` of the `own` profiles; --figure_only
redraws it from the record).
`docs/hooks/tables.py` ('wind-compare') renders the docs table from it.
"""

import dataclasses
import datetime as dt
import json
import os
import platform
import sys
import time
from typing import Any, Dict, Optional, Sequence

from absl import flags

import ble_latex  # pylint: disable=unused-import  # Fixes first.
from ble_latex import quiet
from ble_latex import safe_io
from ble_latex.cli import common as cli
from ble_latex.run import provenance
from ble_latex.wind import sources
from ble_latex.run import episode_log

_HERE = os.path.dirname(os.path.abspath(__file__))
_ROOT = os.path.dirname(_HERE)
FLAGS = flags.FlagValues()
flags.DEFINE_list('sources', list(sources.SOURCES), 'Real sources '
                  f'compared, of {list(sources.SOURCES)}.',
                  flag_values=FLAGS)
flags.DEFINE_integer('samples', 2000, 'Columns sampled from each GFS grid.',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('fields', 64, 'VAE forecast keys.', lower_bound=1,
                     flag_values=FLAGS)
flags.DEFINE_integer('points', 32, 'Samples (place, time) per VAE field.',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('seed', 0, 'Seed of the samples (VAE: PRNGKey(seed)).',
                     lower_bound=0, flag_values=FLAGS)
flags.DEFINE_list('common_pressures_pa', ['5000', '7000', '10000'],
                  'Levels every source is compared at [Pa].',
                  flag_values=FLAGS)
flags.DEFINE_string('realdata_dir', sources.REALDATA_DIR,
                    'Folder of the real files (PROVENANCE.md).',
                    flag_values=FLAGS)
flags.DEFINE_string('json', str(episode_log.RECORDS_DIR / 'wind_compare.json'),
                    'The record.', flag_values=FLAGS)
flags.DEFINE_string('figure', os.path.join(_ROOT, 'docs', 'assets',
                                           'wind_compare.png'),
                    'The figure (empty: none).', flag_values=FLAGS)
flags.DEFINE_boolean('figure_only', False, 'Only redraw --figure from the '
                     'record --json (samples nothing).', flag_values=FLAGS)


def _summary(comparison: Dict[str, Any]) -> Dict[str, Any]:
  """`stats.compare`'s distances (the distributions are in the profiles)."""
  return {'wasserstein_u_mps': comparison['wasserstein_u_mps'],
          'wasserstein_v_mps': comparison['wasserstein_v_mps'],
          'per_level': [{k: r[k] for k in ('pressure_pa', 'wasserstein_u_mps',
                                           'wasserstein_v_mps')}
                        for r in comparison['per_level']]}


def _draw(rows: Sequence[Dict[str, Any]]) -> None:
  if FLAGS.figure:
    from ble_latex.plots import figures  # pylint: disable=g-import-not-at-top
    figures.plot_wind_compare([r['own'] for r in rows], FLAGS.figure)
    print(f'wrote {FLAGS.figure}')


def _main(argv: Sequence[str]) -> None:
  del argv
  if FLAGS.figure_only:
    with open(FLAGS.json, encoding='utf-8') as f:
      _draw(json.load(f)['sources'])
    return
  unknown = sources.unknown(FLAGS.sources)
  if unknown:
    raise cli.CommandUsageError(f'--sources: unknown {unknown}')
  try:
    common = sorted(float(p) for p in FLAGS.common_pressures_pa)
  except ValueError:
    raise cli.CommandUsageError('--common_pressures_pa: numbers in Pa, got '
                                f'{FLAGS.common_pressures_pa}') from None
  if len(common) < 2:
    raise cli.CommandUsageError('--common_pressures_pa needs 2 or more levels')
  with quiet.third_party_noise():
    # pylint: disable=g-import-not-at-top
    import jax
    from ble_latex.wind import stats
    # pylint: enable=g-import-not-at-top
  version = provenance.code_version()
  load_before = [round(x, 2) for x in os.getloadavg()]
  date = dt.datetime.now(dt.timezone.utc).isoformat(timespec='minutes')
  began = time.perf_counter()
  with quiet.third_party_noise():
    vae_own = stats.sample_vae(jax.random.PRNGKey(FLAGS.seed),
                               stats.vae_levels(), num_fields=FLAGS.fields,
                               points_per_field=FLAGS.points)
  # The same columns at the common levels (the VAE's grid holds them all).
  vae_common = stats.sample_vae(jax.random.PRNGKey(FLAGS.seed), common,
                                num_fields=FLAGS.fields,
                                points_per_field=FLAGS.points)
  vae_label = "BLE's VAE forecast"
  vae_own = dataclasses.replace(vae_own, label=vae_label)
  vae_common = dataclasses.replace(vae_common, label=vae_label)
  rows = [{'name': 'vae', 'label': vae_label, 'file': None,
           'own': stats.profile(vae_own), 'common': stats.profile(
               vae_common, band=(common[0], common[-1]))}]
  for name in FLAGS.sources:
    relative, label, _ = sources.SOURCES[name]
    path = sources.path(name, FLAGS.realdata_dir)
    sample = lambda levels, band=stats.FLIGHT_BAND_PA: stats.sample_era5(
        path, levels, num_samples=FLAGS.samples, seed=FLAGS.seed,
        region='domain', label=label, band=band)  # pylint: disable=cell-var-from-loop
    own, at_common = sample(None), sample(common)
    rows.append({
        'name': name, 'label': label, 'file': relative,
        'own': stats.profile(own),
        'common': stats.profile(at_common, band=(common[0], common[-1])),
        'vs_vae': _summary(stats.compare(vae_common, at_common))})
    print(f'{name}: {rows[-1]["own"]["columns"]} columns, apart '
          f'{rows[-1]["own"]["apart"]}', file=sys.stderr, flush=True)
  wall = time.perf_counter() - began
  record = {
      'command': ' '.join(['python', 'benchmarks/wind_compare.py',
                           *sys.argv[1:]]),
      'date_utc': date, 'host': platform.node(), 'cpus': os.cpu_count(),
      'loadavg_before': load_before,
      'loadavg_after': [round(x, 2) for x in os.getloadavg()],
      'wall_s': round(wall, 1), **version,
      'settings': {
          'vae_fields': FLAGS.fields, 'vae_points_per_field': FLAGS.points,
          'vae_radius_km': list(stats.RADIUS_KM),
          'grid_samples': FLAGS.samples, 'grid_region': 'domain',
          'seed': FLAGS.seed, 'common_pressures_pa': common,
          'flight_band_pa': [round(p, 1) for p in stats.FLIGHT_BAND_PA],
          'apart_deg': list(stats.APART_DEG)},
      'notes': [
          'Every real source is one time step (a snapshot); a sounding is '
          'one column: ' + stats.SINGLE_COLUMN_NOTE + '.',
          "The VAE's grid spans 50-140 hPa: in 15-25 km it reaches 15.2-20.6 "
          'km only.',
          'Files and licences: shared/realdata/PROVENANCE.md.'],
      'sources': rows}
  safe_io.atomic_write(FLAGS.json, json.dumps(record, indent=1) + '\n')
  print(f'wrote {FLAGS.json}')
  _draw(rows)


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'wind_compare.py', FLAGS, argv, doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
