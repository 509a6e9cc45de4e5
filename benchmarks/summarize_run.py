r"""A training run's episode log as the summary committed beside its records.

  python benchmarks/summarize_run.py benchmarks/records/sac_jax/n32/seed_2 \
      [--every=100]

Reads RUN/episodes.jsonl (a run log: it stays out of git) and writes
RUN/episodes_summary.json: the means over each block of --every episodes
(`ble_latex.run.episode_log.summarize`) with the command and the number of
episodes read.
"""

import json
import os
import sys
from typing import Optional, Sequence

from absl import flags

from ble_latex import safe_io
from ble_latex.cli import common as cli
from ble_latex.run import episode_log

FLAGS = flags.FlagValues()
flags.DEFINE_integer('every', 100, 'Episodes per block.', lower_bound=1,
                     flag_values=FLAGS)


def summary(run_dir: str, every: int) -> dict:
  """The summary record of RUN/episodes.jsonl (blocks of `every` episodes)."""
  log = os.path.join(run_dir, episode_log.EPISODE_LOG)
  records = episode_log.read(log)
  if not records:
    raise cli.CommandFailure(f'{log}: no episode log there')
  return {'about': 'benchmarks/summarize_run.py: means over blocks of '
                   f'{every} episodes of {episode_log.EPISODE_LOG}',
          'command': f'python benchmarks/summarize_run.py {run_dir} '
                     f'--every={every}',
          'episodes': len(records), 'every': every,
          'blocks': episode_log.summarize(records, every)}


def _main(argv: Sequence[str]) -> int:
  if len(argv) != 2:
    raise cli.CommandUsageError('give one run directory (RUN/episodes.jsonl)')
  run_dir = argv[1]
  out = os.path.join(run_dir, episode_log.EPISODE_SUMMARY)
  problem = safe_io.output_problem(out)
  if problem:
    raise cli.CommandUsageError(f'{out}: {problem}')
  record = summary(run_dir, FLAGS.every)
  safe_io.atomic_write(out, json.dumps(record, indent=1) + '\n')
  print(f'{out}: {record["episodes"]} episodes, {len(record["blocks"])} '
        'blocks', flush=True)
  return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/summarize_run.py', FLAGS, argv,
                      doc=__doc__, positional=True)


if __name__ == '__main__':
  sys.exit(main())
