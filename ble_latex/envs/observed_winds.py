# coding=utf-8
"""The observation's wind column: corrected by measured winds, or drifted.

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
truth is read. With `EnvParams.wind_lookahead` = N > 0 each level's entry
is instead the mean of that wind over an N-stride drift at the level
(`column`). With both 0 (the defaults) the column is the forecast at the
balloon, the paper's observation.

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


def column(state: env_types.EnvState, params: env_types.EnvParams,
           wind: Any, pressures_pa: Array) -> Tuple[Array, Array]:
  """The observed wind column (features 0-49 read it).

  At each level P_i the wind w(x, y, P_i, t) the observation reads is the
  forecast, plus with a memory (`params.wind_memory` = K > 0) the
  posterior-mean noise given it (Eq. (2) above). Without a lookahead
  (`params.wind_lookahead` = 0) the column is w at the balloon now. With
  N > 0 strides it is, level by level, the mean wind of an isobaric drift
  that starts at the balloon and stays at P_i for N strides of
  dt = `params.stride_s`, on w, by forward Euler (a kinematic trajectory:
  Stohl 1998, Atmos. Environ. 32, 947, Sec. 2):

    x_0 = x, x_{k+1} = x_k + w(x_k, P_i, t + k dt) dt,
    column_i = (x_N - x_0) / (N dt),

  where a level would take the balloon over the next N strides (the
  forecast planners fly the same winds along their plans). The memory's
  Gaussian process is fitted once per observation.

  Args:
    state: The env state (its balloon, forecast and memory).
    params: The env parameters (`wind_memory`, `wind_lookahead`,
      `stride_s`).
    wind: The env's `winds.Wind` (its `forecast_column`).
    pressures_pa: The column's levels. # [Pa]

  Returns:
    (u, v) at each level. # [m/s]
  """
  f = state.flight
  memory = state.wind_memory
  weights = None if memory is None else noise_gp.fit(memory)

  def observed(x_m, y_m, t_s):
    """w at each level, the balloon at (x_m, y_m) (scalars or per level)."""
    if jnp.ndim(x_m) == 0:
      u, v = wind.forecast_column(state, x_m, y_m, pressures_pa, t_s)
    elif wind.host:  # A host column is asked at one position at a time.
      u, v = jax.lax.map(
          lambda a: wind.forecast_column(state, a[0], a[1], a[2][None], t_s),
          (x_m, y_m, pressures_pa))
      u, v = u[:, 0], v[:, 0]
    else:
      u, v = wind.forecast_column(state, x_m, y_m, pressures_pa, t_s)
    if memory is None:
      return u, v
    at = jnp.broadcast_to
    points = jax.vmap(point, in_axes=(0, 0, 0, None))(
        at(x_m, pressures_pa.shape), at(y_m, pressures_pa.shape),
        pressures_pa, t_s).astype(memory.du.dtype)
    du, dv = jax.vmap(noise_gp.posterior_mean, in_axes=(None, None, 0))(
        memory, weights, points)
    return u + du.astype(u.dtype), v + dv.astype(v.dtype)

  n = params.wind_lookahead
  if not n:
    return observed(f.x_m, f.y_m, f.time_s)
  dt = jnp.asarray(params.stride_s, f.x_m.dtype)  # [s]
  x0 = jnp.broadcast_to(f.x_m, pressures_pa.shape)
  y0 = jnp.broadcast_to(f.y_m, pressures_pa.shape)

  def drift(k, xy):
    u, v = observed(xy[0], xy[1], f.time_s + k * dt)
    return xy[0] + u * dt, xy[1] + v * dt

  x, y = jax.lax.fori_loop(0, n, drift, (x0, y0))
  return (x - x0) / (n * dt), (y - y0) / (n * dt)
