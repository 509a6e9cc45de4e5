# coding=utf-8
"""The observation's wind column corrected by the balloon's measured winds.

With `EnvParams.wind_memory` = K > 0 the env keeps the balloon's last K
measured-minus-forecast winds (`EnvState.wind_memory`, one per measurement:
at reset and after every stride) and its observation's wind column (features
0-49) becomes

  forecast(x, y, P_i, t) + E[noise(x, y, P_i, t) | measurements],

the Gaussian-process posterior mean of BLE's simplex noise at each of the 25
column levels P_i given the K measurements (`wind.noise_gp`, Eq. (2):
Rasmussen & Williams 2006, Eq. 2.23, with the covariance of BLE's own noise
harmonics). It is the wind `latex_mpc` plans in (its `wind_memory`), and what
BLE's Perciatelli features read through BLE's wind GP; nothing of the future
truth is read. With K = 0 (the default) the column is the forecast, the
paper's observation, and nothing here runs.

Pure functions of the env state; the env calls `start` where a balloon is
placed, `remember` where it measures and `column` where it observes.
"""

from typing import Any, Optional, Tuple

import jax
import jax.numpy as jnp

from ble_latex.envs import env_types
from ble_latex.wind import noise_gp

Array = jax.Array


def start(params: env_types.EnvParams,
          dtype: Any) -> Optional[noise_gp.Measurements]:
  """A placed balloon's memory: K empty rows, or None when K is 0."""
  if not params.wind_memory:
    return None
  return noise_gp.empty(params.wind_memory, dtype)


def point(x_m: Array, y_m: Array, pressure_pa: Array, t_s: Array) -> Array:
  """A GP point: (x [km], y [km], pressure [Pa], time [h]), `noise_gp`'s."""
  return jnp.stack([x_m / 1000.0, y_m / 1000.0, pressure_pa, t_s / 3600.0])


def measurement(state: env_types.EnvState, wind: Any
                ) -> Tuple[Array, Array, Array]:
  """Where the balloon is and its measured-minus-forecast wind there.

  Args:
    state: The env state (its measured wind at the balloon, `wind_u`,
      `wind_v`).
    wind: The env's `winds.Wind` (its forecast at the balloon's pressure).

  Returns:
    (`point` of the balloon, du, dv [m/s]).
  """
  f = state.flight
  u0, v0 = wind.forecast_column(state, f.x_m, f.y_m, f.pressure_pa, f.time_s)
  return (point(f.x_m, f.y_m, f.pressure_pa, f.time_s), state.wind_u - u0,
          state.wind_v - v0)


def remember(state: env_types.EnvState, wind: Any) -> env_types.EnvState:
  """`state` with its measured wind (`wind_u`, `wind_v`) in its memory.

  The measured-minus-forecast wind at the balloon (forecast from
  `wind.forecast_column` at its pressure) joins the memory; the oldest row
  goes. A state without a memory is returned as it is.

  Args:
    state: The env state, just measured (`jax_env.measure`).
    wind: The env's `winds.Wind`.

  Returns:
    The state with the measurement remembered.
  """
  if state.wind_memory is None:
    return state
  dtype = state.wind_memory.du.dtype
  where, du, dv = measurement(state, wind)
  memory = noise_gp.add(state.wind_memory, where.astype(dtype),
                        du.astype(dtype), dv.astype(dtype))
  return state.replace(wind_memory=memory)


def column(state: env_types.EnvState, column_u: Array, column_v: Array,
           pressures_pa: Array) -> Tuple[Array, Array]:
  """The observed wind column: the forecast column, corrected if remembered.

  Args:
    state: The env state (its balloon and memory).
    column_u: Forecast eastward wind at `pressures_pa`. # [m/s]
    column_v: Forecast northward wind there. # [m/s]
    pressures_pa: The column's levels. # [Pa]

  Returns:
    (u, v): the forecast plus the posterior-mean noise at each level given
    the memory; the forecast itself without a memory. # [m/s]
  """
  memory = state.wind_memory
  if memory is None:
    return column_u, column_v
  f = state.flight
  points = jax.vmap(lambda p: point(f.x_m, f.y_m, p, f.time_s))(
      pressures_pa).astype(memory.du.dtype)
  weights = noise_gp.fit(memory)
  du, dv = jax.vmap(noise_gp.posterior_mean, in_axes=(None, None, 0))(
      memory, weights, points)
  return (column_u + du.astype(column_u.dtype),
          column_v + dv.astype(column_v.dtype))
