# coding=utf-8
"""The latex balloon as environments: gym, gymnasium, batched JAX; features, reward, BLE adapters."""
