# coding=utf-8
"""Old import path of the features (`ble_latex.ble.features`) and decoder."""

from ble_latex.ble.features import LatexFeatureConstructor
from ble_latex.envs.jax_features import NamedLatexFeatures
from ble_latex.envs.jax_features import NUM_FEATURES

__all__ = ['LatexFeatureConstructor', 'NamedLatexFeatures', 'NUM_FEATURES']
