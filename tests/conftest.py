"""Shared pytest setup: ble_latex is imported first so its BLE fixes apply."""

import os

os.environ.setdefault('TF_CPP_MIN_LOG_LEVEL', '3')
os.environ.setdefault('JAX_PLATFORMS', 'cpu')

import ble_latex  # noqa: E402,F401  pylint: disable=g-import-not-at-top,unused-import
