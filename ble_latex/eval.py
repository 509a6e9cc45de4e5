# coding=utf-8
r"""Evaluates an agent on held-out latex seeds (`ble-latex-eval`), BLE-style.

Same flags and meaning as BLE's `balloon_learning_environment.eval.eval`, with
the latex env and suites:

  ble-latex-eval --agent=sac --suite=latex_tiny --output_dir=/tmp/latex/eval \
      --checkpoint_dir=/tmp/latex/sac/checkpoints --checkpoint_idx=49

Writes OUTPUT_DIR/SUITE/NAME.json: one object per seed with seed, reward,
tw50, tw50_window, window_steps, steps, helium_vented_mols, sand_dropped_kg, terminal_reason,
final_distance_km and flight_path (README, "Eval output").
"""

import json
import sys
from typing import Optional, Sequence

from absl import app
from absl import flags

import ble_latex  # pylint: disable=unused-import  # Fixes first.
from ble_latex import cli
from ble_latex import quiet

with quiet.third_party_noise():
  # pylint: disable=g-import-not-at-top
  from balloon_learning_environment.eval import suites as ble_suites
  import gym

  from ble_latex import eval_lib
  from ble_latex import metrics
  from ble_latex import runner
  from ble_latex import suites
  # pylint: enable=g-import-not-at-top

flags.DEFINE_string('agent', 'sac', 'The name of the agent to create.')
flags.DEFINE_string('env_name', 'LatexBalloon-v0', 'Environment to evaluate.')
flags.DEFINE_string('suite', 'latex_tiny',
                    f'Evaluation suite: {sorted(suites.SUITE_SIZES)} (held '
                    'out), latex_validation (for choosing checkpoints) or '
                    'any BLE suite.')
flags.DEFINE_string('agent_gin_file', None, 'Gin file for agent configuration.')
flags.DEFINE_multi_string('gin_file', [], 'Extra gin files.')
flags.DEFINE_multi_string('gin_bindings', [],
                          'Gin bindings to override default values.')
flags.DEFINE_string('output_dir', '/tmp/ble_latex/eval',
                    'The directory to output the json summary.')
flags.DEFINE_integer('num_shards', 1, 'Number of shards to split the suite.',
                     lower_bound=1)
flags.DEFINE_integer('shard_idx', 0, 'The index of this shard.', lower_bound=0)
flags.DEFINE_boolean('pretty_json', False, 'Indent the json output.')
flags.DEFINE_string('checkpoint_dir', None, 'Directory to load checkpoints.')
flags.DEFINE_integer('checkpoint_idx', None, 'Checkpoint iteration to load.')
flags.DEFINE_string('name_override', None, 'Name of the json output file.')
flags.DEFINE_integer('max_episode_length', None,
                     'Override the suite\'s episode length.')
flags.DEFINE_integer('seed', 0, 'Agent seed.')
FLAGS = flags.FLAGS


def main(argv: Sequence[str]) -> None:
  if len(argv) > 1:
    raise app.UsageError(f'Unexpected arguments: {argv[1:]}')
  runner.bind_gin(FLAGS.agent, FLAGS.agent_gin_file, FLAGS.gin_file,
                  FLAGS.gin_bindings)
  suite = ble_suites.get_eval_suite(FLAGS.suite)
  seeds = eval_lib.shard(suite.seeds, FLAGS.num_shards, FLAGS.shard_idx)
  with quiet.third_party_noise():
    env = gym.make(FLAGS.env_name).unwrapped
  agent = runner.create_agent(FLAGS.agent, env, seed=FLAGS.seed)
  if (FLAGS.checkpoint_dir is None) != (FLAGS.checkpoint_idx is None):
    raise app.UsageError('--checkpoint_dir and --checkpoint_idx go together.')
  if FLAGS.checkpoint_dir is not None:
    agent.load_checkpoint(FLAGS.checkpoint_dir, FLAGS.checkpoint_idx)
  max_steps = FLAGS.max_episode_length or suite.max_episode_length
  results = eval_lib.evaluate(agent, env, seeds, max_steps,
                     description=f'eval {FLAGS.agent} {FLAGS.suite}')
  name = FLAGS.name_override or (
      f'{FLAGS.agent}_{FLAGS.checkpoint_idx}'
      if FLAGS.checkpoint_idx is not None else FLAGS.agent)
  path = eval_lib.output_path(FLAGS.output_dir, FLAGS.suite, name,
                              FLAGS.num_shards, FLAGS.shard_idx)
  eval_lib.write_results(path, results, FLAGS.pretty_json)
  print(json.dumps({'output': path, **metrics.summarize(results)}))


def check() -> None:
  """Unknown agent, suite, env or gin file: one line, exit status 2."""
  cli.check_agent(FLAGS.agent)
  cli.check_suite(FLAGS.suite)
  cli.check_env_name(FLAGS.env_name)
  cli.check_gin_files([FLAGS.agent_gin_file, *FLAGS.gin_file])


def run(argv: Optional[Sequence[str]] = None) -> None:
  """Console-script entry point (see `cli.run_absl`)."""
  cli.run_absl(main, 'ble-latex-eval', argv, doc=__doc__, check=check)


if __name__ == '__main__':
  run()
