# coding=utf-8
"""Old import path of the gym envs (ble_latex 0.1), kept: `ble_latex.ble.gym_env`."""

from ble_latex.ble.gym_env import LatexBalloonDiscreteEnv
from ble_latex.ble.gym_env import LatexBalloonEnv

__all__ = ['LatexBalloonDiscreteEnv', 'LatexBalloonEnv']
