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
    """BLE's features, without BLE's out-of-range pressure message.

    BLE logs "Balloon pressure P not fully represented by feature
    constructor" whenever the balloon is outside [min_pressure,
    max_pressure] (5000-14000 Pa, the pressures of BLE's generative winds).
    The latex balloon's band reaches above 5000 Pa (about 20.5 km, up to
    `latex_controller.band_high_m`), where BLE's superpressure balloon
    never flies, so BLE logged at every such step (hundreds of lines an
    episode, breaking `ble-latex-eval`'s progress bar). Nothing is wrong
    there: BLE's features saturate the balloon's pressure and level at the
    column's top (`_nearest_pressure_level`: "a warning has been logged,
    quantize"), and BLE's generative field is clipped to its 5000 Pa edge,
    so the top level's wind is the wind the balloon flies in. Only that
    message is dropped, only while BLE computes these features.
    """
    with quiet.log_filter(
        lambda record: not str(record.msg).startswith(_RANGE_WARNING),
        absl_logging.get_absl_logger()):
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
