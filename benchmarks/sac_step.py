"""SAC training-step time: Dopamine's replay sampling and target update vs ours.

One `ble_latex.agents.sac.SACAgent` (the paper's 2 x 256 networks, batch 256,
71 features, 3 actions) with a replay buffer of --transitions random
transitions in 216-step episodes times `_train_step()` (replay sample, jitted
SAC update, soft target update; blocked until the new parameters are ready)
in two configurations, alternating in the same process for --rounds rounds:

- dopamine: Dopamine's own `OutOfGraphReplayBuffer.sample_transition_batch`
  (per-index Python loop, `sample_index_batch`) and its eager
  `_maybe_sync_weights` (one JAX op per parameter leaf and operation);
- ble_latex: `VectorReplayBuffer` (array indexing, same batches) and the one
  jitted `optax.incremental_update`.

  python benchmarks/sac_step.py --steps 200 --rounds 3 --json benchmarks/sac_step.json
"""

import argparse
import functools
import json
import statistics
import sys
import time


def main() -> int:
  parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
  parser.add_argument('--steps', type=int, default=200,
                      help='training steps timed per round and config')
  parser.add_argument('--rounds', type=int, default=3)
  parser.add_argument('--transitions', type=int, default=20_000)
  parser.add_argument('--json', help='also write the numbers here')
  args = parser.parse_args()
  if min(args.steps, args.rounds) < 1 or args.transitions < 2000:
    parser.error('need --steps, --rounds >= 1 and --transitions >= 2000')

  import ble_latex  # noqa: F401  pylint: disable=g-import-not-at-top,unused-import
  from ble_latex.agents import sac  # pylint: disable=g-import-not-at-top
  from dopamine.jax.agents.sac import sac_agent  # pylint: disable=g-import-not-at-top
  from dopamine.replay_memory import circular_replay_buffer  # pylint: disable=g-import-not-at-top
  import jax  # pylint: disable=g-import-not-at-top
  import numpy as np  # pylint: disable=g-import-not-at-top

  agent = sac.SACAgent(3, (71,), seed=0, min_replay_history=1000,
                       replay_capacity=max(100_000, args.transitions))
  rng = np.random.default_rng(0)
  for i in range(args.transitions):
    agent._replay.add(  # pylint: disable=protected-access
        rng.normal(size=71).astype(np.float32),
        rng.uniform(-1, 1, 3).astype(np.float32), rng.random(), False,
        episode_end=(i % 216 == 215))
  agent.state = rng.normal(size=(71, 1)).astype(np.float32)

  def use_dopamine(on: bool) -> None:
    replay = agent._replay  # pylint: disable=protected-access
    if on:
      replay.__class__ = circular_replay_buffer.OutOfGraphReplayBuffer
      agent._sample_from_replay_buffer = functools.partial(  # pylint: disable=protected-access
          sac_agent.SACAgent._sample_from_replay_buffer, agent)  # pylint: disable=protected-access
      agent._maybe_sync_weights = functools.partial(  # pylint: disable=protected-access
          sac_agent.SACAgent._maybe_sync_weights, agent)  # pylint: disable=protected-access
    else:
      replay.__class__ = sac.VectorReplayBuffer
      agent.__dict__.pop('_sample_from_replay_buffer', None)
      agent.__dict__.pop('_maybe_sync_weights', None)

  def time_steps(config: str) -> float:
    use_dopamine(config == 'dopamine')
    for _ in range(5):  # Warm-up (compilation on the first call).
      agent._train_step()  # pylint: disable=protected-access
    jax.block_until_ready(agent.target_params)
    start = time.perf_counter()
    for _ in range(args.steps):
      agent._train_step()  # pylint: disable=protected-access
    jax.block_until_ready(agent.target_params)
    return (time.perf_counter() - start) / args.steps * 1e3

  times = {'dopamine': [], 'ble_latex': []}
  for _ in range(args.rounds):
    for config in times:
      times[config].append(time_steps(config))
  best = {k: min(v) for k, v in times.items()}
  result = {
      'ms_per_train_step_best': best,
      'ms_per_train_step_median': {k: statistics.median(v)
                                   for k, v in times.items()},
      'speedup_best': best['dopamine'] / best['ble_latex'],
      'steps': args.steps, 'rounds': args.rounds,
      'transitions': args.transitions,
  }
  print('| replay sampling + target update | ms per SAC training step (best '
        'of rounds) |')
  print('|---|---|')
  for k, v in best.items():
    print(f'| {k} | {v:.2f} |')
  print(f'speed-up: {result["speedup_best"]:.2f}x')
  if args.json:
    with open(args.json, 'w') as f:
      json.dump(result, f, indent=2)
  return 0


if __name__ == '__main__':
  sys.exit(main())
