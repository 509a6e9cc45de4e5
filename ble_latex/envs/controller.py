# coding=utf-8
"""Old import path, kept for gin files (`import ble_latex.envs.controller`).

`AltitudeController.*` is gin's name of `ble_latex.flight.params.controller`;
the action Box is `jax_env.ACTION_LOW` / `ACTION_HIGH`.
"""

from ble_latex.envs.jax_env import ACTION_HIGH
from ble_latex.envs.jax_env import ACTION_LOW
from ble_latex.flight.params import controller

__all__ = ['ACTION_HIGH', 'ACTION_LOW', 'controller']
