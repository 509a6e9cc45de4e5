# coding=utf-8
"""Old import path, kept for users: `ble_latex.ble.discrete_features`."""

from ble_latex.ble.discrete_features import LatexPerciatelliFeatureConstructor

__all__ = ['LatexPerciatelliFeatureConstructor']
