# coding=utf-8
"""Gym environments for the latex balloon: `LatexBalloon-v0` and the discrete one.

`LatexBalloonEnv` is BLE's `BalloonEnv` with the paper's continuous action
(desired altitude a0 [m], time factor a1, float flag a2) driving the vent/ballast
altitude controller every 20 simulated minutes, 3-day episodes (216 steps),
the paper's reward and the paper's observation (`ble_latex.envs.jax_features`).
`LatexBalloonDiscreteEnv` keeps BLE's Discrete(3) `AltitudeControlCommand` and
Perciatelli features so BLE's own agents fly the latex balloon unchanged.

Both use BLE's old gym API: `reset(seed=...)` returns the observation and
`step` returns (observation, reward, done, info). Contract: docs/environment.md.
"""

import math
import secrets
from typing import Any, Callable, Dict, Mapping, Optional, Tuple, Union

from balloon_learning_environment.env import balloon_env
from balloon_learning_environment.env import features
from balloon_learning_environment.env import wind_field
from balloon_learning_environment.env.balloon import control
from balloon_learning_environment.env.balloon import standard_atmosphere
from balloon_learning_environment.env.rendering import renderer as renderer_lib
import gin
import gym
import jax
import numpy as np

from ble_latex import gin_values
from ble_latex.ble import arena as arena_lib
from ble_latex.ble import balloon as balloon_lib
from ble_latex.ble import discrete_features
from ble_latex.ble import features as latex_features
from ble_latex.ble import wind as ble_wind
from ble_latex.envs import env_params
from ble_latex.envs import jax_env
from ble_latex.envs import seeds

# Info keys at every step (see README, "Environment contract").
INFO_KEYS = jax_env.INFO_KEYS


# One seed check for every env (`ble_latex.envs.seeds`).
MAX_SEED = seeds.MAX_SEED
validate_seed = seeds.validate_seed


def validate_discrete_action(action: Any) -> int:
  """An `AltitudeControlCommand` value 0, 1 or 2 as int, else ValueError."""
  valid = False
  if action is not None and not isinstance(action, (bool, np.bool_)):
    a = np.asarray(action)
    if a.shape == () and a.dtype.kind in 'iuf':
      value = a.item()
      valid = math.isfinite(value) and value in (0, 1, 2)
  if not valid:
    raise ValueError(f'action must be 0 (DOWN), 1 (STAY) or 2 (UP), got '
                     f'{action!r}')
  return int(value)


class LatexActionBox(gym.spaces.Box):
  """The (a0, a1, a2) Box, plus `n`: its dimension, where BLE's commands read it.

  BLE 1.0.1's train and eval pass `env.action_space.n` to the agent's
  constructor (`num_actions`) and to the metric collectors; ble_latex's Box
  agents take the action dimension there (`agents.sac.SACAgent`). The space
  is a Box: test `isinstance(space, gym.spaces.Discrete)`, not `n`.
  """

  @property
  def n(self) -> int:
    """The action dimension (3), BLE's `num_actions` for a Box agent."""
    return int(self.shape[0])


class LatexBalloonEnv(balloon_env.BalloonEnv):
  """Station-keeping with a vent/ballast latex balloon, continuous actions."""

  def __init__(
      self,
      *,
      station_keeping_radius_km: Optional[float] = None,
      arena: Optional[arena_lib.LatexBalloonArena] = None,
      reward_function: Optional[Callable[..., float]] = None,
      feature_constructor_factory: Callable[
          [wind_field.WindField, standard_atmosphere.Atmosphere],
          features.FeatureConstructor] = (
              latex_features.LatexFeatureConstructor),
      wind_field_factory: Optional[Callable[[], wind_field.WindField]] = None,
      episode_steps: Optional[int] = None,
      seed: Optional[int] = None,
      renderer: Optional[renderer_lib.Renderer] = None):
    """Constructs the environment.

    Args:
      station_keeping_radius_km: The station radius (`EnvParams.radius_km`):
        the core's reward, TW50 and BLE's metrics; None: gin's
        `latex_episode.station_keeping_radius_km`. A given `arena` flies
        its own. # [km]
      arena: A latex balloon arena; built from the factories if None.
      reward_function: None: the core's reward (Eq. reward_function and
        the optional resource penalty, `jax_features.reward`); else
        (simulator_state, vented_mols, dropped_kg) -> reward on BLE objects
        (e.g. `ble_latex.ble.reward.latex_reward`).
      feature_constructor_factory: Builds the observation features.
      wind_field_factory: Builds the wind field: by default BLE's generative
        VAE field with BLE's noise, drawn and flown inside the flight core
        (`ble_latex.ble.wind.CoreGenerativeWindField`);
        `ble_latex.ble.gridded_field.GriddedWindField` for ERA5 data, or gin's
        `latex_episode.wind_field_factory = @GriddedWindField` (plain
        `wind.gridded.Era5Settings`), flown in the core too (its grid in
        `EnvParams.wind_grid`); any other BLE
        `WindField` is flown through host callbacks.
      episode_steps: Steps per episode (None: gin's `latex_episode.*`, the
        core's `env_params.episode`); 216 x 20 min = 3 days. The episode is
        cut there (`info['time_limit']`, `info['TimeLimit.truncated']`).
      seed: PRNG seed in [0, 2**32); the same seed gives the identical
        trajectory. None: a random one.
      renderer: An optional BLE renderer.
    """
    bound = env_params.episode()  # gin's `latex_episode.*`.
    if episode_steps is None:
      episode_steps = bound['episode_steps']
    if wind_field_factory is None:
      wind_field_factory = (bound['wind_field_factory'] or
                            ble_wind.CoreGenerativeWindField)
    gin_values.check_int('latex_episode.episode_steps', episode_steps,
                         minimum=1)
    if station_keeping_radius_km is not None:
      gin_values.check_number('station_keeping_radius_km',
                              station_keeping_radius_km, above=0.0)
    validate_seed(seed)
    if seed is None:  # BLE would use time in microseconds, beyond 2**32.
      seed = secrets.randbits(32)
    if arena is None:
      arena = arena_lib.LatexBalloonArena(
          feature_constructor_factory, wind_field_factory(),
          episode_steps=episode_steps,
          station_keeping_radius_km=station_keeping_radius_km)
    super().__init__(
        station_keeping_radius_km=float(arena.params.radius_km),
        arena=arena,
        reward_function=reward_function,
        feature_constructor_factory=feature_constructor_factory,
        seed=seed,
        renderer=renderer)

  @property
  def action_space(self) -> gym.spaces.Box:
    """(desired altitude a0 [m], time factor a1 [.], float flag a2 [.])."""
    return LatexActionBox(low=jax_env.ACTION_LOW, high=jax_env.ACTION_HIGH,
                          dtype=np.float32)

  @property
  def episode_steps(self) -> int:
    """Steps per episode (the time limit; the window of `tw50_window`)."""
    return int(self.arena.params.episode_steps)

  @property
  def reward_range(self) -> Tuple[float, float]:
    return (-float('inf'), 1.0)

  def reset(self,
            *,
            seed: Optional[int] = None,
            return_info: bool = False,
            options: Optional[Mapping[str, Any]] = None
            ) -> Union[np.ndarray, Tuple[np.ndarray, Mapping[str, Any]]]:
    """Resets to a new flight; `seed` re-seeds the env first (as BLE).

    The seed seeds BLE's JAX key (which samples the flight: start position,
    altitude, time, atmosphere and wind) and gym's `np_random`.

    Raises:
      ValueError: If `seed` is not None or an int in [0, 2**32); the env is
        left exactly as it was.
    """
    del options  # No reset options.
    validate_seed(seed)  # Before anything changes.
    seed = None if seed is None else int(seed)  # gym refuses NumPy ints.
    gym.Env.reset(self, seed=seed)
    # BLE's `BalloonEnv.reset`, without BLE objects nobody asked for.
    if seed is not None:
      self.seed(seed)
    self._rng, arena_rng = jax.random.split(self._rng)
    observation = self.arena.reset(arena_rng)
    if self._renderer is not None:
      self._renderer.reset()
      self._renderer.step(self.arena.get_simulator_state())
    return (observation, self._get_info()) if return_info else observation

  def step(
      self, action: Any) -> Tuple[np.ndarray, float, bool, Dict[str, Any]]:
    """Applies one 20-minute controller action.

    Args:
      action: (a0 desired altitude [m], a1 time factor, a2 float flag), inside
        `action_space`. NaN/inf or out-of-range values raise ValueError and
        leave the state untouched.

    Returns:
      (observation, reward, done, info); `info`: docs/environment.md.
    """
    # The action's one check is the arena driver's step (`check_action`).
    if self.arena.info['time_limit'] or self._is_terminal():
      raise RuntimeError('step() called on a finished episode; call reset().')
    before = self.arena.flight() if self._reward_fn is not None else None
    observation = self.arena.step(action)
    if self._renderer is not None or self._reward_fn is not None:
      simulator_state = self.arena.get_simulator_state()
    if self._renderer is not None:
      self._renderer.step(simulator_state)
    if self._reward_fn is None:
      reward = self.arena.reward  # The core's.
    else:
      state = simulator_state.balloon_state
      reward = self._reward_fn(
          simulator_state,
          state.helium_vented_mols - float(before['helium_vented_mols']),
          state.sand_dropped_kg - float(before['sand_dropped_kg']))
    self._global_iteration += 1
    info = self._get_info()
    done = self._is_terminal() or info['time_limit']
    return observation, reward, done, info

  def _is_terminal(self) -> bool:
    """Whether the flight has ended (the core's status is not OK)."""
    status = int(self.arena.flight()['status'])
    return status != balloon_lib.LatexBalloonStatus.OK

  def _get_info(self, balloon_state: Any = None) -> Dict[str, Any]:
    """The core's info of the last reset/step (`jax_env.info_dict`)."""
    del balloon_state  # The core's.
    return dict(self.arena.info)

  def __str__(self) -> str:
    return 'LatexBalloonEnv'


@gin.configurable
class LatexBalloonDiscreteEnv(LatexBalloonEnv):
  """BLE's Discrete(3) interface on the latex balloon, for BLE's agents.

  `AltitudeControlCommand` meaning: UP = ballast to a fixed ascent rate,
  DOWN = vent to a fixed descent rate, STAY = float. Observations are BLE's
  Perciatelli features (1099 values) with the latex balloon's reachable
  pressure range, so station_seeker, random_walk, dqn and quantile run as is.
  """

  def __init__(self,
               *,
               ascent_rate_mps: float = 1.0,  # [m/s]
               feature_constructor_factory: Callable[
                   [wind_field.WindField, standard_atmosphere.Atmosphere],
                   features.FeatureConstructor] = (
                       discrete_features.LatexPerciatelliFeatureConstructor),
               **kwargs: Any):
    gin_values.check_number('LatexBalloonDiscreteEnv.ascent_rate_mps',
                            ascent_rate_mps, above=0.0)
    self._ascent_rate_mps = ascent_rate_mps
    super().__init__(feature_constructor_factory=feature_constructor_factory,
                     **kwargs)

  @property
  def action_space(self) -> gym.spaces.Discrete:
    return gym.spaces.Discrete(3)

  def step(
      self, action: int) -> Tuple[np.ndarray, float, bool, Dict[str, Any]]:
    """Applies one BLE command; anything but 0, 1 or 2 raises ValueError."""
    return super().step(self.continuous_action(validate_discrete_action(
        action)))

  def continuous_action(self, action: int) -> np.ndarray:
    """Maps an AltitudeControlCommand to the controller's (a0, a1, a2)."""
    command = control.AltitudeControlCommand(action)
    altitude = float(self.arena.flight()['altitude_m'])
    low, high = jax_env.ACTION_LOW, jax_env.ACTION_HIGH
    if command == control.AltitudeControlCommand.STAY:
      return np.array([np.clip(altitude, low[0], high[0]), 1.0, 1.0])
    sign = 1.0 if command == control.AltitudeControlCommand.UP else -1.0
    target = altitude + sign * self._ascent_rate_mps * (
        self.arena.params.stride_s)
    return np.array([np.clip(target, low[0], high[0]), 1.0, -1.0])

  def __str__(self) -> str:
    return 'LatexBalloonDiscreteEnv'

