# coding=utf-8
"""Observation features of the latex balloon (paper, "High-level SAC").

`LatexFeatureConstructor` is a BLE `features.FeatureConstructor`: the arena
calls `observe()` with each measurement and `get_features()` for the vector.
Every feature is scaled to [-1, 1] (clipped). Index map (N_LEVELS = 25):

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

import collections
import math
from typing import Deque

from balloon_learning_environment.env import features
from balloon_learning_environment.env import simulator_data
from balloon_learning_environment.env import wind_field
from balloon_learning_environment.env.balloon import standard_atmosphere
from balloon_learning_environment.utils import transforms
from balloon_learning_environment.utils import units
import gin
import gym
import numpy as np

from ble_latex import physics

N_LEVELS = 25
NUM_FEATURES = 2 * N_LEVELS + 21
HISTORY = 3
_TOLERANCE = 1e-5


def bearing_errors(u: np.ndarray, v: np.ndarray, x_m: float,
                   y_m: float) -> np.ndarray:
  """Angle between wind (u, v) and the direction to the target. # [rad]

  As BLE's Perciatelli features: 0 when the wind blows straight at the target,
  pi when straight away; 0 at the target, pi in calm air.

  Args:
    u: Eastward wind components. # [m/s]
    v: Northward wind components. # [m/s]
    x_m: Balloon x offset from the target. # [m]
    y_m: Balloon y offset from the target. # [m]

  Returns:
    Bearing errors in [0, pi]. # [rad]
  """
  u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
  distance = math.hypot(x_m, y_m)
  speed = np.hypot(u, v)
  if distance < _TOLERANCE:
    return np.zeros_like(speed)
  cos_error = (-x_m * u - y_m * v) / (distance * np.maximum(speed, _TOLERANCE))
  error = np.arccos(np.clip(cos_error, -1.0, 1.0))
  return np.where(speed < _TOLERANCE, math.pi, error)


@gin.configurable
class LatexFeatureConstructor(features.FeatureConstructor):
  """The paper's wind-column + ambient + history + resource features."""

  def __init__(self,
               forecast: wind_field.WindField,
               atmosphere: standard_atmosphere.Atmosphere,
               *,
               min_pressure: float = 5000.0,  # [Pa]
               max_pressure: float = 14000.0):  # [Pa]
    self._forecast = forecast
    self._atmosphere = atmosphere
    self.pressure_levels = np.linspace(min_pressure, max_pressure, N_LEVELS)
    self._state = None
    self._wind_at_balloon = None
    self._initial_sand = None
    self._initial_helium = None
    self._initial_mass = None
    self._altitudes: Deque[float] = collections.deque(maxlen=HISTORY)
    self._ascent_rates: Deque[float] = collections.deque(maxlen=HISTORY)
    self._float_actions: Deque[float] = collections.deque(maxlen=HISTORY)

  def observe(self, observation: simulator_data.SimulatorObservation) -> None:
    state = observation.balloon_observation
    if self._state is None:
      self._initial_sand = max(state.sand_kg, _TOLERANCE)
      self._initial_helium = max(state.helium_mols, _TOLERANCE)
      self._initial_mass = physics.total_mass(
          state.payload_kg, state.sand_kg, state.helium_mols)
      for _ in range(HISTORY):
        self._altitudes.append(state.altitude_m)
        self._ascent_rates.append(state.ascent_rate_mps)
        self._float_actions.append(0.0)
    else:
      # The previous observation becomes history t-1.
      self._altitudes.appendleft(self._state.altitude_m)
      self._ascent_rates.appendleft(self._state.ascent_rate_mps)
      self._float_actions.appendleft(float(state.last_float_action))
    self._state = state
    self._wind_at_balloon = observation.wind_at_balloon

  def get_features(self) -> np.ndarray:
    s = self._state
    x_m, y_m = s.x.meters, s.y.meters
    column = self._forecast.get_forecast_column(
        s.x, s.y, self.pressure_levels, s.time_elapsed)
    u = np.array([w.u.meters_per_second for w in column])
    v = np.array([w.v.meters_per_second for w in column])
    speeds = np.hypot(u, v)

    wind_u = self._wind_at_balloon.u.meters_per_second
    wind_v = self._wind_at_balloon.v.meters_per_second
    ambient = self._atmosphere.at_height(units.Distance(m=s.altitude_m))
    volume = physics.volume(s.helium_mols, ambient.temperature,
                            ambient.pressure)
    distance_km = math.hypot(x_m, y_m) / 1000.0
    heading = math.atan2(-x_m, -y_m)

    f = np.empty(NUM_FEATURES, dtype=np.float64)
    f[0:N_LEVELS] = 1.0 - np.exp(-speeds / 30.0)  # BLE's squash, vectorised.
    f[N_LEVELS:2 * N_LEVELS] = bearing_errors(u, v, x_m, y_m) / math.pi
    i = 2 * N_LEVELS
    f[i] = _scale_altitude(s.altitude_m)
    f[i + 1] = s.ascent_rate_mps / 5.0
    f[i + 2] = transforms.squash_to_unit_interval(math.hypot(wind_u, wind_v),
                                                  30.0)
    f[i + 3] = bearing_errors(np.array([wind_u]), np.array([wind_v]),
                              x_m, y_m)[0] / math.pi
    f[i + 4] = physics.drag_area(volume) / 25.0
    f[i + 5] = volume / 100.0
    f[i + 6] = physics.total_mass(s.payload_kg, s.sand_kg,
                                  s.helium_mols) / self._initial_mass
    f[i + 7] = transforms.squash_to_unit_interval(distance_km, 250.0)
    f[i + 8] = math.sin(heading)
    f[i + 9] = math.cos(heading)
    f[i + 10:i + 13] = [_scale_altitude(h) for h in self._altitudes]
    f[i + 13:i + 16] = np.asarray(self._ascent_rates) / 5.0
    f[i + 16:i + 19] = np.asarray(self._float_actions)
    f[i + 19] = s.sand_kg / self._initial_sand
    f[i + 20] = s.helium_mols / self._initial_helium
    return np.clip(f, -1.0, 1.0).astype(np.float32)

  @property
  def observation_space(self) -> gym.spaces.Box:
    return gym.spaces.Box(low=-1.0, high=1.0, shape=(NUM_FEATURES,),
                          dtype=np.float32)


def _scale_altitude(altitude_m: float) -> float:
  return (altitude_m - 17_500.0) / 3_500.0
