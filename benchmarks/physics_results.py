"""Paper physics vs realistic latex physics, side by side (issues 28, 44).

  make baselines baselines-realistic long-flights   # the evals (Makefile)
  python benchmarks/physics_results.py --json=benchmarks/records/physics_results.json \
      --paper=benchmarks/results/latex_small \
      --realistic=benchmarks/results_realistic/latex_small \
      --realistic_stress=benchmarks/results_realistic_stress/latex_small \
      --paper_long=benchmarks/results_7day/latex_small \
      --realistic_long=benchmarks/results_7day_realistic/latex_small
  make realistic-task   # the realistic task's evals (issue 63), then
  python benchmarks/physics_results.py --json=benchmarks/records/physics_results.json \
      --realistic_task=benchmarks/results_realistic_task/latex_small \
      --realistic_task_long=benchmarks/results_7day_realistic_task/latex_small

The record (`--json`) keeps one section per folder flag (`paper`,
`realistic`, `realistic_stress`, `paper_long`, `realistic_long`,
`realistic_task`, `realistic_task_long`); a rerun
replaces only the sections whose folders it is given and keeps the others
(so the paper's rows need not be flown again to re-measure the realistic
ones). `realistic_uncalibrated` and `realistic_long_uncalibrated` hold the
rows flown before issue 44's calibration (lift walk 1.4 g/sqrt(s), +5/-2 K,
150 Pa), kept for the record; README's and docs/physics.md's tables are
generated from this record (`docs/hooks/tables.py`).

Reads `ble-latex-eval` JSON files (one per agent, the file name is the
agent's) and prints two Markdown tables:

1. The 3-day suite: per agent, TW50 over the window (mean ± std), % of
   episodes out of resources, helium vented and sand dropped, in the paper's
   model and under gin_configs/latex_realistic.gin. Files named
   `<prefix>_seed_<s>.json` (several training seeds of one setting, e.g.
   `benchmarks/sac_seeds.py report`'s) also give one row of the mean ± std
   over seeds of their per-seed means.
2. Long flights (`--max_episode_length=504`, 7 days): days aloft before the
   episode ended (mean ± std; an episode that reaches the time limit counts
   its 7 days), % of flights aloft for all 7 days, TW50 over the 7 days.
"""

import json
import os
import sys
from typing import Any, Dict, List, Optional, Sequence

from absl import flags

from ble_latex import safe_io
from ble_latex.cli import common as cli
from ble_latex.run import metrics
from ble_latex.run import records

FLAGS = flags.FlagValues()
flags.DEFINE_string('paper', None, '3-day evals, paper physics (a folder).',
                    flag_values=FLAGS)
flags.DEFINE_string('realistic', None, '3-day evals, realistic physics.',
                    flag_values=FLAGS)
flags.DEFINE_string('paper_long', None, '7-day evals, paper physics.',
                    flag_values=FLAGS)
flags.DEFINE_string('realistic_long', None, '7-day evals, realistic physics.',
                    flag_values=FLAGS)
flags.DEFINE_string('realistic_stress', None,
                    '3-day evals, realistic physics at the 1.4 g/sqrt(s) '
                    'stress setting of the lift disturbance.',
                    flag_values=FLAGS)
flags.DEFINE_string('realistic_task', None,
                    '3-day evals, the realistic task (latex_realistic.gin + '
                    'latex_realistic_task.gin, issue 63).', flag_values=FLAGS)
flags.DEFINE_string('realistic_task_long', None,
                    '7-day evals, the realistic task.', flag_values=FLAGS)
flags.DEFINE_string('json', None, 'Also write the rows here.',
                    flag_values=FLAGS)

# The record's sections a folder flag fills (the flag's name).
SECTIONS = ('paper', 'realistic', 'realistic_stress', 'paper_long',
            'realistic_long', 'realistic_task', 'realistic_task_long')


def _load(folder: Optional[str]) -> Dict[str, List[Dict[str, Any]]]:
  """The eval records of every `*.json` in `folder`, by agent (file) name."""
  if folder is None or not os.path.isdir(folder):
    return {}
  out = {}
  for name in sorted(os.listdir(folder)):
    if not name.endswith('.json') or name.endswith('.partial.json'):
      continue
    out[name[:-len('.json')]] = records.load_eval(os.path.join(folder, name))
  return out


def _rows(folder: Optional[str]) -> Dict[str, Dict[str, Any]]:
  rows = {agent: metrics.summarize_aloft(r)
          for agent, r in _load(folder).items()}
  rows.update(metrics.over_seeds(rows))
  return rows


def _pct(s: Optional[Dict[str, Any]], key: str = 'tw50_window') -> str:
  if s is None:
    return '—'
  spread = ('± {:.1f} (seeds)'.format(100 * s[key + '_std'])
            if 'num_seeds' in s else f'± {100 * s[key + "_std"]:.1f}')
  return f'{100 * s[key + "_mean"]:.1f} % {spread}'


def _cost(s: Optional[Dict[str, Any]]) -> str:
  if s is None:
    return '—'
  return (f'{s["out_of_resources_pct"]:.0f} % / '
          f'{s["helium_vented_mols_mean"]:.1f} mol / '
          f'{s["sand_dropped_kg_mean"]:.2f} kg')


def side_by_side(paper: Dict[str, Dict[str, Any]],
                 realistic: Dict[str, Dict[str, Any]]) -> str:
  """Table 1: the 3-day suite in both physics."""
  lines = ['| agent | TW50 window, paper | TW50 window, realistic '
           '| out of resources / helium / sand, paper '
           '| out of resources / helium / sand, realistic | episodes |',
           '|---|---|---|---|---|---|']
  agents = sorted(set(paper) | set(realistic), key=lambda a: -max(
      paper.get(a, {}).get('tw50_window_mean', -1),
      realistic.get(a, {}).get('tw50_window_mean', -1)))
  for a in agents:
    p, r = paper.get(a), realistic.get(a)
    episodes = '/'.join(str(s['episodes']) for s in (p, r) if s)
    lines.append(f'| {a} | {_pct(p)} | {_pct(r)} | {_cost(p)} | {_cost(r)} '
                 f'| {episodes} |')
  return '\n'.join(lines)


def long_flights(paper: Dict[str, Dict[str, Any]],
                 realistic: Dict[str, Dict[str, Any]]) -> str:
  """Table 2: 7-day flights, days aloft before resources ran out."""
  lines = ['| agent | physics | days aloft (mean ± std) | aloft all 7 days '
           '| TW50 over 7 days | out of resources | episodes |',
           '|---|---|---|---|---|---|---|']
  for mode, rows in (('paper', paper), ('realistic', realistic)):
    for a, s in sorted(rows.items(), key=lambda x: -x[1]['days_aloft_mean']):
      lines.append(
          f'| {a} | {mode} | {s["days_aloft_mean"]:.2f} ± '
          f'{s["days_aloft_std"]:.2f} '
          f'| {s["full_window_pct"]:.0f} % | {_pct(s)} '
          f'| {s["out_of_resources_pct"]:.0f} % | {s["episodes"]} |')
  return '\n'.join(lines)


def _main(argv: Sequence[str]) -> int:
  if len(argv) != 1:
    raise cli.CommandUsageError('takes flags only')
  args = FLAGS
  given = {name: getattr(args, name) for name in SECTIONS
           if getattr(args, name) is not None}
  fresh = {name: _rows(folder) for name, folder in given.items()}
  for name in [n for n, rows in fresh.items() if not rows]:
    print(f'{name}: no eval files in {given[name]}; the record\'s rows kept',
          file=sys.stderr)
    del fresh[name]
  if not fresh:
    raise cli.CommandUsageError('no eval files in the folders given')
  tables = {}
  if args.json and os.path.exists(args.json):
    with open(args.json, encoding='utf-8') as f:
      tables = json.load(f)
  tables.update(fresh)
  get = lambda name: tables.get(name, {})  # pylint: disable=unnecessary-lambda-assignment
  print('3-day suite (latex_small):\n')
  print(side_by_side(get('paper'), get('realistic')))
  if get('realistic_stress'):
    print('\nStress setting (lift walk 1.4 g/sqrt(s)), 3-day suite:\n')
    print(side_by_side({}, get('realistic_stress')))
  if get('paper_long') or get('realistic_long'):
    print('\n7-day flights (504 strides, latex_small seeds):\n')
    print(long_flights(get('paper_long'), get('realistic_long')))
  if get('realistic_task'):
    print('\nThe realistic task (issue 63), 3-day suite:\n')
    print(side_by_side(get('realistic'), get('realistic_task')))
  if get('realistic_task_long'):
    print('\nThe realistic task, 7-day flights:\n')
    print(long_flights({}, get('realistic_task_long')))
  if args.json:
    safe_io.atomic_write(args.json, json.dumps(tables, indent=1) + '\n')
  return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/physics_results.py', FLAGS, argv,
                      doc=__doc__, positional=True)


if __name__ == '__main__':
  sys.exit(main())
