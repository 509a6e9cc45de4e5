# coding=utf-8
"""BLE's metric collectors for latex-balloon training runs.

BLE's collector machinery (`collector.Collector`, `CollectorDispatcher`,
`PickleCollector`, `TensorboardCollector`; it imports TensorFlow) is reused;
what is new:
- `EpisodeLogCollector`: writes RUN/episodes.jsonl (`episode_log`), which a
  resumed run truncates back to its checkpoint so no episode is lost or
  repeated;
- `LatexTensorboardCollector`: BLE's, plus TW50/resources/terminal scalars;
- `ProgressCollector`: a tqdm bar (BLE's ConsoleCollector counts discrete
  actions, which a Box action space does not have).
They receive `metrics.LatexStatistics`.
"""

import json
import os
from typing import List, Optional, Sequence

from balloon_learning_environment.metrics import collector
from balloon_learning_environment.metrics import collector_dispatcher
from balloon_learning_environment.metrics import pickle_collector
from balloon_learning_environment.metrics import statistics_instance
from balloon_learning_environment.metrics import tensorboard_collector
import tqdm

from ble_latex.run import episode_log
from ble_latex.run import metrics
from ble_latex.run import records as records_lib


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

  def end_episode(self, statistics: metrics.LatexStatistics) -> None:
    """Appends the finished episode's summary to episodes.jsonl."""
    with open(self.path, 'a') as f:
      f.write(json.dumps(statistics.summary.to_json()) + '\n')
      f.flush()
      os.fsync(f.fileno())
    self.current_episode += 1


class LatexTensorboardCollector(tensorboard_collector.TensorboardCollector):
  """BLE's tensorboard collector plus TW50, resources and terminal reasons."""

  def end_episode(self, statistics: metrics.LatexStatistics) -> None:
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
    self._recent: List[metrics.EpisodeSummary] = []

  def get_name(self) -> str:
    """BLE's collector name: 'progress'."""
    return 'progress'

  def end_episode(self, statistics: metrics.LatexStatistics) -> None:
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
