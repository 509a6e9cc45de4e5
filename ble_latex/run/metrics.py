# coding=utf-8
"""Per-episode metrics of latex-balloon training and evaluation.

- `EpisodeSummary`: what one episode achieved (TW50 two ways, resources,
  terminal reason), a line of episodes.jsonl; `EpisodeTracker` builds it;
- `LatexStatistics`: BLE's `StatisticsInstance` (a dataclass) plus the env's
  `info` and, at episode end, the `EpisodeSummary`, what the collectors of
  `ble_latex.run.collectors` receive;
- `summarize`: mean / std over episodes; `format_summary` prints them;
- what the studies read beyond it: `edge_fractions` (time near the circle's
  edge, `benchmarks/reward_shape.py`), `summarize_aloft` and `over_seeds`
  (days aloft, rows over training seeds, `benchmarks/physics_results.py`).

No TensorFlow: BLE's collectors (which import it) are in `collectors`.
"""

import collections
import dataclasses
import json
import math
import re
import statistics
import time
from typing import Any, Dict, List, Mapping, Optional, Sequence

from balloon_learning_environment.metrics import statistics_instance
import numpy as np

from ble_latex.envs import task
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
               window_steps: int = task.EPISODE_STEPS):
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


SUMMARY_KEYS = ('tw50', 'tw50_window', 'reward', 'helium_vented_mols',
                'sand_dropped_kg')


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


def format_summary(summary: Mapping[str, Mapping[str, float]]) -> str:
  """One line per eval file (`summarize` of each, by path): mean +- std of
  TW50, reward, resources."""
  lines = []
  for path, s in summary.items():
    lines.append(
        f'{path}: {s["episodes"]} seeds, '
        f'TW50 (window) {100 * s["tw50_window_mean"]:.1f} +- '
        f'{100 * s["tw50_window_std"]:.1f}%, '
        f'TW50 (flown) {100 * s["tw50_mean"]:.1f} +- '
        f'{100 * s["tw50_std"]:.1f}%, '
        f'reward {s["reward_mean"]:.1f} +- {s["reward_std"]:.1f}, '
        f'helium vented {s["helium_vented_mols_mean"]:.1f} +- '
        f'{s["helium_vented_mols_std"]:.1f} mol, '
        f'sand dropped {s["sand_dropped_kg_mean"]:.2f} +- '
        f'{s["sand_dropped_kg_std"]:.2f} kg, '
        f'out of resources {s["out_of_resources_pct"]:.0f}%')
  return '\n'.join(lines)


def per_seed_summary(path: str) -> Dict[str, Any]:
  """An eval record's summary and its per-seed TW50 over the window.

  `ble-latex-eval` records and `benchmarks/planners.py`'s (which may lack
  flight paths) alike: a JSON list of per-episode records with
  `summarize`'s keys.
  """
  with open(path, encoding='utf-8') as f:
    records = json.load(f)
  if not isinstance(records, list) or not records or not all(
      isinstance(r, dict) and 'seed' in r for r in records):
    raise ValueError(f'{path}: not a list of per-episode eval records')
  records = sorted(records, key=lambda r: int(r['seed']))
  summary = summarize(records)
  return {'path': path, 'seeds': [int(r['seed']) for r in records],
          'tw50_window': [float(r['tw50_window']) for r in records],
          'tw50_window_mean': summary['tw50_window_mean'],
          'tw50_window_std': summary['tw50_window_std'],
          'out_of_resources_pct': summary['out_of_resources_pct'],
          'helium_vented_mols_mean': summary['helium_vented_mols_mean'],
          'sand_dropped_kg_mean': summary['sand_dropped_kg_mean']}


# -- What the studies read from eval records beyond `summarize`. -------------

EDGE_KM = 40.0  # [km] The edge band is (EDGE_KM, radius] (reward_shape.py).
SECONDS_PER_DAY = 86_400.0  # [s]
_SEED_FILE = re.compile(r'^(?P<prefix>.+)_seed_(?P<seed>\d+)$')


def edge_fractions(record: Dict[str, Any],
                   radius_km: float = task.STATION_RADIUS_KM
                   ) -> Dict[str, float]:
  """Fractions of an eval record's window by distance from the station.

  Each stride's end point (the flight path after the start) counts for one
  stride of the window (`window_steps`, as TW50 window counts them; strides
  after a flight ended count as outside).

  Returns:
    `edge` (EDGE_KM < d <= radius_km), `core` (d <= EDGE_KM), and
    `edge_share` (edge / (edge + core), NaN when never inside).
  """
  points = record['flight_path'][1:]
  window = record.get('window_steps') or len(points)
  distances = [math.hypot(p['x_km'], p['y_km']) for p in points[:window]]
  edge = sum(EDGE_KM < d <= radius_km for d in distances) / window
  core = sum(d <= EDGE_KM for d in distances) / window
  share = edge / (edge + core) if edge + core > 0 else float('nan')
  return {'edge': edge, 'core': core, 'edge_share': share}


def edge_summary(held: Sequence[Dict[str, Any]]) -> Dict[str, Any]:
  """Means over flights of `edge_fractions` (the share over flights that
  were ever inside)."""
  fractions = [edge_fractions(r) for r in held]
  shares = [f['edge_share'] for f in fractions
            if not math.isnan(f['edge_share'])]
  return {'edge_fraction': statistics.mean(f['edge'] for f in fractions),
          'core_fraction': statistics.mean(f['core'] for f in fractions),
          'edge_share_of_inside': statistics.mean(shares) if shares else None}


def per_seed_edges(held: Sequence[Dict[str, Any]]) -> Dict[str, List[Any]]:
  """Each flight's seed, TW50 window and edge fraction (for paired
  differences between rewards on the same seeds)."""
  return {'seeds': [r['seed'] for r in held],
          'tw50_window': [round(r['tw50_window'], 5) for r in held],
          'edge': [round(edge_fractions(r)['edge'], 5) for r in held]}


def days_aloft(record: Dict[str, Any], stride_s: Optional[float] = None
               ) -> float:
  """Days the episode flew: its strides times the stride [s]
  (default the flight core's). # [day]"""
  if stride_s is None:
    # pylint: disable-next=g-import-not-at-top
    from ble_latex.flight import params as params_lib
    stride_s = params_lib.DEFAULTS.stride_s
  return record['steps'] * stride_s / SECONDS_PER_DAY


def summarize_aloft(records: Sequence[Dict[str, Any]]) -> Dict[str, Any]:
  """`summarize` plus days aloft, the share flying the window and per seed."""
  s = summarize(records)
  days = [days_aloft(r) for r in records]
  s['days_aloft_mean'] = statistics.mean(days)
  s['days_aloft_std'] = statistics.pstdev(days)
  s['full_window_pct'] = 100.0 * statistics.mean(
      r['terminal_reason'] == 'time_limit' for r in records)
  s['seeds'] = [min(r['seed'] for r in records),
                max(r['seed'] for r in records)]
  # Per seed, for paired differences between agents flown on the same
  # seeds (docs/hooks/tables.py).
  s['per_seed'] = {'seeds': [r['seed'] for r in records],
                   'tw50_window': [r['tw50_window'] for r in records]}
  return s


def over_seeds(rows: Mapping[str, Dict[str, Any]]
               ) -> Dict[str, Dict[str, Any]]:
  """Rows `<prefix> (N seeds)`: mean ± std over `<prefix>_seed_<s>` rows of
  `summarize_aloft` (two seeds or more)."""
  groups = collections.defaultdict(list)
  for agent, s in rows.items():
    match = _SEED_FILE.match(agent)
    if match:
      groups[match['prefix']].append(s)
  out = {}
  for prefix, seeds in groups.items():
    if len(seeds) < 2:
      continue
    agg = {}
    for key in ('tw50_window_mean', 'out_of_resources_pct',
                'helium_vented_mols_mean', 'sand_dropped_kg_mean',
                'days_aloft_mean', 'full_window_pct'):
      values = [s[key] for s in seeds]
      agg[key] = statistics.mean(values)
      agg[key + '_over_seeds_std'] = statistics.stdev(values)
    agg['tw50_window_std'] = agg['tw50_window_mean_over_seeds_std']
    agg['days_aloft_std'] = agg['days_aloft_mean_over_seeds_std']
    agg['episodes'] = sum(s['episodes'] for s in seeds)
    agg['num_seeds'] = len(seeds)
    out[f'{prefix} ({len(seeds)} seeds)'] = agg
  return out
