# coding=utf-8
"""Baseline agents for `LatexBalloon-v0` (Box actions), BLE `Agent`s.

- `LatexRandomAgent`: uniform random (a0, a1, a2) inside the action box.
- `GeometricStationSeeker`: Du et al.'s geometric rule through the altitude
  controller: go to the altitude whose forecast wind best points at the target
  (largest speed * cos(bearing error)), float once there. It reads only the
  observation (features.py): the 25-level wind column and the altitude.
BLE's own `station_seeker` flies `LatexBalloonDiscrete-v0` unchanged.
"""

from typing import Optional, Sequence

from balloon_learning_environment.agents import agent
from balloon_learning_environment.env.balloon import standard_atmosphere
import gin
import jax
import numpy as np

from ble_latex.envs import jax_env
from ble_latex.envs import jax_features


class _BoxAgent(agent.Agent):
  """Common constructor of the Box-action baselines."""

  supports_box_actions = True

  def __init__(self, num_actions: int, observation_shape: Sequence[int], *,
               action_low: Optional[Sequence[float]] = None,
               action_high: Optional[Sequence[float]] = None,
               seed: int = 0):
    super().__init__(num_actions, observation_shape)
    # None: the latex core's Box (as SACAgent; BLE's create_agent passes none).
    self._low = np.asarray(
        jax_env.ACTION_LOW if action_low is None else action_low, np.float64)
    self._high = np.asarray(
        jax_env.ACTION_HIGH if action_high is None else action_high,
        np.float64)
    if self._low.shape != (num_actions,) or self._high.shape != (num_actions,):
      raise ValueError(f'action_low/high must have shape ({num_actions},)')
    self._seed = seed


@gin.configurable(denylist=['num_actions', 'observation_shape', 'action_low',
                            'action_high'])
class LatexRandomAgent(_BoxAgent):
  """Uniform random actions in the Box (seeded)."""

  def __init__(self, num_actions, observation_shape, *, action_low=None,
               action_high=None, seed: int = 0):
    super().__init__(num_actions, observation_shape, action_low=action_low,
                     action_high=action_high, seed=seed)
    self._rng = np.random.default_rng(seed)

  def _action(self) -> np.ndarray:
    return self._rng.uniform(self._low, self._high)

  def begin_episode(self, observation: np.ndarray) -> np.ndarray:
    """A uniform random action in the Box."""
    return self._action()

  def step(self, reward: float, observation: np.ndarray) -> np.ndarray:
    """A uniform random action in the Box."""
    return self._action()

  def end_episode(self, reward: float, terminal: bool = True) -> None:
    """Nothing to learn."""
    pass


@gin.configurable(denylist=['num_actions', 'observation_shape', 'action_low',
                            'action_high'])
class GeometricStationSeeker(_BoxAgent):
  """Du et al. (2019): fly to the level whose wind points at the target."""

  def __init__(self, num_actions, observation_shape, *, action_low=None,
               action_high=None, seed: int = 0,
               time_factor: float = 2.0,
               float_within_m: float = 300.0,  # [m]
               min_gain_mps: float = 0.5,  # [m/s]
               min_pressure: float = 5000.0,  # [Pa]
               max_pressure: float = 14000.0):  # [Pa]
    """Constructor.

    Args:
      num_actions: Action dimension (3).
      observation_shape: (71,) latex features (up to 74 with the
        observation options, which it does not read).
      action_low: Box low (None: the latex core's, `jax_env.ACTION_LOW`).
      action_high: Box high (None: `jax_env.ACTION_HIGH`).
      seed: Unused (deterministic policy); kept for the common signature.
      time_factor: a1 used when moving (larger = slower, cheaper).
      float_within_m: Float when this close to the chosen altitude. # [m]
      min_gain_mps: Move only if the best level's velocity towards the target
        beats the current level's by this much. # [m/s]
      min_pressure: Lowest pressure level of the observation. # [Pa]
      max_pressure: Highest pressure level of the observation. # [Pa]
    """
    super().__init__(num_actions, observation_shape, action_low=action_low,
                     action_high=action_high, seed=seed)
    sizes = sorted({jax_features.num_features(sun=s, gas_temperature=g)
                    for s in (False, True) for g in (False, True)})
    if len(tuple(observation_shape)) != 1 or (
        tuple(observation_shape)[0] not in sizes):
      raise ValueError('GeometricStationSeeker reads LatexBalloon-v0 features '
                       f'({sizes[0]}, or {sizes[1:]} with observation '
                       f'options), got {observation_shape}')
    self._time_factor = float(np.clip(time_factor, self._low[1],
                                      self._high[1]))
    self._float_within_m = float_within_m
    self._min_gain_mps = min_gain_mps
    # Level altitudes from BLE's standard atmosphere (nominal lapse rates).
    atmosphere = standard_atmosphere.Atmosphere(jax.random.PRNGKey(0))
    levels = np.linspace(min_pressure, max_pressure, jax_features.N_LEVELS)
    self._level_altitudes = np.array(
        [atmosphere.at_pressure(p).height.meters for p in levels])
    self._target: Optional[float] = None

  def _act(self, observation: np.ndarray) -> np.ndarray:
    named = jax_features.NamedLatexFeatures(observation)
    # Velocity component towards the target at each level. # [m/s]
    towards = named.wind_speeds_mps * np.cos(named.bearing_errors_rad)
    altitude = named.altitude_m
    reachable = ((self._level_altitudes >= self._low[0]) &
                 (self._level_altitudes <= self._high[0]))
    towards = np.where(reachable, towards, -np.inf)
    best = int(np.argmax(towards))
    here = int(np.argmin(np.abs(self._level_altitudes - altitude)))
    if self._target is None or towards[best] > towards[here] + (
        self._min_gain_mps):
      self._target = float(self._level_altitudes[best])
    a0 = float(np.clip(self._target, self._low[0], self._high[0]))
    if abs(a0 - altitude) <= self._float_within_m:
      return np.array([a0, self._time_factor, 1.0])  # Float here.
    return np.array([a0, self._time_factor, -1.0])

  def begin_episode(self, observation: np.ndarray) -> np.ndarray:
    """Forgets the chosen level, then acts as `step` does."""
    self._target = None
    return self._act(observation)

  def step(self, reward: float, observation: np.ndarray) -> np.ndarray:
    """The rule's action for this observation (see the class)."""
    return self._act(observation)

  def end_episode(self, reward: float, terminal: bool = True) -> None:
    """Nothing to learn."""
    pass
