# coding=utf-8
"""ble_latex: a latex (vent/ballast) balloon for the Balloon Learning Environment.

Importing this package is cheap: it only installs the compatibility import hook
(`ble_latex.compat`) that lets BLE 1.0.1 run on today's Python 3.11 stack. It
must happen before any `balloon_learning_environment` env module is imported;
`import gym` does it through the plugin's `gym.envs` entry point.
"""

from ble_latex import compat

compat.install()

__version__ = '0.1.0'
