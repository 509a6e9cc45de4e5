"""Prints README's results table from `ble-latex-eval` JSON files.

  python benchmarks/results_table.py benchmarks/results/latex_small/*.json

One row per file (agent = file name): TW50 over the 3-day window (the
targets' metric) and BLE's TW50 over the steps flown, mean ± std; reward mean ± std,
helium vented, sand dropped, % of episodes out of resources, episodes.
`make results` runs the evals and this script (see README "Results").
"""

import json
import os
import sys
from typing import Optional, Sequence

from absl import flags

from ble_latex import safe_io
from ble_latex.cli import common as cli
from ble_latex.run import metrics
from ble_latex.run import records as records_lib

FLAGS = flags.FlagValues()
flags.DEFINE_string('json', None, 'Also write the rows here.',
                    flag_values=FLAGS)


def row(path: str) -> dict:
  """One table row: `metrics.summarize` of an eval file, plus its name/seeds."""
  records = records_lib.load_eval(path)
  s = metrics.summarize(records)
  return {
      'agent': os.path.splitext(os.path.basename(path))[0],
      'episodes': s['episodes'],
      'tw50_window': (s['tw50_window_mean'], s['tw50_window_std']),
      'tw50': (s['tw50_mean'], s['tw50_std']),
      'reward': (s['reward_mean'], s['reward_std']),
      'helium': s['helium_vented_mols_mean'],
      'sand': s['sand_dropped_kg_mean'],
      'out_of_resources_pct': s['out_of_resources_pct'],
      'seeds': (min(r['seed'] for r in records),
                max(r['seed'] for r in records)),
  }


def markdown(rows) -> str:
  lines = ['| agent | TW50 window (mean ± std) | TW50 flown (mean ± std) '
           '| reward (mean ± std) | helium vented '
           '[mol] | sand dropped [kg] | out of resources | episodes |',
           '|---|---|---|---|---|---|---|---|']
  for r in sorted(rows, key=lambda r: -r['tw50_window'][0]):
    lines.append(
        f'| {r["agent"]} | {100 * r["tw50_window"][0]:.1f} % ± '
        f'{100 * r["tw50_window"][1]:.1f}'
        f' | {100 * r["tw50"][0]:.1f} % ± {100 * r["tw50"][1]:.1f}'
        f' | {r["reward"][0]:.1f} ± {r["reward"][1]:.1f} | {r["helium"]:.1f} '
        f'| {r["sand"]:.2f} | {r["out_of_resources_pct"]:.0f} % '
        f'| {r["episodes"]} |')
  return '\n'.join(lines)


def _main(argv: Sequence[str]) -> int:
  if len(argv) < 2:
    raise cli.CommandUsageError('give ble-latex-eval JSON files')
  args = FLAGS
  rows = [row(p) for p in argv[1:]]
  seeds = {r['seeds'] for r in rows}
  if len(seeds) > 1:
    print(f'warning: the files cover different seeds: {sorted(seeds)}',
          file=sys.stderr)
  print(markdown(rows))
  if args.json:
    safe_io.atomic_write(args.json, json.dumps(rows, indent=1))
  return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/results_table.py', FLAGS, argv,
                      doc=__doc__, positional=True)


if __name__ == '__main__':
  sys.exit(main())
