# coding=utf-8
"""Gymnasium-native latex balloon envs: `ble_latex/LatexBalloon-v0` and the discrete one.

`ble_latex/LatexBalloon-v0` (`LatexBalloonGymnasiumEnv`) flies one balloon of
the JAX core through `host_env.FlightDriver`, the driver the gym 0.25 env
`LatexBalloon-v0` flies too (through its arena): the same jitted functions
for simulation, observation, reward and info. It imports neither gym nor
BLE's balloon/env modules nor TensorFlow, and reads the gym env's gin names
without importing them (`jax_env.params_from_gin`). Its vector entry point
is `gymnasium_vector.LatexBalloonVectorEnv`: all N balloons in one jitted,
vmapped call of the core.

`ble_latex/LatexBalloonDiscrete-v0` (`LatexBalloonDiscreteGymnasiumEnv`)
composes BLE's gym env `LatexBalloonDiscreteEnv` (BLE's Perciatelli
features need BLE's modules); its vector entry point is a `SyncVectorEnv`.

Both:

- `reset(seed=None, options=None)` returns `(obs, info)`. `np_random` is
  seeded by `reset(seed=...)`; the flight of seed s is the flight of
  `gym.make('LatexBalloon-v0').reset(seed=s)` (and of `ble-latex-eval`'s seed
  s): the core's key `jax.random.PRNGKey(s)`. `reset()` without a seed flies
  a seed drawn from `np_random` among the training seeds [0, 1 000 000)
  (never a held-out eval seed), so a sequence of episodes is reproducible
  after one seeded reset.
- `step` returns `(obs, reward, terminated, truncated, info)`: the time limit
  (`episode_steps`, 216) is `truncated`; out of sand, out of helium, burst or
  grounded are `terminated`. `info` is the gym env's (`host_env.info_dict`)
  without `TimeLimit.truncated`.
- `render_mode='rgb_array'`: `render()` draws the flight so far (x/y path with
  the station-keeping circle, altitude vs time) to an RGB array.
- `normalize_actions=True` (continuous env): the action space is
  [-1, 1]^3, mapped affinely onto the controller's Box with gymnasium's
  `rescale_box` (the mapping of `gymnasium.wrappers.RescaleAction`).

The ids are registered with gymnasium by `ble_latex.envs.gymnasium_registration`
when `ble_latex` and gymnasium are both imported (README, "Gymnasium, SB3 and
CleanRL").
"""

import functools
import os
import sys
from typing import Any, Callable, Dict, List, Mapping, Optional, Tuple

import gymnasium
from gymnasium.wrappers import utils as wrapper_utils
import numpy as np

from ble_latex.envs import seeds as seeds_lib
from ble_latex.envs import task
from ble_latex import quiet

with quiet.third_party_noise():
  # pylint: disable=g-import-not-at-top
  import jax
  from ble_latex.envs import controller as controller_lib
  from ble_latex.envs import gymnasium_vector
  from ble_latex.envs import host_env
  from ble_latex.envs import jax_env
  from ble_latex import gin_values
  from ble_latex import jax_cache
  # pylint: enable=g-import-not-at-top

# With $BLE_LATEX_JAX_CACHE=1 the envs' compiled functions are loaded from
# disk after the first process (process-wide, so only on request; see
# ble_latex.jax_cache).
jax_cache.enable_if_requested()


# Set in a child forked from a process whose JAX had started (see
# `_check_not_forked_after_jax`).
_forked_after_jax = False


def _note_fork_in_child() -> None:
  global _forked_after_jax
  bridge = sys.modules.get('jax._src.xla_bridge')
  started = getattr(bridge, 'backends_are_initialized', lambda: False)
  _forked_after_jax = _forked_after_jax or bool(started())


os.register_at_fork(after_in_child=_note_fork_in_child)


def _check_not_forked_after_jax() -> None:
  """A clear error instead of a silent deadlock in a forked worker.

  The env simulates with JAX, and JAX's runtime does not survive `fork()`
  once it has started: a worker forked after the parent built an env (as
  `gymnasium.vector.AsyncVectorEnv` does, to read the spaces) hangs forever
  at its first JAX call.
  """
  if _forked_after_jax:
    raise RuntimeError(
        'ble_latex envs cannot be built in a process forked after JAX '
        'started (it would deadlock). Use the spawn start method: '
        "gymnasium.make_vec(ID, num_envs=N, asynchronous=True), or "
        "vector_kwargs={'context': 'spawn'} with vectorization_mode='async' / "
        "AsyncVectorEnv(..., context='spawn').")


def to_gymnasium_space(space: Any) -> gymnasium.Space:
  """The gymnasium equivalent of a gym 0.25 Box or Discrete space."""
  import gym  # pylint: disable=g-import-not-at-top
  if isinstance(space, gym.spaces.Box):
    return gymnasium.spaces.Box(low=space.low, high=space.high,
                                shape=space.shape, dtype=space.dtype)
  if isinstance(space, gym.spaces.Discrete):
    return gymnasium.spaces.Discrete(int(space.n), start=int(space.start))
  raise TypeError(f'no gymnasium equivalent for {space!r}')


def _check_render_mode(env: gymnasium.Env, render_mode: Optional[str]) -> None:
  if render_mode is not None and render_mode not in env.metadata[
      'render_modes']:
    raise ValueError(f'render_mode must be None or one of '
                     f'{env.metadata["render_modes"]}, got {render_mode!r}')


def _split_done(done: bool, info: Mapping[str, Any]
                ) -> Tuple[bool, bool, Dict[str, Any]]:
  """(terminated, truncated, info without `TimeLimit.truncated`)."""
  info = dict(info)
  truncated = bool(info.pop('TimeLimit.truncated', False))
  return bool(done) and not truncated, truncated, info


class _FlightDrawing:
  """Records (t, x, y, altitude) after each reset/step; draws rgb_array."""

  render_mode: Optional[str]
  _flight: List[Tuple[float, float, float, float]]
  _figure: Any

  def _radius_km(self) -> float:
    raise NotImplementedError

  def render(self) -> Optional[np.ndarray]:
    """The flight so far as an (H, W, 3) uint8 image ('rgb_array'), or None."""
    if self.render_mode != 'rgb_array':
      return None
    return self._draw_flight()

  def _draw_flight(self) -> np.ndarray:
    # pylint: disable=g-import-not-at-top
    from matplotlib import figure as mpl_figure
    from matplotlib import patches as mpl_patches
    from matplotlib.backends import backend_agg
    # pylint: enable=g-import-not-at-top
    if self._figure is None:
      self._figure = mpl_figure.Figure(figsize=(8.0, 4.0), dpi=80,
                                       layout='constrained')
      backend_agg.FigureCanvasAgg(self._figure)
    fig = self._figure
    fig.clear()
    ax_xy, ax_alt = fig.subplots(1, 2, width_ratios=(1.0, 1.4))
    radius = self._radius_km()
    t, x, y, alt = (np.array(c, dtype=float).reshape(-1)
                    for c in zip(*self._flight)) if self._flight else (
                        np.zeros(0),) * 4
    ax_xy.add_patch(mpl_patches.Circle((0.0, 0.0), radius, fill=False,
                                       color='k', ls='--', lw=1.0))
    ax_xy.plot(0.0, 0.0, marker='+', color='k')
    if len(x):
      ax_xy.plot(x, y, color='tab:blue', lw=1.5)
      ax_xy.plot(x[-1], y[-1], marker='o', color='tab:red', ms=5)
    half = max(np.abs(np.concatenate([x, y])).max() if len(x) else 0.0,
               radius) * 1.1
    ax_xy.set_xlim(-half, half)
    ax_xy.set_ylim(-half, half)
    ax_xy.set_aspect('equal')
    ax_xy.set_xlabel('x [km]')
    ax_xy.set_ylabel('y [km]')
    ax_xy.set_title(f'{radius:g} km station', fontsize=9)
    if len(t):
      ax_alt.plot(t, alt, color='tab:blue', lw=1.5)
    ax_alt.set_xlabel('time [h]')
    ax_alt.set_ylabel('altitude [km]')
    ax_alt.grid(alpha=0.3)
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba())[:, :, :3].copy()


def _flight_point(driver: host_env.FlightDriver
                  ) -> Tuple[float, float, float, float]:
  """t [h], x [km], y [km], altitude [km] of the driver's balloon now."""
  f = driver.flight()  # The driver's host copy.
  t, x, y, alt = f['time_s'], f['x_m'], f['y_m'], f['altitude_m']
  return (float(t) / 3600.0, float(x) / 1000.0, float(y) / 1000.0,
          float(alt) / 1000.0)


def _is_core_generative(factory: Any) -> bool:
  """Whether a wind factory is the gym env's default (the core's own field)."""
  module = sys.modules.get('ble_latex.wind.ble_field')
  return factory is None or (
      module is not None and factory is module.CoreGenerativeWindField)


class LatexBalloonGymnasiumEnv(_FlightDrawing, gymnasium.Env):
  """`ble_latex/LatexBalloon-v0`: the paper's continuous action, gymnasium API.

  One balloon of the JAX core (`host_env.FlightDriver`), configured by the
  gym env's gin bindings (`jax_env.params_from_gin`) and these keywords:

  Args:
    render_mode: None or 'rgb_array'.
    normalize_actions: Actions in [-1, 1]^3 mapped onto the Box.
    episode_steps: Strides per episode (time limit); None: gin's
      `LatexBalloonEnv.episode_steps` (216).
    station_keeping_radius_km: Radius drawn by `render` (the gym env's TW50
      radius); None: gin's `LatexBalloonEnv.station_keeping_radius_km` (50).
      The reward's radius is BLE's `perciatelli_reward_function`'s.
    wind_field_factory: None (or the gym env's default): BLE's generative
      field inside the core; any other factory of a BLE `WindField` (e.g.
      `ble_latex.wind.era5.Era5WindField`) is flown through host callbacks. None
      reads gin's `LatexBalloonEnv.wind_field_factory` if bound.
    params: `jax_env.EnvParams` to fly instead of the gin-bound ones.
  """

  metadata = {'render_modes': ['rgb_array'], 'render_fps': 4}

  def __init__(self, *, render_mode: Optional[str] = None,
               normalize_actions: bool = False,
               episode_steps: Optional[int] = None,
               station_keeping_radius_km: Optional[float] = None,
               wind_field_factory: Optional[Callable[[], Any]] = None,
               params: Optional[jax_env.EnvParams] = None):
    _check_render_mode(self, render_mode)
    self.render_mode = render_mode
    _check_not_forked_after_jax()
    if episode_steps is not None:
      gin_values.check_int('episode_steps', episode_steps, minimum=1)
    gym_bound = jax_env.episode()
    self._gym_kwargs = {k: v for k, v in (
        ('episode_steps', episode_steps),
        ('station_keeping_radius_km', station_keeping_radius_km),
        ('wind_field_factory', wind_field_factory)) if v is not None}
    if station_keeping_radius_km is not None:
      radius_name = 'station_keeping_radius_km'
    else:
      radius_name = 'gin binding LatexBalloonEnv.station_keeping_radius_km'
      station_keeping_radius_km = gym_bound.get('station_keeping_radius_km',
                                                task.STATION_RADIUS_KM)
    self._station_keeping_radius_km = gin_values.check_number(
        radius_name, station_keeping_radius_km, above=0.0)
    factory = (wind_field_factory if wind_field_factory is not None else
               gym_bound.get('wind_field_factory'))
    with quiet.third_party_noise():
      params = params if params is not None else jax_env.params_from_gin()
      if episode_steps is not None:
        params = params.replace(episode_steps=int(episode_steps))
      self._driver = host_env.FlightDriver(
          params, None if _is_core_generative(factory) else factory())
    self.observation_space = gymnasium_vector.observation_space()
    self._box_action_space = gymnasium_vector.action_space()
    self._from_normalized = None
    self.normalize_actions = bool(normalize_actions)
    if self.normalize_actions:
      dtype = self._box_action_space.dtype.type
      self.action_space, _, self._from_normalized = wrapper_utils.rescale_box(
          self._box_action_space, dtype(-1), dtype(1))
    else:
      self.action_space = self._box_action_space
    self._done = False
    self._gym_env = None
    self._flight: List[Tuple[float, float, float, float]] = []
    self._figure = None

  # -- The simulation. -------------------------------------------------------
  @property
  def driver(self) -> host_env.FlightDriver:
    """The core balloon this env flies (`state`, `params`, `flight()`)."""
    return self._driver

  @property
  def params(self) -> jax_env.EnvParams:
    return self._driver.params

  @property
  def gym_env(self) -> Any:
    """A gym 0.25 `LatexBalloonEnv` with this env's keywords (old API).

    Built on first use (it imports BLE's env modules and TensorFlow) and
    separate from this env's flight; for BLE's tools that need the old API,
    e.g. `eval_lib.evaluate` (examples/sb3_sac.py).
    """
    if self._gym_env is None:
      with quiet.third_party_noise():
        from ble_latex.envs import gym_env as gym_env_lib  # pylint: disable=g-import-not-at-top
        self._gym_env = gym_env_lib.LatexBalloonEnv(**self._gym_kwargs)
    return self._gym_env

  @property
  def radius(self) -> Any:
    """Station-keeping radius (a BLE `units.Distance`), as the gym env's."""
    from balloon_learning_environment.utils import units  # pylint: disable=g-import-not-at-top
    return units.Distance(km=self._station_keeping_radius_km)

  def box_action(self, action: Any) -> np.ndarray:
    """The controller's (a0, a1, a2) for an action of `action_space`.

    Raw actions are checked as the gym env checks them
    (`controller.validate_action`); with `normalize_actions` [-1, 1]^3 maps
    onto the Box (anything outside [-1, 1]^3 is a ValueError).
    """
    if self._from_normalized is None:
      return controller_lib.validate_action(action)
    a = np.asarray(action)
    if (a.shape != self.action_space.shape or a.dtype.kind not in 'iuf' or
        not np.all(np.isfinite(a)) or np.any(np.abs(a) > 1.0)):
      raise ValueError('action must be 3 finite numbers in [-1, 1] '
                       f'(normalize_actions=True), got {action!r}')
    box = self._box_action_space
    return np.clip(self._from_normalized(a.astype(box.dtype)), box.low,
                   box.high)

  def check_action(self, action: Any) -> None:
    """Raises the ValueError `step` would raise for `action` (`box_action`)."""
    self.box_action(action)

  # -- gymnasium API. --------------------------------------------------------
  def reset(self, *, seed: Optional[int] = None,
            options: Optional[Mapping[str, Any]] = None
            ) -> Tuple[np.ndarray, Dict[str, Any]]:
    """Starts a new flight; see the module docstring for seeding.

    Raises:
      ValueError: `seed` not None or an int in [0, 2**32), or any `options`
        (there are none); nothing is changed.
    """
    seeds_lib.validate_seed(seed)
    if options:
      raise ValueError(f'reset takes no options, got {dict(options)!r}')
    super().reset(seed=None if seed is None else int(seed))
    if seed is None:  # Reproducible once np_random was seeded.
      seed = int(self.np_random.integers(seeds_lib.TRAIN_SEED_LIMIT))
    obs = self._driver.reset(jax_env.arena_key(jax.random.PRNGKey(int(seed))))
    self._done = False
    if self.render_mode is not None:
      self._flight = [_flight_point(self._driver)]
    _, _, info = _split_done(False, self._driver.info)
    return obs, info

  def step(self, action: Any
           ) -> Tuple[np.ndarray, float, bool, bool, Dict[str, Any]]:
    """One 20-minute action (see `box_action` for what is accepted).

    Raises:
      ValueError: An action outside the action space; nothing changes.
      RuntimeError: Before `reset` or after the episode ended.
    """
    box = self.box_action(action)
    if self._done:
      raise RuntimeError('step() called on a finished episode; call reset().')
    obs, reward, done, info = self._driver.step(box)
    terminated, truncated, info = _split_done(done, info)
    self._done = bool(done)
    if self.render_mode is not None:
      self._flight.append(_flight_point(self._driver))
    return obs, float(reward), terminated, truncated, info

  def close(self) -> None:
    if self._gym_env is not None:
      self._gym_env.close()
      self._gym_env = None
    self._figure = None
    super().close()

  def _radius_km(self) -> float:
    return self._station_keeping_radius_km

  def __str__(self) -> str:
    return f'{type(self).__name__}(LatexBalloon-v0 on the JAX core)'


class LatexBalloonDiscreteGymnasiumEnv(_FlightDrawing, gymnasium.Env):
  """`ble_latex/LatexBalloonDiscrete-v0`: BLE's Discrete(3), gymnasium API.

  Owns BLE's gym env `ble_latex.envs.gym_env.LatexBalloonDiscreteEnv` (BLE's
  Perciatelli features, for BLE's agents); keyword arguments other than
  `render_mode` go to it (gin-configurable, like the gym env).
  """

  metadata = {'render_modes': ['rgb_array'], 'render_fps': 4}

  def __init__(self, *, render_mode: Optional[str] = None, **env_kwargs: Any):
    if 'normalize_actions' in env_kwargs:
      raise ValueError('normalize_actions is for the Box action of '
                       'ble_latex/LatexBalloon-v0; this env is Discrete(3)')
    _check_render_mode(self, render_mode)
    self.render_mode = render_mode
    _check_not_forked_after_jax()
    with quiet.third_party_noise():
      from ble_latex.envs import gym_env as gym_env_lib  # pylint: disable=g-import-not-at-top
      self._env = gym_env_lib.LatexBalloonDiscreteEnv(**env_kwargs)
    self.observation_space = to_gymnasium_space(self._env.observation_space)
    self.action_space = to_gymnasium_space(self._env.action_space)
    self._flight: List[Tuple[float, float, float, float]] = []
    self._figure = None

  @property
  def gym_env(self) -> Any:
    """The gym 0.25 env that simulates (old API; BLE's agents fly it)."""
    return self._env

  @property
  def arena(self) -> Any:
    """The inner env's arena (`runner.flight_point` reads the state here)."""
    return self._env.arena

  @property
  def radius(self) -> Any:
    """Station-keeping radius (a BLE `units.Distance`)."""
    return self._env.radius

  def check_action(self, action: Any) -> None:
    """Raises the ValueError `step` would raise for `action` (0, 1 or 2)."""
    from ble_latex.envs import gym_env as gym_env_lib  # pylint: disable=g-import-not-at-top
    gym_env_lib.validate_discrete_action(action)

  def reset(self, *, seed: Optional[int] = None,
            options: Optional[Mapping[str, Any]] = None
            ) -> Tuple[np.ndarray, Dict[str, Any]]:
    """Starts a new flight; see the module docstring for seeding."""
    seeds_lib.validate_seed(seed)
    if options:
      raise ValueError(f'reset takes no options, got {dict(options)!r}')
    super().reset(seed=None if seed is None else int(seed))
    if seed is None:  # Reproducible once np_random was seeded.
      seed = int(self.np_random.integers(seeds_lib.TRAIN_SEED_LIMIT))
    obs, info = self._env.reset(seed=int(seed), return_info=True)
    self._flight = [self._flight_point()]
    return obs, dict(info)

  def step(self, action: Any
           ) -> Tuple[np.ndarray, float, bool, bool, Dict[str, Any]]:
    obs, reward, done, info = self._env.step(action)
    terminated, truncated, info = _split_done(done, info)
    self._flight.append(self._flight_point())
    return obs, float(reward), terminated, truncated, info

  def close(self) -> None:
    self._env.close()
    self._figure = None
    super().close()

  def _flight_point(self) -> Tuple[float, float, float, float]:
    """t [h], x [km], y [km], altitude [km] of the balloon now."""
    s = self._env.arena.get_balloon_state()
    return (s.time_elapsed.total_seconds() / 3600.0, s.x.kilometers,
            s.y.kilometers, s.altitude_m / 1000.0)

  def _radius_km(self) -> float:
    return self._env.radius.kilometers

  def __str__(self) -> str:
    return f'{type(self).__name__}({self._env})'


def make_vector_env(env_id: str, num_envs: int = 1, *,
                    asynchronous: bool = False, context: str = 'spawn',
                    **env_kwargs: Any) -> gymnasium.vector.VectorEnv:
  """N balloons of `env_id` as one vector env of N independent envs.

  `gymnasium_vector.CheckedSyncVectorEnv` (a `SyncVectorEnv` that checks
  every balloon's action before stepping any; or with `asynchronous=True`
  an `AsyncVectorEnv`, one process per balloon, where each worker checks
  its own). `gymnasium.make_vec('ble_latex/LatexBalloonDiscrete-v0',
  num_envs=N)` lands here; the continuous id's default is the batched
  `gymnasium_vector.LatexBalloonVectorEnv` (`make_vector_latex_balloon`).

  Args:
    env_id: A registered `ble_latex/...` id.
    num_envs: Number of balloons.
    asynchronous: One worker process per balloon (`AsyncVectorEnv`).
    context: multiprocessing start method of those workers. 'spawn' because
      the env runs JAX, which deadlocks in a child forked after it started,
      and AsyncVectorEnv builds one env in the parent before it forks; 'fork'
      raises a RuntimeError in the workers ('forkserver' works too).
    **env_kwargs: Passed to `gymnasium.make` for each balloon
      (`normalize_actions`, `max_episode_steps`, `render_mode`, ...).

  Returns:
    A gymnasium vector env; `reset(seed=s)` seeds balloon i with s + i.
  """
  # The spec itself (not the id) travels to spawned workers: they need not
  # import ble_latex first for the id to be known.
  env_fn = functools.partial(gymnasium.make, gymnasium.spec(env_id),
                             **env_kwargs)
  if asynchronous:
    return gymnasium.vector.AsyncVectorEnv([env_fn] * num_envs,
                                           context=context)
  return gymnasium_vector.CheckedSyncVectorEnv([env_fn] * num_envs)


def make_vector_latex_balloon(num_envs: int = 1, *, asynchronous: bool = False,
                              context: str = 'spawn', **env_kwargs: Any
                              ) -> gymnasium.vector.VectorEnv:
  """`make_vec('ble_latex/LatexBalloon-v0', num_envs=N)`: the batched core.

  `gymnasium_vector.LatexBalloonVectorEnv` (all N balloons in one jitted,
  vmapped call); with `asynchronous=True` an `AsyncVectorEnv` of single envs
  (see `make_vector_env`).
  """
  if asynchronous:
    return make_vector_env('ble_latex/LatexBalloon-v0', num_envs,
                           asynchronous=True, context=context, **env_kwargs)
  _check_not_forked_after_jax()
  with quiet.third_party_noise():
    return gymnasium_vector.LatexBalloonVectorEnv(num_envs, **env_kwargs)


make_vector_latex_balloon_discrete = functools.partial(
    make_vector_env, 'ble_latex/LatexBalloonDiscrete-v0')
