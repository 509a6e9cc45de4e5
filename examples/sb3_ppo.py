# coding=utf-8
r"""Stable-Baselines3 PPO on ble_latex/LatexBalloon-v0: train, save, reload,
evaluate.

  python examples/sb3_ppo.py --total_timesteps=200000 --n_envs=4
  python examples/sb3_ppo.py --short   # CI's run

SB3's own tools, unchanged: `make_vec_env` (a DummyVecEnv of
`gymnasium.make`), `PPO('MlpPolicy', ...)`, `save` / `PPO.load`,
`evaluate_policy`. PPO's Gaussian policy wants actions near [-1, 1]:
`make_env` adds gymnasium's `RescaleAction(-1, 1)` when the env's Box is
another one (the raw 14 000-21 000 m Box), and nothing when it already is
[-1, 1], so the script runs the same with either. The reloaded policy's
deterministic actions are checked to lie inside the env's Box.
"""

import argparse
import json
import os
import sys
import tempfile
import time
from typing import Any, Dict, Optional, Sequence

import gymnasium
import numpy as np

import ble_latex  # pylint: disable=unused-import  # Registers the ids.

ENV_ID = 'ble_latex/LatexBalloon-v0'


def make_env(max_episode_steps: Optional[int] = None) -> gymnasium.Env:
  """The env with actions in [-1, 1] (RescaleAction if its Box is raw)."""
  kwargs = ({} if max_episode_steps is None else
            {'max_episode_steps': max_episode_steps})
  env = gymnasium.make(ENV_ID, **kwargs)
  box = env.action_space
  if not (np.all(box.low == -1) and np.all(box.high == 1)):
    one = np.ones(box.shape, np.float32)  # float32: no precision warning.
    env = gymnasium.wrappers.RescaleAction(env, -one, one)
  return env


def parse_args(argv: Optional[Sequence[str]]) -> argparse.Namespace:
  parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
  parser.add_argument('--total_timesteps', type=int, default=200_000)
  parser.add_argument('--n_envs', type=int, default=4)
  parser.add_argument('--n_steps', type=int, default=432,
                      help='Steps per env per update (default: 2 episodes).')
  parser.add_argument('--batch_size', type=int, default=64)
  parser.add_argument('--n_epochs', type=int, default=10)
  parser.add_argument('--max_episode_steps', type=int, default=None,
                      help="Episode length (default: the env's 216).")
  parser.add_argument('--n_eval_episodes', type=int, default=5)
  parser.add_argument('--seed', type=int, default=0)
  parser.add_argument('--model_out', default=None,
                      help='Save the model here (.zip; default: a temp file).')
  parser.add_argument('--torch_threads', type=int, default=1)
  parser.add_argument('--short', action='store_true',
                      help='A tiny run (CI): 2 envs x 16 steps x 2 updates, '
                      '12-step episodes, 2 eval episodes.')
  args = parser.parse_args(argv)
  if args.short:
    args.total_timesteps, args.n_envs, args.n_steps = 64, 2, 16
    args.batch_size, args.n_epochs, args.n_eval_episodes = 16, 1, 2
    args.max_episode_steps = args.max_episode_steps or 12
  for name in ('total_timesteps', 'n_envs', 'n_steps', 'batch_size',
               'n_epochs', 'n_eval_episodes', 'torch_threads'):
    if getattr(args, name) < 1:
      parser.error(f'--{name} must be >= 1')
  return args


def main(argv: Optional[Sequence[str]] = None) -> Dict[str, Any]:
  args = parse_args(argv)
  # pylint: disable=g-import-not-at-top
  import torch
  from stable_baselines3 import PPO
  from stable_baselines3.common.env_util import make_vec_env
  from stable_baselines3.common.evaluation import evaluate_policy
  from stable_baselines3.common.monitor import Monitor
  # pylint: enable=g-import-not-at-top
  torch.set_num_threads(args.torch_threads)
  start = time.monotonic()
  vec_env = make_vec_env(make_env, n_envs=args.n_envs, seed=args.seed,
                         env_kwargs={'max_episode_steps':
                                     args.max_episode_steps})
  model = PPO('MlpPolicy', vec_env, n_steps=args.n_steps,
              batch_size=args.batch_size, n_epochs=args.n_epochs,
              seed=args.seed, device='cpu', verbose=0)
  model.learn(total_timesteps=args.total_timesteps)
  train_s = time.monotonic() - start
  with tempfile.TemporaryDirectory() as tmp:
    path = args.model_out or os.path.join(tmp, 'ppo.zip')
    model.save(path)
    loaded = PPO.load(path, device='cpu')
  # Monitor: evaluate_policy's episode returns are the env's own.
  eval_env = Monitor(make_env(args.max_episode_steps))
  mean_reward, std_reward = evaluate_policy(
      loaded, eval_env, n_eval_episodes=args.n_eval_episodes,
      deterministic=True)
  obs, _ = eval_env.reset(seed=1_000_000)
  action, _ = loaded.predict(obs, deterministic=True)
  # The action the env flies: RescaleAction maps [-1, 1] onto its Box.
  box = eval_env.unwrapped.action_space
  rescale = eval_env.env  # Inside the Monitor.
  flown = (rescale.action(np.clip(action, -1, 1))
           if isinstance(rescale, gymnasium.wrappers.RescaleAction)
           else action)
  eval_env.close()
  vec_env.close()
  summary = {
      'env_steps': int(model.num_timesteps),
      'eval_mean_reward': float(mean_reward),
      'eval_std_reward': float(std_reward),
      'first_action': [float(a) for a in flown],
      'action_in_box': bool(np.all(flown >= box.low - 1e-3) and
                            np.all(flown <= box.high + 1e-3)),
      'train_s': round(train_s, 1),
      'total_s': round(time.monotonic() - start, 1),
  }
  print(json.dumps(summary))
  return summary


if __name__ == '__main__':
  main()
  sys.exit(0)
