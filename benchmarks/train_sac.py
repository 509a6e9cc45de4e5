"""Trains SAC with the paper's settings, then picks a policy on validation seeds.

Two steps, both resumable (re-run the same command after a kill):

  # 1. Up to 2500 episodes on the default wind field (gin_configs/sac.gin:
  #    the paper's SAC settings), exporting the policy after every iteration.
  python benchmarks/train_sac.py train --base_dir=RUN --episodes=2500

  # 2. Evaluate every --every-th exported policy on the first
  #    --validation_episodes seeds of `latex_validation` (seeds from 2e6: not
  #    training, not held out), keep the best TW50 among those with at most
  #    --max_oor_pct % of episodes out of resources, and write it to --output.
  python benchmarks/train_sac.py select --base_dir=RUN \
      --output=ble_latex/agents/policies/sac_latex.msgpack

  # 3. Report it on the held-out seeds (README "Results"):
  ble-latex-eval --agent=sac_pretrained --suite=latex_small \
      --output_dir=benchmarks/results

`select` can run while `train` is still going (it only reads finished policy
files); its results accumulate in RUN/validation.json.
"""

import json
import math
import os
import sys
from typing import Any, Dict, List, Optional, Sequence

from absl import flags

from ble_latex.cli import common as cli
from ble_latex.run import run_dir
from ble_latex.run import selection
from ble_latex.run import wind_file

FLAGS = flags.FlagValues()
flags.DEFINE_string('base_dir', None, 'The training run.', flag_values=FLAGS)
flags.mark_flag_as_required('base_dir', flag_values=FLAGS)
flags.DEFINE_integer('episodes', 2500, 'train: episodes in all.',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('episodes_per_iteration', 10, 'train: episodes per '
                     'iteration (a checkpoint and a policy each).',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('seed', 0, 'train: agent seed.', flag_values=FLAGS)
cli.define_gin_flags(FLAGS, files_help=None,
                     bindings_help='train: gin bindings.')
flags.DEFINE_integer('every', 10, 'select: evaluate the policy of every this '
                     'many iterations.', lower_bound=1, flag_values=FLAGS)
flags.DEFINE_boolean('include_newest', False, 'select: also evaluate the '
                     'newest policy (e.g. a run stopped between two '
                     'multiples of --every).', flag_values=FLAGS)
flags.DEFINE_integer('validation_episodes', 30, 'select: latex_validation '
                     'seeds flown per policy.', flag_values=FLAGS)
flags.DEFINE_float('max_oor_pct', 10.0, 'select: most % of episodes out of '
                   'resources of the chosen policy.', flag_values=FLAGS)
flags.DEFINE_string('output', None, 'select: write the chosen policy here.',
                    flag_values=FLAGS)
flags.DEFINE_string('era5_path', None, 'select: fly the validation on this '
                    'ERA5 file, flights starting in the validation dates '
                    '(ble_latex.wind.gridded.DATE_SPLITS; docs/era5.md).',
                    flag_values=FLAGS)



def train(base_dir: str, episodes: int, episodes_per_iteration: int,
          seed: int, gin_bindings: List[str]) -> None:
  """Runs (or resumes) `ble-latex-train` with policy snapshots."""
  from ble_latex.run import gin_binding  # pylint: disable=g-import-not-at-top
  from ble_latex.run import suites  # pylint: disable=g-import-not-at-top
  from ble_latex.run import train_lib  # pylint: disable=g-import-not-at-top
  gin_binding.bind_gin('sac', None, [], gin_bindings)
  train_lib.train(
      agent_name='sac', env_name='LatexBalloon-v0', base_dir=base_dir,
      num_iterations=math.ceil(episodes / episodes_per_iteration),
      episodes_per_iteration=episodes_per_iteration,
      max_episode_length=suites.EPISODE_STEPS,
      collectors=['progress', 'episodes', 'tensorboard'], seed=seed,
      policy_snapshot_period=1)


def select(base_dir: str, every: int, include_newest: bool,
           validation_episodes: int, max_oor_pct: float,
           output: Optional[str], era5_path: Optional[str] = None) -> int:
  """Evaluates candidate policies on validation seeds; writes the best.

  With `era5_path` the seeds fly ERA5 winds from the validation dates
  (`suites.era5_dates('latex_validation')`), never the training dates.
  """
  import gym  # pylint: disable=g-import-not-at-top
  from ble_latex.agents.sac import pretrained  # pylint: disable=g-import-not-at-top
  from ble_latex.agents.sac import agent as sac  # pylint: disable=g-import-not-at-top
  from ble_latex.run import gin_binding  # pylint: disable=g-import-not-at-top
  from ble_latex.run import eval_lib  # pylint: disable=g-import-not-at-top
  from ble_latex.run import metrics  # pylint: disable=g-import-not-at-top
  from ble_latex.run import suites  # pylint: disable=g-import-not-at-top

  suite = suites.get_eval_suite('latex_validation')
  if not 1 <= validation_episodes <= len(suite.seeds):
    raise ValueError(f'--validation_episodes must be in [1, '
                     f'{len(suite.seeds)}], got {validation_episodes}')
  seeds = suite.seeds[:validation_episodes]
  results_path = os.path.join(base_dir, 'validation.json')
  results: Dict[str, Dict[str, Any]] = {}
  if os.path.exists(results_path):
    with open(results_path) as f:
      # Results of older versions lack the window TW50: flown again.
      results = {k: v for k, v in json.load(f).items()
                 if v.get('seeds') == [seeds[0], seeds[-1]] and
                 'tw50_window_mean' in v}
  gin_binding.bind_gin('sac_pretrained', None, [], [])
  era5 = wind_file.era5_bindings(
      era5_path, None, suites.era5_dates('latex_validation'))
  if era5:
    gin_binding.bind_gin('sac_pretrained', None, [], era5)
    results_path = os.path.join(base_dir, 'validation_era5.json')
    results = {}
    if os.path.exists(results_path):
      with open(results_path) as f:
        results = {k: v for k, v in json.load(f).items()
                   if v.get('seeds') == [seeds[0], seeds[-1]]}
  env = gym.make('LatexBalloon-v0').unwrapped
  space = env.action_space
  for path in run_dir.snapshot_candidates(base_dir, every, include_newest):
    name = os.path.basename(path)
    if name in results:
      continue
    agent = sac.SACPretrainedAgent(
        space.shape[0], env.observation_space.shape, action_low=space.low,
        action_high=space.high, policy_path=path)
    records = eval_lib.evaluate(agent, env, seeds, suite.max_episode_length,
                                description=f'validate {name}')
    summary = metrics.summarize(records)
    summary['seeds'] = [seeds[0], seeds[-1]]
    summary['iteration'] = agent.policy_info['iteration']
    summary['training_steps'] = agent.policy_info['training_steps']
    summary['note'] = agent.policy_info['note']
    results[name] = summary
    eval_lib.write_results(results_path, results, pretty=True)

  print('| policy | note | validation TW50 window | TW50 flown | reward | '
        'out of resources |')
  print('|---|---|---|---|---|---|')
  for name in sorted(results):
    r = results[name]
    print(f'| {name} | {r["note"]} | {100 * r["tw50_window_mean"]:.1f} % | '
          f'{100 * r["tw50_mean"]:.1f} % | '
          f'{r["reward_mean"]:.1f} | {r["out_of_resources_pct"]:.0f} % |')
  chosen = selection.best_named(results, max_oor_pct)
  if chosen is None:
    print(f'no policy has <= {max_oor_pct} % out of resources',
          file=sys.stderr)
    return 1
  r = results[chosen]
  print(f'best: {chosen} ({r["note"]}), validation TW50 (window) '
        f'{100 * r["tw50_window_mean"]:.1f} % on {validation_episodes} seeds')
  if output:
    policy = pretrained.load_policy(os.path.join(base_dir, 'policies', chosen))
    policy['note'] = (
        f'{r["note"]}; chosen among {len(results)} exported policies by TW50 '
        f'(window) on latex_validation seeds {seeds[0]}..{seeds[-1]} '
        f'({100 * r["tw50_window_mean"]:.1f} %, <= {max_oor_pct:g} % out of '
        'resources)')
    pretrained.write_policy(policy, output)
    print(f'wrote {output}')
  return 0


def _main(argv: Sequence[str]) -> int:
  if len(argv) != 2 or argv[1] not in ('train', 'select'):
    raise cli.CommandUsageError('give one command: train or select')
  args = FLAGS
  if argv[1] == 'train':
    train(args.base_dir, args.episodes, args.episodes_per_iteration,
          args.seed, args.gin_bindings)
    return 0
  return select(args.base_dir, args.every, args.include_newest,
                args.validation_episodes, args.max_oor_pct, args.output,
                args.era5_path)


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/train_sac.py', FLAGS, argv,
                      doc=__doc__, positional=True)


if __name__ == '__main__':
  sys.exit(main())
