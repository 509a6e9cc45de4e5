# coding=utf-8
"""Old import path of the BLE balloon view, kept: `ble_latex.ble.balloon`."""

from ble_latex.ble.balloon import create_state
from ble_latex.ble.balloon import LatexBalloon
from ble_latex.ble.balloon import LatexBalloonState
from ble_latex.ble.balloon import LatexBalloonStatus

__all__ = ['create_state', 'LatexBalloon', 'LatexBalloonState',
           'LatexBalloonStatus']
