# coding=utf-8
"""Evaluation on held-out seeds (BLE's `eval_lib.eval_agent` for the latex envs).

Used by `ble-latex-eval` (in one process, or seed by seed on Ray workers,
`ble_latex.run.distributed`) and the demo. Records per seed: seed, reward, tw50,
tw50_window, window_steps, steps, helium_vented_mols, sand_dropped_kg,
terminal_reason, final_distance_km and flight_path (docs/training.md).
"""

import contextlib
import dataclasses
import json
import os
from typing import Any, Dict, List, Optional, Sequence, Tuple

from balloon_learning_environment.agents import agent as base_agent
import gin
import gym
import tqdm

from ble_latex import errors
from ble_latex import quiet
from ble_latex.run import batch_eval
from ble_latex.run import gin_binding
from ble_latex.run import metrics
from ble_latex.run import runner
from ble_latex import safe_io


@dataclasses.dataclass(frozen=True, kw_only=True)
class EvalSpec:
  """Everything that decides how an agent flies an eval episode.

  `ble-latex-eval` builds one from its flags; a Ray worker rebuilds the same
  agent and env from it (`build`), so it holds only plain values.
  """
  agent: str
  env_name: str = 'LatexBalloon-v0'
  agent_gin_file: Optional[str] = None
  gin_files: Tuple[str, ...] = ()
  gin_bindings: Tuple[str, ...] = ()
  checkpoint_dir: Optional[str] = None
  checkpoint_idx: Optional[int] = None
  seed: int = 0  # Agent seed.

  def absolute(self) -> 'EvalSpec':
    """The same spec with file paths made absolute (for other processes)."""
    absolute = lambda p: None if p is None else os.path.abspath(p)
    return dataclasses.replace(
        self, agent_gin_file=absolute(self.agent_gin_file),
        gin_files=tuple(absolute(p) for p in self.gin_files),
        checkpoint_dir=absolute(self.checkpoint_dir))


def build(spec: EvalSpec) -> Tuple[base_agent.Agent, gym.Env]:
  """Binds gin for `spec` and builds its agent (checkpoint loaded) and env.

  Gin's configuration is process-wide and BLE's binding locks it: what was
  bound before is cleared first.
  """
  gin.clear_config()
  gin_binding.bind_gin(spec.agent, spec.agent_gin_file, spec.gin_files,
                       spec.gin_bindings)
  with quiet.third_party_noise():
    env = gym.make(spec.env_name).unwrapped
  agent = runner.create_agent(spec.agent, env, seed=spec.seed)
  if spec.checkpoint_dir is not None:
    agent.load_checkpoint(spec.checkpoint_dir, spec.checkpoint_idx)
  return agent, env


def shard(seeds: Sequence[int], num_shards: int, shard_idx: int) -> List[int]:
  """BLE's sharding of a suite's seeds."""
  if not 0 <= shard_idx < num_shards:
    raise errors.ConfigError(
        f'--shard_idx must be in [0, --num_shards={num_shards}), got '
        f'{shard_idx}')
  start = int(len(seeds) * shard_idx / num_shards)
  end = int(len(seeds) * (shard_idx + 1) / num_shards)
  return list(seeds[start:end])


def fly(agent: base_agent.Agent, env: gym.Env, seed: int, max_steps: int,
        episode: int = 0) -> Dict[str, Any]:
  """One deterministic (eval-mode) episode from `seed`: its record."""
  agent.set_mode(base_agent.AgentMode.EVAL)
  summary, flight = runner.run_episode(
      env, agent, episode=episode, seed=seed, max_steps=max_steps,
      record_flight=True)
  record = summary.to_json()
  del record['episode'], record['wall_time_s']
  record['flight_path'] = flight
  return record


def progress_postfix(results: List[Dict[str, Any]]) -> Dict[str, str]:
  """The running means a progress bar shows."""
  stats = metrics.summarize(results)
  return {'tw50_window': f'{stats["tw50_window_mean"]:.3f}',
          'tw50': f'{stats["tw50_mean"]:.3f}',
          'reward': f'{stats["reward_mean"]:.1f}'}


def evaluate(agent: base_agent.Agent, env: gym.Env, seeds: Sequence[int],
             max_steps: int, description: str = 'eval', batched: bool = True
             ) -> List[Dict[str, Any]]:
  """Flies one deterministic episode per seed, in order; returns the records.

  Agents that fly the JAX core fly `batch_eval.BATCH_SIZE` seeds at once
  (`batch_eval`; equal records per seed within float32 noise) unless
  `batched` is False; every other agent one balloon at a time.
  """
  if batched and batch_eval.flies_batched(agent, env):
    return batch_eval.evaluate(agent, env, seeds, max_steps,
                               description=description,
                               postfix=progress_postfix)
  results = []
  bar = tqdm.tqdm(seeds, desc=description, unit='episode', dynamic_ncols=True)
  for i, seed in enumerate(bar):
    results.append(fly(agent, env, seed, max_steps, episode=i))
    bar.set_postfix(progress_postfix(results))
  return results


def output_path(output_dir: str, suite: str, name: str, num_shards: int,
                shard_idx: int) -> str:
  """The eval file `OUTPUT_DIR/SUITE/NAME.json` (`NAME_SHARD.json` with shards).

  Args:
    output_dir: The eval output folder.
    suite: The eval suite's name.
    name: The file's name (agent, `agent_IDX` with a checkpoint).
    num_shards: Number of shards the suite is split into.
    shard_idx: This shard's index (used only when `num_shards` > 1).

  Returns:
    The path of the eval file.
  """
  if num_shards > 1:
    name = f'{name}_{shard_idx}'
  return os.path.join(output_dir, suite, f'{name}.json')


def lock_output(path: str) -> contextlib.AbstractContextManager:
  """Context manager: this process is the one writer of the eval file `path`.

  Locks the file, not its folder, so shards and other agents' evals write
  side by side (`safe_io.locked_file`, which also covers its
  `.partial.json`).

  Raises:
    safe_io.InUseError: On entering, if another eval writes `path`.
  """
  return safe_io.locked_file(path, what='eval output')


def write_results(path: str, results: List[Dict[str, Any]],
                  pretty: bool = False) -> None:
  """Writes the records as JSON, atomically (`safe_io.atomic_write`)."""
  safe_io.atomic_write(path, json.dumps(results, indent=2 if pretty else None))
