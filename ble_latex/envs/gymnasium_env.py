# coding=utf-8
"""`ble_latex/LatexBalloon-v0`: one latex balloon under Gymnasium's API.

`LatexBalloonGymnasiumEnv` is the host wrapper of `jax_env.LatexBalloonJaxEnv`
for one balloon; the vector env (`gymnasium_vector.LatexBalloonVectorEnv`)
shares its base (`Balloons`): one action check (`validate_actions`), one seed
rule (`SeedRule`) and one set of compiled functions
(`gymnasium_compile.Compiled`). A step goes wrapper `step` -> the action
check -> the jitted step (`Compiled.step`; [-1, 1]^3 actions mapped onto the
Box there by `jax_env.to_box`) -> `jax_env.LatexBalloonJaxEnv.step_env` ->
`flight.dynamics.step`. Neither imports gym, `ble_latex.ble`, BLE,
TensorFlow nor Dopamine; both read the env's gin names
(`env_params.params_from_gin`).

- `reset(seed=None, options=None)` returns `(obs, info)`. The flight of seed
  s is the flight of `gym.make('LatexBalloon-v0').reset(seed=s)` (and of
  `ble-latex-eval`'s seed s): the core's key `jax.random.PRNGKey(s)`.
  Without a seed, seeds are drawn from `np_random` among the training seeds
  [0, 1 000 000) (never a held-out eval seed), so episodes are reproducible
  after one seeded reset. There are no options.
- `step` returns `(obs, reward, terminated, truncated, info)` straight from
  the core: out of sand, out of helium, burst or grounded are `terminated`,
  the time limit (`episode_steps`, 216) is `truncated`. `info` is
  `jax_env.info_dict` without `TimeLimit.truncated`.
- Actions are checked once, at the boundary: shape (3,), finite, inside the
  Box, or [-1, 1]^3 with `normalize_actions=True` (mapped affinely onto the
  Box by `jax_env.to_box`, the mapping of the functional env and the
  trainer); anything else is a ValueError naming the component, and nothing
  changes. The registered id defaults to `normalize_actions=True` (the
  spec's kwargs; `gymnasium.make(ID, normalize_actions=False)` for the raw
  Box) and `spec.max_episode_steps` = 216; the class itself defaults to the
  raw Box (BLE's arena builds it).
- The env stops at the end of an episode (stepping it again is a
  RuntimeError); `render_mode='rgb_array'` draws the flight so far
  (`gymnasium_render.draw_flight`).
- It flies BLE's generative field inside the core, or ERA5 when the params
  hold its grid (`EnvParams.wind_grid`, e.g. gin's
  `latex_episode.wind_field_factory = @GriddedWindField`), or a `HostWind`
  asked on the host at every sub-step (a BLE `WindField`:
  `host_wind=ble_latex.ble.wind.host_wind(field)`).

The ids are registered with gymnasium by
`ble_latex.envs.gymnasium_registration` when `ble_latex` is imported.
"""

import datetime as dt
from typing import (Any, Callable, Dict, List, Mapping, NamedTuple, Optional,
                    Tuple)

import gymnasium
import numpy as np

from ble_latex import errors
from ble_latex import quiet
from ble_latex.envs import gymnasium_render as render_lib
from ble_latex.envs import seeds as seeds_lib

with quiet.third_party_noise():
  # pylint: disable=g-import-not-at-top
  import jax
  from ble_latex import gin_values
  from ble_latex.envs import env_params
  from ble_latex.envs import env_types
  from ble_latex.envs import gymnasium_compile as compile_lib
  from ble_latex.envs import jax_env
  from ble_latex.envs import winds
  # pylint: enable=g-import-not-at-top

# Names of the action components in messages.
COMPONENTS = ('a0 (desired altitude [m])', 'a1 (time factor)',
              'a2 (float flag)')


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


def check_options(options: Any) -> None:
  """Raises ValueError unless `options` is None or empty (there are none)."""
  if options is None or (isinstance(options, Mapping) and not options):
    return
  raise ValueError(f'reset takes no options (None or {{}}), got {options!r}')


def single_info(raw: Mapping[str, Any]) -> Dict[str, Any]:
  """`jax_env.info_dict` without `TimeLimit.truncated` (gymnasium's
  `truncated` says it)."""
  info = jax_env.info_dict(raw)
  info.pop('TimeLimit.truncated', None)
  return info


class SeedRule:
  """The one seed/options rule of every Gymnasium env here (a mixin).

  Mixed in before `gymnasium.Env` / `gymnasium.vector.VectorEnv`, whose
  `reset` seeds `np_random`; `num_envs` is None for one balloon.
  """

  num_envs: Optional[int] = None

  def _episode_seeds(self, seed: Any, options: Any) -> np.ndarray:
    """The seed rule: seeds s + i, or training seeds from `np_random`.

    Args:
      seed: None, an int s (balloon i flies s + i), or (vector envs,
        gymnasium's `VectorEnv.reset`) one seed per balloon, each an int in
        [0, 2**32) or None (a training seed drawn from `np_random`, which
        the given seeds seed).
      options: None or empty.

    Returns:
      One seed per balloon (one for the single env).

    Raises:
      ValueError: `seed` not None or an int with s + N - 1 < 2**32 or (vector
        envs) a list of N such seeds or Nones, or any `options`; nothing is
        changed.
    """
    count = 1 if self.num_envs is None else self.num_envs
    check_options(options)
    if self.num_envs is not None and isinstance(seed, (list, tuple,
                                                       np.ndarray)):
      return self._listed_seeds(seed, count)
    seeds_lib.validate_seed(seed)
    if seed is not None and int(seed) + count > seeds_lib.MAX_SEED:
      raise ValueError(f'seed + num_envs - 1 must be < 2**32 (balloon i flies '
                       f'seed + i), got seed {seed} with {count} envs')
    super().reset(seed=None if seed is None else int(seed))  # np_random.
    if seed is None:
      return self.np_random.integers(seeds_lib.TRAIN_SEED_LIMIT, size=count)
    return int(seed) + np.arange(count)

  def _listed_seeds(self, seed: Any, count: int) -> np.ndarray:
    """One seed per balloon from a list of ints and Nones (see above)."""
    seed = list(seed) if np.ndim(seed) == 1 else None
    if seed is None or len(seed) != count:
      raise ValueError(f'seed must be None, an int or a list of one seed per '
                       f'balloon ({count}), got {seed!r}')
    for i, s in enumerate(seed):
      try:
        seeds_lib.validate_seed(s)
      except ValueError as e:
        raise ValueError(f'seed[{i}]: {e}') from None
    given = [int(s) for s in seed if s is not None]
    if given:  # `np_random` from the given seeds (None entries draw from it).
      self.np_random = np.random.Generator(np.random.PCG64(
          np.random.SeedSequence(given)))
    drawn = self.np_random.integers(seeds_lib.TRAIN_SEED_LIMIT, size=count)
    return np.array([d if s is None else int(s) for s, d in zip(seed, drawn)],
                    np.int64)


class HostWind(NamedTuple):
  """A wind the core asks on the host at every physics sub-step.

  For winds that cannot fly in JAX; built outside `envs/` (a BLE
  `WindField`: `ble_latex.ble.wind.host_wind`).

  Attributes:
    wind: The core's `winds.Wind` over the host's field (through
      `jax.pure_callback`).
    reset: Called at every start with (the arena's wind key, the drawn
      start time); returns the flight's start time if the field chooses its
      own, else None.
  """
  wind: Any
  reset: Callable[[jax.Array, dt.datetime], Optional[dt.datetime]]


class Balloons(SeedRule):
  """What the single and the vector env share (a mixin of both).

  Attributes:
    params: The env parameters (`env_types.EnvParams`, checked).
    state: The core's `env_types.EnvState` (a leading balloon axis in the
      vector env); None before the first reset.
    normalize_actions: Actions in [-1, 1]^3, mapped affinely onto the Box
      (`jax_env.to_box`, inside the compiled step).
  """

  def _setup(self, params: Optional[env_types.EnvParams],
             episode_steps: Optional[int], normalize_actions: bool,
             compiled: compile_lib.Compiled, host_wind: bool = False,
             wind_file: Any = None) -> None:
    """Checks and sets the params, spaces and compiled functions.

    `wind_file`: the env flies that wind file (`winds.grid_from_file`, as
    --wind_file: per-seed stations on a gridded snapshot, a sounding's
    site), in `params` or gin's.

    Raises:
      ValueError: A bad `episode_steps` or params (`errors.ConfigError`);
        params read from gin whose `latex_episode.wind_field_factory` is
        neither None nor ERA5 without `host_wind`; a bad wind file
        (`errors.BadFileError`) or one given with `host_wind`.
    """
    if episode_steps is not None:
      gin_values.check_int('episode_steps', episode_steps, minimum=1)
    if wind_file is not None and host_wind:
      raise errors.ConfigError('wind_file and host_wind are two wind '
                               'sources: give one')
    if params is not None and wind_file is not None:
      params = params.replace(wind_grid=winds.grid_from_file(wind_file))
    if params is None:
      with quiet.third_party_noise():
        params = env_params.params_from_gin(wind_file=wind_file)
      factory = env_params.episode()['wind_field_factory']
      if (factory is not None and params.wind_grid is None and not host_wind
          and wind_file is None):
        raise errors.ConfigError(
            f'gin binding latex_episode.wind_field_factory = {factory!r}: '
            'the Gymnasium envs fly the core\'s generative field or ERA5 in '
            'JAX; fly a BLE WindField with host_wind='
            'ble_latex.ble.wind.host_wind(field) or gym\'s LatexBalloon-v0')
    else:
      params = env_params.check_params(params)
    if episode_steps is not None:
      params = params.replace(episode_steps=int(episode_steps))
    self.params = params
    self.state: Optional[env_types.EnvState] = None
    self._fns = compiled
    # False: a reset compiles `start` ahead, not `step` (a caller that flies
    # the flights elsewhere: the batched eval, `run.batch_eval`).
    self.compile_step_ahead = True
    self.normalize_actions = bool(normalize_actions)
    core = jax_env.LatexBalloonJaxEnv(normalize_actions=self.normalize_actions)
    self._single_action_space = core.action_space(params)
    self._single_observation_space = core.observation_space(params)

  def check_action(self, actions: Any) -> np.ndarray:
    """The one check of actions (`validate_actions`) in the action space.

    Returns:
      The actions as float32, what the compiled step takes (raw Box
      actions, or [-1, 1]^3 that it maps onto the Box).

    Raises:
      ValueError: See `validate_actions`; the env is unchanged.
    """
    space = self._single_action_space
    what = ' (normalize_actions=True)' if self.normalize_actions else ''
    return validate_actions(actions, self.num_envs, space.low, space.high,
                            what).astype(np.float32)

  def _step(self, actions: np.ndarray) -> Any:
    """The compiled step of checked actions; the host's packed values."""
    if self.state is None:
      raise RuntimeError('reset() must be called before step()')
    self._fns.wait('step')
    parts, packed = self._fns.step(self.state, actions, self.params,
                                   np.bool_(self.normalize_actions))
    self.state = self.state.replace(**parts)
    return self._fns.unpack('step', packed)


class LatexBalloonGymnasiumEnv(Balloons, gymnasium.Env):
  """`ble_latex/LatexBalloon-v0`: one latex balloon, gymnasium's API.

  Args:
    render_mode: None or 'rgb_array'.
    normalize_actions: Actions in [-1, 1]^3 mapped onto the Box.
    episode_steps: Strides per episode (the time limit); None: gin's
      `latex_episode.episode_steps` (216).
    station_keeping_radius_km: The station radius (`EnvParams.radius_km`:
      the reward's, TW50's and the circle `render` draws); None: the
      params' (gin's `latex_episode.station_keeping_radius_km`, 50). # [km]
    host_wind: None: the core's own winds (BLE's generative field, or ERA5
      when the params hold its grid); a `HostWind`: its wind, asked on the
      host at every sub-step (`ble_latex.ble.wind.host_wind(field)` for a
      BLE `WindField`).
    params: `env_types.EnvParams` to fly instead of the gin-bound ones.
    wind_file: A wind file (ERA5, GFS NetCDF/GRIB2, a sounding; a glob or
      list): the env flies it as --wind_file does (`winds.grid_from_file`).

  Attributes:
    flight: The balloon's `FlightState` after the last reset or step, as
      NumPy values by field name (the host copy the step brought back).
    start_date_time: Date and time of the flight's start (BLE's draw, or
      the host wind's own).
    location_key: The key of BLE's station location draw.

  Raises:
    ValueError: An unknown `render_mode`, a `host_wind` that is not a
      `HostWind`, or a bad `episode_steps`, `station_keeping_radius_km` or
      `params` (`errors.ConfigError`).
    RuntimeError: Built in a process forked after JAX started.
  """

  metadata = {'render_modes': ['rgb_array'], 'render_fps': 4}
  num_envs = None

  def __init__(self, *, render_mode: Optional[str] = None,
               normalize_actions: bool = False,
               episode_steps: Optional[int] = None,
               station_keeping_radius_km: Optional[float] = None,
               host_wind: Optional[HostWind] = None,
               params: Optional[env_types.EnvParams] = None,
               wind_file: Any = None):
    render_lib.check_render_mode(self, render_mode)
    self.render_mode = render_mode
    compile_lib.check_not_forked_after_jax()
    if station_keeping_radius_km is not None:
      station_keeping_radius_km = gin_values.check_number(
          'station_keeping_radius_km', station_keeping_radius_km, above=0.0)
    if host_wind is not None and not isinstance(host_wind, HostWind):
      raise ValueError(f'host_wind must be None or a gymnasium_env.HostWind '
                       f'(ble_latex.ble.wind.host_wind(field)), got '
                       f'{host_wind!r}')
    self._wind_field = host_wind
    compiled = compile_lib.generative(batched=False)
    if host_wind is not None:
      compiled = compile_lib.Compiled(jax_env.LatexBalloonJaxEnv(
          host_wind.wind, normalize_actions=False), batched=False)
    self._setup(params, episode_steps, normalize_actions, compiled,
                host_wind=host_wind is not None, wind_file=wind_file)
    if station_keeping_radius_km is not None:
      self.params = self.params.replace(radius_km=station_keeping_radius_km)
    self.action_space = self._single_action_space
    self.observation_space = self._single_observation_space
    self.flight: Optional[Dict[str, np.ndarray]] = None
    self.start_date_time: Optional[dt.datetime] = None
    self.location_key: Optional[jax.Array] = None
    self._done = False
    self._path: List[Tuple[float, float, float, float]] = []
    self._figure = None

  @property
  def host_wind_field(self) -> Optional[HostWind]:
    """The `HostWind` flown through host callbacks, or None.

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
    return self.start(np.asarray(
        compile_lib.arena_keys(seeds.astype(np.uint32)))[0])

  def start(self, arena_key: jax.Array) -> Tuple[np.ndarray, Dict[str, Any]]:
    """The flight of BLE's arena key (`reset(seed=s)` flies s's arena key).

    A host wind is reset with the arena's wind key and start time; one that
    chooses its own start time (ERA5's `start_date_time`) sets the flight's
    date.
    """
    self._fns.ahead(arena_key, self.params, self.normalize_actions,
                    step=self.compile_step_ahead)
    state, keys = self._fns.draw(arena_key, self.params)
    start = env_types.START_EPOCH + dt.timedelta(
        seconds=int(state.start_time_offset_s))
    if self._wind_field is not None:
      start = self._wind_field.reset(keys['wind'], start) or start
    self.start_date_time, self.location_key = start, keys['location']
    self._fns.wait('start')
    self.state, packed = self._fns.start(state, self.params)
    obs, raw, flight = self._fns.unpack('start', packed)
    self._set_flight(flight, first=True)
    self._done = False
    return obs, single_info(raw)

  def step(self, action: Any
           ) -> Tuple[np.ndarray, float, bool, bool, Dict[str, Any]]:
    """One 20-minute action (see `check_action` for what is accepted).

    Raises:
      ValueError: An action outside the action space; nothing changes.
      RuntimeError: Before `reset` or after the episode ended.
    """
    action = self.check_action(action)
    if self._done:
      raise RuntimeError('step() called on a finished episode; call reset().')
    obs, reward, terminated, raw, flight = self._step(action)
    self._set_flight(flight)
    truncated = bool(raw['truncated'])
    self._done = bool(terminated) or truncated
    return obs, float(reward), bool(terminated), truncated, single_info(raw)

  def measured_wind(self) -> Tuple[float, float]:
    """The ground-truth wind at the balloon (the measurement). # [m/s]"""
    u, v = jax.device_get((self.state.wind_u, self.state.wind_v))
    return float(u), float(v)

  def _set_flight(self, flight: Any, first: bool = False) -> None:
    self.flight = render_lib.flight_values(flight)
    if self.render_mode is not None:
      self._path = ([] if first else self._path) + [
          render_lib.flight_point(self.flight)]

  def render(self) -> Optional[np.ndarray]:
    """The flight so far as an (H, W, 3) uint8 image ('rgb_array'), or None."""
    if self.render_mode != 'rgb_array':
      return None
    self._figure = render_lib.draw_flight(self._figure, self._path,
                                          self.params.radius_km)
    return render_lib.figure_rgb(self._figure)

  def close(self) -> None:
    self._figure = None
    super().close()

  def __str__(self) -> str:
    return f'{type(self).__name__}(LatexBalloon-v0 on the JAX core)'
