# coding=utf-8
"""`ble_latex/LatexBalloonDiscrete-v0`: BLE's Discrete(3) under gymnasium's API.

`LatexBalloonDiscreteGymnasiumEnv` composes BLE's gym env
`ble_latex.ble.gym_env.LatexBalloonDiscreteEnv` (BLE's Perciatelli features
need BLE's modules and TensorFlow); its vector entry point
(`make_vector_latex_balloon_discrete`) is a `SyncVectorEnv`. Seeding,
`(obs, info)` / five-tuple steps, `render_mode='rgb_array'` and the fork
check are the continuous env's (`ble_latex.envs.gymnasium_env`, its
rendering `gymnasium_render`, its vector envs `gymnasium_vector`).
"""

import functools
from typing import Any, Dict, List, Mapping, Optional, Tuple

import gymnasium
import numpy as np

from ble_latex import quiet
from ble_latex.envs import gymnasium_compile
from ble_latex.envs import gymnasium_env
from ble_latex.envs import gymnasium_render
from ble_latex.envs import gymnasium_vector

ENV_ID = 'ble_latex/LatexBalloonDiscrete-v0'


def to_gymnasium_space(space: Any) -> gymnasium.Space:
  """The gymnasium equivalent of a gym 0.25 Box or Discrete space."""
  import gym  # pylint: disable=g-import-not-at-top
  if isinstance(space, gym.spaces.Box):
    return gymnasium.spaces.Box(low=space.low, high=space.high,
                                shape=space.shape, dtype=space.dtype)
  if isinstance(space, gym.spaces.Discrete):
    return gymnasium.spaces.Discrete(int(space.n), start=int(space.start))
  raise TypeError(f'no gymnasium equivalent for {space!r}')


def split_done(done: bool, info: Mapping[str, Any]
               ) -> Tuple[bool, bool, Dict[str, Any]]:
  """gym's (done, info) as (terminated, truncated, info without
  `TimeLimit.truncated`)."""
  info = dict(info)
  truncated = bool(info.pop('TimeLimit.truncated', False))
  return bool(done) and not truncated, truncated, info


class LatexBalloonDiscreteGymnasiumEnv(gymnasium_env.SeedRule,
                                       gymnasium.Env):
  """`ble_latex/LatexBalloonDiscrete-v0`: BLE's Discrete(3), gymnasium API.

  Owns BLE's gym env `ble_latex.ble.gym_env.LatexBalloonDiscreteEnv` (BLE's
  Perciatelli features, for BLE's agents); keyword arguments other than
  `render_mode` go to it (gin-configurable, like the gym env).
  """

  metadata = {'render_modes': ['rgb_array'], 'render_fps': 4}

  def __init__(self, *, render_mode: Optional[str] = None, **env_kwargs: Any):
    if 'normalize_actions' in env_kwargs:
      raise ValueError('normalize_actions is for the Box action of '
                       'ble_latex/LatexBalloon-v0; this env is Discrete(3)')
    gymnasium_render.check_render_mode(self, render_mode)
    self.render_mode = render_mode
    gymnasium_compile.check_not_forked_after_jax()
    with quiet.third_party_noise():
      from ble_latex.ble import gym_env as gym_env_lib  # pylint: disable=g-import-not-at-top
      self._env = gym_env_lib.LatexBalloonDiscreteEnv(**env_kwargs)
    self.observation_space = to_gymnasium_space(self._env.observation_space)
    self.action_space = to_gymnasium_space(self._env.action_space)
    self._path: List[Tuple[float, float, float, float]] = []
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
    from ble_latex.ble import gym_env as gym_env_lib  # pylint: disable=g-import-not-at-top
    gym_env_lib.validate_discrete_action(action)

  def reset(self, *, seed: Optional[int] = None,
            options: Optional[Mapping[str, Any]] = None
            ) -> Tuple[np.ndarray, Dict[str, Any]]:
    """Starts a new flight; seeded as `ble_latex/LatexBalloon-v0`."""
    seed = int(self._episode_seeds(seed, options)[0])
    obs, info = self._env.reset(seed=seed, return_info=True)
    self._path = []
    self._record()
    return obs, dict(info)

  def step(self, action: Any
           ) -> Tuple[np.ndarray, float, bool, bool, Dict[str, Any]]:
    obs, reward, done, info = self._env.step(action)
    terminated, truncated, info = split_done(done, info)
    self._record()
    return obs, float(reward), terminated, truncated, info

  def _record(self) -> None:
    if self.render_mode is not None:
      self._path.append(
          gymnasium_render.flight_point(self._env.arena.flight()))

  def render(self) -> Optional[np.ndarray]:
    """The flight so far as an (H, W, 3) uint8 image ('rgb_array'), or None."""
    if self.render_mode != 'rgb_array':
      return None
    self._figure = gymnasium_render.draw_flight(self._figure, self._path,
                                                self._env.radius.kilometers)
    return gymnasium_render.figure_rgb(self._figure)

  def close(self) -> None:
    self._env.close()
    self._figure = None
    super().close()

  def __str__(self) -> str:
    return f'{type(self).__name__}({self._env})'


# `gymnasium.make_vec(ENV_ID, num_envs=N)`: N independent envs.
make_vector_latex_balloon_discrete = functools.partial(
    gymnasium_vector.make_vector_env, ENV_ID)
