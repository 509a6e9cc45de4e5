# coding=utf-8
"""Wind fields and noise in JAX."""
