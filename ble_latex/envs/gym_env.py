# coding=utf-8
"""Old import path of the gym envs, kept for users: `ble_latex.ble.gym_env`."""

from ble_latex.ble.gym_env import INFO_KEYS
from ble_latex.ble.gym_env import LatexBalloonDiscreteEnv
from ble_latex.ble.gym_env import LatexBalloonEnv
from ble_latex.ble.gym_env import validate_discrete_action
from ble_latex.ble.gym_env import validate_seed

__all__ = ['INFO_KEYS', 'LatexBalloonDiscreteEnv', 'LatexBalloonEnv',
           'validate_discrete_action', 'validate_seed']
