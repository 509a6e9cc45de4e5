r"""A planner sweep's flights as the summary committed beside its declaration.

  python benchmarks/planner_sweep_summary.py \
      --records=DIR/latex_validation --names=buffer06,buffer10 \
      --json=benchmarks/records/planners/realistic_task/validation_sweep.json \
      [--early_hours=6]

Reads DIR/NAME.json (`benchmarks/planners.py`'s flights, one per seed, with
their flight paths: ~0.7 MB for 16 three-day flights, too big to commit)
and DIR/timing/NAME.json (the settings they were flown with, `run_config`)
for each NAME, and writes one record: per setting its gin files and
bindings, the summary (`run.tables.summarize_flights`: TW50 over the window,
out of resources, sand, helium) and per seed the TW50, strides flown, the
terminal reason, the sand and helium spent, and what of them went in the
first --early_hours (a flight's opening manoeuvre). docs' tables are
generated from the record (`docs/hooks/tables.py`).
"""

import json
import os
import pathlib
import sys
from typing import Any, Dict, Optional, Sequence

from absl import flags

from ble_latex import safe_io
from ble_latex.cli import common as cli
from ble_latex.run import records
from ble_latex.run import tables

FLAGS = flags.FlagValues()
flags.DEFINE_string('records', None, 'Folder of the flights (NAME.json, '
                    'timing/NAME.json).', flag_values=FLAGS)
flags.DEFINE_list('names', None, 'The settings flown, in the order of the '
                  'record.', flag_values=FLAGS)
flags.DEFINE_string('json', None, 'The summary record written.',
                    flag_values=FLAGS)
flags.DEFINE_float('early_hours', 6.0, 'The opening span whose spending is '
                   'counted apart [h].', lower_bound=0.0, flag_values=FLAGS)


def early_spend(flight: Dict[str, Any], hours: float) -> Dict[str, float]:
  """Sand [kg] and the fraction of the launch helium spent by `hours`."""
  path = flight['flight_path']
  first = path[0]
  by = [p for p in path if p['t_s'] <= hours * 3600.0][-1]
  return {'sand_kg': first['sand_kg'] - by['sand_kg'],
          'helium_fraction': (first['helium_mols'] - by['helium_mols']) /
                             first['helium_mols']}


def setting(folder: pathlib.Path, name: str, hours: float) -> Dict[str, Any]:
  """The summary of one setting's flights (`folder`/`name`.json)."""
  path = folder / f'{name}.json'
  flights = records.load_eval(str(path))
  timing = tables.load(folder / 'timing' / f'{name}.json')
  config = timing.get('run_config') or {}
  totals = tables.summarize_flights(flights, path)
  early = [early_spend(f, hours) for f in flights]
  return {
      'name': name,
      'gin_files': config.get('gin_files', []),
      'gin_bindings': config.get('gin_bindings', []),
      'summary': {k: v for k, v in totals.items() if k != 'per_seed'},
      'per_seed': {
          'seeds': [f['seed'] for f in flights],
          'tw50_window': [f['tw50_window'] for f in flights],
          'steps': [f['steps'] for f in flights],
          'terminal_reason': [f['terminal_reason'] for f in flights],
          'sand_dropped_kg': [f['sand_dropped_kg'] for f in flights],
          'helium_vented_mols': [f['helium_vented_mols'] for f in flights],
          'early_sand_kg': [e['sand_kg'] for e in early],
          'early_helium_fraction': [e['helium_fraction'] for e in early],
      },
  }


def summary(folder: str, names: Sequence[str], hours: float) -> Dict[str, Any]:
  """The record: the command's inputs and one entry per setting."""
  return {'records': folder, 'early_hours': hours,
          'settings': [setting(pathlib.Path(folder), n, hours)
                       for n in names]}


def _check() -> None:
  for flag in ('records', 'names', 'json'):
    if not FLAGS[flag].value:
      raise cli.CommandUsageError(f'--{flag} is required')
  if not os.path.isdir(FLAGS.records):
    raise cli.CommandUsageError(f'--records: no folder {FLAGS.records}')
  problem = safe_io.output_problem(FLAGS.json)
  if problem:
    raise cli.CommandUsageError(f'--json {FLAGS.json}: {problem}')


def _main(unused_argv: Sequence[str]) -> int:
  try:
    record = summary(FLAGS.records, FLAGS.names, FLAGS.early_hours)
  except (KeyError, IndexError, ValueError) as e:  # A record not a sweep's.
    raise cli.CommandFailure(f'{FLAGS.records}: {e}') from e
  safe_io.atomic_write(FLAGS.json, json.dumps(record, indent=1) + '\n')
  print(f'{FLAGS.json}: {len(record["settings"])} settings', flush=True)
  return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/planner_sweep_summary.py', FLAGS,
                      argv, doc=__doc__, check=_check)


if __name__ == '__main__':
  sys.exit(main())
