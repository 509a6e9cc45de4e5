# coding=utf-8
"""Evaluation on held-out seeds (BLE's `eval_lib.eval_agent` for the latex envs).

Used by `ble-latex-eval` and the demo. Records per seed: seed, reward, tw50,
tw50_window, window_steps, steps, helium_vented_mols, sand_dropped_kg, terminal_reason,
final_distance_km and flight_path (README, "Training and evaluation").
"""

import json
import os
from typing import Any, Dict, List, Sequence

from balloon_learning_environment.agents import agent as base_agent
import gym
import tqdm

from ble_latex import metrics
from ble_latex import runner
from ble_latex import safe_io
from ble_latex import suites  # pylint: disable=unused-import  # Registers latex suites.


def shard(seeds: Sequence[int], num_shards: int, shard_idx: int) -> List[int]:
  """BLE's sharding of a suite's seeds."""
  if not 0 <= shard_idx < num_shards:
    raise ValueError(f'shard_idx must be in [0, {num_shards}), got {shard_idx}')
  start = int(len(seeds) * shard_idx / num_shards)
  end = int(len(seeds) * (shard_idx + 1) / num_shards)
  return list(seeds[start:end])


def evaluate(agent: base_agent.Agent, env: gym.Env, seeds: Sequence[int],
             max_steps: int, description: str = 'eval'
             ) -> List[Dict[str, Any]]:
  """Flies one deterministic episode per seed; returns the records."""
  agent.set_mode(base_agent.AgentMode.EVAL)
  results = []
  bar = tqdm.tqdm(seeds, desc=description, unit='episode', dynamic_ncols=True)
  for i, seed in enumerate(bar):
    summary, flight = runner.run_episode(
        env, agent, episode=i, seed=seed, max_steps=max_steps,
        record_flight=True)
    record = summary.to_json()
    del record['episode'], record['wall_time_s']
    record['flight_path'] = flight
    results.append(record)
    stats = metrics.summarize(results)
    bar.set_postfix(tw50_window=f'{stats["tw50_window_mean"]:.3f}',
                    tw50=f'{stats["tw50_mean"]:.3f}',
                    reward=f'{stats["reward_mean"]:.1f}')
  return results


def output_path(output_dir: str, suite: str, name: str, num_shards: int,
                shard_idx: int) -> str:
  if num_shards > 1:
    name = f'{name}_{shard_idx}'
  return os.path.join(output_dir, suite, f'{name}.json')


def write_results(path: str, results: List[Dict[str, Any]],
                  pretty: bool = False) -> None:
  """Writes the records as JSON, atomically (`safe_io.atomic_write`)."""
  safe_io.atomic_write(path, json.dumps(results, indent=2 if pretty else None))
