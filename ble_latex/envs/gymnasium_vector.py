# coding=utf-8
"""`gymnasium.make_vec('ble_latex/LatexBalloon-v0', num_envs=N)`: one batched core.

`LatexBalloonVectorEnv` steps all N balloons in one jitted, vmapped call of
the functional core (`jax_env.LatexBalloonJaxEnv.advance` and
`jax_env.observation`), the same functions `host_env.FlightDriver` runs for
one balloon (the gym and Gymnasium envs). It is a `gymnasium.vector.VectorEnv`
with gymnasium's conventions:

- `reset(seed=s)` flies balloon i in the world of seed s + i (the flight of
  `gymnasium.make('ble_latex/LatexBalloon-v0').reset(seed=s + i)`) and seeds
  `np_random` with s; `reset()` draws N training seeds in [0, 1 000 000) from
  `np_random`. `episode_seeds` holds each balloon's current seed.
- `step(actions)`, actions of shape (N, 3), returns `(obs, reward,
  terminated, truncated, info)` as arrays; out of sand/helium, burst or
  grounded are `terminated`, the core's time limit (`episode_steps`, and
  `max_episode_steps` if given) `truncated`.
- Auto-reset in the same step (`AutoresetMode.SAME_STEP`, the core's gymnax
  convention): a balloon whose episode ended gets a new flight from a seed
  drawn from `np_random` at once; `obs` and `info` are the new flight's,
  `info['final_obs']` / `info['final_info']` (with masks `_final_obs`,
  `_final_info`) hold the last observation and info of the ended episode.
- `info` has the single env's keys (`host_env.info_dict`, the one source of
  the info), each an array over balloons with gymnasium's `_key` mask.
- Actions are checked at the boundary: shape (N, 3), finite, inside the Box
  (or [-1, 1]^3 with `normalize_actions=True`, mapped as the single env
  maps them); anything else is a ValueError naming the balloon and the
  component, and nothing changes.
"""

import functools
from typing import Any, Callable, Dict, Mapping, Optional, Sequence, Tuple

import gymnasium
from gymnasium.vector import utils as vector_utils
from gymnasium.vector.vector_env import AutoresetMode
from gymnasium.wrappers import utils as wrapper_utils
import jax
from jax import lax
import jax.numpy as jnp
import numpy as np

from ble_latex import gin_values
from ble_latex.envs import host_env
from ble_latex.envs import jax_env
from ble_latex.envs import seeds as seeds_lib

# Names of the action components in messages (as the single env's).
COMPONENTS = ('a0 (desired altitude [m])', 'a1 (time factor)',
              'a2 (float flag)')
# Balloons reset in one padded call when only a few episodes end (N > this);
# more at once reset the whole batch (two compiled sizes at most).
RESET_CHUNK = 16
# step_info columns the derived (non pass-through) info entries depend on;
# `info_arrays` calls `host_env.info_dict` once per distinct combination
# (tests check the result against info_dict of every balloon).
_GROUP_COLUMNS = ('status', 'decision', 'truncated', 'time_limit', 'time_s')
# Dropped as in the single env (gymnasium's `truncated` says it).
_DROPPED_KEYS = ('TimeLimit.truncated',)


def observation_space() -> gymnasium.spaces.Box:
  """One balloon's observation space: the 71 features in [-1, 1]."""
  return gymnasium.spaces.Box(-1.0, 1.0,
                              (jax_env.LatexBalloonJaxEnv.num_features,),
                              np.float32)


def action_space() -> gymnasium.spaces.Box:
  """One balloon's raw action space (a0 [m], a1, a2), the controller's Box."""
  return gymnasium.spaces.Box(np.asarray(jax_env.ACTION_LOW, np.float32),
                              np.asarray(jax_env.ACTION_HIGH, np.float32),
                              dtype=np.float32)


def _strong(tree: Any) -> Any:
  """`tree` without weak types (so a step's input and output avals match)."""
  return jax.tree.map(lambda x: lax.convert_element_type(x, x.dtype), tree)


class _BatchedCore:
  """The jitted, vmapped core functions (one set per process)."""

  def __init__(self, env: jax_env.LatexBalloonJaxEnv):
    self.env = env

    def reset_one(seed, params):
      obs, state = env.reset(jax.random.PRNGKey(seed), params)
      return _strong(state), obs, jax_env.step_info(state, params)

    def step_one(state, action, params):
      obs, state, reward, terminated, info = env.step_env(None, state, action,
                                                          params)
      return _strong(state), obs, reward, terminated | info['time_limit'], info

    def select(mask, new, old):
      def pick(n, o):
        return jnp.where(mask.reshape(mask.shape + (1,) * (n.ndim - 1)), n, o)
      return jax.tree.map(pick, new, old)

    def scatter(old, index, new):
      return jax.tree.map(lambda o, n: o.at[index].set(n), old, new)

    self.reset = jax.jit(jax.vmap(reset_one, in_axes=(0, None)))
    self.step = jax.jit(jax.vmap(step_one, in_axes=(0, 0, None)))
    self.select = jax.jit(select)
    self.scatter = jax.jit(scatter)


@functools.lru_cache(maxsize=1)
def _core() -> _BatchedCore:
  return _BatchedCore(jax_env.LatexBalloonJaxEnv())


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
    For each key of `host_env.info_dict` (but `TimeLimit.truncated`): an
    array over balloons (float64 / bool, or object for strings and
    timedeltas) and its mask under `_key`.
  """
  n = len(raw['status'])
  mask = np.ones(n, bool) if mask is None else np.asarray(mask, bool)
  columns = np.stack([np.asarray(raw[c], np.float64) for c in _GROUP_COLUMNS],
                     axis=1)
  groups, first, inverse = np.unique(columns, axis=0, return_index=True,
                                     return_inverse=True)
  inverse = inverse.reshape(-1)
  per_group = [host_env.info_dict({k: v[i] for k, v in raw.items()})
               for i in first]
  del groups
  keys = list(dict.fromkeys(k for d in per_group for k in d
                            if k not in _DROPPED_KEYS))
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


def validate_actions(actions: Any, num_envs: int, low: np.ndarray,
                     high: np.ndarray, what: str = '') -> np.ndarray:
  """Checks a batch of actions; returns it as float64 of shape (N, 3).

  Raises:
    ValueError: not numeric, shape other than (N, 3), NaN/inf, or outside
      [low, high], naming the balloon and component; `what` is appended
      (e.g. '(normalize_actions=True)').
  """
  try:
    kind = np.asarray(actions).dtype.kind
    a = np.asarray(actions, dtype=np.float64) if kind in 'iuf' else None
  except (TypeError, ValueError, OverflowError):
    a = None
  if a is None:
    raise ValueError(f'actions must be numbers of shape ({num_envs}, 3) '
                     f'(a0, a1, a2 per balloon){what}, got {actions!r}')
  if a.shape != (num_envs, 3):
    raise ValueError(f'actions must have shape ({num_envs}, 3) (a0, a1, a2 '
                     f'per balloon){what}, got shape {a.shape}')
  bad = ~np.isfinite(a)
  if bad.any():
    i, j = np.argwhere(bad)[0]
    raise ValueError(f'actions[{i}] {COMPONENTS[j]} must be finite{what}, '
                     f'got {a[i, j]}')
  bad = (a < low) | (a > high)
  if bad.any():
    i, j = np.argwhere(bad)[0]
    raise ValueError(f'actions[{i}] {COMPONENTS[j]} must be in '
                     f'[{low[j]:g}, {high[j]:g}]{what}, got {a[i, j]}')
  return a


def validate_each(actions: Any,
                  checks: Sequence[Callable[[Any], Any]]) -> None:
  """Checks every balloon's action before any balloon is stepped.

  For vector envs of independent single envs (`CheckedSyncVectorEnv`):
  balloon i's action goes through `checks[i]`, the single env's own check
  (the one the env's `step` applies), so a bad action for one balloon
  leaves every balloon unstepped.

  Args:
    actions: One action per balloon (a sequence or an array with a leading
      balloon axis).
    checks: Per balloon, a function that raises ValueError for a bad action.

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
  `check_action` (`validate_each`): a bad action raises a ValueError naming
  the balloon, and no balloon has moved.
  """

  def step(self, actions: Any) -> Tuple[Any, np.ndarray, np.ndarray,
                                        np.ndarray, Dict[str, Any]]:
    validate_each(actions,
                  [env.unwrapped.check_action for env in self.envs])
    return super().step(actions)


class LatexBalloonVectorEnv(gymnasium.vector.VectorEnv):
  """N latex balloons on the batched core (`make_vec`'s default).

  Args:
    num_envs: Number of balloons N.
    normalize_actions: Actions in [-1, 1]^3, mapped affinely onto the Box
      (as `ble_latex/LatexBalloon-v0` with `normalize_actions=True`).
    episode_steps: Strides per episode (the core's time limit, `truncated`);
      None: gin's `LatexBalloonEnv.episode_steps` (216).
    max_episode_steps: An extra limit, as gymnasium's `TimeLimit` on the
      single env (`truncated` once a balloon has flown that many steps).
    params: `jax_env.EnvParams` to fly (checked, `jax_env.check_params`);
      `jax_env.params_from_gin()` if None.
    render_mode: Only None (use vectorization_mode='sync' to render).
  """

  metadata = {'autoreset_mode': AutoresetMode.SAME_STEP, 'render_modes': []}

  def __init__(self, num_envs: int = 1, *, normalize_actions: bool = False,
               episode_steps: Optional[int] = None,
               max_episode_steps: Optional[int] = None,
               params: Optional[jax_env.EnvParams] = None,
               render_mode: Optional[str] = None):
    if (isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer))
        or num_envs < 1):
      raise ValueError(f'num_envs must be an int >= 1, got {num_envs!r}')
    if render_mode is not None:
      raise ValueError(
          f'render_mode={render_mode!r}: the batched vector env does not '
          "render; use gymnasium.make_vec(..., vectorization_mode='sync', "
          "render_mode='rgb_array') for per-balloon frames")
    for name, value in (('episode_steps', episode_steps),
                        ('max_episode_steps', max_episode_steps)):
      if value is not None:
        gin_values.check_int(name, value, minimum=1)
    self.num_envs = int(num_envs)
    params = (jax_env.params_from_gin() if params is None else
              jax_env.check_params(params))
    if episode_steps is not None:  # Checked above.
      params = params.replace(episode_steps=int(episode_steps))
    self.params = params
    self.max_episode_steps = (None if max_episode_steps is None else
                              int(max_episode_steps))
    self.render_mode = None
    self.normalize_actions = bool(normalize_actions)
    self._box = action_space()
    if self.normalize_actions:
      dtype = self._box.dtype.type
      single_action, _, self._from_normalized = wrapper_utils.rescale_box(
          self._box, dtype(-1), dtype(1))
    else:
      single_action, self._from_normalized = self._box, None
    self.single_action_space = single_action
    self.single_observation_space = observation_space()
    self.action_space = vector_utils.batch_space(single_action, self.num_envs)
    self.observation_space = vector_utils.batch_space(
        self.single_observation_space, self.num_envs)
    self._core = _core()
    self._state: Optional[jax_env.EnvState] = None
    self._elapsed = np.zeros(self.num_envs, np.int64)
    self.episode_seeds = np.zeros(self.num_envs, np.int64)

  # -- gymnasium API. --------------------------------------------------------
  def reset(self, *, seed: Optional[int] = None,
            options: Optional[Mapping[str, Any]] = None
            ) -> Tuple[np.ndarray, Dict[str, Any]]:
    """New flights for all balloons (seed s: balloon i flies seed s + i).

    Raises:
      ValueError: `seed` not None or an int with s + N - 1 < 2**32, or any
        `options`; nothing is changed.
    """
    seeds_lib.validate_seed(seed)
    if seed is not None and int(seed) + self.num_envs > seeds_lib.MAX_SEED:
      raise ValueError(f'seed + num_envs - 1 must be < 2**32 (balloon i flies '
                       f'seed + i), got seed {seed} with {self.num_envs} envs')
    if options:
      raise ValueError(f'reset takes no options, got {dict(options)!r}')
    super().reset(seed=None if seed is None else int(seed))
    if seed is None:
      episode_seeds = self.np_random.integers(seeds_lib.TRAIN_SEED_LIMIT,
                                              size=self.num_envs)
    else:
      episode_seeds = int(seed) + np.arange(self.num_envs)
    state, obs, raw = self._core.reset(self._seeds(episode_seeds),
                                       self.params)
    obs, raw = jax.device_get((obs, raw))
    self._state = state
    self._elapsed[:] = 0
    self.episode_seeds = np.asarray(episode_seeds, np.int64)
    return np.array(obs), info_arrays(raw)

  def step(self, actions: Any) -> Tuple[np.ndarray, np.ndarray, np.ndarray,
                                        np.ndarray, Dict[str, Any]]:
    """One 20-minute action for every balloon; auto-resets ended episodes."""
    box = self.box_actions(actions)
    if self._state is None:
      raise RuntimeError('reset() must be called before step()')
    state, obs, reward, done, raw = self._core.step(
        self._state, jnp.asarray(box, jnp.float32), self.params)
    self._state = state
    obs, reward, done, raw = jax.device_get((obs, reward, done, raw))
    obs = np.array(obs)
    raw = {k: np.array(v) for k, v in raw.items()}
    self._elapsed += 1
    truncated = raw['truncated'].astype(bool)
    # The core's done is a terminal status or its time limit.
    terminated = np.asarray(done, bool) & ~truncated
    if self.max_episode_steps is not None:
      truncated |= self._elapsed >= self.max_episode_steps
    ended = terminated | truncated
    if not ended.any():
      return (obs, reward.astype(np.float64), terminated, truncated,
              info_arrays(raw))
    final_obs = np.full(self.num_envs, None, dtype=object)
    for i in np.flatnonzero(ended):
      final_obs[i] = obs[i].copy()
    final_info = info_arrays(raw, mask=ended)
    new_seeds = self.np_random.integers(seeds_lib.TRAIN_SEED_LIMIT,
                                        size=int(ended.sum()))
    new_obs, new_raw = self._reset_some(ended, new_seeds)
    obs[ended] = new_obs
    for key, value in new_raw.items():
      raw[key][ended] = value
    self._elapsed[ended] = 0
    self.episode_seeds[ended] = new_seeds
    info = info_arrays(raw)
    info.update({'final_obs': final_obs, '_final_obs': ended.copy(),
                 'final_info': final_info, '_final_info': ended.copy()})
    return obs, reward.astype(np.float64), terminated, truncated, info

  def close_extras(self, **kwargs: Any) -> None:
    del kwargs
    self._state = None

  # -- Helpers. --------------------------------------------------------------
  def box_actions(self, actions: Any) -> np.ndarray:
    """The controller's (a0, a1, a2) per balloon, validated (N, 3) float64.

    Raises:
      ValueError: See `validate_actions`; the env is unchanged.
    """
    if self._from_normalized is None:
      return validate_actions(actions, self.num_envs, self._box.low,
                              self._box.high)
    a = validate_actions(actions, self.num_envs, -np.ones(3), np.ones(3),
                         ' (normalize_actions=True)')
    box = self._box
    return np.clip(self._from_normalized(a.astype(box.dtype)), box.low,
                   box.high).astype(np.float64)

  @property
  def state(self) -> Optional[jax_env.EnvState]:
    """The batched core state (`jax_env.EnvState` with a leading N axis)."""
    return self._state

  @staticmethod
  def _seeds(values: np.ndarray) -> jax.Array:
    return jnp.asarray(np.asarray(values, np.uint32))

  def _reset_some(self, ended: np.ndarray, new_seeds: np.ndarray
                  ) -> Tuple[np.ndarray, Dict[str, np.ndarray]]:
    """New flights where `ended`; returns their observations and step_info."""
    index = np.flatnonzero(ended)
    core = self._core
    if self.num_envs > RESET_CHUNK and len(index) <= RESET_CHUNK:
      pad = RESET_CHUNK - len(index)
      index_p = np.concatenate([index, np.full(pad, index[0])])
      seeds_p = np.concatenate([new_seeds, np.full(pad, new_seeds[0])])
      state, obs, raw = core.reset(self._seeds(seeds_p), self.params)
      self._state = core.scatter(self._state, jnp.asarray(index_p), state)
      obs, raw = jax.device_get((obs, raw))
      take = slice(0, len(index))
    else:
      all_seeds = np.zeros(self.num_envs, np.int64)
      all_seeds[index] = new_seeds
      state, obs, raw = core.reset(self._seeds(all_seeds), self.params)
      self._state = core.select(jnp.asarray(ended), state, self._state)
      obs, raw = jax.device_get((obs, raw))
      take = index
    return (np.asarray(obs)[take],
            {k: np.asarray(v)[take] for k, v in raw.items()})


def make_vector_env(num_envs: int = 1, **kwargs: Any) -> LatexBalloonVectorEnv:
  """`LatexBalloonVectorEnv(num_envs, **kwargs)`."""
  return LatexBalloonVectorEnv(num_envs, **kwargs)
