# coding=utf-8
"""The paper's figures from training runs, eval results and wind fields.

One function per figure; each takes already-loaded data and an output path and
writes a PNG with matplotlib's Agg canvas (no display, no global pyplot state):

  * `plot_training_curves`     Fig. 2: reward and TW50 per episode + rolling
                               mean.
  * `plot_wind_fields`         Fig. 3: forecast wind arrows coloured by
                               direction.
  * `plot_trajectories`        Fig. 4: bird's-eye flight paths, 50 km circle.
  * `plot_terminal_conditions` Fig. 5: cumulative terminal reasons per episode.
  * `plot_trajectory_3d`       Fig. 6: trained vs untrained agent in 3D with the
                               station-keeping cylinder.

(Fig. 1, altitude and ascent rate under vent/ballast/float commands, is
`plots.validation`, drawn by `ble-latex-validate`.) The loaders read the run/eval file formats of
`ble-latex-train` (RUN/episodes.jsonl) and `ble-latex-eval` (OUT/SUITE/A.json)
and check every record against its schema (`ble_latex.run.records`), raising
ValueError naming the file, record and field; see docs/plots.md. Nothing
here imports BLE; `plots.wind_samples` gathers wind data from the env.
"""

import dataclasses
import math
import os
import textwrap
from typing import Any, Dict, Mapping, Optional, Sequence, Tuple

from matplotlib import collections as mpl_collections
from matplotlib import colors as mpl_colors
from matplotlib import figure as mpl_figure
from matplotlib import patches as mpl_patches
from matplotlib.backends import backend_agg
import numpy as np

from ble_latex.envs import task
from ble_latex.flight import controller
from ble_latex.run import records

STATION_RADIUS_KM = task.STATION_RADIUS_KM  # [km] Station-keeping radius.
# [km] The range of the desired-altitude action a0 (the controller's Box).
ALTITUDE_BAND_KM = (float(controller.ACTION_LOW[0]) / 1000.0,
                    float(controller.ACTION_HIGH[0]) / 1000.0)
ROLLING_WINDOW = 50  # Episodes in the paper's rolling mean.
# The paper's result after 2500 episodes (50-episode rolling mean).
PAPER_REWARD = 110.0
PAPER_TW50 = 0.25

# Colours of the terminal reasons, in plot order (`records.TERMINAL_REASONS`,
# the values an episode's `terminal_reason` may take).
# `cumulative_terminal_counts` appends any other reason it is given
# (notebooks); the loaders reject them.
TERMINAL_COLORS = dict(zip(records.TERMINAL_REASONS, (
    'tab:green', 'tab:olive', 'tab:orange', 'tab:red', 'tab:purple',
    'tab:brown', 'tab:gray')))
_DPI = 120


# ---------------------------------------------------------------------------
# Data helpers.
# ---------------------------------------------------------------------------


def rolling_mean(values: Sequence[float], window: int = ROLLING_WINDOW
                 ) -> np.ndarray:
  """Trailing rolling mean; the first window-1 entries average what exists.

  out[i] = mean(values[max(0, i - window + 1) : i + 1]).

  Args:
    values: One value per episode.
    window: Number of episodes averaged (the paper uses 50).

  Returns:
    An array as long as `values`.

  Raises:
    ValueError: if `window` < 1.
  """
  if window < 1:
    raise ValueError(f'window must be >= 1, got {window}')
  x = np.asarray(values, dtype=np.float64)
  if x.size == 0:
    return x
  cumsum = np.concatenate([[0.0], np.cumsum(x)])
  ends = np.arange(1, x.size + 1)
  starts = np.maximum(ends - window, 0)
  return (cumsum[ends] - cumsum[starts]) / (ends - starts)


def cumulative_terminal_counts(episodes: Sequence[Mapping[str, Any]]
                               ) -> Dict[str, np.ndarray]:
  """Cumulative count of each terminal reason after each episode.

  Args:
    episodes: Records with a 'terminal_reason'.

  Returns:
    reason -> int array (len(episodes),), in TERMINAL_COLORS order, then any
    other reason in order of first appearance; only reasons that occur.
  """
  reasons = [str(e['terminal_reason']) for e in episodes]
  order = [r for r in TERMINAL_COLORS if r in reasons]
  order += [r for r in dict.fromkeys(reasons) if r not in TERMINAL_COLORS]
  return {r: np.cumsum([x == r for x in reasons]).astype(int) for r in order}


def common_seed(records: Sequence[Mapping[str, Any]],
                others: Sequence[Mapping[str, Any]],
                seed: Optional[int] = None) -> int:
  """The seed to compare: `seed` if both have it, else the first common one.

  Args:
    records: Eval records of the first agent (their order decides).
    others: Eval records of the second agent.
    seed: A requested seed, or None.

  Returns:
    A seed present in both.

  Raises:
    ValueError: if `seed` is missing from either, or there is no common seed.
  """
  seeds = [r['seed'] for r in records]
  other_seeds = {r['seed'] for r in others}
  if seed is not None:
    if seed not in seeds or seed not in other_seeds:
      raise ValueError(f'seed {seed} is not in both eval files (first has '
                       f'{sorted(seeds)}, second has {sorted(other_seeds)})')
    return seed
  for s in seeds:
    if s in other_seeds:
      return s
  raise ValueError(f'the eval files share no seed (first has {sorted(seeds)}, '
                   f'second has {sorted(other_seeds)})')


def _flight_arrays(record: Mapping[str, Any]) -> Dict[str, np.ndarray]:
  """t [h], x [km], y [km], altitude [km] of a record's flight path."""
  flight = record.get('flight_path')
  if not flight:
    raise ValueError(f'seed {record.get("seed")}: no flight_path to plot '
                     '(evaluate with ble-latex-eval, which records it)')
  return {
      't_h': np.array([p['t_s'] for p in flight], dtype=float) / 3600.0,
      'x_km': np.array([p['x_km'] for p in flight], dtype=float),
      'y_km': np.array([p['y_km'] for p in flight], dtype=float),
      'alt_km': np.array([p['altitude_m'] for p in flight], dtype=float) / 1e3,
  }


def save_png(fig: mpl_figure.Figure, path: str, *, dpi: int = _DPI
             ) -> mpl_figure.Figure:
  """Writes `fig` to `path` (PNG, `dpi` dots per inch) on its own Agg canvas
  (no pyplot state); returns it, for callers that inspect it."""
  folder = os.path.dirname(os.path.abspath(path))
  os.makedirs(folder, exist_ok=True)
  backend_agg.FigureCanvasAgg(fig)
  fig.savefig(path, dpi=dpi)
  return fig


# ---------------------------------------------------------------------------
# Figures.
# ---------------------------------------------------------------------------


def plot_training_curves(episodes: Sequence[Mapping[str, Any]], path: str, *,
                         window: int = ROLLING_WINDOW,
                         paper_reference: bool = True
                         ) -> mpl_figure.Figure:
  """Paper Fig. 2: episode reward and TW50 per episode with a rolling mean.

  The TW50 panel shows `tw50_window` (per episode and rolling mean) and the
  rolling mean of BLE's `tw50` over the steps flown.

  Args:
    episodes: RUN/episodes.jsonl records (see `load_episodes`).
    path: Output PNG.
    window: Rolling-mean window [episodes].
    paper_reference: Draw the paper's result (reward ~110, TW50 ~25%, 50-episode
      rolling mean after 2500 episodes) as dashed lines.

  Returns:
    The figure, written to `path`.
  """
  if not episodes:
    raise ValueError('no episodes to plot')
  ep = np.array([e['episode'] for e in episodes])
  fig = mpl_figure.Figure(figsize=(9, 6.5), layout='constrained')
  axes = fig.subplots(2, 1, sharex=True)
  for ax, key, label, scale, ref, color in (
      (axes[0], 'reward', 'episode reward', 1.0, PAPER_REWARD, 'tab:blue'),
      (axes[1], 'tw50_window', 'TW50 [%]', 100.0, 100.0 * PAPER_TW50,
       'tab:green')):
    values = scale * np.array([float(e[key]) for e in episodes])
    if key == 'tw50_window':
      flown = 100.0 * np.array([float(e['tw50']) for e in episodes])
      ax.plot(ep, rolling_mean(flown, window), color='0.45', lw=1.2,
              label=f'TW50 over steps flown, {window}-ep. mean')
    ax.plot(ep, values, color=color, lw=0.6, alpha=0.45, label='per episode')
    ax.plot(ep, rolling_mean(values, window), color=color, lw=2.2,
            label=(f'{window}-episode rolling mean' if key == 'reward' else
                   f'TW50 over the 3-day window, {window}-ep. mean'))
    if paper_reference:
      ax.axhline(ref, color='0.35', ls='--', lw=1.0,
                 label='paper (50-ep. mean, 2500 ep.)')
    ax.set_ylabel(label)
    ax.grid(alpha=0.3)
    ax.legend(loc='lower right', fontsize=8)
  axes[1].set_ylim(-2, 102)
  axes[1].set_xlabel('episode')
  last = slice(-min(window, len(episodes)), None)
  fig.suptitle(
      f'Training: {len(episodes)} episodes; last {window}: reward '
      f'{np.mean([e["reward"] for e in episodes[last]]):.1f}, TW50 window '
      f'{100 * np.mean([e["tw50_window"] for e in episodes[last]]):.1f}% '
      f'(flown {100 * np.mean([e["tw50"] for e in episodes[last]]):.1f}%)')
  return save_png(fig, path)


def seed_curves(runs: Mapping[str, Sequence[Mapping[str, Any]]], key: str,
                window: int = ROLLING_WINDOW) -> np.ndarray:
  """[runs, episodes] rolling means of `key` over the episodes all runs have.

  Raises:
    ValueError: No runs, or a run without episodes.
  """
  if not runs or any(not episodes for episodes in runs.values()):
    raise ValueError('need at least one run, each with episodes')
  n = min(len(episodes) for episodes in runs.values())
  return np.array([rolling_mean([float(e[key]) for e in episodes[:n]], window)
                   for episodes in runs.values()])


def plot_seed_curves(runs: Mapping[str, Sequence[Mapping[str, Any]]],
                     path: str, *, window: int = ROLLING_WINDOW,
                     validation: Optional[
                         Mapping[str, Sequence[Mapping[str, Any]]]] = None
                     ) -> mpl_figure.Figure:
  """Training curves of several seeds in one figure: mean and band.

  Top: the `window`-episode rolling mean of `tw50_window` of each run (thin),
  their mean over runs (thick) and the min-max band, over the episodes all
  runs have. Middle: the same for the episode reward. Bottom, with
  `validation`: each run's validated snapshots (TW50 over the window on the
  fixed validation seeds, deterministic policy) against training episodes,
  with mean and band over the snapshots all runs have.

  Args:
    runs: episodes.jsonl records of each run, by label (e.g. 'seed 0').
    path: Output PNG.
    window: Rolling-mean window [episodes].
    validation: validation.jsonl records of each run, by the same labels.

  Returns:
    The figure, written to `path`.

  Raises:
    ValueError: `validation` is not keyed like `runs`, or a run has none.
  """
  if validation is not None and (
      set(validation) != set(runs) or
      any(not records for records in validation.values())):
    raise ValueError('validation needs records for each run and no other')
  n = seed_curves(runs, 'reward', window).shape[1]
  fig = mpl_figure.Figure(figsize=(9, 9.5 if validation else 6.5),
                          layout='constrained')
  axes = fig.subplots(3 if validation else 2, 1)
  axes[1].sharex(axes[0])
  ep = np.arange(n)
  for ax, key, label, scale in (
      (axes[0], 'tw50_window', 'TW50 over the 3-day window [%]', 100.0),
      (axes[1], 'reward', 'episode reward', 1.0)):
    curves = scale * seed_curves(runs, key, window)
    for name, curve in zip(runs, curves):
      ax.plot(ep, curve, lw=0.7, alpha=0.6, label=name)
    ax.fill_between(ep, curves.min(axis=0), curves.max(axis=0),
                    color='0.6', alpha=0.25, label='min-max over runs')
    ax.plot(ep, curves.mean(axis=0), color='k', lw=2.2,
            label=f'mean of {len(runs)} runs')
    ax.set_ylabel(label)
    ax.grid(alpha=0.3)
  axes[0].legend(loc='lower right', fontsize=8, ncol=2)
  axes[1].set_xlabel('training episode')
  if validation:
    ax = axes[2]
    common = sorted(set.intersection(*[
        {r['training_episodes'] for r in records}
        for records in validation.values()]))
    table = []
    for name in runs:
      by_episodes = {r['training_episodes']: 100.0 * r['tw50_window_mean']
                     for r in validation[name]}
      xs = sorted(by_episodes)
      ax.plot(xs, [by_episodes[x] for x in xs], lw=0.7, alpha=0.6,
              marker='.', ms=2, label=name)
      table.append([by_episodes[x] for x in common])
    if common:
      table = np.array(table)
      ax.fill_between(common, table.min(axis=0), table.max(axis=0),
                      color='0.6', alpha=0.25, label='min-max over runs')
      ax.plot(common, table.mean(axis=0), color='k', lw=2.2,
              label=f'mean of {len(runs)} runs')
    first = next(iter(validation.values()))[0]
    ax.set_ylabel(f'validation TW50 window [%]\n({first["episodes"]} seeds, '
                  'deterministic)')
    ax.set_xlabel('training episode')
    ax.grid(alpha=0.3)
    ax.legend(loc='lower right', fontsize=8, ncol=2)
  fig.suptitle(f'{len(runs)} training runs, {window}-episode rolling means '
               f'over their first {n} episodes')
  return save_png(fig, path)


def plot_terminal_conditions(episodes: Sequence[Mapping[str, Any]],
                             path: str) -> mpl_figure.Figure:
  """Paper Fig. 5: cumulative count of each terminal reason vs episode.

  Args:
    episodes: RUN/episodes.jsonl records (see `load_episodes`).
    path: Output PNG.

  Returns:
    The figure, written to `path`.
  """
  if not episodes:
    raise ValueError('no episodes to plot')
  ep = np.array([e['episode'] for e in episodes])
  counts = cumulative_terminal_counts(episodes)
  fig = mpl_figure.Figure(figsize=(8, 4.5), layout='constrained')
  ax = fig.subplots()
  for reason, count in counts.items():
    ax.step(ep, count, where='post', lw=2,
            color=TERMINAL_COLORS.get(reason),
            label=f'{reason.replace("_", " ")} ({count[-1]})')
  ax.set_xlabel('episode')
  ax.set_ylabel('cumulative episodes')
  ax.set_title('Terminal conditions')
  ax.grid(alpha=0.3)
  ax.legend(loc='upper left')
  return save_png(fig, path)


def _station_circle(radius_km: float, **kwargs: Any) -> mpl_patches.Circle:
  return mpl_patches.Circle((0.0, 0.0), radius_km, fill=False, **kwargs)


def plot_trajectories(records: Sequence[Mapping[str, Any]], path: str, *,
                      max_trajectories: int = 6,
                      radius_km: float = STATION_RADIUS_KM
                      ) -> mpl_figure.Figure:
  """Paper Fig. 4: bird's-eye flight paths with the station-keeping circle.

  One panel per episode (the first `max_trajectories` records), the path
  coloured by flight time, start (circle) and end (cross) marked, titled with
  seed and TW50.

  Args:
    records: Eval records with flight paths (see `load_eval`).
    path: Output PNG.
    max_trajectories: Most episodes shown.
    radius_km: Station-keeping radius. # [km]

  Returns:
    The figure, written to `path`.
  """
  if max_trajectories < 1:
    raise ValueError(f'max_trajectories must be >= 1, got {max_trajectories}')
  records = list(records)[:max_trajectories]
  if not records:
    raise ValueError('no eval records to plot')
  flights = [_flight_arrays(r) for r in records]
  n = len(records)
  ncols = min(n, 3)
  nrows = math.ceil(n / ncols)
  fig = mpl_figure.Figure(figsize=(4.2 * ncols + 1.0, 4.0 * nrows),
                          layout='constrained')
  axes = np.atleast_1d(fig.subplots(nrows, ncols, squeeze=False)).ravel()
  t_max = max(max(f['t_h'].max() for f in flights), 1e-9)
  norm = mpl_colors.Normalize(0.0, t_max)
  lines = None
  for ax, record, f in zip(axes, records, flights):
    xy = np.stack([f['x_km'], f['y_km']], axis=1)
    lines = mpl_collections.LineCollection(
        np.stack([xy[:-1], xy[1:]], axis=1), cmap='viridis', norm=norm, lw=1.8)
    lines.set_array(0.5 * (f['t_h'][:-1] + f['t_h'][1:]))
    ax.add_collection(lines)
    ax.add_patch(_station_circle(radius_km, color='k', ls='--', lw=1.2))
    ax.plot(0, 0, marker='+', color='k', ms=8)
    ax.plot(*xy[0], marker='o', color='tab:green', ms=7, label='start')
    ax.plot(*xy[-1], marker='X', color='tab:red', ms=8, label='end')
    half = max(np.abs(xy).max(), radius_km) * 1.1
    ax.set_xlim(-half, half)
    ax.set_ylim(-half, half)
    ax.set_aspect('equal')
    ax.set_title(f'seed {record["seed"]}: TW50 {100 * record["tw50_window"]:.0f}% (window), '
                 f'{record["terminal_reason"].replace("_", " ")}', fontsize=9)
    ax.set_xlabel('x [km]')
    ax.set_ylabel('y [km]')
    ax.grid(alpha=0.3)
  axes[0].legend(loc='upper right', fontsize=8)
  for ax in axes[n:]:
    ax.set_visible(False)
  fig.colorbar(lines, ax=axes[:n].tolist(), label='flight time [h]',
               shrink=0.8)
  fig.suptitle(f'Flight paths, {radius_km:g} km station-keeping radius')
  return save_png(fig, path)


def plot_trajectory_3d(trained: Mapping[str, Any], untrained: Mapping[str, Any],
                       path: str, *, labels: Tuple[str, str] = (
                           'trained', 'untrained'),
                       radius_km: float = STATION_RADIUS_KM,
                       altitude_band_km: Tuple[float, float] = ALTITUDE_BAND_KM
                       ) -> mpl_figure.Figure:
  """Paper Fig. 6: 3D flight of a trained and an untrained agent, same seed.

  Draws the station-keeping cylinder (radius `radius_km`, altitudes
  `altitude_band_km`) translucent.

  Args:
    trained: Eval record (with flight path) of the trained agent.
    untrained: Eval record of the untrained agent for the same seed.
    path: Output PNG.
    labels: Legend names of the two agents.
    radius_km: Station-keeping radius. # [km]
    altitude_band_km: Cylinder bottom and top. # [km]

  Returns:
    The figure, written to `path`.
  """
  flights = [_flight_arrays(trained), _flight_arrays(untrained)]
  fig = mpl_figure.Figure(figsize=(8.5, 7), layout='constrained')
  ax = fig.add_subplot(projection='3d')
  theta = np.linspace(0.0, 2.0 * np.pi, 60)
  z = np.array(altitude_band_km)
  theta_grid, z_grid = np.meshgrid(theta, z)
  ax.plot_surface(radius_km * np.cos(theta_grid),
                  radius_km * np.sin(theta_grid), z_grid, color='tab:gray',
                  alpha=0.15, linewidth=0)
  for h in z:
    ax.plot(radius_km * np.cos(theta), radius_km * np.sin(theta), h,
            color='tab:gray', lw=0.8, alpha=0.6)
  for record, f, label, color in zip((trained, untrained), flights, labels,
                                     ('tab:blue', 'tab:red')):
    ax.plot(f['x_km'], f['y_km'], f['alt_km'], color=color, lw=1.8,
            label=f'{label}: TW50 {100 * record["tw50_window"]:.0f}% (window), '
                  f'{record["terminal_reason"].replace("_", " ")}')
    ax.scatter(f['x_km'][:1], f['y_km'][:1], f['alt_km'][:1], color=color,
               marker='o', s=40)
    ax.scatter(f['x_km'][-1:], f['y_km'][-1:], f['alt_km'][-1:], color=color,
               marker='X', s=50)
  reach = max(radius_km, *(np.abs(f[k]).max() for f in flights
                           for k in ('x_km', 'y_km'))) * 1.05
  ax.set_xlim(-reach, reach)
  ax.set_ylim(-reach, reach)
  low = min(altitude_band_km[0], *(f['alt_km'].min() for f in flights))
  high = max(altitude_band_km[1], *(f['alt_km'].max() for f in flights))
  ax.set_zlim(low - 0.5, high + 0.5)
  ax.set_box_aspect((1.0, 1.0, 0.6))
  ax.set_xlabel('x [km]')
  ax.set_ylabel('y [km]')
  ax.set_zlabel('altitude [km]')
  ax.legend(loc='upper left', fontsize=9)
  ax.set_title(f'seed {trained["seed"]}: start o, end x; cylinder '
               f'{radius_km:g} km, {altitude_band_km[0]:g}-'
               f'{altitude_band_km[1]:g} km')
  return save_png(fig, path)


@dataclasses.dataclass
class WindPanelRow:
  """Forecast wind on an x-y grid at several pressure levels (one date)."""
  title: str
  x_km: np.ndarray  # (nx,) [km]
  y_km: np.ndarray  # (ny,) [km]
  pressures_pa: np.ndarray  # (levels,) [Pa]
  altitudes_km: np.ndarray  # (levels,) [km] Standard-atmosphere altitude.
  u_mps: np.ndarray  # (levels, ny, nx) [m/s] Eastward (+x).
  v_mps: np.ndarray  # (levels, ny, nx) [m/s] Northward (+y).
  balloon_xy_km: Optional[Tuple[float, float]] = None  # [km]

  def __post_init__(self):
    shape = (len(self.pressures_pa), len(self.y_km), len(self.x_km))
    for name in ('u_mps', 'v_mps'):
      value = np.asarray(getattr(self, name), dtype=float)
      if value.shape != shape:
        raise ValueError(f'{name} has shape {value.shape}, expected {shape} '
                         '(levels, ny, nx)')
      if not np.all(np.isfinite(value)):
        raise ValueError(f'{name} of "{self.title}" has non-finite values')
      setattr(self, name, value)
    if len(self.altitudes_km) != len(self.pressures_pa):
      raise ValueError('altitudes_km and pressures_pa differ in length')


def wind_direction_deg(u_mps: np.ndarray, v_mps: np.ndarray) -> np.ndarray:
  """Direction the wind blows toward, degrees counter-clockwise from east.

  atan2(v, u) in (-180, 180]: 0 = toward east, 90 = toward north.
  """
  return np.degrees(np.arctan2(v_mps, u_mps))


def plot_wind_fields(rows: Sequence[WindPanelRow], path: str, *,
                     radius_km: float = STATION_RADIUS_KM
                     ) -> mpl_figure.Figure:
  """Paper Fig. 3: forecast wind arrows coloured by direction.

  One row per date/seed (e.g. favourable vs unfavourable), one column per
  pressure level; arrow colour is the direction (hsv colormap on atan2(v, u)),
  arrow length the speed; the station-keeping circle and the balloon's start
  position are drawn.

  Args:
    rows: One `WindPanelRow` per date/seed.
    path: Output PNG.
    radius_km: Station-keeping radius. # [km]

  Returns:
    The figure, written to `path`.
  """
  if not rows:
    raise ValueError('no wind fields to plot')
  nrows = len(rows)
  ncols = max(len(r.pressures_pa) for r in rows)
  fig = mpl_figure.Figure(figsize=(3.6 * ncols + 1.2, 3.7 * nrows + 0.4),
                          layout='constrained')
  axes = fig.subplots(nrows, ncols, squeeze=False)
  norm = mpl_colors.Normalize(-180.0, 180.0)
  speed_max = max(float(np.hypot(r.u_mps, r.v_mps).max()) for r in rows)
  key_speed = max(1.0, float(np.round(speed_max / 2.0)))  # [m/s]
  quiver = None
  for i, row in enumerate(rows):
    xx, yy = np.meshgrid(row.x_km, row.y_km)
    spacing = float(np.ptp(row.x_km)) / max(len(row.x_km) - 1, 1)  # [km]
    for j in range(ncols):
      ax = axes[i, j]
      if j >= len(row.pressures_pa):
        ax.set_visible(False)
        continue
      u, v = row.u_mps[j], row.v_mps[j]
      # Same scale everywhere: the fastest arrow spans ~1.6 grid cells.
      quiver = ax.quiver(xx, yy, u, v, wind_direction_deg(u, v), cmap='hsv',
                         norm=norm, angles='xy', scale_units='xy',
                         scale=max(speed_max, 1e-6) / (1.6 * spacing),
                         width=0.006)
      ax.add_patch(_station_circle(radius_km, color='k', lw=1.5))
      if row.balloon_xy_km is not None:
        ax.plot(*row.balloon_xy_km, marker='*', color='k', ms=10)
      ax.set_aspect('equal')
      ax.set_title(f'{row.pressures_pa[j]:.0f} Pa '
                   f'(~{row.altitudes_km[j]:.1f} km)', fontsize=9)
      if i == nrows - 1:
        ax.set_xlabel('x [km]')
      if j == 0:
        ax.set_ylabel(f'{row.title}\ny [km]', fontsize=9)
  if quiver is not None:
    quiver.axes.quiverkey(quiver, 0.9, 0.975, key_speed, f'{key_speed:g} m/s',
                          labelpos='E', coordinates='figure',
                          fontproperties={'size': 9})
    bar = fig.colorbar(quiver, ax=axes.ravel().tolist(), shrink=0.8,
                       ticks=[-180, -90, 0, 90, 180])
    bar.set_label('wind blows toward')
    bar.ax.set_yticklabels(['W', 'S', 'E', 'N', 'W'])
  fig.suptitle('Forecast wind (circle: station-keeping radius, star: balloon '
               'at reset)')
  return save_png(fig, path)


def plot_wind_stats(a: Any, b: Any, stats: Mapping[str, Any], path: str
                    ) -> mpl_figure.Figure:
  """Two wind sources side by side (`ble_latex.wind.stats.compare`).

  Four panels over the pressure levels (top of the band at the top): the
  distributions of u and of v of each source (box: quartiles, whiskers:
  5-95 %), the Wasserstein distance between the sources per level, and per
  level the fraction of samples whose wind opposes (> 90 deg) the wind at
  some other level of the band (direction diversity).

  Args:
    a: The first source's columns: `.label`, `.pressures_pa` (L,) in Pa, `.u`,
      `.v` (N, L) in m/s (a `stats.WindSamples`).
    b: The second source's, at the same levels.
    stats: `stats.compare(a, b)`.
    path: Output PNG.

  Returns:
    The figure, written to `path`.
  """
  pressures = np.asarray(a.pressures_pa, dtype=float)
  labels = [f'{p:.0f}' for p in pressures]
  rows = np.arange(len(pressures), dtype=float)
  fig = mpl_figure.Figure(figsize=(15.0, 0.45 * len(pressures) + 3.2),
                          layout='constrained')
  axes = fig.subplots(1, 4, sharey=True)
  colors = ('tab:blue', 'tab:orange')
  for ax, name in zip(axes[:2], ('u', 'v')):
    for k, (source, color) in enumerate(zip((a, b), colors)):
      ax.boxplot(np.asarray(getattr(source, name)),
                 positions=rows + (k - 0.5) * 0.35, widths=0.3,
                 orientation='horizontal', whis=(5, 95), showfliers=False,
                 patch_artist=True, manage_ticks=False,
                 boxprops={'facecolor': color, 'alpha': 0.6},
                 medianprops={'color': 'k'})
    ax.axvline(0.0, color='0.6', lw=0.8)
    ax.set_xlabel(f'{name} [m/s]')
    ax.set_title(f'{name} per level')
  per_level = stats['per_level']
  for name, style, color in (('u', 'o-', 'k'), ('v', 's--', '0.5')):
    key = f'wasserstein_{name}_mps'
    axes[2].plot([r[key] for r in per_level], rows, style, color=color,
                 label=f'{name} (all levels {stats[key]:.2f})')
  axes[2].set_xlabel('Wasserstein distance [m/s]')
  axes[2].set_title('distance between the sources')
  axes[2].set_xlim(left=0.0)
  axes[2].legend(fontsize=8)
  diversity = stats['direction_diversity']
  for key, source, color in (('a', a, colors[0]), ('b', b, colors[1])):
    d = diversity[key]
    axes[3].plot(d['opposing_by_level'], rows, 'o-', color=color,
                 label=(f'{_short(source.label)}: any pair '
                        f'{100 * d["opposing_any_fraction"]:.0f} %, pairs '
                        f'{100 * d["opposing_pair_fraction"]:.0f} %'))
  axes[3].set_xlim(0.0, 1.0)
  axes[3].set_xlabel('fraction opposing another level')
  axes[3].set_title('direction diversity (> 90 deg)')
  axes[3].legend(fontsize=8)
  axes[0].set_yticks(rows, labels)
  axes[0].set_ylabel('pressure [Pa]')
  axes[0].invert_yaxis()  # Low pressure (high altitude) at the top.
  handles = [mpl_patches.Patch(color=c, alpha=0.6, label=_short(s.label))
             for c, s in zip(colors, (a, b))]
  fig.legend(handles=handles, loc='outside upper center', ncol=2)
  single = [_short(s.label) for s in (a, b) if np.shape(s.u)[0] == 1]
  if single:
    fig.suptitle(f'{", ".join(single)}: one column (a sounding): a single '
                 'sample, not a distribution', fontsize=9)
  return save_png(fig, path)


def plot_wind_compare(profiles: Sequence[Mapping[str, Any]], path: str
                      ) -> mpl_figure.Figure:
  """Wind sources in the flight band (`ble_latex.wind.stats.profile`).

  Three panels: each source's wind speed per level against height (median,
  5-95 % band; a single column is one line, drawn dashed), the fraction of
  columns with two levels >= 90 and >= 135 deg apart (hatched: one column,
  so 0 or 1), and the spread of each column's winds over the band (largest
  difference between two levels; median, whiskers 5-95 %).

  Args:
    profiles: `stats.profile` of each source, in the order drawn.
    path: Output PNG.

  Returns:
    The figure, written to `path`.
  """
  fig = mpl_figure.Figure(figsize=(15.0, 5.6), layout='constrained')
  axes = fig.subplots(1, 3)
  colors = [f'C{i}' for i in range(len(profiles))]
  x = np.arange(len(profiles), dtype=float)
  for k, (prof, color) in enumerate(zip(profiles, colors)):
    km = np.asarray(prof['heights_m']) / 1000.0
    speed = prof['speed_mps']
    single = prof['single_column']
    axes[0].plot([q['p50'] for q in speed], km, '--' if single else '-',
                 color=color, label=(prof['label'] +
                                     (' (one column)' if single else
                                      f' ({prof["columns"]} columns)')))
    if not single:
      axes[0].fill_betweenx(km, [q['p5'] for q in speed],
                            [q['p95'] for q in speed], color=color,
                            alpha=0.15)
    for j, key in enumerate(('ge90', 'ge135')):
      axes[1].bar(x[k] + (j - 0.5) * 0.38, prof['apart'][key], width=0.36,
                  color=color, alpha=1.0 if j == 0 else 0.55,
                  hatch='//' if single else None, edgecolor='k', lw=0.5)
    spread = prof['shear']['spread_mps']
    axes[2].errorbar(x[k], spread['p50'],
                     yerr=[[spread['p50'] - spread['p5']],
                           [spread['p95'] - spread['p50']]],
                     fmt='o', color=color, capsize=4)
  axes[0].set_xlabel('wind speed [m/s]')
  axes[0].set_ylabel('height [km] (US Standard Atmosphere)')
  axes[0].set_title('speed per level (median, 5-95 %)')
  axes[0].legend(fontsize=7)
  names = [textwrap.fill(p['label'], 30) for p in profiles]
  axes[1].set_xticks(x, names, fontsize=7, rotation=25, ha='right')
  axes[1].set_ylim(0.0, 1.05)
  axes[1].set_ylabel('fraction of columns')
  axes[1].set_title('two levels >= 90 deg (dark) / >= 135 deg apart')
  axes[2].set_xticks(x, names, fontsize=7, rotation=25, ha='right')
  axes[2].set_ylabel('largest wind difference in the band [m/s]')
  axes[2].set_title('spread over 15-25 km (median, 5-95 %)')
  axes[2].set_ylim(bottom=0.0)
  return save_png(fig, path)


def _short(label: str, length: int = 40) -> str:
  """A label cut to `length` characters (file paths: their end)."""
  return label if len(label) <= length else '...' + label[-(length - 3):]
