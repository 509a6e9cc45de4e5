# coding=utf-8
"""Old import path of the vector env, kept for users: `ble_latex.envs.gymnasium_env`."""

from ble_latex.envs.gymnasium_env import CheckedSyncVectorEnv
from ble_latex.envs.gymnasium_env import info_arrays
from ble_latex.envs.gymnasium_env import LatexBalloonVectorEnv
from ble_latex.envs.gymnasium_env import validate_actions
from ble_latex.envs.gymnasium_env import validate_each

__all__ = ['CheckedSyncVectorEnv', 'LatexBalloonVectorEnv', 'info_arrays',
           'validate_actions', 'validate_each']
