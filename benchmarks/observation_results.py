"""SAC runs of different observations side by side, into one record (issue 47).

  python benchmarks/observation_results.py \\
      --run=paper=benchmarks/records/sac_jax/n32 \\
      --run=wind_memory16=benchmarks/records/sac_jax/wind_memory16 \\
      --run=wind_lookahead12=benchmarks/records/sac_jax/wind_lookahead12 \\
      --reference=sac_pretrained=benchmarks/results/latex_small/sac_pretrained.json \\
      --reference=latex_mpc=benchmarks/records/planners/latex_small/latex_mpc.json \\
      --reference=latex_mpc_oracle=benchmarks/records/planners/latex_small/latex_mpc_oracle.json

Each `--run NAME=BASE_DIR` is a `benchmarks/sac_seeds.py` run: its seeds'
validation curves (`seed_S/validation.jsonl`), the observation they trained
on (`seed_S/run.json`'s `latex_observation.*` settings, `wind_memory` and
`wind_lookahead`, 0 where one is not recorded: runs from before it existed
observed without it) and its report (`report.json`,
written by `sac_seeds.py report`: each seed's snapshot chosen on
`latex_validation` and flown held out). Where a seed's held-out eval file is
here (`held_out_file`, git-ignored), its per-seed TW50s are kept, so the
docs' `observation` table pairs it seed by seed with each `--reference`
(other agents' eval records on the same suite). Writes `--json`; the docs'
tables are generated from it (`docs/hooks/tables.py`).
"""

import json
import os
import sys
from typing import Any, Dict, Optional, Sequence

from absl import flags

from ble_latex import safe_io
from ble_latex.cli import common as cli
from ble_latex.envs import env_params
from ble_latex.run import episode_log
from ble_latex.run import gin_binding
from ble_latex.run import metrics
from ble_latex.run import records

FLAGS = flags.FlagValues()
flags.DEFINE_multi_string('run', [], 'NAME=BASE_DIR of a sac_seeds.py run '
                          '(report.json and seed_S/).', flag_values=FLAGS)
flags.DEFINE_multi_string('reference', [], 'NAME=PATH: another agent\'s '
                          'eval record on the held-out suite.',
                          flag_values=FLAGS)
flags.DEFINE_string('json', str(episode_log.RECORDS_DIR / 'sac_jax' / 'observation_results.json'),
                    'The record.', flag_values=FLAGS)


def _pairs(items: Sequence[str], flag: str) -> Dict[str, str]:
  out = {}
  for item in items:
    name, sep, path = item.partition('=')
    if not sep or not name or not path:
      raise cli.CommandUsageError(f'--{flag} {item!r}: want NAME=PATH')
    out[name] = path
  return out


def _read_json(path: str) -> Any:
  with open(path, encoding='utf-8') as f:
    return json.load(f)


def run_entry(base_dir: str) -> Dict[str, Any]:
  """One run's seeds: observation, validation curve, choice, held out."""
  report = _read_json(os.path.join(base_dir, 'report.json'))
  seeds = {}
  for row in report['rows']:
    seed_dir = os.path.join(base_dir, f'seed_{row["seed"]}')
    info = _read_json(os.path.join(seed_dir, 'run.json'))
    curve = [[r['iteration'], r['tw50_window_mean'],
              r['out_of_resources_pct']]
             for r in records.load_validation(
                 os.path.join(seed_dir, 'validation.jsonl'))]
    held = row.get('held_out_file')
    seeds[str(row['seed'])] = {
        'observation': {k: int(info.get(k, 0))
                        for k in env_params.OBSERVATION_FIELDS},
        'validation': curve,
        'chosen_round': row['iteration'],
        'training_minutes': row['training_minutes'],
        'chosen_validation_tw50_window': row['validation_tw50_window'],
        'chosen_validation_oor_pct': row['validation_out_of_resources_pct'],
        'heldout_tw50_window_mean': row['held_out_tw50_window'],
        'heldout_oor_pct': row['held_out_out_of_resources_pct'],
        'heldout': (metrics.per_seed_summary(held)
                    if held and os.path.exists(held) else None)}
  return {'base_dir': base_dir, 'max_iteration': report['max_iteration'],
          'max_oor_pct': report['max_oor_pct'],
          'held_out_suite': report['held_out_suite'], 'seeds': seeds}


def _main(argv: Sequence[str]) -> int:
  del argv
  runs = _pairs(FLAGS.run, 'run')
  references = _pairs(FLAGS.reference, 'reference')
  if not runs:
    raise cli.CommandUsageError('give at least one --run NAME=BASE_DIR')
  try:
    record = {
        'about': 'benchmarks/observation_results.py: SAC (jitted trainer, '
                 'sac_jax.gin) on different observations (issue 47): '
                 'validation curves on latex_validation, the snapshot chosen '
                 'there, its held-out flights.',
        'command': ' '.join(sys.argv),
        'runs': {name: run_entry(path) for name, path in runs.items()},
        'references': {name: metrics.per_seed_summary(path)
                       for name, path in references.items()}}
  except (OSError, ValueError, KeyError, TypeError) as error:
    raise cli.CommandFailure(gin_binding.one_line(error)) from error
  safe_io.atomic_write(FLAGS.json, json.dumps(record, indent=1) + '\n')
  for name, run in record['runs'].items():
    for seed, entry in run['seeds'].items():
      print(f'{name} seed {seed}: round {entry["chosen_round"]}, validation '
            f'{100 * entry["chosen_validation_tw50_window"]:.1f} %, held out '
            f'{100 * entry["heldout_tw50_window_mean"]:.1f} %'
            + ('' if entry['heldout'] else ' (no per-seed file here)'))
  return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/observation_results.py', FLAGS,
                      argv, doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
