"""DAgger runs and their held-out flights, into one record (issue 47).

  python benchmarks/dagger_results.py --name=gpu_h200 \\
      --runs=benchmarks/dagger/gpu_h200 \\
      --heldout=benchmarks/results_dagger/latex_small/dagger_gpu_seed_{seed}.json \\
      --machine='one NVIDIA H200 (lent), 3 seeds side by side'

Reads each `--runs/seed_S/summary.json` (`benchmarks/train_dagger.py`) or,
for a run whose summary did not come back, the per-round lines of its log
`--runs/seed_S.log` (`--from_logs`); and, where given, the `ble-latex-eval`
record of the seed's best student on a held-out suite (`--heldout`, with
`{seed}`). Writes one group `--name` into `--json` (other groups kept):
per training seed the validation curve, the best round, labels and wall
time, and the held-out flights' per-seed TW50 over the window (flight
paths left out). `--reference NAME=PATH` adds other agents' per-seed records
on the same suite (the planners, the shipped SAC policy), which the docs'
`dagger` table pairs with the students seed by seed
(`docs/hooks/tables.py`).
"""

import glob
import json
import os
import re
import sys
from typing import Optional, Sequence

from absl import flags

from ble_latex import safe_io
from ble_latex.cli import common as cli
from ble_latex.run import metrics

FLAGS = flags.FlagValues()
flags.DEFINE_string('name', None, 'The group written (e.g. gpu_h200).',
                    flag_values=FLAGS)
flags.DEFINE_string('runs', None, 'Folder of seed_S run directories.',
                    flag_values=FLAGS)
flags.DEFINE_bool('from_logs', False, 'Read the rounds from seed_S.log.',
                  flag_values=FLAGS)
flags.DEFINE_string('heldout', None, 'Eval record of seed S\'s best student '
                    '(a path with {seed}).', flag_values=FLAGS)
flags.DEFINE_multi_string('reference', [], 'NAME=PATH: another agent\'s '
                          'eval record on the same suite.', flag_values=FLAGS)
flags.DEFINE_string('machine', '', 'Where the runs trained.',
                    flag_values=FLAGS)
flags.DEFINE_string('note', '', 'What differs in this group.',
                    flag_values=FLAGS)
flags.DEFINE_string('json', 'benchmarks/dagger/results.json', 'The record.',
                    flag_values=FLAGS)

# A round's line in train_dagger.py's log (`dagger.train`'s `log`).
_ROUND = re.compile(
    r'^round (\d+): beta ([0-9.]+), (\d+) labels \((\d+) in all\), fit loss '
    r'([0-9.]+), validation TW50 window ([0-9.]+) \((\d+) % out of '
    r'resources\); fly (\d+) s, fit (\d+) s$')


def _rounds_from_summary(path: str) -> list:
  with open(path, encoding='utf-8') as f:
    summary = json.load(f)
  return [{'round': r['round'], 'beta': r['beta'], 'labelled': r['labelled'],
           'fit_loss': r['fit_loss'],
           'validation_tw50_window': r['validation']['tw50_window_mean'],
           'validation_out_of_resources_pct':
               r['validation']['out_of_resources_pct'],
           'validation_episodes': r['validation']['episodes'],
           'wall_s': r['fly_s'] + r['fit_s'] + r['validate_s']}
          for r in summary['rounds']]


def _rounds_from_log(path: str) -> list:
  rounds = []
  with open(path, encoding='utf-8') as f:
    for line in f:
      m = _ROUND.match(line.strip())
      if m:
        rounds.append({
            'round': int(m[1]), 'beta': float(m[2]), 'labelled': int(m[3]),
            'fit_loss': float(m[5]), 'validation_tw50_window': float(m[6]),
            'validation_out_of_resources_pct': float(m[7]),
            'wall_s_fly_fit': int(m[8]) + int(m[9])})
  if not rounds:
    raise ValueError(f'{path}: no round lines')
  return rounds


def per_seed(path: str) -> dict:
  """An eval record's summary and its per-seed TW50 over the window.

  `ble-latex-eval` records and `benchmarks/planners.py`'s (which may lack
  flight paths) alike: a JSON list of per-episode records with
  `metrics.summarize`'s keys.
  """
  with open(path, encoding='utf-8') as f:
    records = json.load(f)
  if not isinstance(records, list) or not records or not all(
      isinstance(r, dict) and 'seed' in r for r in records):
    raise ValueError(f'{path}: not a list of per-episode eval records')
  records = sorted(records, key=lambda r: int(r['seed']))
  summary = metrics.summarize(records)
  return {'path': path, 'seeds': [int(r['seed']) for r in records],
          'tw50_window': [float(r['tw50_window']) for r in records],
          'tw50_window_mean': summary['tw50_window_mean'],
          'tw50_window_std': summary['tw50_window_std'],
          'out_of_resources_pct': summary['out_of_resources_pct'],
          'helium_vented_mols_mean': summary['helium_vented_mols_mean'],
          'sand_dropped_kg_mean': summary['sand_dropped_kg_mean']}


def _main(argv: Sequence[str]) -> int:
  del argv
  try:
    return _write()
  except (OSError, ValueError, KeyError) as error:
    raise cli.CommandFailure(cli.one_line(error)) from error


def _write() -> int:
  if not FLAGS.name or not FLAGS.runs:
    raise cli.CommandUsageError('give --name and --runs')
  pattern = 'seed_*.log' if FLAGS.from_logs else 'seed_*/summary.json'
  found = sorted(glob.glob(os.path.join(FLAGS.runs, pattern)))
  if not found:
    raise cli.CommandUsageError(f'no {pattern} under {FLAGS.runs}')
  seeds = {}
  for path in found:
    seed = int(re.search(r'seed_(\d+)', path)[1])
    rounds = (_rounds_from_log(path) if FLAGS.from_logs else
              _rounds_from_summary(path))
    fit = [r for r in rounds if r['validation_out_of_resources_pct'] <= 5.0]
    best = max(fit, key=lambda r: (r['validation_tw50_window'], -r['round']))
    entry = {'rounds': rounds, 'best_round': best['round'],
             'best_validation_tw50_window': best['validation_tw50_window'],
             'labels': sum(r['labelled'] for r in rounds)}
    if FLAGS.heldout:
      entry['heldout'] = per_seed(FLAGS.heldout.format(seed=seed))
    seeds[str(seed)] = entry
  references = {}
  for item in FLAGS.reference:
    name, sep, path = item.partition('=')
    if not sep or not name or not path:
      raise cli.CommandUsageError(f'--reference {item!r}: want NAME=PATH')
    references[name] = per_seed(path)
  record = {}
  if os.path.exists(FLAGS.json):
    with open(FLAGS.json, encoding='utf-8') as f:
      record = json.load(f)
  record.setdefault('about', 'benchmarks/dagger_results.py: DAgger runs '
                    '(issue 47), validation on latex_validation, held-out '
                    'flights of the best validated students.')
  record.setdefault('groups', {})[FLAGS.name] = {
      'runs': FLAGS.runs, 'machine': FLAGS.machine, 'note': FLAGS.note,
      'command': ' '.join(sys.argv), 'seeds': seeds,
      'references': references}
  safe_io.atomic_write(FLAGS.json, json.dumps(record, indent=1) + '\n')
  for seed, entry in seeds.items():
    held = entry.get('heldout')
    print(f'{FLAGS.name} seed {seed}: {len(entry["rounds"])} rounds, best '
          f'round {entry["best_round"]} validation '
          f'{100 * entry["best_validation_tw50_window"]:.1f} %'
          + (f', held out {100 * held["tw50_window_mean"]:.1f} %' if held
             else ''))
  return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/dagger_results.py', FLAGS, argv,
                      doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
