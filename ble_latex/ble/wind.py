# coding=utf-8
"""BLE's `WindField` interface on the flight core's generative wind.

`CoreGenerativeWindField` is the gym envs' default wind field: BLE's
generative (VAE) forecast plus BLE's simplex noise, drawn from the arena's
key by the flight core (`jax_env.LatexBalloonJaxEnv.draw`) and flown inside
the core's jitted step. This object gives BLE's consumers (the Perciatelli
features of BLE's agents, renderers, `SimulatorState` users) the same field
through BLE's methods: `get_forecast`, `get_forecast_column` and
`get_ground_truth` evaluate the core's `wind.generative` / `jax_env`
functions on the flight the arena is flying (`attach`).

`reset` does nothing: the arena's `FlightDriver` draws the field from the
same key BLE's arena would give `WindField.reset`.
"""

import datetime as dt
from typing import Callable, List, Optional, Sequence

from balloon_learning_environment.env import wind_field
from balloon_learning_environment.utils import units
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex.envs import jax_env


@jax.jit
def _forecast(state: jax_env.EnvState, x, y, pressures, t):
  return jax_env.forecast_column(state, x, y, pressures, t)


@jax.jit
def _ground_truth(state: jax_env.EnvState, x, y, pressure, t):
  return jax_env.ground_truth_wind(state, x, y, pressure, t)


def _vectors(u: np.ndarray, v: np.ndarray) -> List[wind_field.WindVector]:
  return [wind_field.WindVector(units.Velocity(mps=float(a)),
                                units.Velocity(mps=float(b)))
          for a, b in zip(np.atleast_1d(u), np.atleast_1d(v))]


class CoreGenerativeWindField(wind_field.WindField):
  """BLE's generative field as the flight core draws and flies it."""

  def __init__(self):
    super().__init__()
    self._state_fn: Optional[Callable[[], jax_env.EnvState]] = None

  def attach(self, state_fn: Callable[[], jax_env.EnvState]) -> None:
    """Reads the field of the flight `state_fn()` returns (the arena's)."""
    self._state_fn = state_fn

  def _state(self) -> jax_env.EnvState:
    state = None if self._state_fn is None else self._state_fn()
    if state is None:
      raise RuntimeError('CoreGenerativeWindField is drawn by the latex '
                         'arena: reset the env before querying it.')
    return state

  def reset(self, key: jnp.ndarray, date_time: dt.datetime) -> None:
    """Nothing to do: the arena's driver draws the field from `key`."""
    del key, date_time

  def reset_forecast(self, key: jnp.ndarray, date_time: dt.datetime) -> None:
    del key, date_time

  def get_forecast(self, x: units.Distance, y: units.Distance, pressure: float,
                   elapsed_time: dt.timedelta) -> wind_field.WindVector:
    return self.get_forecast_column(x, y, [pressure], elapsed_time)[0]

  def get_forecast_column(
      self, x: units.Distance, y: units.Distance, pressures: Sequence[float],
      elapsed_time: dt.timedelta) -> List[wind_field.WindVector]:
    u, v = jax.device_get(_forecast(
        self._state(), jnp.float32(x.meters), jnp.float32(y.meters),
        jnp.asarray(np.asarray(pressures, np.float32)),
        jnp.float32(elapsed_time.total_seconds())))
    return _vectors(u, v)

  def get_ground_truth(self, x: units.Distance, y: units.Distance,
                       pressure: float,
                       elapsed_time: dt.timedelta) -> wind_field.WindVector:
    u, v = jax.device_get(_ground_truth(
        self._state(), jnp.float32(x.meters), jnp.float32(y.meters),
        jnp.float32(pressure), jnp.float32(elapsed_time.total_seconds())))
    return _vectors(u, v)[0]

