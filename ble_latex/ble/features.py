# coding=utf-8
"""Observation features of the latex balloon (paper, "High-level SAC").

The features are computed by `ble_latex.envs.jax_features.features` (the flight
core's observation, batched or not). `LatexFeatureConstructor` is the same
computation behind BLE's `features.FeatureConstructor` interface (`observe()`
a measurement, `get_features()` the vector), for code that holds BLE objects;
the latex arena computes them inside the core. Every feature is scaled to
[-1, 1] (clipped). Index map (N_LEVELS = 25):

| index   | feature                                                            | scaling                  |
|---------|--------------------------------------------------------------------|--------------------------|
| 0-24    | forecast wind speed |v| at 25 pressure levels, 5000..14000 Pa      | squash(|v|, 30 m/s)      |
| 25-49   | bearing error theta of that wind to the target, same levels       | theta / pi               |
| 50      | altitude h                                                         | (h - 17.5 km) / 3.5 km   |
| 51      | ascent rate hdot                                                   | hdot / 5 m/s             |
| 52      | measured wind speed at the balloon |v_h|                           | squash(|v_h|, 30 m/s)    |
| 53      | bearing error at the balloon theta_h                               | theta_h / pi             |
| 54      | drag area A                                                        | A / 25 m^2               |
| 55      | envelope volume V                                                  | V / 100 m^3              |
| 56      | total system mass m_T                                              | m_T / initial m_T        |
| 57      | distance to the target |x|                                        | squash(|x|, 250 km)      |
| 58, 59  | heading to the target sin(theta_x), cos(theta_x)                   | as is                    |
| 60-62   | altitudes at t-1, t-2, t-3                                         | as index 50              |
| 63-65   | ascent rates at t-1, t-2, t-3                                      | as index 51              |
| 66-68   | float actions a2 at t-1, t-2, t-3                                  | as is ([-1, 1])          |
| 69      | sand mass m_s                                                      | m_s / initial m_s        |
| 70      | helium n                                                           | n / initial n            |

71 features: exactly the items the paper lists (its text says 74 and 77 in
different places; the listed items add up to 71). The wind column is BLE's
forecast (the agent's view); the balloon moves in forecast + simplex noise
(BLE's ground truth), and features 52-53 use that measured wind. At reset the
history slots hold the current values and float actions 0.
"""

import math
from typing import Optional

from balloon_learning_environment.env import features
from balloon_learning_environment.env import simulator_data
from balloon_learning_environment.env import wind_field
from balloon_learning_environment.env.balloon import standard_atmosphere
from balloon_learning_environment.utils import transforms
from balloon_learning_environment.utils import units
import gin
import gym
import jax.numpy as jnp
import numpy as np

from ble_latex.envs import jax_features

N_LEVELS = jax_features.N_LEVELS
NUM_FEATURES = jax_features.NUM_FEATURES
HISTORY = jax_features.HISTORY


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

  def observe(self, observation: simulator_data.SimulatorObservation) -> None:
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
    return gym.spaces.Box(low=-1.0, high=1.0, shape=(NUM_FEATURES,),
                          dtype=np.float32)


class NamedLatexFeatures:
  """The 71 features decoded back into named quantities (the decoder).

  The inverse of the scalings in the module's index map, as BLE's
  `features.NamedPerciatelliFeatures` is of its Perciatelli features. Values
  that the encoder clipped to [-1, 1] decode to the edge of their range (an
  altitude above 21 km reads as 21 km); squashed magnitudes near 1 decode to
  large finite values.

  Attributes:
    wind_speeds_mps: [25] forecast wind speed |v| at PRESSURE_LEVELS. # [m/s]
    bearing_errors_rad: [25] angle between that wind and the direction to
      the target. # [rad]
    altitude_m: Altitude h. # [m]
    ascent_rate_mps: Ascent rate hdot. # [m/s]
    wind_speed_mps: Measured wind speed at the balloon. # [m/s]
    bearing_error_rad: Bearing error of the measured wind. # [rad]
    drag_area_m2: Drag area A. # [m^2]
    volume_m3: Envelope volume V. # [m^3]
    mass_fraction: Total system mass / its value at reset. # [.]
    distance_km: Distance to the target. # [km]
    sin_heading, cos_heading: Heading to the target. # [.]
    altitude_history_m: [3] altitudes at t-1, t-2, t-3. # [m]
    ascent_rate_history_mps: [3] ascent rates at t-1, t-2, t-3. # [m/s]
    float_action_history: [3] float actions a2 at t-1, t-2, t-3. # [.]
    sand_fraction: Sand / sand at reset. # [.]
    helium_fraction: Helium / helium at reset. # [.]
  """

  def __init__(self, observation: np.ndarray):
    """Decodes one observation.

    Args:
      observation: [71] features of `LatexBalloon-v0`.

    Raises:
      ValueError: If the observation is not 71 features.
    """
    f = np.asarray(observation)
    if f.shape != (NUM_FEATURES,):
      raise ValueError(f'NamedLatexFeatures needs {NUM_FEATURES} features '
                       f'(LatexBalloon-v0), got shape {f.shape}')
    n = N_LEVELS
    # Features 0-24 are 1 - exp(-|v| / c).
    squashed = np.clip(f[:n], 0.0, 1.0 - 1e-6)
    self.wind_speeds_mps = -jax_features.SPEED_SQUASH_MPS * np.log1p(-squashed)
    self.bearing_errors_rad = f[n:2 * n] * math.pi
    scalars = [float(x) for x in f[2 * n:2 * n + 10]]
    self.altitude_m = _altitude_m(scalars[0])
    self.ascent_rate_mps = scalars[1] * jax_features.ASCENT_RATE_SCALE_MPS
    self.wind_speed_mps = _unsquash(scalars[2], jax_features.SPEED_SQUASH_MPS)
    self.bearing_error_rad = scalars[3] * math.pi
    self.drag_area_m2 = scalars[4] * jax_features.DRAG_AREA_SCALE_M2
    self.volume_m3 = scalars[5] * jax_features.VOLUME_SCALE_M3
    self.mass_fraction = scalars[6]
    self.distance_km = _unsquash(scalars[7], jax_features.DISTANCE_SQUASH_KM)
    self.sin_heading, self.cos_heading = scalars[8], scalars[9]
    h = 2 * n + 10
    self.altitude_history_m = np.array(
        [_altitude_m(float(x)) for x in f[h:h + HISTORY]])
    self.ascent_rate_history_mps = (
        f[h + HISTORY:h + 2 * HISTORY].astype(np.float64) *
        jax_features.ASCENT_RATE_SCALE_MPS)
    self.float_action_history = f[h + 2 * HISTORY:h + 3 * HISTORY].copy()
    self.sand_fraction, self.helium_fraction = float(f[-2]), float(f[-1])


def _altitude_m(scaled: float) -> float:
  """Undoes (h - 17.5 km) / 3.5 km. # [m]"""
  return (jax_features.ALTITUDE_CENTER_M +
          jax_features.ALTITUDE_SCALE_M * scaled)


def _unsquash(squashed: float, constant: float) -> float:
  """BLE's `undo_squash_to_unit_interval`, the value kept inside [0, 1)."""
  return transforms.undo_squash_to_unit_interval(
      min(max(squashed, 0.0), 1.0 - 1e-6), constant)
