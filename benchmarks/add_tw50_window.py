"""Adds `tw50_window` to episode / eval records written before it existed.

  python benchmarks/add_tw50_window.py benchmarks/records/sac_paper_run/episodes.jsonl \
      benchmarks/results/latex_small/*.json

Older `episodes.jsonl` lines and `ble-latex-eval` records carry BLE's `tw50`
(steps within 50 km / steps flown) and `steps`. The number of steps within
the radius is then exactly `tw50 * steps` (an integer; checked), so
`tw50_window = tw50 * steps / window_steps` is what `metrics.EpisodeTracker`
writes today for the same flight. Records that already have the field are
checked against the derivation instead. Files are rewritten atomically.
"""

import json
import sys
from typing import Any, Dict, Optional, Sequence

from absl import flags

from ble_latex import safe_io
from ble_latex.cli import common as cli
from ble_latex.run import metrics

FLAGS = flags.FlagValues()
flags.DEFINE_integer('window_steps', 216,
                     'Episode length in steps (216 = 3 days).', lower_bound=1,
                     flag_values=FLAGS)


def upgrade(record: Dict[str, Any], window_steps: int) -> Dict[str, Any]:
  """The record with `tw50_window` and `window_steps` (derived, checked)."""
  steps = int(record['steps'])
  within = float(record['tw50']) * steps
  if abs(within - round(within)) > 1e-6:
    raise ValueError(f'seed {record.get("seed")}: tw50 * steps = {within} is '
                     'not a whole number of steps')
  window = min(window_steps, record.get('window_steps', window_steps))
  derived = metrics.tw50_fractions(round(within), steps, window)
  if 'tw50_window' in record:
    if abs(record['tw50_window'] - derived['tw50_window']) > 1e-12:
      raise ValueError(f'seed {record.get("seed")}: stored tw50_window '
                       f'{record["tw50_window"]} != {derived["tw50_window"]}')
    return record
  out = {}
  for key, value in record.items():  # Keep the writer's key order.
    out[key] = value
    if key == 'tw50':
      out['tw50_window'] = derived['tw50_window']
      out['window_steps'] = window
  return out


def _main(argv: Sequence[str]) -> int:
  files = argv[1:]
  if not files:
    raise cli.CommandUsageError('give episodes.jsonl or ble-latex-eval .json '
                                'files to upgrade')
  args = FLAGS
  for path in files:
    with open(path) as f:
      text = f.read()
    if path.endswith('.jsonl'):
      records = [json.loads(line) for line in text.splitlines() if line]
      new = [upgrade(r, args.window_steps) for r in records]
      data = ''.join(json.dumps(r) + '\n' for r in new)
    else:
      records = json.loads(text)
      new = [upgrade(r, args.window_steps) for r in records]
      data = json.dumps(new, indent=2 if text.startswith('[\n') else None)
    safe_io.atomic_write(path, data)
    s = metrics.summarize(new)
    print(f'{path}: {len(new)} records, TW50 window '
          f'{100 * s["tw50_window_mean"]:.1f} %, flown '
          f'{100 * s["tw50_mean"]:.1f} %')
  return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/add_tw50_window.py', FLAGS, argv,
                      doc=__doc__, positional=True)


if __name__ == '__main__':
  sys.exit(main())
