# coding=utf-8
"""The wind that `plots.figures.plot_wind_fields` draws, sampled from an env.

`wind_rows` builds a registered balloon env (gin already bound), resets it
per seed and samples its forecast wind on a square x-y grid
(`sample_wind_grid`), one `figures.WindPanelRow` per seed. `ble-latex-plot
--wind_seed(s)` (`cli/plot.py`) calls it before anything is drawn.
"""

import datetime as dt
from typing import Any, Dict, List, Sequence

import numpy as np

from ble_latex import errors
from ble_latex import quiet
from ble_latex.plots import figures


def sample_wind_grid(field: Any, pressures_pa: Sequence[float], *,
                     extent_km: float, num_points: int,
                     elapsed: dt.timedelta) -> Dict[str, np.ndarray]:
  """Forecast wind on a square x-y grid, one column query per grid point.

  Args:
    field: A reset BLE `wind_field.WindField` (generative, ERA5, ...).
    pressures_pa: Pressure levels. # [Pa]
    extent_km: Grid from -extent_km to +extent_km in x and y. # [km]
    num_points: Grid points per side.
    elapsed: Time since the field's start.

  Returns:
    x_km, y_km (num_points,) and u_mps, v_mps (levels, num_points, num_points),
    indexed [level, y, x].
  """
  # pylint: disable-next=g-import-not-at-top
  from balloon_learning_environment.utils import units
  axis = np.linspace(-extent_km, extent_km, num_points)  # [km]
  shape = (len(pressures_pa), num_points, num_points)
  u, v = np.empty(shape), np.empty(shape)
  for iy, y in enumerate(axis):
    for ix, x in enumerate(axis):
      column = field.get_forecast_column(
          units.Distance(km=float(x)), units.Distance(km=float(y)),
          list(pressures_pa), elapsed)
      u[:, iy, ix] = [w.u.meters_per_second for w in column]
      v[:, iy, ix] = [w.v.meters_per_second for w in column]
  return {'x_km': axis, 'y_km': axis, 'u_mps': u, 'v_mps': v}


def wind_rows(seeds: Sequence[int], pressures_pa: Sequence[float], *,
              env_name: str, hours: float, extent_km: float,
              num_points: int) -> List[figures.WindPanelRow]:
  """Builds the env (gin already parsed), resets per seed, samples the wind.

  Args:
    seeds: Env seeds, one row each.
    pressures_pa: Pressure levels, one column each. # [Pa]
    env_name: A registered balloon env.
    hours: Forecast time after the reset. # [h]
    extent_km: Grid half-width. # [km]
    num_points: Grid points per side.

  Returns:
    One `figures.WindPanelRow` per seed.

  Raises:
    errors.UsageError: `env_name` (--env_name) is not a registered balloon
      env.
  """
  with quiet.third_party_noise():
    import gym  # pylint: disable=g-import-not-at-top
  try:
    with quiet.third_party_noise():
      env = gym.make(env_name)
  except gym.error.Error as e:
    raise errors.UsageError(f'--env_name={env_name}: {e}') from e
  try:
    if not hasattr(env.unwrapped, 'arena'):
      raise errors.UsageError(f'--env_name={env_name}: not a balloon env '
                              '(it has no arena to take the wind from)')
    return [_wind_row(env, seed, pressures_pa, hours=hours,
                      extent_km=extent_km, num_points=num_points)
            for seed in seeds]
  finally:
    env.close()


def _wind_row(env: Any, seed: int, pressures_pa: Sequence[float], *,
              hours: float, extent_km: float,
              num_points: int) -> figures.WindPanelRow:
  """Resets `env` to `seed` and samples its forecast wind."""
  env.reset(seed=seed)
  arena = env.unwrapped.arena
  simulator_state = arena.get_simulator_state()
  field = simulator_state.wind_field
  atmosphere = simulator_state.atmosphere
  state = simulator_state.balloon_state
  elapsed = dt.timedelta(hours=hours)
  grid = sample_wind_grid(field, pressures_pa, extent_km=extent_km,
                          num_points=num_points, elapsed=elapsed)
  altitudes = [atmosphere.at_pressure(p).height.kilometers
               for p in pressures_pa]
  when = (state.date_time + elapsed).strftime('%Y-%m-%d %H:%M UTC')
  return figures.WindPanelRow(
      title=f'seed {seed}, {when}\n{type(field).__name__}',
      pressures_pa=np.asarray(pressures_pa, dtype=float),
      altitudes_km=np.asarray(altitudes),
      balloon_xy_km=(state.x.kilometers, state.y.kilometers), **grid)
