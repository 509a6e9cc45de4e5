# coding=utf-8
"""Old import path of the gym envs, kept for users: `ble_latex.envs.gym_env`.

`from ble_latex import env; env.LatexBalloonEnv(...)` and `import
ble_latex.env` in a gin file keep working; new code imports
`ble_latex.envs.gym_env`.
"""

from ble_latex.envs.gym_env import LatexBalloonDiscreteEnv
from ble_latex.envs.gym_env import LatexBalloonEnv

__all__ = ['LatexBalloonEnv', 'LatexBalloonDiscreteEnv']
