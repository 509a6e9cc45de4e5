# coding=utf-8
"""One latex balloon on the JAX core, driven from Python (NumPy in and out).

`FlightDriver` is what every stepwise env flies: the gym envs BLE uses
(through `ble_latex.envs.arena`) and the Gymnasium ones. It runs the jitted
`jax_env.LatexBalloonJaxEnv` functions of one balloon (`draw`, `measure`,
`advance`, `observation`), so the gym envs, the Gymnasium envs and the
batched env are the same code. It does not import BLE's balloon or gym
modules (nor TensorFlow).

Winds: by default BLE's generative field is drawn from the reset key inside
JAX (`jax_env.GENERATIVE_WIND`). Any BLE `WindField` object (e.g.
`ble_latex.wind.era5.Era5WindField`) can be flown instead: the driver resets it
with the key BLE's arena would give it and the core queries it through host
callbacks (`jax.pure_callback`) at every physics sub-step; slower, same
physics.

`info_dict` turns the core's `jax_env.step_info` numbers into the gym env's
`info` (README, "Environment contract").
"""

import dataclasses
import datetime as dt
import functools
from typing import Any, Dict, Mapping, Optional, Tuple

import jax
import jax.numpy as jnp
import numpy as np

from ble_latex.envs import jax_env
from ble_latex.flight import state as state_lib

# Moved to the functional env (kept until the arena flies the Gymnasium env).
INFO_KEYS = jax_env.INFO_KEYS
info_dict = jax_env.info_dict
START_EPOCH = jax_env.START_EPOCH


def callback_wind(wind_field: Any) -> jax_env.Wind:
  """A `jax_env.Wind` that asks a BLE `WindField` object on the host.

  Args:
    wind_field: A BLE `wind_field.WindField` (reset by the caller).

  Returns:
    The wind: `get_ground_truth` and `get_forecast_column` of the object,
    called through `jax.pure_callback` (the core stays jittable).
  """
  # Imported here: BLE's wind_field is only needed for external fields.
  from balloon_learning_environment.utils import units  # pylint: disable=g-import-not-at-top

  def host_truth(x, y, p, t):
    w = wind_field.get_ground_truth(
        units.Distance(m=float(x)), units.Distance(m=float(y)), float(p),
        dt.timedelta(seconds=float(t)))
    return np.array([w.u.meters_per_second, w.v.meters_per_second],
                    dtype=np.asarray(x).dtype)

  def host_column(x, y, pressures, t):
    column = wind_field.get_forecast_column(
        units.Distance(m=float(x)), units.Distance(m=float(y)),
        [float(p) for p in np.asarray(pressures)],
        dt.timedelta(seconds=float(t)))
    return np.array([[w.u.meters_per_second for w in column],
                     [w.v.meters_per_second for w in column]],
                    dtype=np.asarray(x).dtype)

  def ground_truth(state, x, y, p, t):
    del state
    uv = jax.pure_callback(host_truth, jax.ShapeDtypeStruct((2,), x.dtype),
                           x, y, p, t)
    return uv[0], uv[1]

  def forecast_column(state, x, y, pressures, t):
    del state
    uv = jax.pure_callback(
        host_column, jax.ShapeDtypeStruct((2,) + pressures.shape, x.dtype),
        x, y, pressures, t)
    return uv[0], uv[1]

  return jax_env.Wind(ground_truth, forecast_column)


# The parts of `EnvState` a step changes (the world is fixed at reset).
_STEP_PARTS = ('flight', 'history', 'wind_u', 'wind_v', 'steps')


def _strong(tree: Any) -> Any:
  """The same values without JAX weak types (one jit signature per step)."""
  return jax.tree.map(lambda a: jnp.asarray(a, jnp.asarray(a).dtype), tree)


class _Packed:
  """What the host reads after a step, packed into one array (one copy).

  Copying each of ~40 small arrays to the host costs more than the step
  itself; the values are packed (losslessly: float32 values, and ints and
  bools below 2**24) into one vector inside the jitted function and split
  on the host.
  """

  def __init__(self, example: Any):
    leaves, self.treedef = jax.tree.flatten(example)
    self.shapes = [np.shape(leaf) for leaf in leaves]
    self.dtypes = [np.dtype(leaf.dtype) for leaf in leaves]
    floats = [d for d in self.dtypes if d.kind == 'f']
    self.dtype = max(floats, key=lambda d: d.itemsize) if floats else (
        np.dtype(np.float32))
    self.ends = np.cumsum([int(np.prod(shape)) for shape in self.shapes])

  def pack(self, tree: Any) -> jax.Array:
    return jnp.concatenate([jnp.ravel(leaf).astype(self.dtype)
                            for leaf in jax.tree.leaves(tree)])

  def unpack(self, packed: Any) -> Any:
    flat = np.asarray(packed)
    parts = np.split(flat, self.ends[:-1])
    return jax.tree.unflatten(self.treedef, [
        part.reshape(shape).astype(dtype)
        for part, shape, dtype in zip(parts, self.shapes, self.dtypes)])


class _Jitted:
  """The jitted functions of one `LatexBalloonJaxEnv` (one balloon).

  `step` returns only the state's changing parts (not a copy of the
  forecast grid and noise tables) and, packed in one array, what the host
  reads: observation, reward, done, `step_info`, the flight.
  """

  def __init__(self, env: jax_env.LatexBalloonJaxEnv):
    self.env = env
    self.draw = jax.jit(env.draw)
    self._start_jit = jax.jit(self._start)
    self._step_jit = jax.jit(self._step)
    self._packers: Dict[Any, _Packed] = {}

  def _packer(self, name: str, fn, *args) -> _Packed:
    key = (name, jax.tree.structure(args))
    if key not in self._packers:
      self._packers[key] = _Packed(jax.eval_shape(fn, *args)[1])
    return self._packers[key]

  def _start_host(self, state, params):
    state = _strong(jax_env.measure(state, self.env.wind))
    return state, (jax_env.observation(state, params, self.env.wind),
                   jax_env.step_info(state, params), state.flight)

  def _start(self, state: jax_env.EnvState, params: jax_env.EnvParams):
    state, host = self._start_host(state, params)
    return state, self._packer('start', self._start_host, state,
                               params).pack(host)

  def _step_host(self, state, action, params):
    obs, state, reward, terminated, info = self.env.step_env(
        None, state, action, params)
    parts = _strong({k: getattr(state, k) for k in _STEP_PARTS})
    return parts, (obs, reward, terminated | info['time_limit'], info,
                   state.flight)

  def _step(self, state: jax_env.EnvState, action: jax.Array,
            params: jax_env.EnvParams):
    parts, host = self._step_host(state, action, params)
    return parts, self._packer('step', self._step_host, state, action,
                               params).pack(host)

  def start(self, state: jax_env.EnvState, params: jax_env.EnvParams):
    """(measured state, (observation, step_info, flight) on the host)."""
    state, packed = self._start_jit(state, params)
    return state, self._packer('start', self._start_host, state,
                               params).unpack(packed)

  def step(self, state: jax_env.EnvState, action: np.ndarray,
           params: jax_env.EnvParams):
    """(changed state parts, (obs, reward, done, info, flight) on host)."""
    parts, packed = self._step_jit(state, action, params)
    return parts, self._packer('step', self._step_host, state, action,
                               params).unpack(packed)


@functools.lru_cache(maxsize=1)
def _generative() -> _Jitted:
  """One compiled set per process for BLE's generative field."""
  return _Jitted(jax_env.LatexBalloonJaxEnv())


class FlightDriver:
  """One balloon of the core, stepped from Python.

  Args:
    params: The env parameters (checked, `jax_env.check_params`);
      `jax_env.params_from_gin()` if None.
    wind_field: None for BLE's generative field drawn from the reset key
      (in JAX), or any BLE `WindField` object (host callbacks).
  """

  def __init__(self, params: Optional[jax_env.EnvParams] = None,
               wind_field: Any = None):
    self.params = (jax_env.params_from_gin() if params is None else
                   jax_env.check_params(params))
    self.wind_field = wind_field
    self._fns = (_generative() if wind_field is None else
                 _Jitted(jax_env.LatexBalloonJaxEnv(
                     callback_wind(wind_field))))
    self.state: Optional[jax_env.EnvState] = None
    self.start_date_time: Optional[dt.datetime] = None
    self.location_key: Optional[jax.Array] = None
    self.observation: Optional[np.ndarray] = None
    self.info: Dict[str, Any] = {}
    self.reward = float('nan')  # Reward of the last step.
    # Host copy of the flight after the last reset/step, and the device
    # state it was copied from.
    self._flight: Any = None
    self._flight_of: Any = None
    self.volume_m3 = float('nan')  # Envelope volume after the last step. # [m^3]

  def reset(self, arena_key: jax.Array) -> np.ndarray:
    """Draws a new flight from BLE's arena key; returns the observation.

    The world is BLE's `arena.reset(arena_key)`: atmosphere, start time,
    start distance/angle/altitude, wind (an external field is reset with
    the arena's wind key and start time; one that chooses its own start
    time, as ERA5's `start_date_time`, sets the flight's date).
    """
    state, keys = self._fns.draw(arena_key, self.params)
    start = START_EPOCH + dt.timedelta(
        seconds=int(state.start_time_offset_s))
    if self.wind_field is not None:
      self.wind_field.reset(keys['wind'], start)
      start = getattr(self.wind_field, 'start_date_time', None) or start
    self.start_date_time = start
    self.location_key = keys['location']
    self.state, (obs, info, self._flight) = self._fns.start(state,
                                                            self.params)
    self._flight_of = self.state.flight
    self.observation = np.asarray(obs)
    self._set_info(info)
    return self.observation

  def step(self, action: np.ndarray) -> Tuple[np.ndarray, float, bool,
                                              Dict[str, Any]]:
    """One 20-minute action (already validated by the env).

    Returns:
      (observation [71] float32, reward, done, info) as in `jax_env`'s
      `step_env`, with `info` as `info_dict`.
    """
    if self.state is None:
      raise RuntimeError('reset() must be called before step()')
    parts, (obs, reward, done, info, self._flight) = self._fns.step(
        self.state, np.asarray(action, np.float32), self.params)
    self.state = self.state.replace(**parts)
    self._flight_of = self.state.flight
    self.reward = float(reward)
    self.observation = np.asarray(obs)
    self._set_info(info)
    return self.observation, self.reward, bool(done), self.info

  def _set_info(self, info: Mapping[str, np.ndarray]) -> None:
    self.info = info_dict(info)
    self.volume_m3 = float(info['volume_m3'])

  def flight(self) -> Dict[str, Any]:
    """The balloon's `FlightState` as NumPy values (host copy)."""
    flight = self._flight
    if flight is None or self.state.flight is not self._flight_of:
      flight = jax.device_get(self.state.flight)  # Set from outside.
    return {f.name: np.asarray(getattr(flight, f.name))
            for f in dataclasses.fields(flight)}

  def measured_wind(self) -> Tuple[float, float]:
    """The ground-truth wind at the balloon (the measurement). # [m/s]"""
    u, v = jax.device_get((self.state.wind_u, self.state.wind_v))
    return float(u), float(v)
