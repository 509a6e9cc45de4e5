# coding=utf-8
"""Old import path of the latex arena, kept for users: `ble_latex.ble.arena`."""

from ble_latex.ble.arena import LatexBalloonArena

__all__ = ['LatexBalloonArena']
