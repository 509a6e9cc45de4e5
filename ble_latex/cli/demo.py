# coding=utf-8
"""`make demo`: the project's main job, short (a few minutes on 2 CPU cores).

1. Trains SAC (paper settings, fewer warm-up steps) on LatexBalloon-v0 with
   BLE's generative wind for --iterations x --episodes_per_iteration episodes;
2. evaluates the trained and an untrained SAC on the held-out `latex_tiny`
   suite (10 seeds);
3. draws the paper's figures (training curves, terminal conditions,
   trajectories, 3D trained vs untrained, wind fields, and the vent/ballast
   validation figure) into --output_dir.

A few episodes are far too few to learn station-keeping (the paper trains
2500); this shows the whole pipeline working. See README "Results".
"""

import argparse
import json
import os
import sys
from typing import Optional, Sequence

import ble_latex  # pylint: disable=unused-import  # Fixes first.
from ble_latex.cli import common as cli
from ble_latex import quiet

with quiet.third_party_noise():
  # pylint: disable=g-import-not-at-top
  import gym

  from ble_latex.cli import plot
  from ble_latex.cli import validate
  from ble_latex import configs
  from ble_latex.run import eval_lib
  from ble_latex.run import metrics
  from ble_latex.run import runner
  from ble_latex.run import suites
  from ble_latex.run import train_lib
  # pylint: enable=g-import-not-at-top

_SAC = 'ble_latex.agents.sac.SACAgent'


def run(output_dir: str, iterations: int, episodes_per_iteration: int,
        suite: str) -> dict:
  """Runs the demo; returns the eval summaries."""
  run_dir = os.path.join(output_dir, 'sac_run')
  eval_dir = os.path.join(output_dir, 'eval')
  figures = os.path.join(output_dir, 'figures')
  configs.bind_gin('sac', None, [], [
      f'{_SAC}.min_replay_history = 432',  # Learn after 2 episodes.
  ])
  print(f'[1/3] Training SAC for {iterations * episodes_per_iteration} '
        f'episodes into {run_dir}', flush=True)
  train_lib.train(agent_name='sac', env_name='LatexBalloon-v0', base_dir=run_dir,
              num_iterations=iterations,
              episodes_per_iteration=episodes_per_iteration,
              max_episode_length=suites.EPISODE_STEPS,
              collectors=['progress', 'episodes', 'tensorboard'])

  print(f'[2/3] Evaluating trained and untrained SAC on {suite}', flush=True)
  env = gym.make('LatexBalloon-v0').unwrapped
  seeds = suites.get_eval_suite(suite).seeds
  paths, summaries = {}, {}
  for name, checkpoint in (('sac', iterations - 1), ('sac_untrained', None)):
    agent = runner.create_agent('sac', env)
    if checkpoint is not None:
      agent.load_checkpoint(os.path.join(run_dir, 'checkpoints'), checkpoint)
    results = eval_lib.evaluate(agent, env, seeds, suites.EPISODE_STEPS,
                                description=f'eval {name}')
    paths[name] = eval_lib.output_path(eval_dir, suite, name, 1, 0)
    eval_lib.write_results(paths[name], results)
    summaries[name] = metrics.summarize(results)

  print(f'[3/3] Figures into {figures}', flush=True)
  code = plot.main([
      f'--output_dir={figures}', f'--run_dir={run_dir}',
      f'--eval_json={paths["sac"]}',
      f'--baseline_eval_json={paths["sac_untrained"]}',
      f'--wind_seeds={seeds[0]},{seeds[1]}', '--wind_grid=15'])
  if code:
    raise RuntimeError(f'ble-latex-plot exited with status {code}')
  if validate.main(['--output_dir', figures]):
    raise RuntimeError('ble-latex-validate failed')
  print(json.dumps(summaries, indent=1))
  return summaries


def main(argv: Optional[Sequence[str]] = None) -> int:
  parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
  parser.add_argument('--output_dir', default='demo_output')
  parser.add_argument('--iterations', type=int, default=2)
  parser.add_argument('--episodes_per_iteration', type=int, default=5)
  parser.add_argument('--suite', default='latex_tiny')
  args = parser.parse_args(argv)
  try:
    cli.check_suite(args.suite)
  except cli.CommandUsageError as e:
    cli.usage_error('ble-latex-demo', str(e))
  run(args.output_dir, args.iterations, args.episodes_per_iteration,
      args.suite)
  return 0


if __name__ == '__main__':
  sys.exit(main())
