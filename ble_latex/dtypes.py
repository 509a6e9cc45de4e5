# coding=utf-8
"""Array dtype helpers every layer may use (the floor of the package).

Light on purpose: only JAX's numpy.
"""

from typing import Any

import jax.numpy as jnp


def float_dtype(*values: Any) -> Any:
  """The floating dtype of the inputs (the default float for integers).

  JAX's type promotion of `values` (`jnp.result_type`); when that is no
  floating type (all integers or booleans), JAX's default float (float32, or
  float64 under `jax_enable_x64`), so that computing in it never truncates.

  Args:
    values: Arrays, scalars or dtypes.

  Returns:
    A floating numpy dtype.
  """
  dtype = jnp.result_type(*values)
  if not jnp.issubdtype(dtype, jnp.floating):
    dtype = jnp.result_type(float)
  return dtype
