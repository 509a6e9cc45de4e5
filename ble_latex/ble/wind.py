# coding=utf-8
"""The BLE `WindField` adapters of the flight core, both directions.

- `CoreGenerativeWindField`: BLE's `WindField` interface on the core's
  generative wind. It is the gym envs' default wind field: BLE's generative
  (VAE) forecast plus BLE's simplex noise, drawn from the arena's key by the
  flight core (`jax_env.LatexBalloonJaxEnv.draw`) and flown inside the core's
  jitted step. This object gives BLE's consumers (the Perciatelli features of
  BLE's agents, renderers, `SimulatorState` users) the same field through
  BLE's methods: `get_forecast`, `get_forecast_column` and
  `get_ground_truth` evaluate the core's `wind.generative` / `jax_env`
  functions on the flight the arena is flying (`attach`). `reset` does
  nothing: the arena's driver draws the field from the same key BLE's arena
  would give `WindField.reset`.
- `callback_wind`: the core's `winds.Wind` over any BLE `WindField` object
  (e.g. `ble_latex.ble.gridded_field.GriddedWindField`), asked on the host
  through `jax.pure_callback` at every physics sub-step; `host_wind`: the same, with
  its reset, as the Gymnasium env's `host_wind=`.
"""

import datetime as dt
from typing import Any, Callable, List, Optional, Sequence, Tuple

from balloon_learning_environment.env import wind_field
from balloon_learning_environment.utils import units
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex.envs import env_types
from ble_latex.envs import gymnasium_env
from ble_latex.envs import winds


def _vectors(u: np.ndarray, v: np.ndarray) -> List[wind_field.WindVector]:
  """BLE's WindVectors of winds (u, v). # [m/s]"""
  return [wind_field.WindVector(units.Velocity(mps=float(a)),
                                units.Velocity(mps=float(b)))
          for a, b in zip(np.atleast_1d(u), np.atleast_1d(v))]


def _uv(vectors: Sequence[wind_field.WindVector], dtype: Any) -> np.ndarray:
  """[2, ...] (u, v) of BLE's WindVectors. # [m/s]"""
  return np.array([[w.u.meters_per_second for w in vectors],
                   [w.v.meters_per_second for w in vectors]], dtype=dtype)


def callback_wind_fn(
    ground_truth: Callable[..., wind_field.WindVector]
) -> Callable[..., Tuple[jax.Array, jax.Array]]:
  """A pure JAX wind function that asks a BLE ground-truth call on the host.

  Args:
    ground_truth: (x, y, pressure [Pa], time elapsed) -> WindVector, e.g. a
      BLE `WindField.get_ground_truth`.

  Returns:
    (x [m], y [m], p [Pa], t [s]) -> (u, v) [m/s] in x's dtype, through
    `jax.pure_callback` (the core stays jittable).
  """
  def host(x, y, p, t):
    w = ground_truth(units.Distance(m=float(x)), units.Distance(m=float(y)),
                     float(p), dt.timedelta(seconds=float(t)))
    return _uv([w], np.asarray(x).dtype)[:, 0]

  def wind_fn(x, y, p, t):
    uv = jax.pure_callback(host, jax.ShapeDtypeStruct((2,), x.dtype),
                           x, y, p, t)
    return uv[0], uv[1]
  return wind_fn


def callback_wind(field: wind_field.WindField) -> winds.Wind:
  """A `winds.Wind` that asks a BLE `WindField` object on the host.

  Args:
    field: A BLE `wind_field.WindField` (reset by the caller).

  Returns:
    The wind: `get_ground_truth` and `get_forecast_column` of the object,
    called through `jax.pure_callback` (the core stays jittable).
  """
  truth = callback_wind_fn(field.get_ground_truth)

  def host_column(x, y, pressures, t):
    column = field.get_forecast_column(
        units.Distance(m=float(x)), units.Distance(m=float(y)),
        [float(p) for p in np.asarray(pressures)],
        dt.timedelta(seconds=float(t)))
    return _uv(column, np.asarray(x).dtype)

  def ground_truth(state, x, y, p, t):
    del state
    return truth(x, y, p, t)

  def forecast_column(state, x, y, pressures, t):
    del state
    uv = jax.pure_callback(
        host_column, jax.ShapeDtypeStruct((2,) + pressures.shape, x.dtype),
        x, y, pressures, t)
    return uv[0], uv[1]

  return winds.Wind(ground_truth, forecast_column, host=True)


def host_wind(field: wind_field.WindField) -> gymnasium_env.HostWind:
  """The Gymnasium env's `host_wind` of a BLE `WindField` object.

  Args:
    field: A BLE `wind_field.WindField`.

  Returns:
    Its `callback_wind`, and a reset that resets the field with the
    arena's wind key and start time at every start and returns the field's
    own start time (`start_date_time`, ERA5's) if it has one.
  """

  def reset(key: jax.Array, start: dt.datetime) -> Optional[dt.datetime]:
    field.reset(key, start)
    return getattr(field, 'start_date_time', None)

  return gymnasium_env.HostWind(callback_wind(field), reset)


def _wind(grid: Any) -> winds.Wind:
  """The core's wind: ERA5 on `grid`, or BLE's generative field (None)."""
  return winds.GENERATIVE_WIND if grid is None else winds.era5_wind(grid)


@jax.jit
def _forecast(grid: Any, state: env_types.EnvState, x, y, pressures, t):
  wind = _wind(grid)
  return wind.forecast_column(state, x, y, pressures, t)


@jax.jit
def _ground_truth(grid: Any, state: env_types.EnvState, x, y, pressure, t):
  wind = _wind(grid)
  return wind.ground_truth(state, x, y, pressure, t)


class CoreGenerativeWindField(wind_field.WindField):
  """The core's wind as the flight core draws and flies it.

  BLE's generative field, or ERA5 when the flight's params hold its grid
  (`env_types.EnvParams.wind_grid`).
  """

  def __init__(self):
    super().__init__()
    self._state_fn: Optional[Callable[[], env_types.EnvState]] = None
    self._params_fn: Optional[Callable[[], env_types.EnvParams]] = None

  def attach(self, state_fn: Callable[[], env_types.EnvState],
             params_fn: Optional[Callable[[], env_types.EnvParams]] = None
             ) -> None:
    """Reads the field of the flight `state_fn()` returns (the arena's).

    Args:
      state_fn: The flight's state.
      params_fn: Its params (ERA5's grid); None: BLE's generative field.
    """
    self._state_fn = state_fn
    self._params_fn = params_fn

  def _grid(self) -> Any:
    """The flight's ERA5 grid, or None (BLE's generative field)."""
    return None if self._params_fn is None else self._params_fn().wind_grid

  def _state(self) -> env_types.EnvState:
    state = None if self._state_fn is None else self._state_fn()
    if state is None:
      raise RuntimeError('CoreGenerativeWindField is drawn by the latex '
                         'arena: reset the env before querying it.')
    return state

  def reset(self, key: jnp.ndarray, date_time: dt.datetime) -> None:
    """Nothing to do: the arena's driver draws the field from `key`."""
    del key, date_time

  def reset_forecast(self, key: jnp.ndarray, date_time: dt.datetime) -> None:
    """No-op: the core's field was drawn by the env's reset."""
    del key, date_time

  def get_forecast(self, x: units.Distance, y: units.Distance, pressure: float,
                   elapsed_time: dt.timedelta) -> wind_field.WindVector:
    """BLE's `get_forecast`: the core's forecast at one point."""
    return self.get_forecast_column(x, y, [pressure], elapsed_time)[0]

  def get_forecast_column(
      self, x: units.Distance, y: units.Distance, pressures: Sequence[float],
      elapsed_time: dt.timedelta) -> List[wind_field.WindVector]:
    """BLE's `get_forecast_column`: the forecast at several pressures."""
    u, v = jax.device_get(_forecast(
        self._grid(), self._state(), jnp.float32(x.meters),
        jnp.float32(y.meters), jnp.asarray(np.asarray(pressures, np.float32)),
        jnp.float32(elapsed_time.total_seconds())))
    return _vectors(u, v)

  def get_ground_truth(self, x: units.Distance, y: units.Distance,
                       pressure: float,
                       elapsed_time: dt.timedelta) -> wind_field.WindVector:
    """BLE's `get_ground_truth`: forecast plus simplex noise, from the core."""
    u, v = jax.device_get(_ground_truth(
        self._grid(), self._state(), jnp.float32(x.meters),
        jnp.float32(y.meters), jnp.float32(pressure),
        jnp.float32(elapsed_time.total_seconds())))
    return _vectors(u, v)[0]
