# coding=utf-8
"""Gymnasium-native latex balloon envs: `ble_latex/LatexBalloon-v0` and the discrete one.

Each env owns (composes) an instance of the gym 0.25 env BLE uses
(`ble_latex.env.LatexBalloonEnv` / `LatexBalloonDiscreteEnv`), so every line
of simulation, reward, observation and info is shared; this module only
translates the API:

- `reset(seed=None, options=None)` returns `(obs, info)`. `np_random` is
  seeded by `reset(seed=...)`; the flight of seed s is the flight of
  `gym.make('LatexBalloon-v0').reset(seed=s)` (and of `ble-latex-eval`'s seed
  s). `reset()` without a seed flies a seed drawn from `np_random` among the
  training seeds [0, 1 000 000) (never a held-out eval seed), so a sequence
  of episodes is reproducible after one seeded reset.
- `step` returns `(obs, reward, terminated, truncated, info)`: the inner
  env's `done` with `info['TimeLimit.truncated']` (the 216-step limit) is
  `truncated`; out of sand, out of helium, burst or grounded are `terminated`.
- `render_mode='rgb_array'`: `render()` draws the flight so far (x/y path with
  the station-keeping circle, altitude vs time) to an RGB array.
- `normalize_actions=True` (continuous env): the action space is
  [-1, 1]^3, mapped affinely onto the controller's Box with gymnasium's
  `rescale_box` (the mapping of `gymnasium.wrappers.RescaleAction`).

The ids are registered with gymnasium by `ble_latex.gymnasium_registration`
when `ble_latex` and gymnasium are both imported (README, "Gymnasium, SB3 and
CleanRL").
"""

import functools
import os
import sys
from typing import Any, Dict, List, Mapping, Optional, Tuple

import gymnasium
from gymnasium.wrappers import utils as wrapper_utils
import numpy as np

from ble_latex import quiet

with quiet.third_party_noise():
  # pylint: disable=g-import-not-at-top
  import gym
  from ble_latex import env as gym_env_lib
  from ble_latex import suites
  # pylint: enable=g-import-not-at-top


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


def to_gymnasium_space(space: gym.Space) -> gymnasium.Space:
  """The gymnasium equivalent of a gym 0.25 Box or Discrete space."""
  if isinstance(space, gym.spaces.Box):
    return gymnasium.spaces.Box(low=space.low, high=space.high,
                                shape=space.shape, dtype=space.dtype)
  if isinstance(space, gym.spaces.Discrete):
    return gymnasium.spaces.Discrete(int(space.n), start=int(space.start))
  raise TypeError(f'no gymnasium equivalent for {space!r}')


class LatexBalloonGymnasiumEnv(gymnasium.Env):
  """`ble_latex/LatexBalloon-v0`: the paper's continuous action, gymnasium API.

  Keyword arguments other than `render_mode` and `normalize_actions` go to
  `ble_latex.env.LatexBalloonEnv` (gin-configurable, like the gym env):
  `episode_steps`, `wind_field_factory`, `station_keeping_radius_km`, ...
  """

  metadata = {'render_modes': ['rgb_array'], 'render_fps': 4}
  _GYM_ENV_CLASS = gym_env_lib.LatexBalloonEnv

  def __init__(self, *, render_mode: Optional[str] = None,
               normalize_actions: bool = False, **env_kwargs: Any):
    if render_mode is not None and render_mode not in self.metadata[
        'render_modes']:
      raise ValueError(f'render_mode must be None or one of '
                       f'{self.metadata["render_modes"]}, got {render_mode!r}')
    self.render_mode = render_mode
    _check_not_forked_after_jax()
    with quiet.third_party_noise():
      self._env = self._GYM_ENV_CLASS(**env_kwargs)
    self.observation_space = to_gymnasium_space(self._env.observation_space)
    self._box_action_space = to_gymnasium_space(self._env.action_space)
    self._from_normalized = None
    self.normalize_actions = bool(normalize_actions)
    if self.normalize_actions:
      if not isinstance(self._box_action_space, gymnasium.spaces.Box):
        raise ValueError('normalize_actions=True needs a Box action space, '
                         f'this env has {self._box_action_space}')
      dtype = self._box_action_space.dtype.type
      self.action_space, _, self._from_normalized = wrapper_utils.rescale_box(
          self._box_action_space, dtype(-1), dtype(1))
    else:
      self.action_space = self._box_action_space
    self._flight: List[Tuple[float, float, float, float]] = []
    self._figure = None

  # -- The shared simulation. ------------------------------------------------
  @property
  def gym_env(self) -> gym_env_lib.LatexBalloonEnv:
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

  def box_action(self, action: Any) -> np.ndarray:
    """The controller's (a0, a1, a2) for an action of `action_space`.

    Identity unless `normalize_actions`; then [-1, 1]^3 maps onto the Box
    (anything outside [-1, 1]^3 is a ValueError, like an out-of-range action
    of the raw env).
    """
    if self._from_normalized is None:
      return action
    a = np.asarray(action)
    if (a.shape != self.action_space.shape or a.dtype.kind not in 'iuf' or
        not np.all(np.isfinite(a)) or np.any(np.abs(a) > 1.0)):
      raise ValueError('action must be 3 finite numbers in [-1, 1] '
                       f'(normalize_actions=True), got {action!r}')
    box = self._box_action_space
    return np.clip(self._from_normalized(a.astype(box.dtype)), box.low,
                   box.high)

  # -- gymnasium API. --------------------------------------------------------
  def reset(self, *, seed: Optional[int] = None,
            options: Optional[Mapping[str, Any]] = None
            ) -> Tuple[np.ndarray, Dict[str, Any]]:
    """Starts a new flight; see the module docstring for seeding.

    Raises:
      ValueError: `seed` not None or an int in [0, 2**32), or any `options`
        (there are none); nothing is changed.
    """
    gym_env_lib.validate_seed(seed)
    if options:
      raise ValueError(f'reset takes no options, got {dict(options)!r}')
    super().reset(seed=None if seed is None else int(seed))
    if seed is None:  # Reproducible once np_random was seeded.
      seed = int(self.np_random.integers(suites.EVAL_SEED_OFFSET))
    obs, info = self._env.reset(seed=int(seed), return_info=True)
    self._flight = [self._flight_point()]
    return obs, dict(info)

  def step(self, action: Any
           ) -> Tuple[np.ndarray, float, bool, bool, Dict[str, Any]]:
    obs, reward, done, info = self._env.step(self.box_action(action))
    info = dict(info)
    truncated = bool(info.pop('TimeLimit.truncated', False))
    terminated = bool(done) and not truncated
    self._flight.append(self._flight_point())
    return obs, float(reward), terminated, truncated, info

  def render(self) -> Optional[np.ndarray]:
    """The flight so far as an (H, W, 3) uint8 image ('rgb_array'), or None."""
    if self.render_mode != 'rgb_array':
      return None
    return self._draw_flight()

  def close(self) -> None:
    self._env.close()
    self._figure = None
    super().close()

  # -- Rendering. ------------------------------------------------------------
  def _flight_point(self) -> Tuple[float, float, float, float]:
    """t [h], x [km], y [km], altitude [km] of the balloon now."""
    s = self._env.arena.get_balloon_state()
    return (s.time_elapsed.total_seconds() / 3600.0, s.x.kilometers,
            s.y.kilometers, s.altitude_m / 1000.0)

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
    radius = self.radius.kilometers
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

  def __str__(self) -> str:
    return f'{type(self).__name__}({self._env})'


class LatexBalloonDiscreteGymnasiumEnv(LatexBalloonGymnasiumEnv):
  """`ble_latex/LatexBalloonDiscrete-v0`: BLE's Discrete(3), gymnasium API."""

  _GYM_ENV_CLASS = gym_env_lib.LatexBalloonDiscreteEnv

  def __init__(self, *, render_mode: Optional[str] = None, **env_kwargs: Any):
    if 'normalize_actions' in env_kwargs:
      raise ValueError('normalize_actions is for the Box action of '
                       'ble_latex/LatexBalloon-v0; this env is Discrete(3)')
    super().__init__(render_mode=render_mode, normalize_actions=False,
                     **env_kwargs)


def make_vector_env(env_id: str, num_envs: int = 1, *,
                    asynchronous: bool = False, context: str = 'spawn',
                    **env_kwargs: Any) -> gymnasium.vector.VectorEnv:
  """N latex balloons stepped by one call; `gymnasium.make_vec`'s default.

  `gymnasium.make_vec('ble_latex/LatexBalloon-v0', num_envs=N, **env_kwargs)`
  lands here (the ids' `vector_entry_point`). Today each balloon is its own
  env (`SyncVectorEnv`, or with `asynchronous=True` an `AsyncVectorEnv`, one
  process per balloon); a batched core can take over behind this signature.

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
  return gymnasium.vector.SyncVectorEnv([env_fn] * num_envs)


make_vector_latex_balloon = functools.partial(make_vector_env,
                                              'ble_latex/LatexBalloon-v0')
make_vector_latex_balloon_discrete = functools.partial(
    make_vector_env, 'ble_latex/LatexBalloonDiscrete-v0')
