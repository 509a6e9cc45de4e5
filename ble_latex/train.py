# coding=utf-8
r"""Trains an agent on the latex balloon (`ble-latex-train`), BLE-style.

Same flags and meaning as BLE's `balloon_learning_environment.train`, with the
latex env and SAC as defaults:

  ble-latex-train --base_dir=/tmp/latex/sac --num_iterations=50 \
      --episodes_per_iteration=10

The run directory holds `checkpoints/` (one per iteration), `episodes.jsonl`
(one line per episode) and `metrics/` (tensorboard, pickle). Killed and
restarted with the same flags, training resumes after the last checkpoint:
episodes logged after it are dropped and re-run from their seeds, so no
episode is lost or repeated. Episode i always flies env seed i (held-out eval
seeds start at 1,000,000).
"""

import sys
from typing import Optional, Sequence

from absl import app
from absl import flags

import ble_latex  # pylint: disable=unused-import  # Fixes first.
from ble_latex import cli
from ble_latex import quiet

with quiet.third_party_noise():
  # pylint: disable=g-import-not-at-top
  from ble_latex import metrics
  from ble_latex import runner
  from ble_latex import suites
  from ble_latex import train_lib
  # pylint: enable=g-import-not-at-top

flags.DEFINE_string('agent', 'sac', 'Type of agent to create.')
flags.DEFINE_string('env_name', 'LatexBalloon-v0',
                    'Name of environment to create.')
flags.DEFINE_integer('num_iterations', 50, 'Number of iterations to train.')
flags.DEFINE_integer('episodes_per_iteration', 10,
                     'Episodes per iteration; a checkpoint is written after '
                     'each iteration.')
flags.DEFINE_integer('max_episode_length', suites.EPISODE_STEPS,
                     'Maximum steps per episode (216 x 20 min = 3 days).')
flags.DEFINE_string('base_dir', None,
                    'Directory for checkpoints, episodes.jsonl and metrics.')
flags.DEFINE_string('agent_gin_file', None,
                    'Gin file for agent configuration (default: the agent\'s).')
flags.DEFINE_multi_string('gin_file', [],
                          'Extra gin files (e.g. gin_configs/paper_era5.gin).')
flags.DEFINE_multi_string('gin_bindings', [],
                          'Gin bindings to override default values.')
flags.DEFINE_multi_string('collectors', ['progress', 'episodes', 'tensorboard'],
                          f'Collectors: {sorted(metrics.AVAILABLE_COLLECTORS)}.')
flags.DEFINE_integer('seed', 0, 'Seed of the agent (env seeds are episode '
                     'indices).')
flags.DEFINE_integer('policy_snapshot_period', 0,
                     'SAC only: every this many iterations also export the '
                     'policy (~1 MB) to BASE_DIR/policies/, for choosing one '
                     'on a validation suite afterwards. 0: never.')
flags.mark_flag_as_required('base_dir')
FLAGS = flags.FLAGS


def main(argv: Sequence[str]) -> None:
  if len(argv) > 1:
    raise app.UsageError(f'Unexpected arguments: {argv[1:]}')
  runner.bind_gin(FLAGS.agent, FLAGS.agent_gin_file, FLAGS.gin_file,
                  FLAGS.gin_bindings)
  train_lib.train(agent_name=FLAGS.agent, env_name=FLAGS.env_name,
        base_dir=FLAGS.base_dir, num_iterations=FLAGS.num_iterations,
        episodes_per_iteration=FLAGS.episodes_per_iteration,
        max_episode_length=FLAGS.max_episode_length,
        collectors=FLAGS.collectors, seed=FLAGS.seed,
        policy_snapshot_period=FLAGS.policy_snapshot_period)


def check() -> None:
  """Unknown agent, env, collector or gin file: one line, exit status 2."""
  cli.check_agent(FLAGS.agent)
  cli.check_env_name(FLAGS.env_name)
  for name in FLAGS.collectors:
    if name not in metrics.AVAILABLE_COLLECTORS:
      raise cli.CommandUsageError(cli.unknown(
          'collector', name, metrics.AVAILABLE_COLLECTORS))
  cli.check_gin_files([FLAGS.agent_gin_file, *FLAGS.gin_file])


def run(argv: Optional[Sequence[str]] = None) -> None:
  """Console-script entry point (see `cli.run_absl`)."""
  cli.run_absl(main, 'ble-latex-train', argv, doc=__doc__, check=check)


if __name__ == '__main__':
  run()
