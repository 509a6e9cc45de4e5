"""DAgger runs and their held-out flights, into one record (issue 47).

  python benchmarks/dagger_results.py --name=gpu_h200 \\
      --runs=benchmarks/records/dagger/gpu_h200 \\
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
from ble_latex.run import dagger
from ble_latex.run import episode_log
from ble_latex.run import gin_binding
from ble_latex.run import metrics

FLAGS = flags.FlagValues()
flags.DEFINE_string('name', None, 'The group written (e.g. gpu_h200).',
                    flag_values=FLAGS)
flags.DEFINE_string('runs', None, 'Folder of seed_S run directories.',
                    flag_values=FLAGS)
flags.DEFINE_bool('from_logs', False, 'Read the rounds from seed_S.log '
                  '(the best round within DaggerConfig\'s default '
                  'out-of-resources bound unless a run.json is beside).',
                  flag_values=FLAGS)
flags.DEFINE_string('heldout', None, 'Eval record of seed S\'s best student '
                    '(a path with {seed}).', flag_values=FLAGS)
flags.DEFINE_multi_string('reference', [], 'NAME=PATH: another agent\'s '
                          'eval record on the same suite.', flag_values=FLAGS)
flags.DEFINE_string('machine', '', 'Where the runs trained.',
                    flag_values=FLAGS)
flags.DEFINE_string('note', '', 'What differs in this group.',
                    flag_values=FLAGS)
flags.DEFINE_string('json', str(episode_log.RECORDS_DIR / 'dagger' / 'results.json'), 'The record.',
                    flag_values=FLAGS)

def _records_from_summary(path: str) -> list:
  """The trainer's per-round records (`dagger.train`'s summary.json)."""
  with open(path, encoding='utf-8') as f:
    return json.load(f)['rounds']


def _bound(seed_dir: str) -> float:
  """The run's `max_out_of_resources_pct` (its run.json, else the default)."""
  path = os.path.join(seed_dir, 'run.json')
  if os.path.exists(path):
    with open(path, encoding='utf-8') as f:
      return float(json.load(f)['config']['max_out_of_resources_pct'])
  return dagger.DaggerConfig().max_out_of_resources_pct


def _main(argv: Sequence[str]) -> int:
  del argv
  try:
    return _write()
  except (OSError, ValueError, KeyError) as error:
    raise cli.CommandFailure(gin_binding.one_line(error)) from error


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
    records = (dagger.records_from_log(path) if FLAGS.from_logs else
               _records_from_summary(path))
    best = dagger.best_round(records, _bound(
        os.path.join(FLAGS.runs, f'seed_{seed}')))
    if best is None:
      raise ValueError(f'{path}: no round within the out-of-resources bound')
    entry = {'rounds': [dagger.flat_round(r) for r in records],
             'best_round': best['round'],
             'best_validation_tw50_window':
                 best['validation']['tw50_window_mean'],
             'labels': sum(r['labelled'] for r in records)}
    if FLAGS.heldout:
      entry['heldout'] = metrics.per_seed_summary(FLAGS.heldout.format(seed=seed))
    seeds[str(seed)] = entry
  references = {}
  for item in FLAGS.reference:
    name, sep, path = item.partition('=')
    if not sep or not name or not path:
      raise cli.CommandUsageError(f'--reference {item!r}: want NAME=PATH')
    references[name] = metrics.per_seed_summary(path)
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
