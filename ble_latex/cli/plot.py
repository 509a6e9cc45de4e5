# coding=utf-8
r"""`ble-latex-plot`: the paper's figures from a run, eval files and the wind.

  ble-latex-plot --output_dir=/tmp/latex/plots \
      --run_dir=/tmp/latex/sac \
      --eval_json=/tmp/latex/eval/latex_tiny/sac_49.json \
      --baseline_eval_json=/tmp/latex/eval/latex_tiny/random.json \
      --wind_seeds=3,11

Writes into --output_dir, each only when its inputs are given:

  training_curves.png      --run_dir: reward and TW50 per episode with the
                           50-episode rolling mean (paper Fig. 2).
  terminal_conditions.png  --run_dir: cumulative terminal reasons (Fig. 5).
  seed_curves.png          --seed_run_dirs (2 or more): TW50 over the window
                           and reward, rolling means of each training run,
                           their mean and min-max band (e.g. the seeds of
                           `ble-latex-train --seeds`); with the jitted
                           trainer's validation.jsonl in every run, also
                           their validated snapshots.
  trajectories.png         --eval_json (the first one): bird's-eye paths of up
                           to --max_trajectories seeds, 50 km circle (Fig. 4).
  trajectory_3d.png        --eval_json and --baseline_eval_json: the same seed
                           (--seed, else the first common one) flown by both,
                           with the station-keeping cylinder (Fig. 6).
  wind_field.png           --wind_seed or --wind_seeds: forecast wind arrows
                           coloured by direction at --wind_pressures_pa, one
                           row per seed (Fig. 3). The env is built after
                           latex_env.gin, --gin_file and --gin_bindings, so a
                           binding can select e.g. the ERA5 wind field.
  wind_stats.png           --wind_stats --wind_file (alias --era5_path; any
  wind_stats.json          file the readers take: ERA5, a GFS-style NetCDF
                           analysis, GRIB2, a University of Wyoming
                           sounding): the VAE forecast (or
                           --wind_stats_against, a second file) vs the file,
                           per pressure level in 5000-14000 Pa: distributions
                           of u and v, Wasserstein distances, direction
                           diversity (how often winds at two levels point
                           > 90 deg apart); and in the JSON each source's
                           profile in 15-25 km (speed quantiles per level,
                           the fraction of columns with two levels >= 90 and
                           >= 135 deg apart, vertical shear). A sounding is
                           one column: a single sample, said so in both
                           files. See ble_latex.wind.stats.
  track_map.png            --eval_json (the first one): the tracks of up to
                           --max_trajectories seeds on a latitude/longitude
                           map with coastlines (landmetrics' bundled GSHHG
                           grid), launch, end, station and its circle.
  flight_time.png          --eval_json: the same seeds' altitude, sand,
                           helium and distance from the station against
                           time since launch.
  tracks.kml               --export=kml,geojson,csv (any of them): every
  tracks.geojson           record of the first --eval_json as KML 2.2,
  tracks.csv               GeoJSON (RFC 7946) and CSV (one row per point:
                           seed, t_s, utc, lat, lon, altitude_m, ...). Lat/lon
                           and UTC are the record's (`ble_latex.run.tracks`);
                           a record written before them gets its lat/lon
                           from its station (or the nominal 1 N 113 W) and
                           no times.
  feasibility_map.png      --feasibility --wind_file: where station-keeping
  feasibility.json         is possible: zero inside the hull of the winds
  hodograph*.png           of the flight band, every column of a grid (a
                           sounding: its one column, hodograph.png), with
                           a hodograph per --feasibility_sites LAT:LON.
                           See ble_latex.wind.feasibility.
  summary.json             for every eval file: mean/std of TW50, reward,
                           helium vented, sand dropped, % out of resources
                           (also printed).

Every input is read and checked (each record against its schema, see
`ble_latex.run.records`) and the wind sampled before the first figure is
drawn, so a bad input leaves nothing written. Prints the paths written. Exit
status 0 on success, 1 on bad input (a message naming the file, record and
field), 2 on bad flags.
"""

import json
import os
import sys
from typing import Any, List, Optional, Sequence

from absl import flags
import numpy as np

import ble_latex  # pylint: disable=unused-import  # Fixes before BLE imports.
from ble_latex import configs
from ble_latex import quiet
from ble_latex import safe_io
from ble_latex.cli import common as cli

with quiet.third_party_noise():
  # pylint: disable=g-import-not-at-top
  from ble_latex.plots import exports
  from ble_latex.plots import feasibility as feasibility_plots
  from ble_latex.plots import figures as plots
  from ble_latex.plots import maps
  from ble_latex.plots import wind_samples
  from ble_latex.run import episode_log
  from ble_latex.run import gin_binding
  from ble_latex.run import records as records_lib
  from ble_latex.run import tracks as tracks_lib
  # pylint: enable=g-import-not-at-top
# Imported on first use (BLE's collectors import TensorFlow): `--help` stays
# fast.
metrics = cli.lazy_module('ble_latex.run.metrics')

TRAINING_CURVES = 'training_curves.png'
TERMINAL_CONDITIONS = 'terminal_conditions.png'
TRAJECTORIES = 'trajectories.png'
TRAJECTORY_3D = 'trajectory_3d.png'
TRACK_MAP = 'track_map.png'
FLIGHT_TIME = 'flight_time.png'
WIND_FIELD = 'wind_field.png'
SEED_CURVES = 'seed_curves.png'
SUMMARY = 'summary.json'
WIND_STATS = 'wind_stats.png'
WIND_STATS_JSON = 'wind_stats.json'
DEFAULT_PRESSURES_PA = ('14000', '10000', '7000', '5000')  # [Pa] ~14-21 km.

# The command's own flags (`cli.run_absl`).
FLAGS = flags.FlagValues()
flags.DEFINE_string('output_dir', None, 'Folder for the PNGs and summary.json.',
                    flag_values=FLAGS)
flags.DEFINE_string('run_dir', None,
                    'Training run folder (ble-latex-train --base_dir) holding '
                    'episodes.jsonl.', flag_values=FLAGS)
flags.DEFINE_multi_string('seed_run_dirs', [],
                          'Training run folders drawn together in '
                          f'{SEED_CURVES} (e.g. BASE_DIR/seed_0 ...).',
                          flag_values=FLAGS)
flags.DEFINE_multi_string('eval_json', [],
                          'ble-latex-eval result file(s) OUT/SUITE/AGENT.json; '
                          'the first one is plotted, all are summarized.',
                          flag_values=FLAGS)
flags.DEFINE_string('baseline_eval_json', None,
                    'Eval file of the untrained/baseline agent for the 3D '
                    'comparison (also summarized).', flag_values=FLAGS)
flags.DEFINE_integer('max_trajectories', 6, 'Most flight paths in '
                     f'{TRAJECTORIES}, {TRACK_MAP} and {FLIGHT_TIME}.',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_list('export', [], 'Formats to export every record of the '
                  'first --eval_json in (comma-separated): ' +
                  ', '.join(f'{k} ({v[0]})' for k, v in
                            exports.FORMATS.items()) + '.',
                  flag_values=FLAGS)
flags.DEFINE_integer('seed', None, f'Seed shown in {TRAJECTORY_3D} (default: '
                     'the first seed common to both eval files).',
                     flag_values=FLAGS)
flags.DEFINE_integer('rolling_window', plots.ROLLING_WINDOW,
                     'Episodes in the training-curve rolling mean.',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_boolean('paper_reference', True,
                     'Draw the paper\'s result in the training curves.',
                     flag_values=FLAGS)
flags.DEFINE_integer('wind_seed', None, 'Env seed (date, location, wind) of '
                     f'{WIND_FIELD}.', flag_values=FLAGS)
flags.DEFINE_list('wind_seeds', [], 'Several env seeds, one row each (e.g. a '
                  'favourable and an unfavourable day).', flag_values=FLAGS)
flags.DEFINE_float('wind_hours', 0.0, 'Forecast time after the reset [h].',
                   lower_bound=0.0, flag_values=FLAGS)
flags.DEFINE_list('wind_pressures_pa', list(DEFAULT_PRESSURES_PA),
                  'Pressure levels [Pa], one column each.', flag_values=FLAGS)
flags.DEFINE_float('wind_extent_km', 300.0, 'Grid half-width [km].',
                   lower_bound=1.0, flag_values=FLAGS)
flags.DEFINE_integer('wind_grid', 21, 'Arrows per grid side.', lower_bound=2,
                     flag_values=FLAGS)
flags.DEFINE_string('env_name', 'LatexBalloon-v0', 'Env whose wind is drawn.',
                    flag_values=FLAGS)
cli.define_gin_flags(
    FLAGS, files_help='Extra gin files (after latex_env.gin).',
    bindings_help='Gin bindings, e.g. "latex_episode.wind_field_factory = '
    '@GriddedWindField".', files_alias=True)
flags.DEFINE_boolean('wind_stats', False, f'Compare two wind sources: '
                     f'{WIND_STATS} and {WIND_STATS_JSON}.', flag_values=FLAGS)
flags.DEFINE_string('wind_file', None, 'Wind file or glob compared by '
                    '--wind_stats: ERA5, another CF NetCDF analysis, GRIB2 or '
                    'a University of Wyoming sounding (the reader chosen by '
                    'content). --era5_path is an alias.', flag_values=FLAGS)
flags.DEFINE_alias('era5_path', 'wind_file', flag_values=FLAGS)
flags.DEFINE_string('wind_stats_against', 'vae', "The other source: 'vae' "
                    "(BLE's generative forecast) or a second wind file/glob.",
                    flag_values=FLAGS)
flags.DEFINE_list('wind_stats_pressures_pa', [], 'Levels compared [Pa] '
                  "(default: the wind file's levels in 5000-14000 Pa).",
                  flag_values=FLAGS)
flags.DEFINE_integer('wind_stats_samples', 2000, 'Samples (place, time) of '
                     'each gridded source (a sounding is one column).',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_enum('wind_stats_region', 'station', ['station', 'domain'],
                  'Where a grid is sampled: station (50-200 km from the '
                  "centre of its area) or domain (uniformly over its area).",
                  flag_values=FLAGS)
flags.DEFINE_integer('wind_stats_fields', 64, 'VAE forecast keys (fields).',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('wind_stats_points', 32, 'Samples (place, time) per VAE '
                     'field.', lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('wind_stats_seed', 0, 'Seed of the samples.',
                     lower_bound=0, flag_values=FLAGS)
flags.mark_flag_as_required('output_dir', flag_values=FLAGS)


flags.DEFINE_boolean('feasibility', False, 'Station-keeping feasibility '
                     'map of --wind_file (ble_latex.wind.feasibility).',
                     flag_values=FLAGS)
flags.DEFINE_list('feasibility_sites', [], 'LAT:LON sites of --feasibility '
                  'hodographs (a grid), e.g. 19.7:-155.1.', flag_values=FLAGS)


def _sites(values: Sequence[str]) -> List[List[float]]:
  """--feasibility_sites as [[lat, lon], ...] (usage error if malformed)."""
  try:
    sites = [[float(x) for x in v.split(':')] for v in values]
  except ValueError:
    sites = [[]]
  if any(len(site) != 2 for site in sites):
    raise flags.ValidationError(f'--feasibility_sites={",".join(values)}: '
                                'expected LAT:LON[,LAT:LON...] [deg]')
  return sites


def wind_stats(f: flags.FlagValues) -> Any:
  """Samples the two sources of --wind_stats and compares them.

  Args:
    f: The parsed flags.

  Returns:
    (samples of the other source, samples of --wind_file, the comparison):
    `stats.compare_file`.

  Raises:
    flags.ValidationError: bad --wind_stats_pressures_pa.
    OSError, ValueError: a bad wind file (named).
  """
  with quiet.third_party_noise():
    from ble_latex.wind import stats  # pylint: disable=g-import-not-at-top
  pressures = (_float_list('wind_stats_pressures_pa',
                           f.wind_stats_pressures_pa)
               if f.wind_stats_pressures_pa else None)
  if pressures is not None and len(pressures) < 2:
    raise flags.ValidationError('--wind_stats_pressures_pa needs 2 or more '
                                'levels (direction diversity is between '
                                'levels)')
  if pressures is not None:
    pressures = sorted(pressures)
  with quiet.third_party_noise():  # JAX's backend start-up lines.
    return stats.compare_file(
        f.wind_file, pressures_pa=pressures,
        against=None if f.wind_stats_against == 'vae' else
        f.wind_stats_against, num_samples=f.wind_stats_samples,
        seed=f.wind_stats_seed, num_fields=f.wind_stats_fields,
        points_per_field=f.wind_stats_points, region=f.wind_stats_region)


def _float_list(name: str, values: Sequence[str]) -> List[float]:
  try:
    out = [float(v) for v in values]
  except ValueError as e:
    raise flags.ValidationError(f'--{name}: {e}') from e
  if not out or not all(np.isfinite(out)) or min(out) <= 0:
    raise flags.ValidationError(
        f'--{name} needs finite positive numbers, got {values}')
  return out


def _wind_seed_list(f: flags.FlagValues) -> List[int]:
  try:
    seeds = [int(s) for s in f.wind_seeds]
  except ValueError as e:
    raise flags.ValidationError(f'--wind_seeds: {e}') from e
  if f.wind_seed is not None:
    seeds = [f.wind_seed] + [s for s in seeds if s != f.wind_seed]
  if any(s < 0 for s in seeds):
    raise flags.ValidationError(f'--wind_seed(s) must be >= 0, got {seeds}')
  return seeds


def run(f: flags.FlagValues) -> List[str]:
  """Makes every figure whose inputs are given; returns the paths written.

  All inputs are loaded and validated (and the wind sampled) first: an error
  in any of them raises before anything is drawn or written.

  Args:
    f: The parsed flags.

  Returns:
    The paths written, in drawing order.

  Raises:
    flags.ValidationError, errors.UsageError: bad flag values (exit
      status 2).
    OSError, ValueError: a missing or malformed input, naming the file (and
      record and field).
  """
  out = f.output_dir
  written = []
  # 1. Flags that need no file.
  wind_seeds = _wind_seed_list(f)
  pressures = _float_list('wind_pressures_pa', f.wind_pressures_pa)
  if f.seed is not None and not (f.eval_json and f.baseline_eval_json):
    raise flags.ValidationError('--seed needs --eval_json and '
                                '--baseline_eval_json')
  # 2. Load (and so validate) every input file.
  episodes = None
  if f.run_dir:
    episodes = records_lib.load_episodes(
        os.path.join(f.run_dir, episode_log.EPISODE_LOG))
  if len(f.seed_run_dirs) == 1:
    raise flags.ValidationError('--seed_run_dirs needs 2 or more runs (one '
                                'run: --run_dir)')
  seed_runs = {
      d: records_lib.load_episodes(os.path.join(d, episode_log.EPISODE_LOG))
      for d in f.seed_run_dirs}
  # The jitted trainer's runs also log validated snapshots: drawn when every
  # run has them.
  validation_logs = [os.path.join(d, episode_log.VALIDATION_LOG)
                     for d in seed_runs]
  seed_validation = (
      {d: records_lib.load_validation(p)
       for d, p in zip(seed_runs, validation_logs)}
      if seed_runs and all(os.path.exists(p) for p in validation_logs)
      else None)
  evals = {p: records_lib.load_eval(p) for p in f.eval_json}
  baseline = (records_lib.load_eval(f.baseline_eval_json)
              if f.baseline_eval_json else None)
  first = next(iter(evals.values())) if evals else None
  # The map's flights, or every record when exported.
  flights = [tracks_lib.track(r, f'{f.eval_json[0]}: seed {r["seed"]}')
             for r in (first or [])[:None if f.export else
                                     f.max_trajectories]]
  seed_3d = None
  if first and baseline:
    try:
      seed_3d = plots.common_seed(first, baseline, f.seed)
    except ValueError as e:
      raise ValueError(f'{f.eval_json[0]} and {f.baseline_eval_json}: '
                       f'{e}') from e
  # 3. The wind, from the env.
  rows = None
  if wind_seeds:
    with quiet.third_party_noise():
      gin_binding.bind_gin(None, None, f.gin_file, f.gin_bindings)
    rows = wind_samples.wind_rows(
        wind_seeds, pressures, env_name=f.env_name, hours=f.wind_hours,
        extent_km=f.wind_extent_km, num_points=f.wind_grid)
  elif f.gin_file or f.gin_bindings:
    print('ble-latex-plot: --gin_file/--gin_bindings only affect '
          f'{WIND_FIELD} (give --wind_seed); ignored.', file=sys.stderr)

  compared = None
  if f.wind_stats:  # With --wind_file (`_main` checks).
    compared = wind_stats(f)

  # 4. Draw.
  os.makedirs(out, exist_ok=True)

  def draw(figure: Any, name: str, *args: Any, **kwargs: Any) -> None:
    path = os.path.join(out, name)
    figure(*args, path, **kwargs)
    written.append(path)

  if episodes is not None:
    draw(plots.plot_training_curves, TRAINING_CURVES, episodes,
         window=f.rolling_window, paper_reference=f.paper_reference)
    draw(plots.plot_terminal_conditions, TERMINAL_CONDITIONS, episodes)
  if seed_runs:
    label = lambda d: os.path.basename(os.path.normpath(d))
    draw(plots.plot_seed_curves, SEED_CURVES,
         {label(d): e for d, e in seed_runs.items()}, window=f.rolling_window,
         validation=(None if seed_validation is None else
                     {label(d): v for d, v in seed_validation.items()}))
  if first is not None:
    draw(plots.plot_trajectories, TRAJECTORIES, first,
         max_trajectories=f.max_trajectories)
  if flights:
    shown = flights[:f.max_trajectories]
    title = (f'{os.path.basename(f.eval_json[0])}: '
             f'{first[0].get("wind_source", "winds not recorded")}')
    title = title if len(title) <= 90 else title[:87] + '...'
    draw(maps.plot_track_map, TRACK_MAP, shown, title=title)
    draw(maps.plot_flight_time, FLIGHT_TIME, shown, title=title)
  for name in dict.fromkeys(f.export):  # In the order given, once each.
    file_name, writer = exports.FORMATS[name]
    path = os.path.join(out, file_name)
    safe_io.atomic_write(path, writer(flights))
    written.append(path)
  if seed_3d is not None:
    by_seed = lambda records: next(r for r in records if r['seed'] == seed_3d)
    names = (os.path.splitext(os.path.basename(f.eval_json[0]))[0],
             os.path.splitext(os.path.basename(f.baseline_eval_json))[0])
    draw(plots.plot_trajectory_3d, TRAJECTORY_3D, by_seed(first),
         by_seed(baseline), labels=names)
  if rows is not None:
    draw(plots.plot_wind_fields, WIND_FIELD, rows)
  if compared is not None:
    other, era5_samples, comparison = compared
    draw(plots.plot_wind_stats, WIND_STATS, other, era5_samples, comparison)
    path = os.path.join(out, WIND_STATS_JSON)
    safe_io.atomic_write(path, json.dumps(comparison, indent=2))
    written.append(path)
    if 'note' in comparison:
      print(f'ble-latex-plot: --wind_stats: {comparison["note"]}',
            file=sys.stderr)
  if f.feasibility:  # With --wind_file (`_check`).
    written += feasibility_plots.write(f.wind_file, out,
                                       _sites(f.feasibility_sites))['outputs']
  if baseline is not None:
    evals[f.baseline_eval_json] = baseline
  if evals:
    summary = {path: metrics.summarize(r) for path, r in evals.items()}
    print(metrics.format_summary(summary))
    path = os.path.join(out, SUMMARY)
    safe_io.atomic_write(path, json.dumps(summary, indent=2))
    written.append(path)
  return written


def _check() -> None:
  unknown = [n for n in FLAGS.export if n not in exports.FORMATS]
  if unknown:
    raise cli.CommandUsageError(
        f'--export: unknown format(s) {", ".join(unknown)}; choose from '
        f'{", ".join(exports.FORMATS)}')
  if FLAGS.export and not FLAGS.eval_json:
    raise cli.CommandUsageError('--export needs --eval_json (the records '
                                'exported)')
  if not (FLAGS.run_dir or FLAGS.seed_run_dirs or FLAGS.eval_json or
          FLAGS.baseline_eval_json or
          FLAGS.wind_seed is not None or FLAGS.wind_seeds or
          FLAGS.wind_stats or FLAGS.feasibility):
    raise cli.CommandUsageError(
        'nothing to plot; give --run_dir, --seed_run_dirs, --eval_json, '
        '--baseline_eval_json, --wind_seed(s), --wind_stats or --feasibility. '
        'Try --help.')
  if FLAGS.wind_stats and not FLAGS.wind_file:
    raise cli.CommandUsageError('--wind_stats needs --wind_file (alias '
                                '--era5_path): a wind file (ERA5, GFS NetCDF '
                                'or GRIB2, a sounding)')
  if FLAGS.feasibility_sites and not FLAGS.feasibility:
    raise cli.CommandUsageError('--feasibility_sites needs --feasibility')
  if FLAGS.feasibility and not FLAGS.wind_file:
    raise cli.CommandUsageError('--feasibility needs --wind_file: a wind file')
  if not FLAGS.wind_stats and (FLAGS.wind_file and not FLAGS.feasibility or any(
      FLAGS[name].present for name in FLAGS if
      name.startswith('wind_stats_'))):
    raise cli.CommandUsageError('--wind_file (--era5_path) and '
                                '--wind_stats_* need --wind_stats '
                                '(--wind_file: or --feasibility)')
  configs.check_gin_files(FLAGS.gin_file)


def _main(argv: Sequence[str]) -> int:
  """Draws what the flags ask for; 1 on bad input (named), else 0."""
  try:
    written = run(FLAGS)
  except flags.Error as e:
    raise cli.CommandUsageError(str(e)) from e
  except (OSError, ValueError) as e:
    if isinstance(e, ValueError) and gin_binding.refused_config_message(e):
      raise
    print(f'ble-latex-plot: error: {gin_binding.one_line(e)}', file=sys.stderr)
    return 1
  for path in written:
    print(f'wrote {path}')
  return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
  """The command (`cli.run_absl`); returns the exit status."""
  return cli.run_absl(_main, 'ble-latex-plot', FLAGS, argv, doc=__doc__,
                      check=_check)


if __name__ == '__main__':
  sys.exit(main())
