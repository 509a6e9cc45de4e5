"""Launch search methods side by side at equal rollout budgets (issue 46).

  python benchmarks/launch_search.py [--output=benchmarks/records/launch_search.json] \
      [--seeds=0,1,2,3,4,5] [--grid=21,21,4] [--draws=4] \
      [--budgets=4,8,16,32,64] [--repeats=3]
  python benchmarks/launch_search.py --report_only   # figure + table again

Per case (a generative world: env seed s, the station at the forecast grid's
centre) the dense launch grid is scored batched with the geometric seeker
(`ble_latex.launch.scoring`: expected TW50 over --draws noise draws, the
launch box +-150 km east and north, delays 0..21 h); that grid is the
ground truth. Then the grid in a random order, uniform random proposals
and Bayesian optimisation (`bayes_opt` 3.4.0) each propose launches, each
proposal snapped to the grid and costing one evaluation (--draws rollouts);
their regret against the grid optimum at each budget, --repeats seeds per
method (`ble_latex.launch.search`). Resumable: the record (JSON) is written
after every case's grid and every case's comparison; a rerun skips what it
holds, and refuses to resume a record of other settings. Writes the record,
a figure (regret vs rollouts, mean over cases and repeats, +- one standard
error) and a Markdown table beside it.
"""

import io
import json
import os
import sys
import time
from typing import Any, Dict, Optional, Sequence

from absl import flags
import numpy as np

from ble_latex import safe_io
from ble_latex.cli import common as cli
from ble_latex.run import episode_log

FLAGS = flags.FlagValues()
flags.DEFINE_string('output', str(episode_log.RECORDS_DIR / 'launch_search.json'), 'The record.',
                    flag_values=FLAGS)
flags.DEFINE_list('seeds', ['0', '1', '2', '3', '4', '5'], 'World seeds '
                  '(cases).', flag_values=FLAGS)
flags.DEFINE_list('grid', ['21', '21', '4'], 'east,north,hours points.',
                  flag_values=FLAGS)
flags.DEFINE_integer('draws', 4, 'Noise draws per launch.', flag_values=FLAGS)
flags.DEFINE_integer('max_steps', 216, 'Strides per flight.',
                     flag_values=FLAGS)
flags.DEFINE_list('budgets', ['4', '8', '16', '32', '64'], 'Evaluations.',
                  flag_values=FLAGS)
flags.DEFINE_integer('repeats', 3, 'Seeds per search method and case.',
                     flag_values=FLAGS)
flags.DEFINE_bool('report_only', False, 'Only the figure and table from the '
                  'record.', flag_values=FLAGS)

BOX = {'east_km': (-150.0, 150.0), 'north_km': (-150.0, 150.0),
       'hours': (0.0, 21.0)}


def _ints(flag: str, low: int, high: int = 2**32 - 1) -> list:
  """--flag's list as ints in [low, high], or a one-line usage error."""
  values = FLAGS[flag].value
  try:
    ints = [int(v) for v in values]
  except ValueError:
    ints = []
  if not ints or not all(low <= v <= high for v in ints):
    raise cli.CommandUsageError(f'--{flag} takes integers in [{low}, {high}],'
                                f' got {",".join(values)!r}')
  return ints


def _settings() -> Dict[str, Any]:
  """The flags, checked before anything is scored (sizes bounded)."""
  from ble_latex.launch import scoring  # pylint: disable=g-import-not-at-top
  _ints('seeds', 0)
  grid = _ints('grid', 1, scoring.MAX_BALLOONS)
  if len(grid) != 3:
    raise cli.CommandUsageError(f'--grid takes east,north,hours, got '
                                f'{",".join(FLAGS.grid)!r}')
  for name in ('draws', 'max_steps', 'repeats'):
    if FLAGS[name].value < 1:
      raise cli.CommandUsageError(f'--{name} must be >= 1, got '
                                  f'{FLAGS[name].value}')
  n = grid[0] * grid[1] * grid[2]
  try:
    scoring.check_balloons(n, FLAGS.draws, 'grid launches')
  except ValueError as e:
    raise cli.CommandUsageError(f'--grid, --draws: {e}') from e
  budgets = _ints('budgets', 1, n)
  return {'grid': grid, 'draws': FLAGS.draws,
          'max_steps': FLAGS.max_steps, 'box': BOX,
          'budgets': budgets, 'repeats': FLAGS.repeats,
          'agent': 'latex_station_seeker'}


def _load(path: str) -> Optional[Dict[str, Any]]:
  if not os.path.exists(path):
    return None
  try:
    with open(path, encoding='utf-8') as f:
      record = json.load(f)
  except (json.JSONDecodeError, UnicodeDecodeError) as e:
    raise cli.CommandFailure(f'{path}: truncated or not JSON ({e}); give '
                             'another --output') from e
  if not (isinstance(record, dict) and isinstance(record.get('settings'), dict)
          and isinstance(record.get('cases'), dict)):
    raise cli.CommandFailure(f'{path}: not a launch_search record (settings '
                             'and cases expected); give another --output')
  return record


def _write(path: str, record: Dict[str, Any]) -> None:
  safe_io.atomic_write(path, json.dumps(record, indent=1))


def _run(record: Dict[str, Any]) -> None:
  # pylint: disable=g-import-not-at-top
  from ble_latex.launch import controllers
  from ble_latex.launch import scoring
  from ble_latex.launch import search
  from ble_latex.run import gin_binding
  # pylint: enable=g-import-not-at-top
  gin_binding.bind_gin('latex_station_seeker', None, [], [])
  settings = record['settings']
  controller = controllers.controller_named('latex_station_seeker')
  for seed in [int(s) for s in FLAGS.seeds]:
    case = record['cases'].setdefault(str(seed), {})
    world = scoring.generative_world(seed, steps=settings['max_steps'])
    space = scoring.SearchSpace(**BOX).checked(world.params)
    shape = settings['grid']
    launches = scoring.grid(space, *shape)
    if 'tw50' not in case:
      load = os.getloadavg()[0]
      start = time.monotonic()
      scores = scoring.score(world, controller, launches,
                             draws=settings['draws'])
      case.update(
          tw50=np.round(scores.tw50, 6).tolist(),
          score_wall_s=time.monotonic() - start, load_before=load,
          world=world.describe)
      _write(FLAGS.output, record)
      print(f'case {seed}: grid scored in {case["score_wall_s"]:.0f} s '
            f'(load {load:.1f})', flush=True)
    scores = scoring.Scores(launches, np.asarray(case['tw50']),
                            settings['max_steps'])
    table = search.GridTable.from_scores(space, shape, scores)
    best = scoring.ranked(scores, world, 10)
    case.update(optimum=table.optimum, best=best[0],
                top10_outside=sum(not r['inside_radius'] for r in best),
                station_best=float(max(
                    scores.mean[i] for i in range(len(launches))
                    if launches.east_km[i] == 0 and launches.north_km[i] == 0)))
    if 'regret' not in case:
      start = time.monotonic()
      case['regret'] = search.compare(table, settings['budgets'],
                                      range(settings['repeats']))
      case['search_wall_s'] = time.monotonic() - start
      _write(FLAGS.output, record)
      print(f'case {seed}: searches in {case["search_wall_s"]:.0f} s',
            flush=True)


def _report(record: Dict[str, Any]) -> None:
  import matplotlib  # pylint: disable=g-import-not-at-top
  matplotlib.use('Agg')
  from matplotlib import figure  # pylint: disable=g-import-not-at-top
  settings = record['settings']
  cases = {k: c for k, c in record['cases'].items() if 'regret' in c}
  if not cases:
    raise cli.CommandFailure(f'{FLAGS.output}: no finished case')
  budgets = np.array(settings['budgets'])
  rollouts = budgets * settings['draws']
  fig = figure.Figure(figsize=(6.5, 4.5))
  ax = fig.subplots()
  lines = ['| method | ' + ' | '.join(f'{b} evals ({r} rollouts)' for b, r in
                                       zip(budgets, rollouts)) + ' |',
           '|---|' + '---|' * len(budgets)]
  for method in ('grid', 'random', 'bayes'):
    regret = np.array([curve for c in cases.values()
                       for curve in c['regret'][method]])  # [runs, budgets]
    mean = regret.mean(axis=0)
    se = regret.std(axis=0, ddof=1) / np.sqrt(len(regret))
    ax.errorbar(rollouts, mean, yerr=se, marker='o', capsize=3,
                label={'grid': 'grid, random order', 'random': 'uniform random',
                       'bayes': 'Bayesian optimisation'}[method])
    found = (regret == 0).mean(axis=0)
    lines.append(f'| {method} | ' + ' | '.join(
        f'{m:.3f} +- {s:.3f} ({100 * f:.0f}% opt.)'
        for m, s, f in zip(mean, se, found)) + ' |')
  n_grid = int(np.prod(settings['grid']))
  ax.set_xscale('log', base=2)
  ax.set_xlabel(f'rollouts ({settings["draws"]} per evaluated launch)')
  ax.set_ylabel('regret: grid optimum - best found (expected TW50)')
  shape = 'x'.join(map(str, settings['grid']))
  ax.set_title(f'{len(cases)} worlds, grid {shape} = {n_grid} launches '
               f'({n_grid * settings["draws"]} rollouts)', fontsize=10)
  ax.grid(alpha=0.3)
  ax.legend()
  fig.tight_layout()
  stem = os.path.splitext(FLAGS.output)[0]
  png = io.BytesIO()
  fig.savefig(png, format='png', dpi=110)
  safe_io.atomic_write(stem + '.png', png.getvalue())
  case_lines = ['| world seed | grid optimum | best launch (east, north km, '
                '+h) | its distance | station launch, best delay | top-10 '
                'outside 50 km | grid wall (load) |',
                '|---|---|---|---|---|---|---|']
  for seed, c in sorted(cases.items(), key=lambda kv: int(kv[0])):
    b = c['best']
    case_lines.append(
        f'| {seed} | {c["optimum"]:.3f} | ({b["east_km"]:g}, '
        f'{b["north_km"]:g}, +{b["hours"]:g}) | {b["distance_km"]:.0f} km | '
        f'{c["station_best"]:.3f} | {c["top10_outside"]}/10 | '
        f'{c["score_wall_s"]:.0f} s ({c["load_before"]:.1f}) |')
  text = ('Regret (mean +- standard error over cases x repeats; % of runs '
          'at the grid optimum):\n\n' + '\n'.join(lines) + '\n\nCases:\n\n' +
          '\n'.join(case_lines) + '\n')
  safe_io.atomic_write(stem + '.md', text)
  print(text)
  print(f'wrote {stem}.png and {stem}.md')


def _main(argv: Sequence[str]) -> None:
  del argv
  if FLAGS.report_only:
    record = _load(FLAGS.output)
    if record is None:
      raise cli.CommandFailure(f'{FLAGS.output}: no record')
    _report(record)
    return
  settings = _settings()
  cli.prepare_output_dir(os.path.dirname(os.path.abspath(FLAGS.output)),
                         '--output')
  # One writer per record.
  with safe_io.locked_file(FLAGS.output, what='launch_search record'):
    _resume(settings)


def _resume(settings: Dict[str, Any]) -> None:
  record = _load(FLAGS.output)
  if record is None:
    record = {'settings': settings, 'cases': {}}
  elif record['settings'] != json.loads(json.dumps(settings)):
    different = [k for k in settings
                 if record['settings'].get(k) != json.loads(
                     json.dumps(settings[k]))]
    raise cli.CommandUsageError(
        f'{FLAGS.output} holds a run of other settings ({", ".join(different)}'
        '); give another --output')
  _run(record)
  _report(record)


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'launch_search', FLAGS, argv, doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
