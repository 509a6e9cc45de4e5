# coding=utf-8
"""Old import path, kept for users: `ble_latex.ble.wind`."""

from ble_latex.ble.wind import CoreGenerativeWindField

__all__ = ['CoreGenerativeWindField']
