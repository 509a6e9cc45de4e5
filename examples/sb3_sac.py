# coding=utf-8
r"""Trains Stable-Baselines3 SAC on ble_latex/LatexBalloon-v0, then evaluates it.

  python examples/sb3_sac.py --total_timesteps=20000 --suite=latex_tiny \
      --output_dir=runs/sb3_eval

Training uses the gymnasium env with `normalize_actions=True` (SAC acts in
[-1, 1]^3). Evaluation flies the trained policy deterministically on the
suite's held-out seeds with `ble-latex-eval`'s own loop (`eval_lib.evaluate`)
on the same simulation, and writes OUTPUT_DIR/SUITE/NAME.json in its per-seed
schema (seed, reward, tw50, steps, helium_vented_mols, sand_dropped_kg,
terminal_reason, final_distance_km, flight_path), so `ble-latex-plot
--eval_json` and `benchmarks/results_table.py` read it. Prints the path and
the summary as one JSON line, like `ble-latex-eval`.

Needs the test extra (`pip install -c constraints.txt -e '.[test]'`: SB3 and
the CPU build of torch).
"""

import argparse
import json
import sys
import time
from typing import Any, Optional, Sequence

import ble_latex  # Registers the ble_latex/... gymnasium ids.
from ble_latex import quiet

with quiet.third_party_noise():
  # pylint: disable=g-import-not-at-top
  from balloon_learning_environment.agents import agent as base_agent
  import gymnasium
  import numpy as np
  import stable_baselines3
  import torch
  from ble_latex.ble import gym_env as ble_gym_env
  from ble_latex.envs import jax_env
  from ble_latex.run import eval_lib
  from ble_latex.run import metrics
  from ble_latex.run import suites
  # pylint: enable=g-import-not-at-top

ENV_ID = 'ble_latex/LatexBalloon-v0'


class SB3PolicyAgent(base_agent.Agent):
  """A trained SB3 model behind BLE's Agent interface (for eval_lib).

  It flies BLE's gym env `LatexBalloon-v0` (the same core and gin-bound
  params), so `eval_lib.evaluate` builds exactly `ble-latex-eval`'s records;
  normalized actions are mapped onto the Box by the env's one mapping
  (`jax_env.to_box`).
  """

  def __init__(self, model: Any, env: gymnasium.Env):
    self._model = model
    super().__init__(num_actions=int(np.prod(env.action_space.shape)),
                     observation_shape=env.observation_space.shape)

  def _act(self, observation: np.ndarray) -> np.ndarray:
    action, _ = self._model.predict(observation, deterministic=True)
    return np.asarray(jax_env.to_box(np.asarray(action, np.float32)))

  def begin_episode(self, observation: np.ndarray) -> np.ndarray:
    return self._act(observation)

  def step(self, reward: float, observation: np.ndarray) -> np.ndarray:
    return self._act(observation)

  def end_episode(self, reward: float, terminal: bool = True) -> None:
    pass


def parse_args(argv: Optional[Sequence[str]]) -> argparse.Namespace:
  parser = argparse.ArgumentParser(
      description='Train SB3 SAC on ble_latex/LatexBalloon-v0 and evaluate it '
      'with ble-latex-eval-compatible JSON.')
  parser.add_argument('--total_timesteps', type=int, default=20_000,
                      help='SAC environment steps (default: %(default)s).')
  parser.add_argument('--max_episode_length', type=int,
                      default=suites.EPISODE_STEPS,
                      help='Steps per training and eval episode '
                      '(default: %(default)s = 3 days).')
  parser.add_argument('--learning_starts', type=int, default=1000,
                      help='Random steps before learning (default: %(default)s).')
  parser.add_argument('--batch_size', type=int, default=256,
                      help='SAC batch size (default: %(default)s).')
  parser.add_argument('--seed', type=int, default=0,
                      help='Seed of SAC and of the training episodes.')
  parser.add_argument('--suite', default='latex_tiny',
                      help='Eval suite (default: %(default)s).')
  parser.add_argument('--num_eval_seeds', type=int, default=None,
                      help="Evaluate on the suite's first N seeds only.")
  parser.add_argument('--output_dir', default='/tmp/ble_latex/sb3_eval',
                      help='Writes OUTPUT_DIR/SUITE/NAME.json.')
  parser.add_argument('--name', default='sb3_sac',
                      help='NAME of the eval file (default: %(default)s).')
  parser.add_argument('--torch_threads', type=int, default=1,
                      help="torch's intra-op threads (default: %(default)s; "
                      "SAC's 256x256 networks gain nothing from more, and "
                      'with other processes on the cores extra threads spin).')
  parser.add_argument('--model_out', default=None,
                      help='Also save the SB3 model here (a .zip).')
  args = parser.parse_args(argv)
  available = sorted(suites.available_suites())
  if args.suite not in available:
    parser.error(f'unknown suite {args.suite!r}; valid: {", ".join(available)}')
  for name in ('total_timesteps', 'max_episode_length', 'batch_size',
               'torch_threads'):
    if getattr(args, name) < 1:
      parser.error(f'--{name} must be >= 1')
  if args.num_eval_seeds is not None and args.num_eval_seeds < 1:
    parser.error('--num_eval_seeds must be >= 1')
  return args


def main(argv: Optional[Sequence[str]] = None) -> int:
  args = parse_args(argv)
  start = time.monotonic()
  torch.set_num_threads(args.torch_threads)
  env = gymnasium.make(ENV_ID, normalize_actions=True,
                       max_episode_steps=args.max_episode_length)
  model = stable_baselines3.SAC(
      'MlpPolicy', env, seed=args.seed, learning_starts=args.learning_starts,
      batch_size=args.batch_size,
      buffer_size=min(1_000_000, args.total_timesteps), verbose=0)
  model.learn(total_timesteps=args.total_timesteps)
  train_s = time.monotonic() - start
  if args.model_out:
    model.save(args.model_out)

  suite = suites.get_eval_suite(args.suite)
  seeds = list(suite.seeds)[:args.num_eval_seeds]
  max_steps = min(args.max_episode_length, suite.max_episode_length)
  results = eval_lib.evaluate(
      SB3PolicyAgent(model, env), ble_gym_env.LatexBalloonEnv(), seeds,
      max_steps,
      description=f'eval {args.name} {args.suite}')
  path = eval_lib.output_path(args.output_dir, args.suite, args.name, 1, 0)
  eval_lib.write_results(path, results)
  print(json.dumps({'output': path, 'train_s': round(train_s, 1),
                    'total_s': round(time.monotonic() - start, 1),
                    **metrics.summarize(results)}))
  env.close()
  return 0


if __name__ == '__main__':
  sys.exit(main())
