# coding=utf-8
"""Observation features of the latex balloon (paper, "High-level SAC").

The features are computed by `ble_latex.envs.jax_features.features` (the flight
core's observation, batched or not). `LatexFeatureConstructor` is the same
computation behind BLE's `features.FeatureConstructor` interface (`observe()`
a measurement, `get_features()` the vector), for code that holds BLE objects;
the latex arena computes them inside the core. Every feature is scaled
to [-1, 1] (clipped); the index map is `ble_latex.envs.jax_features`'s.

The observation options (gin `latex_observation.sun`, `.gas_temperature`)
append features that the core computes from its own flight state (the
flight's sun clock, the helium's temperature), which BLE's measurements do
not carry: the constructor's `observation_space` follows them (the latex
arena's observations are the core's), and `get_features` refuses them.
"""

from typing import Optional

from balloon_learning_environment.env import features
from balloon_learning_environment.env import simulator_data
from balloon_learning_environment.env import wind_field
from balloon_learning_environment.env.balloon import standard_atmosphere
from balloon_learning_environment.utils import units
import gin
import gym
import jax.numpy as jnp
import numpy as np

from ble_latex.envs import env_params
from ble_latex.envs import jax_features

NUM_FEATURES = jax_features.NUM_FEATURES


@gin.configurable(denylist=['forecast', 'atmosphere'])
class LatexFeatureConstructor(features.FeatureConstructor):
  """The paper's wind-column + ambient + history + resource features."""

  def __init__(self,
               forecast: wind_field.WindField,
               atmosphere: standard_atmosphere.Atmosphere,
               *,
               min_pressure: float = 5000.0,  # [Pa]
               max_pressure: float = 14000.0):  # [Pa]
    """Constructor.

    Args:
      forecast: The wind field whose forecast column the features read.
      atmosphere: BLE's atmosphere (ambient temperature and pressure).
      min_pressure: Lowest column level; the core's is fixed. # [Pa]
      max_pressure: Highest column level; the core's is fixed. # [Pa]

    Raises:
      ValueError: If a level differs from the flight core's
        (`jax_features.PRESSURE_LEVELS`, 25 levels 5000..14000 Pa).
    """
    levels = jax_features.PRESSURE_LEVELS
    for name, value, core in (('min_pressure', min_pressure, levels[0]),
                              ('max_pressure', max_pressure, levels[-1])):
      if value != core:
        raise ValueError(
            f'LatexFeatureConstructor.{name} must be {core} (the flight '
            f"core's feature levels are fixed), got {value!r}")
    self.pressure_levels = np.asarray(levels)
    self._forecast = forecast
    self._atmosphere = atmosphere
    self._observation: Optional[simulator_data.SimulatorObservation] = None
    self._initial: Optional[jax_features.InitialResources] = None
    self._history: Optional[jax_features.History] = None
    # gin's `latex_observation.*`, which the latex arena's core observes.
    self._observation_settings = env_params.observation_settings()

  def observe(self, observation: simulator_data.SimulatorObservation) -> None:
    """Records BLE's observation (and, at the first, the reset's resources)."""
    s = observation.balloon_observation
    if self._initial is None:
      self._initial = jax_features.initial_resources(
          s.payload_kg, s.sand_kg, s.helium_mols)
      self._history = jax_features.init_history(s.altitude_m,
                                                s.ascent_rate_mps)
    else:
      # As the core: the state after the step becomes history slot t-1.
      self._history = jax_features.push_history(
          self._history, s.altitude_m, s.ascent_rate_mps,
          float(s.last_float_action))
    self._observation = observation

  def get_features(self) -> np.ndarray:
    """The 71 features of the last observation (`jax_features.features`).

    Raises:
      ValueError: An observation option is on (the core computes those
        features; the latex arena's observations are the core's).
    """
    on = [k for k in env_params.OBSERVATION_SWITCHES
          if self._observation_settings[k]]
    if on:
      raise ValueError(
          f'LatexFeatureConstructor.get_features: latex_observation.'
          f'{on[0]} = True needs the flight core\'s state (the latex arena\'s '
          'observations have it); BLE\'s measurements do not carry it')
    s = self._observation.balloon_observation
    wind = self._observation.wind_at_balloon
    column = self._forecast.get_forecast_column(
        s.x, s.y, self.pressure_levels, s.time_elapsed)
    ambient = self._atmosphere.at_height(units.Distance(m=s.altitude_m))
    return np.asarray(jax_features.features(
        jnp.asarray([w.u.meters_per_second for w in column]),
        jnp.asarray([w.v.meters_per_second for w in column]),
        s.x.meters, s.y.meters, s.altitude_m, s.ascent_rate_mps,
        wind.u.meters_per_second, wind.v.meters_per_second, s.helium_mols,
        s.sand_kg, s.payload_kg, float(ambient.temperature),
        float(ambient.pressure), self._initial, self._history))

  @property
  def observation_space(self) -> gym.spaces.Box:
    """The features in [-1, 1]: 71, plus gin's observation options'."""
    return gym.spaces.Box(
        low=-1.0, high=1.0,
        shape=(env_params.num_features(self._observation_settings),),
        dtype=np.float32)
