# coding=utf-8
"""Old import path of the reward, kept for users: `ble_latex.ble.reward`."""

from ble_latex.ble.reward import latex_reward

__all__ = ['latex_reward']
