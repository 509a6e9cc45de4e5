# coding=utf-8
"""Vector envs of `ble_latex/LatexBalloon-v0`: N balloons under Gymnasium.

`LatexBalloonVectorEnv` (`gymnasium.make_vec`'s default) flies N balloons in
one jitted, vmapped call: the single env's base (`gymnasium_env.Balloons`:
one action check, one seed rule) with a balloon axis. It resets ended
balloons in the same step (`AutoresetMode.SAME_STEP`, the core's gymnax
convention) from seeds drawn from `np_random`, with `info['final_obs']` /
`info['final_info']`; `info` holds the single env's keys as arrays over
balloons with gymnasium's `_key` masks (`info_arrays`). `reset(seed=s)`
flies s + i on balloon i; `reset(seed=[s0, s1, ...])` one seed (or None)
per balloon, as gymnasium's `VectorEnv.reset` takes them.

`make_vector_env` builds N independent single envs instead
(`CheckedSyncVectorEnv`, which checks every balloon's action before it
steps any, or an `AsyncVectorEnv` of spawned workers): the vector entry
point of the discrete id, and of the continuous one with
`asynchronous=True`.
"""

import functools
from typing import (Any, Callable, Dict, Mapping, Optional, Sequence, Tuple,
                    Union)

import gymnasium
from gymnasium.vector import utils as vector_utils
from gymnasium.vector.vector_env import AutoresetMode
import numpy as np

from ble_latex import quiet
from ble_latex.envs import gymnasium_env
from ble_latex.envs import seeds as seeds_lib

with quiet.third_party_noise():
  # pylint: disable=g-import-not-at-top
  import jax
  import jax.numpy as jnp
  from ble_latex import gin_values
  from ble_latex.envs import env_types
  from ble_latex.envs import gymnasium_compile as compile_lib
  from ble_latex.envs import jax_env
  # pylint: enable=g-import-not-at-top

# The vector env resets a few ended balloons in one padded call (N > this);
# more at once reset the whole batch (two compiled sizes at most).
RESET_CHUNK = 16
# step_info columns the derived (non pass-through) info entries depend on;
# `info_arrays` calls `jax_env.info_dict` once per distinct combination.
_GROUP_COLUMNS = ('status', 'decision', 'truncated', 'time_limit', 'time_s')


def check_num_envs(num_envs: Any) -> int:
  """`num_envs` as an int; ValueError unless it is an int in [1, N_max].

  N_max is the functional rollout's `jax_env.MAX_ROLLOUT_BALLOONS` (65 536),
  checked before any balloon, space or env is allocated.
  """
  most = jax_env.MAX_ROLLOUT_BALLOONS
  if (isinstance(num_envs, (bool, np.bool_)) or
      not isinstance(num_envs, (int, np.integer)) or
      not 1 <= num_envs <= most):
    raise ValueError(f'num_envs must be an int in [1, {most}], got '
                     f'{num_envs!r}')
  return int(num_envs)


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
  `check_action` (`validate_each`). `reset` takes gymnasium's seeds (None,
  an int s: s + i, or a list of one int or None per balloon), each checked
  by its env's seed rule, and refuses options that are not a mapping in
  one line.
  """

  def reset(self, *, seed: Union[None, int, Sequence[Optional[int]]] = None,
            options: Optional[Mapping[str, Any]] = None
            ) -> Tuple[Any, Dict[str, Any]]:
    if options is not None and not isinstance(options, Mapping):
      gymnasium_env.check_options(options)  # Raises the one-line error.
    if not isinstance(seed, (list, tuple, np.ndarray)):
      seeds_lib.validate_seed(seed)
      seed = None if seed is None else int(seed)
    elif np.ndim(seed) != 1 or len(seed) != self.num_envs:
      raise ValueError(f'seed must be None, an int or a list of one seed per '
                       f'balloon ({self.num_envs}), got {seed!r}')
    return super().reset(seed=seed, options=options)

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
  per_group = [gymnasium_env.single_info({k: v[i] for k, v in raw.items()})
               for i in first]
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


class LatexBalloonVectorEnv(gymnasium_env.Balloons,
                            gymnasium.vector.VectorEnv):
  """N latex balloons in one jitted, vmapped call (`make_vec`'s default).

  Args:
    num_envs: Number of balloons N.
    normalize_actions: Actions in [-1, 1]^3, mapped affinely onto the Box.
    episode_steps: Strides per episode (the core's time limit, `truncated`);
      None: gin's `latex_episode.episode_steps` (216).
    max_episode_steps: As gymnasium's `TimeLimit` on the single env: the
      core's time limit becomes min(episode_steps, max_episode_steps).
    params: `env_types.EnvParams` to fly (checked, `env_params.check_params`);
      `env_params.params_from_gin()` if None.
    render_mode: Only None (use vectorization_mode='sync' to render).
    wind_file: A wind file every balloon flies (`winds.grid_from_file`).

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
               params: Optional[env_types.EnvParams] = None,
               render_mode: Optional[str] = None, wind_file: Any = None):
    num_envs = check_num_envs(num_envs)
    if render_mode is not None:
      raise ValueError(
          f'render_mode={render_mode!r}: the batched vector env does not '
          "render; use gymnasium.make_vec(..., vectorization_mode='sync', "
          "render_mode='rgb_array') for per-balloon frames")
    compile_lib.check_not_forked_after_jax()
    self.num_envs = int(num_envs)
    self._setup(params, episode_steps, normalize_actions,
                compile_lib.generative(batched=True), wind_file=wind_file)
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

  def reset(self, *, seed: Union[None, int, Sequence[Optional[int]]] = None,
            options: Optional[Mapping[str, Any]] = None
            ) -> Tuple[np.ndarray, Dict[str, Any]]:
    """New flights for all balloons (seed s: balloon i flies seed s + i).

    Args:
      seed: None (training seeds drawn from `np_random`), an int s with
        s + N - 1 < 2**32, or a list of N seeds, each an int in [0, 2**32)
        or None (a training seed drawn from `np_random`, seeded by the
        given ones), as gymnasium's `VectorEnv.reset` takes them.
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
    obs, reward, terminated, raw, _ = self._step(self.check_action(actions))
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

    `ahead`: also compile this batch's `step`
    (`gymnasium_compile.Compiled.ahead`).
    """
    keys = compile_lib.arena_keys(jnp.asarray(np.asarray(seeds, np.uint32)))
    if ahead:
      self._fns.ahead(keys, self.params, self.normalize_actions)
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
  num_envs = check_num_envs(num_envs)
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
