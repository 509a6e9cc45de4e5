# coding=utf-8
"""Seeds of the latex envs: the valid range and the training range.

Light (NumPy only), so the Gymnasium envs check seeds without importing the
gym env module (BLE's env, TensorFlow). `ble_latex.ble.gym_env.validate_seed` is the
same check.
"""

from typing import Any

import numpy as np

MAX_SEED = 2**32  # Exclusive; BLE's PRNGKey(seed) aliases larger seeds.
# Unseeded resets draw training seeds [0, TRAIN_SEED_LIMIT): never a held-out
# evaluation seed (`ble_latex.run.suites.EVAL_SEED_OFFSET`, checked in tests).
TRAIN_SEED_LIMIT = 1_000_000


def validate_seed(seed: Any) -> None:
  """Raises ValueError unless `seed` is None or an int in [0, 2**32).

  `jax.random.PRNGKey` takes seeds modulo 2**32 (so 2**32 + s would silently
  fly seed s) and overflows at 2**64; gym's seeding refuses negative seeds.
  """
  if seed is None:
    return
  if isinstance(seed, (bool, np.bool_)) or not isinstance(
      seed, (int, np.integer)):
    raise ValueError(f'seed must be None or an int in [0, 2**32), got '
                     f'{seed!r} ({type(seed).__name__})')
  if not 0 <= int(seed) < MAX_SEED:
    raise ValueError(f'seed must be in [0, 2**32), got {seed}')
