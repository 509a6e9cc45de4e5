# coding=utf-8
"""The compiled programs of the Gymnasium envs (one balloon or a batch).

`Compiled` jits the three programs a host env runs: `draw` (the world of a
key, `jax_env.LatexBalloonJaxEnv.draw`), `start` (the first measurement,
observation and info) and `step` (`jax_env.LatexBalloonJaxEnv.step_env`,
returning only the state's changed parts and one packed array for the host:
copying each of ~40 small arrays costs more than the step). A first reset
compiles `start` and `step` in a background thread while `draw` compiles
(`Compiled.ahead`). One compiled set per process serves every env on BLE's
generative field or an ERA5 grid (`generative`); `arena_keys` is the seed ->
arena key program. JAX does not survive `fork()` once started:
`check_not_forked_after_jax` turns that deadlock into an error.
"""

import concurrent.futures
import functools
import os
import sys
from typing import Any, Dict, Optional, Tuple

import numpy as np

from ble_latex import quiet

with quiet.third_party_noise():
  # pylint: disable=g-import-not-at-top
  import jax
  from jax import lax
  import jax.numpy as jnp
  from ble_latex import jax_cache
  from ble_latex.envs import env_types
  from ble_latex.envs import jax_env
  # pylint: enable=g-import-not-at-top

# With $BLE_LATEX_JAX_CACHE=1 the envs' compiled functions are loaded from
# disk after the first process (process-wide, so only on request; see
# ble_latex.jax_cache).
jax_cache.enable_if_requested()

# The parts of `EnvState` a step changes (the world is fixed at reset).
_STEP_PARTS = ('flight', 'history', 'wind_u', 'wind_v', 'wind_memory',
               'steps')

# Set in a child forked from a process whose JAX had started (see
# `check_not_forked_after_jax`).
_forked_after_jax = False


def _note_fork_in_child() -> None:
  global _forked_after_jax
  bridge = sys.modules.get('jax._src.xla_bridge')
  started = getattr(bridge, 'backends_are_initialized', lambda: False)
  _forked_after_jax = _forked_after_jax or bool(started())


os.register_at_fork(after_in_child=_note_fork_in_child)


def check_not_forked_after_jax() -> None:
  """A clear error instead of a silent deadlock in a forked worker.

  The env simulates with JAX, and JAX's runtime does not survive `fork()`
  once it has started: a worker forked after the parent built an env (as
  `gymnasium.vector.AsyncVectorEnv` does, to read the spaces) hangs forever
  at its first JAX call.
  """
  if _forked_after_jax:
    raise RuntimeError(
        'ble_latex envs cannot be built in a process forked after JAX '
        'started (it would deadlock). Use the spawn start method: '
        "gymnasium.make_vec(ID, num_envs=N, asynchronous=True), or "
        "vector_kwargs={'context': 'spawn'} with vectorization_mode='async' / "
        "AsyncVectorEnv(..., context='spawn').")


def _strong(tree: Any) -> Any:
  """`tree` without weak types (so a step's input and output avals match)."""
  return jax.tree.map(lambda x: lax.convert_element_type(x, x.dtype), tree)


class _Layout:
  """How the host's values are packed into one array (and split again).

  Recorded while the jitted function is traced: leaves are cast to the
  widest float (losslessly: float32 values, and ints and bools below 2**24)
  and concatenated along the last axis, after any leading balloon axis.
  """

  def __init__(self, tree: Any, lead: Tuple[int, ...]):
    leaves, self.treedef = jax.tree.flatten(tree)
    self.shapes = [tuple(np.shape(leaf))[len(lead):] for leaf in leaves]
    self.dtypes = [np.dtype(leaf.dtype) for leaf in leaves]
    floats = [d for d in self.dtypes if d.kind == 'f']
    self.dtype = max(floats, key=lambda d: d.itemsize) if floats else (
        np.dtype(np.float32))
    self.ends = np.cumsum([int(np.prod(shape)) for shape in self.shapes])

  def pack(self, tree: Any, lead: Tuple[int, ...]) -> jax.Array:
    return jnp.concatenate([jnp.reshape(leaf, lead + (-1,)).astype(self.dtype)
                            for leaf in jax.tree.leaves(tree)], axis=-1)

  def unpack(self, packed: Any) -> Any:
    flat = np.asarray(packed)
    lead = flat.shape[:-1]
    parts = np.split(flat, self.ends[:-1], axis=-1)
    return jax.tree.unflatten(self.treedef, [
        part.reshape(lead + shape).astype(dtype)
        for part, shape, dtype in zip(parts, self.shapes, self.dtypes)])


class Compiled:
  """The jitted functions of one wind, for one balloon or a batch of them.

  `draw(keys, params)` is `LatexBalloonJaxEnv.draw`; `start(state, params)`
  measures the wind and returns (state, packed (obs, step_info, flight));
  `step(state, actions, params, normalized)` returns (changed state parts,
  packed (obs, reward, terminated, step_info, flight)); its actions are the
  Box's raw (a0 [m], a1, a2), or with `normalized` in [-1, 1]^3, mapped
  onto the Box by `jax_env.to_box` (the one mapping) inside the program
  (`normalized` a `np.bool_` argument, not a constant: the Gymnasium
  env's normalized actions and BLE's raw ones fly one compiled program; a
  Python bool would be another signature, so callers pass `np.bool_`);
  `unpack(name, packed)` splits a packed array on the host.

  A first reset compiles all three: `ahead` compiles `start` and `step` in
  a background thread while the caller's `draw` compiles (XLA compiles
  without holding the GIL), and `wait(name)` blocks until that compile has
  ended (the call then finds the program in jit's cache).
  """

  def __init__(self, env: jax_env.LatexBalloonJaxEnv, batched: bool,
               fast_compile: Optional[bool] = None):
    """Jits the three programs.

    Args:
      env: The functional env.
      batched: Programs over a leading balloon axis (the vector env).
      fast_compile: Compile with `jax_cache.fast_compile_options()`; None:
        for one balloon only (a batch's step runs ~10 % faster with XLA's
        defaults at N = 64 and 1024, which a long run pays back).
    """
    # (name, packed width) -> layout: one per trace, since the same set
    # serves envs whose outputs differ (an observation option's features).
    self._layouts: Dict[Tuple[str, int], _Layout] = {}
    # Batch shape -> ((id of the params, step), futures); the id, not
    # the params: the process-wide compiled sets must not keep an env's ERA5
    # grid.
    self._ahead: Dict[Tuple[int, ...],
                      Tuple[Tuple[int, bool], Dict[str, Any]]] = {}

    def over(fn, in_axes):
      return jax.vmap(fn, in_axes=in_axes) if batched else fn

    def pack(name, tree, lead):
      layout = _Layout(tree, lead)  # Recorded while tracing.
      key = (name, int(layout.ends[-1]))
      known = self._layouts.setdefault(key, layout)
      if (known.treedef, known.shapes, known.dtypes) != (
          layout.treedef, layout.shapes, layout.dtypes):
        raise ValueError(f'{name}: two output layouts of width {key[1]} '
                         'in one compiled set; build a separate Compiled')
      return layout.pack(tree, lead)

    def start(state, params):
      wind = env.wind_for(params)  # ERA5 if the params hold a grid.

      def one(state):
        state = _strong(jax_env.measure(state, wind))
        return state, (jax_env.observation(state, params, wind),
                       jax_env.step_info(state, params), state.flight)
      state, host = over(one, 0)(state)
      return state, pack('start', host, state.steps.shape)

    def step(state, actions, params, normalized):
      actions = jnp.where(normalized, jax_env.to_box(actions), actions)
      obs, state, reward, terminated, info = over(
          env.step_env, (None, 0, 0, None))(None, state, actions, params)
      parts = _strong({k: getattr(state, k) for k in _STEP_PARTS})
      return parts, pack('step', (obs, reward, terminated, info,
                                  state.flight), reward.shape)

    if fast_compile is None:
      fast_compile = not batched
    jit = functools.partial(jax.jit, compiler_options=(
        jax_cache.fast_compile_options() if fast_compile else None))
    self.draw = jit(over(env.draw, (0, None)))
    self.start = jit(start)
    self.step = jit(step)  # Call it with `normalized` a np.bool_.

  def unpack(self, name: str, packed: Any) -> Any:
    return self._layouts[(name, int(np.shape(packed)[-1]))].unpack(packed)

  def ahead(self, keys: Any, params: env_types.EnvParams,
            normalized: bool, step: bool = True) -> None:
    """Compiles `start` and `step` for the flights of `draw(keys, params)`.

    Traces `draw` here (jit keeps the trace for the call that follows),
    then compiles the two in a background thread, once per batch shape and
    params object (a params object with a reused id is skipped: its calls
    then compile); a failure there is dropped (the call itself then
    compiles, or raises). `normalized`: the actions `step` will get;
    `step` False: `start` only (a caller that flies the flights elsewhere).
    """
    lead = tuple(np.shape(keys))[:-1]
    done = self._ahead.get(lead)
    if done is not None and done[0] == (id(params), step):
      return
    try:
      drawn, _ = jax.eval_shape(self.draw, keys, params)
    except Exception:  # pylint: disable=broad-except
      return  # `draw` raises it.
    # `start` returns the drawn state without weak types (`_strong`).
    started = jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, x.dtype),
                           drawn)
    actions = jax.ShapeDtypeStruct(lead + (3,), np.float32)
    pool = _compile_pool()
    futures = {'start': pool.submit(
        lambda: self.start.lower(drawn, params).compile())}
    if step:
      futures['step'] = pool.submit(
          lambda: self.step.lower(started, actions, params,
                                  np.bool_(normalized)).compile())
    self._ahead[lead] = ((id(params), step), futures)

  def wait(self, name: str) -> None:
    """Blocks until `ahead`'s compile of `name` ('start' or 'step') ended.

    A compile waited for is forgotten, so later steps only look it up.
    """
    for _, futures in self._ahead.values():
      future = futures.pop(name, None)
      if future is not None:
        concurrent.futures.wait([future])


_pool: Optional[Tuple[int, concurrent.futures.ThreadPoolExecutor]] = None


def _compile_pool() -> concurrent.futures.ThreadPoolExecutor:
  """The process's compile thread (a new one in a forked child)."""
  global _pool
  if _pool is None or _pool[0] != os.getpid():
    _pool = (os.getpid(), concurrent.futures.ThreadPoolExecutor(
        max_workers=1, thread_name_prefix='ble_latex-compile'))
  return _pool[1]


@functools.lru_cache(maxsize=2)
def generative(batched: bool) -> Compiled:
  """One compiled set per process for the core's own winds (BLE's generative
  field, or the ERA5 grid the params hold)."""
  return Compiled(jax_env.LatexBalloonJaxEnv(normalize_actions=False), batched)


@jax.jit
def arena_keys(seeds: jax.Array) -> jax.Array:
  """`jax_env.arena_key(jax.random.PRNGKey(s))` of each seed (one program)."""
  return jax.vmap(lambda s: jax_env.arena_key(jax.random.PRNGKey(s)))(seeds)


