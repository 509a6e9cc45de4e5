# coding=utf-8
"""BLE's Perciatelli features for the latex balloon (the discrete env).

BLE's `PerciatelliFeatureConstructor` marks pressure levels outside the
balloon's reachable range as "unreachable"; it computes that range with BLE's
superpressure-balloon model (`pressure_range_builder`). A latex balloon reaches
any level of its altitude band while it has sand to climb and helium to vent,
so this subclass swaps in that range and keeps everything else of BLE's.
"""

import contextlib
import types
from typing import Iterator

from absl import logging as absl_logging
from balloon_learning_environment.env import features
from balloon_learning_environment.env.balloon import pressure_range_builder
from balloon_learning_environment.env.balloon import standard_atmosphere
from balloon_learning_environment.utils import units
import gin
import numpy as np

from ble_latex import quiet
from ble_latex.ble import balloon as balloon_lib
from ble_latex.flight import params as params_lib


def latex_pressure_range(
    state: balloon_lib.LatexBalloonState,
    atmosphere: standard_atmosphere.Atmosphere
) -> pressure_range_builder.AccessiblePressureRange:
  """Pressures the latex balloon can reach: its controller's band. # [Pa]"""
  del state  # Any level in the band, while resources last.
  band = params_lib.flight_params_from_gin()  # The gin-configured band.
  return pressure_range_builder.AccessiblePressureRange(
      min_pressure=atmosphere.at_height(
          units.Distance(m=band.band_high_m)).pressure,
      max_pressure=atmosphere.at_height(
          units.Distance(m=band.band_low_m)).pressure)


@gin.configurable
class LatexPerciatelliFeatureConstructor(
    features.PerciatelliFeatureConstructor):
  """Perciatelli features (1099 values) with the latex reachable range."""

  def get_features(self) -> np.ndarray:
    """BLE's features; its out-of-range pressure warning once per episode.

    BLE logs "Balloon pressure ... not fully represented by feature
    constructor" at every step the balloon is outside [min_pressure,
    max_pressure] (often: the latex band reaches below 14 km). The arena
    builds a new constructor at each reset, so warning only the first time
    means at most once per episode.
    """
    pressure = self._last_balloon_state.pressure
    outside = not self.min_pressure <= pressure <= self.max_pressure
    if outside and getattr(self, '_range_warned', False):
      with quiet.log_filter(
          lambda record: not str(record.msg).startswith(_RANGE_WARNING),
          absl_logging.get_absl_logger()):
        return super().get_features()
    self._range_warned = outside or getattr(self, '_range_warned', False)
    return super().get_features()

  def _add_wind_features(self, feature_vector: np.ndarray) -> None:
    with _range_builder(latex_pressure_range):
      super()._add_wind_features(feature_vector)


# The start of BLE's warning (features.PerciatelliFeatureConstructor).
_RANGE_WARNING = 'Balloon pressure %.2f not fully represented'


@contextlib.contextmanager
def _range_builder(fn) -> Iterator[None]:
  """Points BLE's features module at `fn` for the range, for one call."""
  original = features.pressure_range_builder
  features.pressure_range_builder = types.SimpleNamespace(
      get_pressure_range=fn)
  try:
    yield
  finally:
    features.pressure_range_builder = original
