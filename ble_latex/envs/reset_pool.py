# coding=utf-8
"""The auto-reset pool: K pre-drawn worlds that `step` resets flights from.

`LatexBalloonJaxEnv.with_reset_pool(key, params, K)` draws the worlds
(`env_types.ResetPool`, held in `EnvParams.reset_pool`); `step` gives a
finished flight world `pool_index(key, K)` with `reset_from_pool`: the
world's observation and small state leaves at once, its large leaves
(forecast grid, noise permutations) pending until the next `step_env`
installs them (`install_world`). Both are `custom_vmap`s whose batched rules
write only the balloons that reset, so a pooled step costs about
`step_env`'s (docs/jax-env.md, "Auto-reset").

K is bounded (`MAX_POOL_SIZE`, `check_pool_size`) before anything is drawn:
each world holds ~0.33 MB on the device (its 21 x 21 x 10 x 9 x 2 float32
forecast grid is 317 520 bytes), and the pool is drawn in one vmapped call.
"""

import functools
from typing import Any, Tuple

import jax
from jax import custom_batching
import jax.numpy as jnp
import numpy as np

from ble_latex import gin_values
from ble_latex.envs import env_types

Array = jax.Array
# The most worlds a pool may hold: 4096 x ~0.33 MB = ~1.3 GB on the device,
# besides the one vmapped reset that draws them (issue 48 item 15: 10**4
# worlds aborted under an 8 GB memory cap, 10**8 asked for terabytes).
MAX_POOL_SIZE = 4096


def check_pool_size(size: Any) -> int:
  """K as an int in [1, `MAX_POOL_SIZE`], checked before anything is drawn.

  Raises:
    errors.ConfigError: One line naming the size, e.g. "reset pool size =
      100000000: expected an int in [1, 4096]".
  """
  return gin_values.check_int('reset pool size', size, minimum=1,
                              maximum=MAX_POOL_SIZE)


def pool_index(key: Array, size: int) -> Array:
  """The pool world `step` gives a flight that ends with step key `key`.

  `jax.random.randint(key, (), 0, size)`: uniform over the K worlds, drawn
  from the step's key (so the same keys give the same worlds).

  Args:
    key: The step's PRNG key.
    size: K, the number of worlds in the pool.

  Returns:
    The world's index in [0, K), int32 scalar.
  """
  return jax.random.randint(key, (), 0, size)


# Leaves with at least this many elements per balloon (the forecast grid,
# the noise permutations) are a pool world's "large" part: `step` leaves
# them to be installed at the start of the next step (`install_world`).
_LARGE_MIN_SIZE = 256


def _is_large(leaf: Any, batch: Tuple[int, ...] = ()) -> bool:
  return int(np.prod(np.shape(leaf)[len(batch):])) >= _LARGE_MIN_SIZE


def _broadcast_unbatched(axis_size: int, x: Any, batched: Any) -> Any:
  """`x`'s leaves with a leading batch axis of `axis_size`: the batched ones
  (`batched`: custom_vmap's per-leaf flags) as they are, the others
  broadcast."""
  return jax.tree.map(
      lambda a, b: a if b else jnp.broadcast_to(a, (axis_size,) + a.shape),
      x, batched)


@custom_batching.custom_vmap
def _install(pending: Array, large: Any, pool_large: Any) -> Any:
  """The large leaves of pool world `pending` where `pending` >= 0."""
  return jax.lax.cond(
      pending >= 0,
      lambda: jax.tree.map(lambda p: p[jnp.maximum(pending, 0)], pool_large),
      lambda: large)


@_install.def_vmap
def _install_batched(axis_size, in_batched, pending, large, pool_large):
  """Batched `_install`: only the balloons with a pending world are written.

  One `lax.dynamic_update_slice` per such balloon in a `lax.while_loop`
  that runs zero times when there is none: a select over every balloon
  would copy N forecast grids (~317 kB each) at every step, and XLA's
  scatter on CPU is an element loop. Installed before anything reads the
  state in the step, so XLA updates the buffers in place (no copy).
  """
  pending_b, large_b, pool_b = in_batched

  batch = functools.partial(_broadcast_unbatched, axis_size)
  pending, large = batch(pending, pending_b), batch(large, large_b)
  if any(jax.tree.leaves(pool_b)):  # A pool per balloon: select.
    out = jax.vmap(_install.fun)(pending, large, batch(pool_large, pool_b))
    return out, jax.tree.map(lambda _: True, out)
  def install(large):
    rows = jnp.nonzero(pending >= 0, size=axis_size, fill_value=0)[0]
    count = jnp.sum((pending >= 0).astype(jnp.int32))

    def body(carry):
      i, large = carry
      row = rows[i]
      world = pending[row]
      return i + 1, jax.tree.map(
          lambda w, p: jax.lax.dynamic_update_slice(
              w, jax.lax.dynamic_index_in_dim(p, world).astype(w.dtype),
              (row,) + (0,) * (w.ndim - 1)), large, pool_large)

    return jax.lax.while_loop(lambda c: c[0] < count, body,
                              (jnp.zeros((), jnp.int32), large))[1]

  # Nothing pending (most steps at small N): not even the row search.
  out = jax.lax.cond(jnp.any(pending >= 0), install, lambda large: large,
                     large)
  return out, jax.tree.map(lambda _: True, out)


def install_world(state: env_types.EnvState, params: env_types.EnvParams
                  ) -> env_types.EnvState:
  """`state` with its pending pool world's large parts in place.

  After an auto-reset from `EnvParams.reset_pool`, `step` returns the new
  world's observation and small state leaves at once, and marks its large
  leaves (forecast grid, noise permutations) as pending
  (`EnvState.pending_world`): `step_env` installs them first thing, where
  XLA can write only those balloons' rows in place. Call this to read such
  a state's winds outside `step_env` (e.g. `ground_truth_wind`). A state
  with nothing pending (`pending_world` < 0, every state of `reset` and of
  a step without a pool) is returned as it is.

  Args:
    state: The env state, possibly with a pending world.
    params: The env parameters holding the `reset_pool`.

  Returns:
    The state with the pending world's large leaves installed and
    `pending_world` set to -1.

  Raises:
    ValueError: `params.reset_pool` is None (nothing could be pending).
  """
  pool = params.reset_pool
  if pool is None:
    raise ValueError('install_world needs EnvParams.reset_pool (the pool '
                     'the pending world comes from)')
  leaves, treedef = jax.tree.flatten(state)
  pool_leaves = jax.tree.leaves(pool.state)
  large = [_is_large(x) for x in leaves]
  new = iter(_install(state.pending_world,
                      [x for x, b in zip(leaves, large) if b],
                      [p for p, b in zip(pool_leaves, large) if b]))
  state = treedef.unflatten([next(new) if b else x
                             for x, b in zip(leaves, large)])
  return state.replace(pending_world=jnp.full_like(state.pending_world, -1))


@custom_batching.custom_vmap
def _select_reset(done: Array, index: Array, small: Any,
                  pool_small: Any) -> Any:
  """Each leaf of `small` replaced by row `index` of its [K, ...] pool leaf
  in `pool_small` where `done`."""
  return jax.tree.map(
      lambda x, p: jnp.where(done, p[index], x).astype(x.dtype), small,
      pool_small)


@_select_reset.def_vmap
def _select_reset_batched(axis_size, in_batched, done, index, small,
                          pool_small):
  """Batched `_select_reset`: the same selects, skipped (`lax.cond`) in a
  step where no balloon's episode ended, so that the common step reads and
  writes none of the reset leaves."""
  done_b, index_b, small_b, pool_b = in_batched

  batch = functools.partial(_broadcast_unbatched, axis_size)
  done, index = batch(done, done_b), batch(index, index_b)
  small = batch(small, small_b)
  if any(jax.tree.leaves(pool_b)):  # A pool per balloon: no shared test.
    out = jax.vmap(_select_reset.fun)(done, index, small,
                                      batch(pool_small, pool_b))
  else:
    out = jax.lax.cond(
        jnp.any(done),
        lambda s: jax.vmap(_select_reset.fun, in_axes=(0, 0, 0, None))(
            done, index, s, pool_small),
        lambda s: s, small)
  return out, jax.tree.map(lambda _: True, out)


def reset_from_pool(done: Array, index: Array, state: env_types.EnvState,
                    obs: Array, pool: env_types.ResetPool
                    ) -> Tuple[env_types.EnvState, Array]:
  """`step`'s auto-reset from the pool (`LatexBalloonJaxEnv.step`).

  Where `done`: pool world `index`'s small leaves and observation now, its
  large leaves pending (`install_world`); elsewhere unchanged.

  Args:
    done: Whether the flight ended (bool scalar; batched under vmap).
    index: The pool world to reset to (`pool_index`).
    state: The env state after the step.
    obs: The observation after the step.
    pool: The pool (`EnvParams.reset_pool`), unbatched.

  Returns:
    (state, observation) after the reset.
  """
  leaves, treedef = jax.tree.flatten(state)
  pool_leaves = jax.tree.leaves(pool.state)
  small = [not _is_large(x) for x in leaves]
  # `pending_world` becomes `index` (row `index` of 0..K-1).
  pending_at, = [i for i, x in enumerate(leaves)
                 if x is state.pending_world]
  pool_leaves[pending_at] = jnp.arange(pool.size, dtype=jnp.int32)
  new_leaves, new_obs = _select_reset(
      done, index, ([x for x, b in zip(leaves, small) if b], obs),
      ([p for p, b in zip(pool_leaves, small) if b], pool.obs))
  new = iter(new_leaves)
  return (treedef.unflatten([next(new) if b else x
                             for x, b in zip(leaves, small)]), new_obs)
