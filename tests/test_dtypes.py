"""The floor's dtype helper (`ble_latex.dtypes`), used by winds and envs."""

import jax.numpy as jnp
import numpy as np

from ble_latex import dtypes


def test_float_dtype_keeps_floats_and_promotes_integers():
  assert dtypes.float_dtype(np.float16(1)) == jnp.float16
  assert dtypes.float_dtype(jnp.ones(2, jnp.float16),
                            jnp.ones(2, jnp.float32)) == jnp.float32
  # Integers and booleans compute in JAX's default float, never truncated.
  assert dtypes.float_dtype(jnp.arange(3), True) == jnp.result_type(float)
  assert jnp.issubdtype(dtypes.float_dtype(1, 2), jnp.floating)
