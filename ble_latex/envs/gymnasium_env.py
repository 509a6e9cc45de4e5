# coding=utf-8
"""The Gymnasium envs of the functional env: one balloon or N, one wrapper.

`ble_latex/LatexBalloon-v0` (`LatexBalloonGymnasiumEnv`, one balloon) and its
`gymnasium.make_vec` default (`LatexBalloonVectorEnv`, N balloons in one
jitted, vmapped call) are one host wrapper around `jax_env.LatexBalloonJaxEnv`
(`_Balloons`): one action check (`validate_actions`), one seed rule, one set
of compiled functions (`_Compiled`), whose step returns only the state's
changed parts and one packed array for the host (copying each of ~40 small
arrays costs more than the step). A step goes wrapper `step` -> the jitted
step (`_Compiled`) -> `jax_env.LatexBalloonJaxEnv.step_env` ->
`flight.dynamics.step`. Neither imports gym, BLE's balloon/env modules nor
TensorFlow; both read the env's gin names (`jax_env.params_from_gin`).

- `reset(seed=None, options=None)` returns `(obs, info)`. The flight of seed
  s (balloon i of the vector env: s + i) is the flight of
  `gym.make('LatexBalloon-v0').reset(seed=s)` (and of `ble-latex-eval`'s seed
  s): the core's key `jax.random.PRNGKey(s)`. Without a seed, seeds are drawn
  from `np_random` among the training seeds [0, 1 000 000) (never a held-out
  eval seed), so episodes are reproducible after one seeded reset. There
  are no options.
- `step` returns `(obs, reward, terminated, truncated, info)` straight from
  the core: out of sand, out of helium, burst or grounded are `terminated`,
  the time limit (`episode_steps`, 216) is `truncated`. `info` is
  `jax_env.info_dict` without `TimeLimit.truncated` (the vector env: each
  key an array over balloons with gymnasium's `_key` mask, `info_arrays`).
- Actions are checked at the boundary: shape (3,) (vector: (N, 3)), finite,
  inside the Box, or [-1, 1]^3 with `normalize_actions=True` (mapped affinely
  onto the Box with gymnasium's `rescale_box`); anything else is a
  ValueError naming the balloon and component, and nothing changes. The
  registered ids default to `normalize_actions=True` (the spec's kwargs;
  `gymnasium.make(ID, normalize_actions=False)` for the raw Box) and
  `spec.max_episode_steps` = 216; the classes themselves default to the raw
  Box (BLE's arena builds them).
- The single env stops at the end of an episode (stepping it again is a
  RuntimeError); `render_mode='rgb_array'` draws the flight so far (with an
  inset around the station once the path is far away, `draw_flight`). The
  vector env resets ended balloons in the same step
  (`AutoresetMode.SAME_STEP`, the core's gymnax convention) from seeds drawn
  from `np_random`, with `info['final_obs']` / `info['final_info']`.
- Both fly BLE's generative field inside the core, or ERA5 when the params
  hold its grid (`EnvParams.wind_grid`: gin's `LatexBalloonEnv.
  wind_field_factory = @Era5WindField`, or an `Era5WindField` factory).
  The single env also flies any other BLE `WindField` (`wind_field_factory`)
  through host callbacks (`ble_latex.ble.wind.callback_wind`).

The ids are registered with gymnasium by `ble_latex.envs.gymnasium_registration`
when `ble_latex` is imported.
"""

import concurrent.futures
import datetime as dt
import functools
import os
import sys
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple

import gymnasium
from gymnasium.vector import utils as vector_utils
from gymnasium.vector.vector_env import AutoresetMode
from gymnasium.wrappers import utils as wrapper_utils
import numpy as np

from ble_latex import quiet
from ble_latex.envs import seeds as seeds_lib

with quiet.third_party_noise():
  # pylint: disable=g-import-not-at-top
  import jax
  from jax import lax
  import jax.numpy as jnp
  from ble_latex import gin_values
  from ble_latex import jax_cache
  from ble_latex.envs import jax_env
  # pylint: enable=g-import-not-at-top

# With $BLE_LATEX_JAX_CACHE=1 the envs' compiled functions are loaded from
# disk after the first process (process-wide, so only on request; see
# ble_latex.jax_cache).
jax_cache.enable_if_requested()

# Names of the action components in messages.
COMPONENTS = ('a0 (desired altitude [m])', 'a1 (time factor)',
              'a2 (float flag)')
# The vector env resets a few ended balloons in one padded call (N > this);
# more at once reset the whole batch (two compiled sizes at most).
RESET_CHUNK = 16
# The parts of `EnvState` a step changes (the world is fixed at reset).
_STEP_PARTS = ('flight', 'history', 'wind_u', 'wind_v', 'steps')
# step_info columns the derived (non pass-through) info entries depend on;
# `info_arrays` calls `jax_env.info_dict` once per distinct combination.
_GROUP_COLUMNS = ('status', 'decision', 'truncated', 'time_limit', 'time_s')

# Set in a child forked from a process whose JAX had started (see
# `_check_not_forked_after_jax`).
_forked_after_jax = False


def _note_fork_in_child() -> None:
  global _forked_after_jax
  bridge = sys.modules.get('jax._src.xla_bridge')
  started = getattr(bridge, 'backends_are_initialized', lambda: False)
  _forked_after_jax = _forked_after_jax or bool(started())


os.register_at_fork(after_in_child=_note_fork_in_child)


def _check_not_forked_after_jax() -> None:
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


def _check_render_mode(env: Any, render_mode: Optional[str]) -> None:
  if render_mode is not None and render_mode not in env.metadata[
      'render_modes']:
    raise ValueError(f'render_mode must be None or one of '
                     f'{env.metadata["render_modes"]}, got {render_mode!r}')


def validate_actions(actions: Any, num_envs: Optional[int], low: np.ndarray,
                     high: np.ndarray, what: str = '') -> np.ndarray:
  """The one check of actions at the host boundary.

  Args:
    actions: One action (a0, a1, a2) if `num_envs` is None, else one per
      balloon, shape (num_envs, 3).
    num_envs: None for one balloon, else the number of balloons.
    low: Lowest value of each component.
    high: Highest value of each component.
    what: Appended to messages, e.g. ' (normalize_actions=True)'.

  Returns:
    The actions as float64, shape (3,) or (num_envs, 3).

  Raises:
    ValueError: Not numeric, another shape, NaN/inf, or outside [low,
      high], naming the balloon and the component.
  """
  single = num_envs is None
  shape = (3,) if single else (num_envs, 3)
  name, per = ('action', '(a0, a1, a2)') if single else (
      'actions', '(a0, a1, a2 per balloon)')
  try:
    kind = np.asarray(actions).dtype.kind
    a = np.asarray(actions, dtype=np.float64) if kind in 'iuf' else None
  except (TypeError, ValueError, OverflowError):
    a = None
  if a is None:
    raise ValueError(f'{name} must be numbers of shape {shape} {per}{what}, '
                     f'got {actions!r}')
  if a.shape != shape:
    raise ValueError(f'{name} must have shape {shape} {per}{what}, got shape '
                     f'{a.shape}: {actions!r}')
  rows = a[None] if single else a
  for bad, requirement in (
      (~np.isfinite(rows), 'be finite'),
      ((rows < low) | (rows > high), None)):
    if bad.any():
      i, j = np.argwhere(bad)[0]
      label = name if single else f'{name}[{i}]'
      requirement = requirement or f'be in [{low[j]:g}, {high[j]:g}]'
      raise ValueError(f'{label} {COMPONENTS[j]} must {requirement}{what}, '
                       f'got {rows[i, j]}')
  return a


def validate_each(actions: Any,
                  checks: Sequence[Callable[[Any], Any]]) -> None:
  """Checks every balloon's action before any balloon is stepped.

  For vector envs of independent single envs (`CheckedSyncVectorEnv`):
  balloon i's action goes through `checks[i]`, the single env's own check,
  so a bad action for one balloon leaves every balloon unstepped.

  Args:
    actions: One action per balloon (a sequence of length N).
    checks: The N single envs' action checks, each raising ValueError on a
      bad action.

  Raises:
    ValueError: Not one action per balloon, or `actions[i]: <the single
      env's message>` for the first bad one.
  """
  n = len(checks)
  try:
    count = len(actions)
  except TypeError:
    count = None
  if count != n or isinstance(actions, (str, bytes)):
    raise ValueError(f'actions must hold one action per balloon ({n}), got '
                     f'{actions!r}')
  for i, (action, check) in enumerate(zip(actions, checks)):
    try:
      check(action)
    except ValueError as e:
      raise ValueError(f'actions[{i}]: {e}') from None


class CheckedSyncVectorEnv(gymnasium.vector.SyncVectorEnv):
  """`SyncVectorEnv` whose `step` checks all actions before stepping any.

  gymnasium's `SyncVectorEnv` steps balloon 0 before balloon 1's action is
  looked at; here every balloon's action is checked first with its env's
  `check_action` (`validate_each`).
  """

  def step(self, actions: Any) -> Tuple[Any, np.ndarray, np.ndarray,
                                        np.ndarray, Dict[str, Any]]:
    validate_each(actions,
                  [env.unwrapped.check_action for env in self.envs])
    return super().step(actions)


def _batch(values: Sequence[Any]) -> np.ndarray:
  """One info entry over balloons, typed as gymnasium's SyncVectorEnv does."""
  first = values[0]
  if type(first) in (int, float, bool) or isinstance(first, np.number):
    return np.asarray(values, dtype=type(first))
  out = np.empty(len(values), dtype=object)
  out[:] = list(values)
  return out


def info_arrays(raw: Mapping[str, np.ndarray],
                mask: Optional[np.ndarray] = None) -> Dict[str, np.ndarray]:
  """The single env's info of N balloons as gymnasium vector info.

  Args:
    raw: `jax_env.step_info` of N balloons (NumPy arrays of shape [N]).
    mask: Which balloons have this info (gymnasium's `_key` masks); all if
      None.

  Returns:
    For each key of `jax_env.info_dict` (but `TimeLimit.truncated`): an
    array over balloons (float64 / bool, or object for strings and
    timedeltas) and its mask under `_key`.
  """
  n = len(raw['status'])
  mask = np.ones(n, bool) if mask is None else np.asarray(mask, bool)
  columns = np.stack([np.asarray(raw[c], np.float64) for c in _GROUP_COLUMNS],
                     axis=1)
  _, first, inverse = np.unique(columns, axis=0, return_index=True,
                                return_inverse=True)
  inverse = inverse.reshape(-1)
  per_group = [_info({k: v[i] for k, v in raw.items()}) for i in first]
  keys = list(dict.fromkeys(k for d in per_group for k in d))
  out = {}
  for key in keys:
    present = np.array([key in d for d in per_group])[inverse]
    value = next(d[key] for d in per_group if key in d)
    if key in raw and present.all():  # Passed through: one per balloon.
      column = np.asarray(raw[key]).astype(type(value))
    else:  # Derived from the group columns.
      column = _batch([per_group[g].get(key, value) for g in inverse])
    out[key] = column
    out[f'_{key}'] = mask & present
  return out


def _info(raw: Mapping[str, Any]) -> Dict[str, Any]:
  """`jax_env.info_dict` without `TimeLimit.truncated` (gymnasium's
  `truncated` says it)."""
  info = jax_env.info_dict(raw)
  info.pop('TimeLimit.truncated', None)
  return info


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


class _Compiled:
  """The jitted functions of one wind, for one balloon or a batch of them.

  `draw(keys, params)` is `LatexBalloonJaxEnv.draw`; `start(state, params)`
  measures the wind and returns (state, packed (obs, step_info, flight));
  `step(state, actions, params)` returns (changed state parts, packed (obs,
  reward, terminated, step_info, flight)); `unpack(name, packed)` splits a
  packed array on the host.

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
    self._layouts: Dict[str, _Layout] = {}
    # Batch shape -> (id of the params, futures); the id, not the params:
    # the process-wide compiled sets must not keep an env's ERA5 grid.
    self._ahead: Dict[Tuple[int, ...], Tuple[int, Dict[str, Any]]] = {}

    def over(fn, in_axes):
      return jax.vmap(fn, in_axes=in_axes) if batched else fn

    def pack(name, tree, lead):
      if name not in self._layouts:  # Recorded while tracing.
        self._layouts[name] = _Layout(tree, lead)
      return self._layouts[name].pack(tree, lead)

    def start(state, params):
      wind = env.wind_for(params)  # ERA5 if the params hold a grid.

      def one(state):
        state = _strong(jax_env.measure(state, wind))
        return state, (jax_env.observation(state, params, wind),
                       jax_env.step_info(state, params), state.flight)
      state, host = over(one, 0)(state)
      return state, pack('start', host, state.steps.shape)

    def step(state, actions, params):
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
    self.step = jit(step)

  def unpack(self, name: str, packed: Any) -> Any:
    return self._layouts[name].unpack(packed)

  def ahead(self, keys: Any, params: jax_env.EnvParams) -> None:
    """Compiles `start` and `step` for the flights of `draw(keys, params)`.

    Traces `draw` here (jit keeps the trace for the call that follows),
    then compiles the two in a background thread, once per batch shape and
    params object (a params object with a reused id is skipped: its calls
    then compile); a failure there is dropped (the call itself then
    compiles, or raises).
    """
    lead = tuple(np.shape(keys))[:-1]
    done = self._ahead.get(lead)
    if done is not None and done[0] == id(params):
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
    self._ahead[lead] = (id(params), {
        'start': pool.submit(
            lambda: self.start.lower(drawn, params).compile()),
        'step': pool.submit(
            lambda: self.step.lower(started, actions, params).compile())})

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
def _generative(batched: bool) -> _Compiled:
  """One compiled set per process for BLE's generative field."""
  return _Compiled(jax_env.LatexBalloonJaxEnv(normalize_actions=False), batched)


def _is_core_generative(factory: Any) -> bool:
  """Whether a wind factory is the default (the core's own field)."""
  module = sys.modules.get('ble_latex.ble.wind')
  return factory is None or (
      module is not None and factory is module.CoreGenerativeWindField)


class SeedRule:
  """The one seed/options rule of every Gymnasium env here (a mixin).

  Mixed in before `gymnasium.Env` / `gymnasium.vector.VectorEnv`, whose
  `reset` seeds `np_random`; `num_envs` is None for one balloon.
  """

  num_envs: Optional[int] = None

  def _episode_seeds(self, seed: Optional[int],
                     options: Optional[Mapping[str, Any]]) -> np.ndarray:
    """The seed rule: seeds s + i, or training seeds from `np_random`.

    Raises:
      ValueError: `seed` not None or an int with s + N - 1 < 2**32, or any
        `options`; nothing is changed.
    """
    count = 1 if self.num_envs is None else self.num_envs
    seeds_lib.validate_seed(seed)
    if seed is not None and int(seed) + count > seeds_lib.MAX_SEED:
      raise ValueError(f'seed + num_envs - 1 must be < 2**32 (balloon i flies '
                       f'seed + i), got seed {seed} with {count} envs')
    if options:
      raise ValueError(f'reset takes no options, got {dict(options)!r}')
    super().reset(seed=None if seed is None else int(seed))  # np_random.
    if seed is None:
      return self.np_random.integers(seeds_lib.TRAIN_SEED_LIMIT, size=count)
    return int(seed) + np.arange(count)


class _Balloons(SeedRule):
  """What the single and the vector env share (a mixin of both).

  Attributes:
    params: The env parameters (`jax_env.EnvParams`, checked).
    state: The core's `jax_env.EnvState` (a leading balloon axis in the
      vector env); None before the first reset.
    normalize_actions: Actions in [-1, 1]^3 mapped affinely onto the Box.
  """

  def _setup(self, params: Optional[jax_env.EnvParams],
             episode_steps: Optional[int], normalize_actions: bool,
             compiled: _Compiled) -> None:
    if episode_steps is not None:
      gin_values.check_int('episode_steps', episode_steps, minimum=1)
    with quiet.third_party_noise():
      params = (jax_env.params_from_gin() if params is None else
                jax_env.check_params(params))
    if episode_steps is not None:
      params = params.replace(episode_steps=int(episode_steps))
    self.params = params
    self.state: Optional[jax_env.EnvState] = None
    self._fns = compiled
    core = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
    self._box = core.action_space(params)
    self.normalize_actions = bool(normalize_actions)
    self._from_normalized = None
    self._single_action_space = self._box
    if self.normalize_actions:
      dtype = self._box.dtype.type
      self._single_action_space, _, self._from_normalized = (
          wrapper_utils.rescale_box(self._box, dtype(-1), dtype(1)))
    self._single_observation_space = core.observation_space(params)

  def box_actions(self, actions: Any) -> np.ndarray:
    """The controller's (a0, a1, a2) of actions of the action space.

    Raises:
      ValueError: See `validate_actions`; the env is unchanged.
    """
    if self._from_normalized is None:
      return validate_actions(actions, self.num_envs, self._box.low,
                              self._box.high)
    a = validate_actions(actions, self.num_envs, -np.ones(3), np.ones(3),
                         ' (normalize_actions=True)')
    return np.clip(self._from_normalized(a.astype(self._box.dtype)),
                   self._box.low, self._box.high).astype(np.float64)


class LatexBalloonGymnasiumEnv(_Balloons, gymnasium.Env):
  """`ble_latex/LatexBalloon-v0`: one latex balloon, gymnasium's API.

  Args:
    render_mode: None or 'rgb_array'.
    normalize_actions: Actions in [-1, 1]^3 mapped onto the Box.
    episode_steps: Strides per episode (the time limit); None: gin's
      `LatexBalloonEnv.episode_steps` (216).
    station_keeping_radius_km: Radius drawn by `render` (TW50's); None:
      gin's `LatexBalloonEnv.station_keeping_radius_km` (50). The reward's
      radius is BLE's `perciatelli_reward_function`'s.
    wind_field_factory: None (or `ble_latex.ble.wind.CoreGenerativeWindField`):
      BLE's generative field inside the core; `ble_latex.wind.era5.
      Era5WindField` (the class, gin's `@Era5WindField`, or a factory of its
      instances): its ERA5 grid in the params (`EnvParams.wind_grid`), flown
      in JAX; any other factory of a BLE `WindField` (third-party fields,
      subclasses) is flown through host callbacks. None reads gin's
      `LatexBalloonEnv.wind_field_factory`.
    params: `jax_env.EnvParams` to fly instead of the gin-bound ones.

  Attributes:
    flight: The balloon's `FlightState` after the last reset or step, as
      NumPy values by field name (the host copy the step brought back).
    start_date_time: Date and time of the flight's start (BLE's draw, or
      the external wind field's own).
    location_key: The key of BLE's station location draw.

  Raises:
    ValueError: An unknown `render_mode`, or a bad `episode_steps`,
      `station_keeping_radius_km` or `params` (`errors.ConfigError`).
    RuntimeError: Built in a process forked after JAX started.
  """

  metadata = {'render_modes': ['rgb_array'], 'render_fps': 4}
  num_envs = None

  def __init__(self, *, render_mode: Optional[str] = None,
               normalize_actions: bool = False,
               episode_steps: Optional[int] = None,
               station_keeping_radius_km: Optional[float] = None,
               wind_field_factory: Optional[Callable[[], Any]] = None,
               params: Optional[jax_env.EnvParams] = None):
    _check_render_mode(self, render_mode)
    self.render_mode = render_mode
    _check_not_forked_after_jax()
    bound = jax_env.episode()  # gin's `LatexBalloonEnv.*`.
    radius_name = 'station_keeping_radius_km'
    if station_keeping_radius_km is None:
      radius_name = 'gin binding LatexBalloonEnv.station_keeping_radius_km'
      station_keeping_radius_km = bound['station_keeping_radius_km']
    self.station_keeping_radius_km = gin_values.check_number(
        radius_name, station_keeping_radius_km, above=0.0)
    factory = (wind_field_factory if wind_field_factory is not None else
               bound['wind_field_factory'])
    self._wind_field = None
    compiled = _generative(batched=False)
    grid = None
    if jax_env.is_era5(factory):  # gin's @Era5WindField: ERA5 in JAX.
      grid = jax_env.era5_grid_from_gin(factory)
    elif not _is_core_generative(factory):
      field = factory()
      if jax_env.is_era5(field):  # An Era5WindField: its grid, in JAX.
        grid = jax_env.era5_grid(field)
      else:  # A third-party BLE WindField: host callbacks.
        # pylint: disable=g-import-not-at-top
        from ble_latex.ble import wind as ble_wind
        # pylint: enable=g-import-not-at-top
        self._wind_field = field
        compiled = _Compiled(jax_env.LatexBalloonJaxEnv(
            ble_wind.callback_wind(field), normalize_actions=False),
            batched=False)
    if grid is not None and params is not None:
      params = params.replace(wind_grid=grid)
    self._setup(params, episode_steps, normalize_actions, compiled)
    if grid is not None and self.params.wind_grid is not grid:
      self.params = jax_env.check_params(self.params.replace(wind_grid=grid))
    self.action_space = self._single_action_space
    self.observation_space = self._single_observation_space
    self.flight: Optional[Dict[str, np.ndarray]] = None
    self.start_date_time: Optional[dt.datetime] = None
    self.location_key: Optional[jax.Array] = None
    self._done = False
    self._path: List[Tuple[float, float, float, float]] = []
    self._figure = None

  check_action = _Balloons.box_actions  # `CheckedSyncVectorEnv`'s check.

  @property
  def host_wind_field(self) -> Any:
    """The BLE `WindField` flown through host callbacks, or None.

    None when the env's winds are JAX winds (the core's generative field,
    or ERA5 in `params.wind_grid`), which pure JAX code such as the
    planners can fly themselves (`wind_for(params)`).
    """
    return self._wind_field

  def reset(self, *, seed: Optional[int] = None,
            options: Optional[Mapping[str, Any]] = None
            ) -> Tuple[np.ndarray, Dict[str, Any]]:
    """Starts a new flight; see the module docstring for seeding.

    Args:
      seed: None (a training seed drawn from `np_random`) or an int s in
        [0, 2**32): the flight of s.
      options: Must be empty or None (the env takes no options).

    Returns:
      (observation [71] float32, info).

    Raises:
      ValueError: A bad `seed` or any `options`; nothing is changed.
    """
    seeds = self._episode_seeds(seed, options)
    return self.start(np.asarray(_arena_keys(seeds.astype(np.uint32)))[0])

  def start(self, arena_key: jax.Array) -> Tuple[np.ndarray, Dict[str, Any]]:
    """The flight of BLE's arena key (`reset(seed=s)` flies s's arena key).

    An external wind field is reset with the arena's wind key and start
    time; one that chooses its own start time (ERA5's `start_date_time`)
    sets the flight's date.
    """
    self._fns.ahead(arena_key, self.params)
    state, keys = self._fns.draw(arena_key, self.params)
    start = jax_env.START_EPOCH + dt.timedelta(
        seconds=int(state.start_time_offset_s))
    if self._wind_field is not None:
      self._wind_field.reset(keys['wind'], start)
      start = getattr(self._wind_field, 'start_date_time', None) or start
    self.start_date_time, self.location_key = start, keys['location']
    self._fns.wait('start')
    self.state, packed = self._fns.start(state, self.params)
    obs, raw, flight = self._fns.unpack('start', packed)
    self._set_flight(flight, first=True)
    self._done = False
    return obs, _info(raw)

  def step(self, action: Any
           ) -> Tuple[np.ndarray, float, bool, bool, Dict[str, Any]]:
    """One 20-minute action (see `box_actions` for what is accepted).

    Raises:
      ValueError: An action outside the action space; nothing changes.
      RuntimeError: Before `reset` or after the episode ended.
    """
    box = self.box_actions(action)
    if self._done:
      raise RuntimeError('step() called on a finished episode; call reset().')
    if self.state is None:
      raise RuntimeError('reset() must be called before step()')
    self._fns.wait('step')
    parts, packed = self._fns.step(self.state, box.astype(np.float32),
                                   self.params)
    self.state = self.state.replace(**parts)
    obs, reward, terminated, raw, flight = self._fns.unpack('step', packed)
    self._set_flight(flight)
    truncated = bool(raw['truncated'])
    self._done = bool(terminated) or truncated
    return obs, float(reward), bool(terminated), truncated, _info(raw)

  def measured_wind(self) -> Tuple[float, float]:
    """The ground-truth wind at the balloon (the measurement). # [m/s]"""
    u, v = jax.device_get((self.state.wind_u, self.state.wind_v))
    return float(u), float(v)

  def _set_flight(self, flight: Any, first: bool = False) -> None:
    self.flight = flight_values(flight)
    if self.render_mode is not None:
      self._path = ([] if first else self._path) + [
          flight_point(self.flight)]

  def render(self) -> Optional[np.ndarray]:
    """The flight so far as an (H, W, 3) uint8 image ('rgb_array'), or None."""
    if self.render_mode != 'rgb_array':
      return None
    self._figure = draw_flight(self._figure, self._path,
                               self.station_keeping_radius_km)
    return figure_rgb(self._figure)

  def close(self) -> None:
    self._figure = None
    super().close()

  def __str__(self) -> str:
    return f'{type(self).__name__}(LatexBalloon-v0 on the JAX core)'


def flight_values(flight: Any) -> Dict[str, np.ndarray]:
  """A `FlightState` (host or device values) as NumPy values by field name."""
  return {name: np.asarray(getattr(flight, name))
          for name in flight.__dataclass_fields__}


def flight_point(flight: Mapping[str, Any]) -> Tuple[float, float, float,
                                                     float]:
  """t [h], x [km], y [km], altitude [km] of a `FlightState`'s values."""
  return (float(flight['time_s']) / 3600.0, float(flight['x_m']) / 1000.0,
          float(flight['y_m']) / 1000.0, float(flight['altitude_m']) / 1000.0)


# `draw_flight` adds an inset around the station when the x/y view is wider
# than this many station radii, spanning +-_INSET_HALF radii.
_INSET_ABOVE = 6.0
_INSET_HALF = 3.0


def draw_flight(figure: Any, path: Sequence[Tuple[float, float, float, float]],
                radius_km: float) -> Any:
  """Draws a flight path (`flight_point`s) and the station circle.

  When the path spans more than `_INSET_ABOVE` station radii, an inset
  zoomed on the station (+-`_INSET_HALF` radii) keeps the circle visible.

  Args:
    figure: A matplotlib Figure to draw on, or None for a new one.
    path: (t [h], x [km], y [km], altitude [km]) points.
    radius_km: The station-keeping circle's radius. # [km]

  Returns:
    The figure (x/y path with the circle, altitude vs time).
  """
  # pylint: disable=g-import-not-at-top
  from matplotlib import figure as mpl_figure
  from matplotlib import patches as mpl_patches
  from matplotlib.backends import backend_agg
  # pylint: enable=g-import-not-at-top
  if figure is None:
    figure = mpl_figure.Figure(figsize=(8.0, 4.0), dpi=80,
                               layout='constrained')
    backend_agg.FigureCanvasAgg(figure)
  figure.clear()
  ax_xy, ax_alt = figure.subplots(1, 2, width_ratios=(1.0, 1.4))
  t, x, y, alt = (np.array(c, dtype=float).reshape(-1)
                  for c in zip(*path)) if path else (np.zeros(0),) * 4

  def draw_path(ax, half, lw, ms):  # Station circle and path, +-half km.
    ax.add_patch(mpl_patches.Circle((0.0, 0.0), radius_km, fill=False,
                                    color='k', ls='--', lw=1.0))
    ax.plot(0.0, 0.0, marker='+', color='k')
    if len(x):
      ax.plot(x, y, color='tab:blue', lw=lw)
      ax.plot(x[-1], y[-1], marker='o', color='tab:red', ms=ms)
    ax.set_xlim(-half, half)
    ax.set_ylim(-half, half)
    ax.set_aspect('equal')

  half = max(np.abs(np.concatenate([x, y])).max() if len(x) else 0.0,
             radius_km) * 1.1
  draw_path(ax_xy, half, lw=1.5, ms=5)
  ax_xy.set_xlabel('x [km]')
  ax_xy.set_ylabel('y [km]')
  ax_xy.set_title(f'{radius_km:g} km station', fontsize=9)
  if half > _INSET_ABOVE * radius_km:
    # The circle would be a few pixels: an inset zoomed on the station.
    zoom = _INSET_HALF * radius_km
    inset = ax_xy.inset_axes((0.62, 0.62, 0.36, 0.36))
    draw_path(inset, zoom, lw=1.0, ms=3)
    inset.set_xticks([])
    inset.set_yticks([])
    inset.set_title(f'+-{zoom:g} km', fontsize=7, pad=2)
    ax_xy.indicate_inset_zoom(inset, edgecolor='0.5')
  if len(t):
    ax_alt.plot(t, alt, color='tab:blue', lw=1.5)
  ax_alt.set_xlabel('time [h]')
  ax_alt.set_ylabel('altitude [km]')
  ax_alt.grid(alpha=0.3)
  return figure


def figure_rgb(figure: Any) -> np.ndarray:
  """A drawn figure as an (H, W, 3) uint8 image."""
  figure.canvas.draw()
  return np.asarray(figure.canvas.buffer_rgba())[:, :, :3].copy()


class LatexBalloonVectorEnv(_Balloons, gymnasium.vector.VectorEnv):
  """N latex balloons in one jitted, vmapped call (`make_vec`'s default).

  Args:
    num_envs: Number of balloons N.
    normalize_actions: Actions in [-1, 1]^3, mapped affinely onto the Box.
    episode_steps: Strides per episode (the core's time limit, `truncated`);
      None: gin's `LatexBalloonEnv.episode_steps` (216).
    max_episode_steps: As gymnasium's `TimeLimit` on the single env: the
      core's time limit becomes min(episode_steps, max_episode_steps).
    params: `jax_env.EnvParams` to fly (checked, `jax_env.check_params`);
      `jax_env.params_from_gin()` if None.
    render_mode: Only None (use vectorization_mode='sync' to render).

  Attributes:
    episode_seeds: Each balloon's current seed.

  Raises:
    ValueError: `num_envs` not an int >= 1, a `render_mode` other than
      None, or a bad `episode_steps`, `max_episode_steps` or `params`
      (`errors.ConfigError`).
    RuntimeError: Built in a process forked after JAX started.
  """

  metadata = {'autoreset_mode': AutoresetMode.SAME_STEP, 'render_modes': []}

  def __init__(self, num_envs: int = 1, *, normalize_actions: bool = False,
               episode_steps: Optional[int] = None,
               max_episode_steps: Optional[int] = None,
               params: Optional[jax_env.EnvParams] = None,
               render_mode: Optional[str] = None):
    if (isinstance(num_envs, bool) or
        not isinstance(num_envs, (int, np.integer)) or num_envs < 1):
      raise ValueError(f'num_envs must be an int >= 1, got {num_envs!r}')
    if render_mode is not None:
      raise ValueError(
          f'render_mode={render_mode!r}: the batched vector env does not '
          "render; use gymnasium.make_vec(..., vectorization_mode='sync', "
          "render_mode='rgb_array') for per-balloon frames")
    _check_not_forked_after_jax()
    self.num_envs = int(num_envs)
    self._setup(params, episode_steps, normalize_actions,
                _generative(batched=True))
    if max_episode_steps is not None:
      limit = gin_values.check_int('max_episode_steps', max_episode_steps,
                                   minimum=1)
      self.params = self.params.replace(
          episode_steps=min(self.params.episode_steps, limit))
    self.render_mode = None
    self.single_action_space = self._single_action_space
    self.single_observation_space = self._single_observation_space
    self.action_space = vector_utils.batch_space(self.single_action_space,
                                                 self.num_envs)
    self.observation_space = vector_utils.batch_space(
        self.single_observation_space, self.num_envs)
    self.episode_seeds = np.zeros(self.num_envs, np.int64)

  def reset(self, *, seed: Optional[int] = None,
            options: Optional[Mapping[str, Any]] = None
            ) -> Tuple[np.ndarray, Dict[str, Any]]:
    """New flights for all balloons (seed s: balloon i flies seed s + i).

    Args:
      seed: None (training seeds drawn from `np_random`) or an int s with
        s + N - 1 < 2**32.
      options: Must be empty or None (the env takes no options).

    Returns:
      (observations [N, 71] float32, vector info).

    Raises:
      ValueError: A bad `seed` or any `options`; nothing is changed.
    """
    seeds = self._episode_seeds(seed, options)
    self.state, obs, raw = self._new_flights(seeds, ahead=True)
    self.episode_seeds = np.asarray(seeds, np.int64)
    return obs, info_arrays(raw)

  def step(self, actions: Any) -> Tuple[np.ndarray, np.ndarray, np.ndarray,
                                        np.ndarray, Dict[str, Any]]:
    """One 20-minute action for every balloon; auto-resets ended episodes."""
    box = self.box_actions(actions)
    if self.state is None:
      raise RuntimeError('reset() must be called before step()')
    self._fns.wait('step')
    parts, packed = self._fns.step(self.state, box.astype(np.float32),
                                   self.params)
    self.state = self.state.replace(**parts)
    obs, reward, terminated, raw, _ = self._fns.unpack('step', packed)
    terminated = terminated.astype(bool)
    truncated = raw['truncated'].astype(bool)
    ended = terminated | truncated
    reward = reward.astype(np.float64)
    if not ended.any():
      return obs, reward, terminated, truncated, info_arrays(raw)
    final_obs = np.full(self.num_envs, None, dtype=object)
    for i in np.flatnonzero(ended):
      final_obs[i] = obs[i].copy()
    final_info = info_arrays(raw, mask=ended)
    seeds = self.np_random.integers(seeds_lib.TRAIN_SEED_LIMIT,
                                    size=int(ended.sum()))
    self._reset_some(ended, seeds, obs, raw)
    info = info_arrays(raw)
    info.update({'final_obs': final_obs, '_final_obs': ended.copy(),
                 'final_info': final_info, '_final_info': ended.copy()})
    return obs, reward, terminated, truncated, info

  def close_extras(self, **kwargs: Any) -> None:
    del kwargs
    self.state = None

  def _new_flights(self, seeds: np.ndarray, ahead: bool = False
                   ) -> Tuple[Any, np.ndarray, Any]:
    """(state, obs, step_info) of new flights from seeds, batched.

    `ahead`: also compile this batch's `step` (`_Compiled.ahead`).
    """
    keys = _arena_keys(jnp.asarray(np.asarray(seeds, np.uint32)))
    if ahead:
      self._fns.ahead(keys, self.params)
    state, _ = self._fns.draw(keys, self.params)
    self._fns.wait('start')
    state, packed = self._fns.start(state, self.params)
    obs, raw, _ = self._fns.unpack('start', packed)
    return state, obs, raw

  def _reset_some(self, ended: np.ndarray, seeds: np.ndarray,
                  obs: np.ndarray, raw: Dict[str, np.ndarray]) -> None:
    """New flights where `ended` (into `obs` and `raw` in place)."""
    index = np.flatnonzero(ended)
    if self.num_envs > RESET_CHUNK and len(index) <= RESET_CHUNK:
      pad = RESET_CHUNK - len(index)
      index_p = np.concatenate([index, np.full(pad, index[0])])
      state, new_obs, new_raw = self._new_flights(
          np.concatenate([seeds, np.full(pad, seeds[0])]))
      self.state = _scatter(self.state, jnp.asarray(index_p), state)
      take = slice(0, len(index))
    else:
      all_seeds = np.zeros(self.num_envs, np.int64)
      all_seeds[index] = seeds
      state, new_obs, new_raw = self._new_flights(all_seeds)
      self.state = _select(jnp.asarray(ended), state, self.state)
      take = index
    obs[ended] = new_obs[take]
    for key, value in new_raw.items():
      raw[key][ended] = value[take]
    self.episode_seeds[ended] = seeds


@jax.jit
def _arena_keys(seeds: jax.Array) -> jax.Array:
  """`jax_env.arena_key(jax.random.PRNGKey(s))` of each seed (one program)."""
  return jax.vmap(lambda s: jax_env.arena_key(jax.random.PRNGKey(s)))(seeds)


@jax.jit
def _select(mask: jax.Array, new: Any, old: Any) -> Any:
  def pick(n, o):
    return jnp.where(mask.reshape(mask.shape + (1,) * (n.ndim - 1)), n, o)
  return jax.tree.map(pick, new, old)


@jax.jit
def _scatter(old: Any, index: jax.Array, new: Any) -> Any:
  return jax.tree.map(lambda o, n: o.at[index].set(n), old, new)


def make_vector_env(env_id: str, num_envs: int = 1, *,
                    asynchronous: bool = False, context: str = 'spawn',
                    **env_kwargs: Any) -> gymnasium.vector.VectorEnv:
  """N balloons of `env_id` as one vector env of N independent envs.

  `CheckedSyncVectorEnv`, or with `asynchronous=True` an `AsyncVectorEnv`
  (one process per balloon, each worker checking its own actions).

  Args:
    env_id: A registered `ble_latex/...` id.
    num_envs: Number of balloons.
    asynchronous: One worker process per balloon (`AsyncVectorEnv`).
    context: multiprocessing start method of those workers. 'spawn' because
      the env runs JAX, which deadlocks in a child forked after it started,
      and AsyncVectorEnv builds one env in the parent before it forks; 'fork'
      raises a RuntimeError in the workers ('forkserver' works too).
    **env_kwargs: Passed to `gymnasium.make` for each balloon.

  Returns:
    A gymnasium vector env; `reset(seed=s)` seeds balloon i with s + i.
  """
  # The spec itself (not the id) travels to spawned workers: they need not
  # import ble_latex first for the id to be known.
  env_fn = functools.partial(gymnasium.make, gymnasium.spec(env_id),
                             **env_kwargs)
  if asynchronous:
    return gymnasium.vector.AsyncVectorEnv([env_fn] * num_envs,
                                           context=context)
  return CheckedSyncVectorEnv([env_fn] * num_envs)


def make_vector_latex_balloon(num_envs: int = 1, *, asynchronous: bool = False,
                              context: str = 'spawn', **env_kwargs: Any
                              ) -> gymnasium.vector.VectorEnv:
  """`make_vec('ble_latex/LatexBalloon-v0', num_envs=N)`: the batched core.

  `LatexBalloonVectorEnv`; with `asynchronous=True` an `AsyncVectorEnv` of
  single envs (`make_vector_env`).

  Args:
    num_envs: Number of balloons N.
    asynchronous: One worker process per balloon (`AsyncVectorEnv`)
      instead of the batched `LatexBalloonVectorEnv`.
    context: multiprocessing start method of the workers (asynchronous
      only; see `make_vector_env`).
    **env_kwargs: Passed to `LatexBalloonVectorEnv`, or to
      `gymnasium.make` for each balloon when asynchronous.

  Returns:
    A gymnasium vector env; `reset(seed=s)` seeds balloon i with s + i.
  """
  if asynchronous:
    return make_vector_env('ble_latex/LatexBalloon-v0', num_envs,
                           asynchronous=True, context=context, **env_kwargs)
  with quiet.third_party_noise():
    return LatexBalloonVectorEnv(num_envs, **env_kwargs)
