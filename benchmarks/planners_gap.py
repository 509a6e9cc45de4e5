"""The clairvoyant planner's gap to another agent, per seed, as a figure.

  python benchmarks/planners_gap.py \
      --upper=benchmarks/records/planners/latex_small/latex_mpc_oracle.json \
      --agent=benchmarks/results/latex_small/sac_pretrained.json \
      --output=benchmarks/records/planners/oracle_gap_sac.png

Both files are `ble-latex-eval` records (benchmarks/planners.py writes the
same). Left: TW50 over the window per seed, the upper bound against the
agent (points below the diagonal are flights the agent loses to what the
winds allowed). Right: the per-seed gap, sorted. Only the seeds in both
files are used; prints the mean gap and the seeds with the largest ones.
"""

import json
import sys
from typing import Optional, Sequence

from absl import flags
import numpy as np

from ble_latex.cli import common as cli

FLAGS = flags.FlagValues()
flags.DEFINE_string('upper', None, 'Records of the upper bound.',
                    flag_values=FLAGS)
flags.DEFINE_string('agent', None, 'Records of the agent compared.',
                    flag_values=FLAGS)
flags.DEFINE_string('output', 'oracle_gap.png', 'Figure to write.',
                    flag_values=FLAGS)
flags.DEFINE_string('upper_name', 'upper bound', 'What --upper flew (axis '
                    'labels).', flag_values=FLAGS)
flags.DEFINE_string('agent_name', 'agent', 'What --agent flew (axis labels).',
                    flag_values=FLAGS)


def _tw50(path: str):
  with open(path) as f:
    records = json.load(f)
  return {int(r['seed']): float(r['tw50_window']) for r in records}


def _main(argv: Sequence[str]) -> int:
  del argv
  if not FLAGS.upper or not FLAGS.agent:
    raise cli.CommandUsageError('give --upper and --agent')
  import matplotlib  # pylint: disable=g-import-not-at-top
  matplotlib.use('Agg')
  import matplotlib.pyplot as plt  # pylint: disable=g-import-not-at-top
  upper, other = _tw50(FLAGS.upper), _tw50(FLAGS.agent)
  seeds = sorted(set(upper) & set(other))
  if not seeds:
    raise cli.CommandUsageError('the two files share no seed')
  u = np.array([upper[s] for s in seeds])
  a = np.array([other[s] for s in seeds])
  gap = u - a
  fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4.2))
  left.scatter(100 * a, 100 * u, s=12)
  left.plot([0, 100], [0, 100], 'k--', lw=0.8)
  left.set_xlabel(f'{FLAGS.agent_name} TW50 window [%]')
  left.set_ylabel(f'{FLAGS.upper_name} TW50 window [%]')
  left.set_title(f'{len(seeds)} seeds')
  order = np.argsort(-gap)
  right.bar(np.arange(len(seeds)), 100 * gap[order])
  right.axhline(0, color='k', lw=0.8)
  right.set_xlabel('seeds, sorted by gap')
  right.set_ylabel(f'{FLAGS.upper_name} - {FLAGS.agent_name} [points]')
  right.set_title(f'mean gap {100 * gap.mean():.1f} points')
  fig.tight_layout()
  fig.savefig(FLAGS.output, dpi=120)
  worst = ', '.join(f'{seeds[i]} ({100 * gap[i]:+.0f})' for i in order[:5])
  print(f'{len(seeds)} seeds: mean gap {100 * gap.mean():.1f} points; '
        f'agent behind on {int(np.sum(gap > 0))}, ahead on '
        f'{int(np.sum(gap < 0))}; largest gaps: {worst}; wrote {FLAGS.output}')
  return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/planners_gap.py', FLAGS, argv,
                      doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
