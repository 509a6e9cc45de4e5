# coding=utf-8
"""The latex balloon arena: BLE's `BalloonArena` flying a `LatexBalloon`.

What differs from BLE's arena:
- the balloon is a latex (vent/ballast) balloon starting at neutral buoyancy at
  an altitude sampled inside the start band;
- one step is one 20-minute controller action, and the balloon re-queries the
  ground-truth wind (forecast + BLE's simplex noise) at every physics sub-step
  instead of using one wind vector for the whole step;
- a wind field that chooses its own start time (ERA5 data) sets the flight's
  date and time.
Everything else — seeding, atmosphere sampling, start distance and angle,
measurements and features — is BLE's.
"""

import datetime as dt
import math
from typing import Callable, Optional, Tuple, Union

from balloon_learning_environment.env import balloon_arena
from balloon_learning_environment.env import features
from balloon_learning_environment.env import wind_field
from balloon_learning_environment.env.balloon import standard_atmosphere
from balloon_learning_environment.utils import sampling
from balloon_learning_environment.utils import units
import gin
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import balloon as balloon_lib
from ble_latex import controller as controller_lib


@gin.configurable(denylist=['feature_constructor_factory',
                            'wind_field_instance', 'seed'])
class LatexBalloonArena(balloon_arena.BalloonArena):
  """A BalloonArena whose balloon vents helium and drops sand."""

  def __init__(self,
               feature_constructor_factory: Callable[
                   [wind_field.WindField, standard_atmosphere.Atmosphere],
                   features.FeatureConstructor],
               wind_field_instance: wind_field.WindField,
               seed: Optional[int] = None,
               *,
               start_altitude_range_m: Tuple[float, float] = (15_000.0,
                                                              20_000.0),
               max_start_distance_km: float = 200.0,
               stride: dt.timedelta = controller_lib.STRIDE):
    """Constructor.

    Args:
      feature_constructor_factory: Builds the feature constructor.
      wind_field_instance: The wind field to fly in.
      seed: Optional seed (BLE semantics).
      start_altitude_range_m: Start altitude is uniform in this range. # [m]
      max_start_distance_km: Start distance is BLE's Beta(1.2, 2) times this.
        # [km]
      stride: Simulated time per action (paper: 20 minutes).
    """
    low, high = start_altitude_range_m
    if not (np.isfinite(low) and np.isfinite(high) and low <= high):
      raise ValueError(
          f'start_altitude_range_m must be finite (low, high), got '
          f'{start_altitude_range_m}')
    if not max_start_distance_km > 0:
      raise ValueError('max_start_distance_km must be > 0, got '
                       f'{max_start_distance_km}')
    self._start_altitude_range_m = (float(low), float(high))
    self._max_start_distance_km = float(max_start_distance_km)
    self._stride = stride
    super().__init__(feature_constructor_factory, wind_field_instance, seed)
    self._step_duration = stride

  def reset(self, seed: Union[int, jnp.ndarray, None] = None) -> np.ndarray:
    observation = super().reset(seed)
    start = getattr(self._wind_field, 'start_date_time', None)
    if start is not None and start != self._balloon.state.date_time:
      # The wind field (e.g. ERA5) picked the flight's date: use it.
      self._balloon.state.date_time = start
      self.feature_constructor = self._feature_constructor_factory(
          self._wind_field, self._atmosphere)
      self.feature_constructor.observe(self.get_measurements())
      observation = self.feature_constructor.get_features()
    return observation

  def step(self, action: np.ndarray) -> np.ndarray:
    """Applies one controller action (a0, a1, a2) for one stride."""
    self._balloon.simulate_step(self._wind_field.get_ground_truth,
                                self._atmosphere, action, self._step_duration)
    self.feature_constructor.observe(self.get_measurements())
    return self.feature_constructor.get_features()

  def _initialize_balloon(
      self, start_date_time: dt.datetime) -> balloon_lib.LatexBalloon:
    """A latex balloon within max_start_distance_km, neutral at its altitude.

    Distance (Beta), angle (uniform) and the centre location follow BLE's
    `_initialize_balloon`; the altitude is uniform in the start band.

    Args:
      start_date_time: The starting date and time.

    Returns:
      A new latex balloon.
    """
    self._rng, *keys = jax.random.split(self._rng, num=5)
    radius = jax.random.beta(keys[0], self._alpha, self._beta).item()
    radius = units.Distance(km=self._max_start_distance_km * radius)
    theta = jax.random.uniform(keys[1], (), minval=0.0, maxval=2.0 * jnp.pi)
    latlng = sampling.sample_location(keys[2])
    low, high = self._start_altitude_range_m
    altitude = jax.random.uniform(keys[3], (), minval=low, maxval=high).item()
    state = balloon_lib.create_state(
        center_latlng=latlng,
        date_time=start_date_time,
        atmosphere=self._atmosphere,
        altitude_m=altitude,
        x=math.cos(theta) * radius,
        y=math.sin(theta) * radius)
    return balloon_lib.LatexBalloon(state)
