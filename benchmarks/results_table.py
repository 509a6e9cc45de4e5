"""Prints README's results table from `ble-latex-eval` JSON files.

  python benchmarks/results_table.py benchmarks/results/latex_small/*.json

One row per file (agent = file name): TW50 mean ± std, reward mean ± std,
helium vented, sand dropped, % of episodes out of resources, episodes.
`make results` runs the evals and this script (see README "Results").
"""

import argparse
import json
import os
import sys

import numpy as np


def row(path: str) -> dict:
  with open(path) as f:
    records = json.load(f)
  if not isinstance(records, list) or not records:
    raise ValueError(f'{path}: not a non-empty ble-latex-eval result list')
  def col(key):
    return np.array([float(r[key]) for r in records])
  out_of = np.mean([r['terminal_reason'] in ('out_of_sand', 'out_of_helium')
                    for r in records])
  return {
      'agent': os.path.splitext(os.path.basename(path))[0],
      'episodes': len(records),
      'tw50': (col('tw50').mean(), col('tw50').std()),
      'reward': (col('reward').mean(), col('reward').std()),
      'helium': col('helium_vented_mols').mean(),
      'sand': col('sand_dropped_kg').mean(),
      'out_of_resources_pct': 100.0 * out_of,
      'seeds': (min(r['seed'] for r in records),
                max(r['seed'] for r in records)),
  }


def markdown(rows) -> str:
  lines = ['| agent | TW50 (mean ± std) | reward (mean ± std) | helium vented '
           '[mol] | sand dropped [kg] | out of resources | episodes |',
           '|---|---|---|---|---|---|---|']
  for r in sorted(rows, key=lambda r: -r['tw50'][0]):
    lines.append(
        f'| {r["agent"]} | {100 * r["tw50"][0]:.1f} % ± {100 * r["tw50"][1]:.1f}'
        f' | {r["reward"][0]:.1f} ± {r["reward"][1]:.1f} | {r["helium"]:.1f} '
        f'| {r["sand"]:.2f} | {r["out_of_resources_pct"]:.0f} % '
        f'| {r["episodes"]} |')
  return '\n'.join(lines)


def main() -> int:
  parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
  parser.add_argument('eval_json', nargs='+')
  parser.add_argument('--json', help='also write the rows here')
  args = parser.parse_args()
  rows = [row(p) for p in args.eval_json]
  seeds = {r['seeds'] for r in rows}
  if len(seeds) > 1:
    print(f'warning: the files cover different seeds: {sorted(seeds)}',
          file=sys.stderr)
  print(markdown(rows))
  if args.json:
    with open(args.json, 'w') as f:
      json.dump(rows, f, indent=1)
  return 0


if __name__ == '__main__':
  sys.exit(main())
