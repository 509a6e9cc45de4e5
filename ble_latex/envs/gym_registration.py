# coding=utf-8
"""Old `gym.envs` entry point, kept: `ble_latex.ble.gym_registration`."""

from ble_latex.ble.gym_registration import register_env

__all__ = ['register_env']
