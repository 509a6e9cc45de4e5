# coding=utf-8
r"""RLlib PPO (Ray 2.58, new API stack) on ble_latex/LatexBalloon-v0.

  python examples/rllib_ppo.py --iterations=50
  python examples/rllib_ppo.py --short   # CI's run

RLlib makes the env by id with `gymnasium.make`; the id is written
`module:id` (`ble_latex:ble_latex/LatexBalloon-v0`), so the env runners
import ble_latex themselves. `env_config` holds `gymnasium.make`'s keyword
arguments (here `max_episode_steps`). RLlib's own `normalize_actions` (on by
default) maps the policy's outputs onto the env's Box, so the same config
works with the raw Box (14 000-21 000 m, ...) and with a normalized one.
Runs on a local Ray with the env in the driver (`num_env_runners=0`), torch
on CPU; needs the `test` extra (`ray[tune]`, torch; RLlib's own imports are
in ray's base package at 2.58).
"""

import argparse
import json
import sys
import time
from typing import Any, Dict, Optional, Sequence

ENV_ID = 'ble_latex:ble_latex/LatexBalloon-v0'


def parse_args(argv: Optional[Sequence[str]]) -> argparse.Namespace:
  parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
  parser.add_argument('--env_id', default=ENV_ID)
  parser.add_argument('--iterations', type=int, default=50,
                      help='algo.train() calls (default: %(default)s).')
  parser.add_argument('--train_batch_size', type=int, default=4000)
  parser.add_argument('--minibatch_size', type=int, default=128)
  parser.add_argument('--num_epochs', type=int, default=10)
  parser.add_argument('--num_envs_per_env_runner', type=int, default=1)
  parser.add_argument('--max_episode_steps', type=int, default=None,
                      help="Episode length (default: the env's 216).")
  parser.add_argument('--num_cpus', type=int, default=2,
                      help="The local Ray's CPUs (default: %(default)s).")
  parser.add_argument('--seed', type=int, default=0)
  parser.add_argument('--short', action='store_true',
                      help='A tiny run (CI): one iteration of 64 steps, '
                      '16-step episodes.')
  args = parser.parse_args(argv)
  if args.short:
    args.iterations, args.train_batch_size, args.minibatch_size = 1, 64, 32
    args.num_epochs, args.num_cpus = 1, 1
    args.max_episode_steps = args.max_episode_steps or 16
  for name in ('iterations', 'train_batch_size', 'minibatch_size',
               'num_epochs', 'num_envs_per_env_runner', 'num_cpus'):
    if getattr(args, name) < 1:
      parser.error(f'--{name} must be >= 1')
  return args


def main(argv: Optional[Sequence[str]] = None) -> Dict[str, Any]:
  args = parse_args(argv)
  # pylint: disable=g-import-not-at-top
  # Not needed for the id (module:id imports it in the env runner); first,
  # so that TensorFlow's start-up lines, when RLlib imports it, stay quiet.
  import ble_latex  # pylint: disable=unused-import
  import ray
  from ray.rllib.algorithms.ppo import PPOConfig
  # pylint: enable=g-import-not-at-top
  env_config = ({} if args.max_episode_steps is None else
                {'max_episode_steps': args.max_episode_steps})
  config = (
      PPOConfig()
      .api_stack(enable_rl_module_and_learner=True,
                 enable_env_runner_and_connector_v2=True)
      .environment(args.env_id, env_config=env_config)
      .framework('torch')
      .env_runners(num_env_runners=0,
                   num_envs_per_env_runner=args.num_envs_per_env_runner,
                   rollout_fragment_length='auto')
      .learners(num_learners=0)
      .training(train_batch_size_per_learner=args.train_batch_size,
                minibatch_size=args.minibatch_size,
                num_epochs=args.num_epochs)
      .debugging(seed=args.seed)
  )
  start = time.monotonic()
  ray.init(num_cpus=args.num_cpus, include_dashboard=False,
           configure_logging=False, log_to_driver=False)
  try:
    algo = config.build_algo()
    result = {}
    for _ in range(args.iterations):
      result = algo.train()
    runners = result.get('env_runners', {})
    learner = result.get('learners', {}).get('default_policy', {})
    summary = {
        'iterations': args.iterations,
        'env_steps': int(runners.get('num_env_steps_sampled_lifetime', 0)),
        'episodes': int(runners.get('num_episodes_lifetime', 0)),
        'episode_return_mean': runners.get('episode_return_mean'),
        'total_loss': learner.get('total_loss'),
        'seconds': round(time.monotonic() - start, 1),
    }
    algo.stop()
  finally:
    ray.shutdown()
  print(json.dumps(summary, default=float))
  return summary


if __name__ == '__main__':
  main()
  sys.exit(0)
