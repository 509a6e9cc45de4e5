# coding=utf-8
"""Per-episode metrics and collectors for latex-balloon training.

BLE's collector machinery (`collector.Collector`, `CollectorDispatcher`,
`PickleCollector`, `TensorboardCollector`) is reused; what is new:
- `LatexStatistics`: BLE's `StatisticsInstance` plus the env's `info` and, at
  episode end, the `EpisodeSummary` (TW50 two ways, resources, terminal
  reason);
- `EpisodeLogCollector`: writes RUN/episodes.jsonl (`episode_log`), which a
  resumed run truncates back to its checkpoint so no episode is lost or
  repeated;
- `LatexTensorboardCollector`: BLE's, plus TW50/resources/terminal scalars;
- `ProgressCollector`: a tqdm bar (BLE's ConsoleCollector counts discrete
  actions, which a Box action space does not have).
"""

import dataclasses
import json
import math
import os
import time
from typing import Any, Dict, List, Mapping, Optional, Sequence

from balloon_learning_environment.metrics import collector
from balloon_learning_environment.metrics import collector_dispatcher
from balloon_learning_environment.metrics import pickle_collector
from balloon_learning_environment.metrics import statistics_instance
from balloon_learning_environment.metrics import tensorboard_collector
import numpy as np
import tqdm

from ble_latex.envs import task
from ble_latex.run import episode_log
from ble_latex.run import records as records_lib

@dataclasses.dataclass
class EpisodeSummary:
  """What one episode achieved (a line of episodes.jsonl).

  Two station-keeping fractions are kept:
  - `tw50`: steps within the radius / steps flown (BLE's `eval_lib`). A flight
    that ends early (out of sand or helium, burst) is scored only on the part
    it flew.
  - `tw50_window`: steps within the radius / `window_steps`, the episode's
    length (216 strides = 3 days): a flight that ends early counts as outside
    for the rest of the window. The project's targets use this one.
  """
  episode: int
  seed: int
  reward: float
  tw50: float  # Fraction of flown steps within the radius.
  tw50_window: float  # Fraction of the episode window within the radius.
  window_steps: int  # Steps in the episode window (time limit).
  steps: int
  helium_vented_mols: float  # [mol]
  sand_dropped_kg: float  # [kg]
  terminal_reason: str
  final_distance_km: float  # [km]
  wall_time_s: float = 0.0  # [s]

  def to_json(self) -> Dict[str, Any]:
    """The summary as a JSON-ready dict (one line of episodes.jsonl)."""
    return dataclasses.asdict(self)


@dataclasses.dataclass
class LatexStatistics(statistics_instance.StatisticsInstance):
  """BLE's per-step statistics plus the env's info and the episode summary."""
  info: Mapping[str, Any] = dataclasses.field(default_factory=dict)
  summary: Optional[EpisodeSummary] = None


def terminal_reason(info: Mapping[str, Any], done: bool) -> str:
  """Why an episode ended, from the env's last info.

  Args:
    info: The env's `info` after the episode's last step.
    done: Whether the env ended the episode.

  Returns:
    `time_limit`, the env's `terminal_reason` (`out_of_sand`,
    `out_of_helium`, `burst`, `grounded`) if it ended the episode, else
    `max_episode_length` (the runner's step cap).
  """
  if info.get('time_limit'):
    return 'time_limit'
  if done:
    return info.get('terminal_reason', 'terminal')
  return 'max_episode_length'


def tw50_fractions(within_steps: int, steps: int,
                   window_steps: int) -> Dict[str, float]:
  """TW50 over the steps flown and over the episode window.

  Args:
    within_steps: Steps that ended within the station-keeping radius.
    steps: Steps flown.
    window_steps: Steps in the episode window (the env's time limit, 216).

  Returns:
    {'tw50': within / steps, 'tw50_window': within / window_steps}.

  Raises:
    ValueError: Counts that are negative or inconsistent.
  """
  if not 0 <= within_steps <= steps <= window_steps or window_steps < 1:
    raise ValueError(
        'need 0 <= within_steps <= steps <= window_steps and window_steps >= '
        f'1, got {within_steps}, {steps}, {window_steps}')
  return {'tw50': within_steps / max(steps, 1),
          'tw50_window': within_steps / window_steps}


class EpisodeTracker:
  """Accumulates one episode's steps into an EpisodeSummary.

  Args:
    episode: Episode number.
    seed: The episode's env seed.
    radius_km: Station-keeping radius. # [km]
    window_steps: Steps of the episode window for `tw50_window` (the env's
      time limit, or the step cap if that is shorter).
  """

  def __init__(self, episode: int, seed: int,
               radius_km: float = task.STATION_RADIUS_KM,
               window_steps: int = 216):
    self.episode, self.seed, self._radius_km = episode, seed, radius_km
    self.window_steps = int(window_steps)
    self.reward, self.steps, self._within = 0.0, 0, 0
    self.info: Mapping[str, Any] = {}
    self._start = time.monotonic()

  def step(self, reward: float, info: Mapping[str, Any]) -> None:
    """Adds one env step.

    Args:
      reward: The step's reward.
      info: The env's `info` after the step (resources, distance, status).
    """
    self.reward += float(reward)
    self.steps += 1
    self._within += info['distance_km'] <= self._radius_km
    self.info = info

  def summary(self, done: bool) -> EpisodeSummary:
    """The episode so far as an `EpisodeSummary`.

    Args:
      done: Whether the env ended the episode (else it was cut at the step cap).

    Returns:
      The summary, with its terminal reason.
    """
    info = self.info
    return EpisodeSummary(
        episode=self.episode,
        seed=self.seed,
        reward=self.reward,
        **tw50_fractions(self._within, self.steps, self.window_steps),
        window_steps=self.window_steps,
        steps=self.steps,
        helium_vented_mols=float(info.get('helium_vented_mols', 0.0)),
        sand_dropped_kg=float(info.get('sand_dropped_kg', 0.0)),
        terminal_reason=terminal_reason(info, done),
        final_distance_km=float(info.get('distance_km', math.nan)),
        wall_time_s=time.monotonic() - self._start)


class _EpisodeCollector(collector.Collector):
  """A collector that acts only at episode ends (BLE's other hooks no-op)."""

  def pre_training(self) -> None:
    pass

  def begin_episode(self) -> None:
    pass

  def step(self, statistics: statistics_instance.StatisticsInstance) -> None:
    pass

  def end_training(self) -> None:
    pass


class EpisodeLogCollector(_EpisodeCollector):
  """Appends each finished episode's summary to RUN/episodes.jsonl."""

  def __init__(self, base_dir: str, num_actions: int, current_episode: int):
    if base_dir is None:
      raise ValueError('EpisodeLogCollector needs a base_dir.')
    super().__init__(base_dir, num_actions, current_episode)
    self.path = os.path.join(base_dir, episode_log.EPISODE_LOG)
    # Drop episodes after the checkpoint we resume from (a killed run may have
    # logged some); they are re-run identically from their seeds.
    episode_log.truncate(self.path, current_episode)

  def get_name(self) -> str:
    """BLE's collector name: 'episodes'."""
    return 'episodes'

  def end_episode(self, statistics: LatexStatistics) -> None:
    """Appends the finished episode's summary to episodes.jsonl."""
    with open(self.path, 'a') as f:
      f.write(json.dumps(statistics.summary.to_json()) + '\n')
      f.flush()
      os.fsync(f.fileno())
    self.current_episode += 1


class LatexTensorboardCollector(tensorboard_collector.TensorboardCollector):
  """BLE's tensorboard collector plus TW50, resources and terminal reasons."""

  def end_episode(self, statistics: LatexStatistics) -> None:
    """Writes BLE's scalars, then TW50, resources and the terminal reason."""
    episode = self.current_episode
    super().end_episode(statistics)
    s = statistics.summary
    w = self.summary_writer
    w.scalar('Train/TW50', s.tw50, episode)
    w.scalar('Train/TW50Window', s.tw50_window, episode)
    w.scalar('Train/HeliumVentedMols', s.helium_vented_mols, episode)
    w.scalar('Train/SandDroppedKg', s.sand_dropped_kg, episode)
    w.scalar('Train/FinalDistanceKm', s.final_distance_km, episode)
    for reason in records_lib.TERMINAL_REASONS:
      w.scalar(f'Train/Terminal/{reason}', float(s.terminal_reason == reason),
               episode)
    w.flush()


class ProgressCollector(_EpisodeCollector):
  """A tqdm progress bar over episodes with TW50, reward and resources."""

  def __init__(self, base_dir: Optional[str], num_actions: int,
               current_episode: int, total_episodes: Optional[int] = None,
               description: str = 'train'):
    super().__init__(None, num_actions, current_episode)
    self._bar = tqdm.tqdm(total=total_episodes, initial=current_episode,
                          desc=description, unit='episode', dynamic_ncols=True)
    self._recent: List[EpisodeSummary] = []

  def get_name(self) -> str:
    """BLE's collector name: 'progress'."""
    return 'progress'

  def end_episode(self, statistics: LatexStatistics) -> None:
    """Advances the bar and shows the episode and its 50-episode means."""
    s = statistics.summary
    self._recent = (self._recent + [s])[-50:]
    n = len(self._recent)
    self._bar.set_postfix(
        tw50=f'{s.tw50:.2f}', tw50_window=f'{s.tw50_window:.2f}',
        tw50_window_50=f'{sum(r.tw50_window for r in self._recent) / n:.2f}',
        reward=f'{s.reward:.1f}', sand=f'{s.sand_dropped_kg:.2f}kg',
        helium=f'{s.helium_vented_mols:.1f}mol', end=s.terminal_reason)
    self._bar.update(1)
    self.current_episode += 1

  def end_training(self) -> None:
    """Closes the progress bar."""
    self._bar.close()


AVAILABLE_COLLECTORS = {
    'progress': ProgressCollector,
    'console': ProgressCollector,  # BLE's name for the console summary.
    'episodes': EpisodeLogCollector,
    'pickle': pickle_collector.PickleCollector,
    'tensorboard': LatexTensorboardCollector,
}


SUMMARY_KEYS = ('tw50', 'tw50_window', 'reward', 'helium_vented_mols',
                'sand_dropped_kg')


def check_collectors(names: Sequence[str]) -> None:
  """Raises ValueError naming an unknown collector."""
  for name in names:
    if name not in AVAILABLE_COLLECTORS:
      raise ValueError(f'Unknown collector {name!r}; available: '
                       f'{sorted(AVAILABLE_COLLECTORS)}')


def dispatcher(base_dir: str, num_actions: int, names: Sequence[str],
               start_episode: int, total_episodes: int, description: str
               ) -> collector_dispatcher.CollectorDispatcher:
  """BLE's `CollectorDispatcher` over the named collectors of a run.

  Args:
    base_dir: The run directory.
    num_actions: Action dimension (BLE's collectors ask for it).
    names: Names from `AVAILABLE_COLLECTORS`.
    start_episode: Episodes already done (a resumed run).
    total_episodes: Episodes the run will have done (the progress bar).
    description: The progress bar's label.
  """
  check_collectors(names)

  def make(name):
    ctor = AVAILABLE_COLLECTORS[name]
    if ctor is ProgressCollector:
      return lambda d, n, e: ctor(d, n, e, total_episodes=total_episodes,
                                  description=description)
    return ctor

  return collector_dispatcher.CollectorDispatcher(
      base_dir, num_actions, [make(name) for name in names], start_episode)


def summarize(records: Sequence[Mapping[str, Any]]) -> Dict[str, float]:
  """Mean/std of both TW50s, reward, resources and % out of resources.

  Raises:
    ValueError: A record lacks a summary key (e.g. `tw50_window` in a file
      written before it existed: re-run the eval).
  """
  if not records:
    return {}
  for i, r in enumerate(records):
    missing = [k for k in (*SUMMARY_KEYS, 'terminal_reason') if k not in r]
    if missing:
      raise ValueError(f'record {i} (seed {r.get("seed")}) lacks {missing}')
  def col(key):
    return np.array([float(r[key]) for r in records])
  out = {'episodes': len(records)}
  for key in SUMMARY_KEYS:
    out[f'{key}_mean'] = float(col(key).mean())
    out[f'{key}_std'] = float(col(key).std())
  out['out_of_resources_pct'] = 100.0 * float(np.mean(
      [r['terminal_reason'] in records_lib.OUT_OF_RESOURCES_REASONS
       for r in records]))
  return out
