# coding=utf-8
"""Launch candidates scored by expected TW50, flown batched on the JAX core.

Where and when to launch (Saunders et al., arXiv 2403.10784): a candidate
launch is an offset east and north of the station [km], a delay after the
world's start [h] and a start altitude [m]. Each is flown for a whole
episode by a controller (`controllers`) in the world of a wind source
(`World`: BLE's generative forecast of a seed, or an ERA5 file with the
station at a given latitude and longitude and a launch date), under K draws
of BLE's simplex forecast-error noise, and scored by its TW50 (the fraction
of the episode's strides ending within the station-keeping radius,
`metrics.EpisodeTracker`'s count) averaged over the draws:

  score(c) = (1/K) sum_k TW50_k(c),  stderr(c) = std_k(TW50_k(c)) / sqrt(K)

(std with ddof 1; 0 for K = 1). Draw 0 is the world's own noise, so with
K = 1 a launch at the world's own start flies `jax_env`'s `reset(key)`
flight exactly. Every candidate x draw is one balloon of one jitted call:
the world's forecast and atmosphere are shared (not copied per balloon), the
noise is shared by the candidates of a draw, and the strides are one
`lax.scan` (`score`).
"""

import dataclasses
import datetime as dt
import functools
import math
from typing import Any, Dict, List, Optional, Tuple

import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import errors
from ble_latex import gin_values
from ble_latex import jax_cache
from ble_latex.envs import env_params
from ble_latex.envs import env_types
from ble_latex.envs import jax_env
from ble_latex.envs import winds
from ble_latex.flight import state as state_lib
from ble_latex.launch import ascent as ascent_lib
from ble_latex.launch import controllers as controllers_lib
from ble_latex.run import tracks
from ble_latex.wind import generative
from ble_latex.wind import gridded
from ble_latex.wind import gridded_checks
from ble_latex.wind import gridded_jax
from ble_latex.wind import members
from ble_latex.wind import simplex

Array = jax.Array
# Candidates flown per jitted call (x the draws): bounds memory. Each
# balloon's own state is ~2 kB; the world is shared.
CHUNK = 2048
# Most candidates x draws one `score` call accepts.
MAX_BALLOONS = 4_000_000
# The generative forecast's grid reaches this far from the station; BLE
# clips positions beyond it (the wind there is the edge's). # [km]
GENERATIVE_EXTENT_KM = 500.0


@dataclasses.dataclass(frozen=True)
class SearchSpace:
  """The box of candidate launches.

  Attributes:
    east_km: (low, high) offset east of the station. # [km]
    north_km: (low, high) offset north of the station. # [km]
    hours: (low, high) delay after the world's start. # [h]
    altitude_m: (low, high) start altitude, or None: the middle of the
      env's start band (`EnvParams.start_altitude_low_m/high_m`). # [m]
  """
  east_km: Tuple[float, float] = (-150.0, 150.0)
  north_km: Tuple[float, float] = (-150.0, 150.0)
  hours: Tuple[float, float] = (0.0, 21.0)
  altitude_m: Optional[Tuple[float, float]] = None

  def checked(self, params: env_types.EnvParams) -> 'SearchSpace':
    """This box with its altitude band filled in; bad bounds are one line.

    Raises:
      errors.ConfigError: a bound not finite, low > high, a negative delay,
        an altitude outside the core's start range (0, 32 km].
    """
    altitude = self.altitude_m
    if altitude is None:
      middle = 0.5 * (params.start_altitude_low_m +
                      params.start_altitude_high_m)
      altitude = (middle, middle)
    for name, (low, high) in (('east_km', self.east_km),
                              ('north_km', self.north_km),
                              ('hours', self.hours),
                              ('altitude_m', altitude)):
      gin_values.check_number(f'launch {name} low', low)
      gin_values.check_number(f'launch {name} high', high)
      if low > high:
        raise errors.ConfigError(
            f'launch {name}: low {low:g} > high {high:g}')
    if self.hours[0] < 0:
      raise errors.ConfigError(
          f'launch hours must be >= 0 (a delay after the world\'s start), '
          f'got {self.hours[0]:g}')
    if altitude[0] <= 0 or altitude[1] > env_params.START_ALTITUDE_MAX_M:
      raise errors.ConfigError(
          'launch altitude_m must lie in '
          f'(0, {env_params.START_ALTITUDE_MAX_M:g}] m, got '
          f'({altitude[0]:g}, {altitude[1]:g})')
    return dataclasses.replace(self, altitude_m=tuple(altitude))

  @property
  def names(self) -> Tuple[str, ...]:
    """The dimensions, in `Launches` order."""
    return ('east_km', 'north_km', 'hours', 'altitude_m')

  def bounds(self) -> np.ndarray:
    """[4, 2] (low, high) per dimension (after `checked`)."""
    if self.altitude_m is None:
      raise errors.ConfigError('launch SearchSpace has no altitude band yet: '
                               'use SearchSpace.checked(params)')
    return np.array([self.east_km, self.north_km, self.hours,
                     self.altitude_m], np.float64)


@dataclasses.dataclass(frozen=True)
class Launches:
  """N candidate launches (NumPy float64 arrays [N]).

  Attributes:
    east_km: Offset east of the station. # [km]
    north_km: Offset north of the station. # [km]
    hours: Delay after the world's start. # [h]
    altitude_m: Start altitude. # [m]
  """
  east_km: np.ndarray
  north_km: np.ndarray
  hours: np.ndarray
  altitude_m: np.ndarray

  def __len__(self) -> int:
    return len(self.east_km)

  def array(self) -> np.ndarray:
    """[N, 4] in `SearchSpace.names` order."""
    return np.stack([self.east_km, self.north_km, self.hours,
                     self.altitude_m], axis=1)

  @classmethod
  def from_array(cls, values: Any) -> 'Launches':
    """From [N, 4] values in `SearchSpace.names` order."""
    values = np.asarray(values, np.float64).reshape(-1, 4)
    return cls(*(values[:, i].copy() for i in range(4)))

  def take(self, index: Any) -> 'Launches':
    """The launches at `index`."""
    return Launches.from_array(self.array()[np.asarray(index, np.int64)])


def check_balloons(n: int, draws: int, what: str = 'launches') -> None:
  """Refuses n x draws > MAX_BALLOONS before anything is allocated.

  Raises:
    errors.ConfigError: One line naming `what` and the count.
  """
  if int(n) * int(draws) > MAX_BALLOONS:
    raise errors.ConfigError(
        f'{n} {what} x {draws} draws = {int(n) * int(draws)} balloons, more '
        f'than {MAX_BALLOONS}; use a coarser grid or fewer draws')


def grid(space: SearchSpace, n_east: int, n_north: int, n_hours: int,
         n_altitudes: int = 1) -> Launches:
  """The dense grid over a (checked) box, east fastest... hours, altitude last.

  Index i = ((a * n_hours + t) * n_north + j) * n_east + k for east k,
  north j, hours t, altitude a. A dimension with one point takes the
  middle of its range.
  """
  axes = []
  for name, n in zip(space.names, (n_east, n_north, n_hours, n_altitudes)):
    gin_values.check_int(f'launch grid points ({name})', n, minimum=1)
  check_balloons(int(n_east) * int(n_north) * int(n_hours) *
                 int(n_altitudes), 1, 'launch grid points')
  for n, (low, high) in zip((n_east, n_north, n_hours, n_altitudes),
                            space.bounds()):
    axes.append(np.linspace(low, high, n) if n > 1 else
                np.array([0.5 * (low + high)]))
  a, t, j, k = np.meshgrid(axes[3], axes[2], axes[1], axes[0], indexing='ij')
  return Launches(k.ravel(), j.ravel(), t.ravel(), a.ravel())


def uniform(space: SearchSpace, n: int, rng: np.random.Generator) -> Launches:
  """n launches uniform in a (checked) box."""
  gin_values.check_int('launch candidates', n, minimum=1)
  check_balloons(n, 1, 'launch candidates')
  bounds = space.bounds()
  return Launches.from_array(rng.uniform(bounds[:, 0], bounds[:, 1], (n, 4)))


@dataclasses.dataclass(frozen=True)
class World:
  """A wind source's world: what every candidate launch flies in.

  Attributes:
    env: The functional env (raw Box actions).
    params: Its params (`wind_grid` set for ERA5; `episode_steps` the
      scoring window).
    state: The world drawn once (atmosphere, forecast, start time; its
      balloon is replaced by each launch's).
    noise_key: Draw 0's noise key (the world's own noise).
    describe: What the records say about the world (source, seed, station,
      date).
  """
  env: jax_env.LatexBalloonJaxEnv
  params: env_types.EnvParams
  state: env_types.EnvState
  noise_key: Array
  describe: Dict[str, Any]


def _world(params: env_types.EnvParams, seed: int,
           describe: Dict[str, Any]) -> World:
  gin_values.check_int('launch world seed', seed, minimum=0,
                       maximum=2**32 - 1)
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  state, keys = jax.jit(env.draw)(
      jax_env.arena_key(jax.random.PRNGKey(seed)), params)
  noise_key, _ = generative.split_wind_key(keys['wind'])
  return World(env, params, state, noise_key, {**describe, 'seed': int(seed)})


def generative_world(seed: int, params: Optional[env_types.EnvParams] = None,
                     steps: Optional[int] = None) -> World:
  """BLE's generative world of env seed `seed` (its forecast, atmosphere).

  Args:
    seed: The env seed (`reset(seed=s)`'s world: its VAE forecast).
    params: Env params (default: the gin-bound ones).
    steps: Strides of the scoring window (default: the params' episode).
  """
  params = env_params.params_from_gin() if params is None else params
  if params.wind_grid is not None:
    raise errors.ConfigError('generative_world: the params hold an ERA5 grid; '
                             'use era5_world')
  params = _with_steps(params, steps)
  return _world(params, seed, {'source': 'generative',
                               'station': 'the forecast grid\'s centre',
                               'winds_vary_in_time': True})


def era5_world(path: Any, *, center_lat: Optional[float] = None,
               center_lon: Optional[float] = None, date: Any = None,
               max_hours: float, seed: int = 0,
               params: Optional[env_types.EnvParams] = None,
               steps: Optional[int] = None) -> World:
  """A wind file's world: the station at (lat, lon), launches from `date`.

  Any wind file `gridded.load` reads (ERA5, a GFS analysis, GRIB2, a
  sounding; the reader chosen by content).

  Args:
    path: Wind file(s) (`gridded.load`).
    center_lat: The station's latitude (None: the centre of the file's
      domain; on a sounding, the site its file names). # [deg N]
    center_lon: The station's longitude (likewise). # [deg E]
    date: The world's start (launch delay 0): an ISO date-time string or a
      `datetime` (naive: UTC); None: the file's first time (a snapshot
      flies its own time whatever the date).
    max_hours: The latest launch delay: the file must hold the episode
      after it. # [h]
    seed: The noise and atmosphere seed.
    params: Env params (default: the gin-bound ones).
    steps: Strides of the scoring window (default: the params' episode).

  Raises:
    errors.ConfigError: a bad date or station, or a window the file does
      not hold.
    FileNotFoundError, errors.BadFileError: as `gridded.load` (a bad file).
  """
  params = _with_steps(
      env_params.params_from_gin() if params is None else params, steps)
  bound = bound_wind_settings(path)  # Before the file is read.
  data = gridded.load(path)  # FileNotFoundError, BadFileError: exit 1.
  if center_lat is None and center_lon is None:
    center_lat = bound.pop('center_lat', None)
    center_lon = bound.pop('center_lon', None)
  bound.pop('center_lat', None), bound.pop('center_lon', None)
  if (center_lat is None) != (center_lon is None):
    raise errors.ConfigError('launch station: give both latitude and '
                             'longitude, or neither (the domain centre)')
  if center_lat is None:
    center_lat, center_lon = domain_centre(data)
  truth = {'truth_path': bound.pop('truth_path', None),
           'truth_members': bool(bound.pop('truth_members', False))}
  if truth['truth_path'] is not None:
    bound['truth'] = gridded.load(truth['truth_path'])
  if truth['truth_members']:
    bound['truth_members'] = gridded_jax.member_truths(path)
  if date is None:
    date = data.start.replace(tzinfo=None)
  try:
    start = (dt.datetime.fromisoformat(date) if isinstance(date, str)
             else date)
  except ValueError as e:
    raise errors.ConfigError(f'launch date {date!r}: not an ISO date') from e
  if not isinstance(start, dt.datetime):
    start = dt.datetime(start.year, start.month, start.day)
  hours = params.episode_steps * params.stride_s / 3600.0 + max_hours
  try:
    wind_grid = gridded_jax.grid_from_data(
        data, center_lat=center_lat, center_lon=center_lon,
        episode_hours=hours,
        start_dates=(start, start + dt.timedelta(minutes=1)), **bound)
  except errors.ConfigError:
    raise
  except OverflowError as e:  # A date near 9999-12-31: start + 1 minute.
    raise errors.ConfigError(
        f'launch date {date!r}: the window after it ({hours:g} h) ends past '
        'year 9999') from e
  except ValueError as e:
    raise errors.ConfigError(str(e).split('\n', 1)[0]) from e
  # The one validator of every path (the eval's and train's params are
  # checked where they are built): the grid's winds and levels too.
  params = env_params.check_params(params.replace(wind_grid=wind_grid))
  return _world(params, seed, {
      'source': 'era5' if data.source == 'ERA5' else data.source,
      'wind_source': winds.wind_source_from_gin(gridded.Era5Settings(
          path=data.paths, member=members.bound(), **truth)),
      'path': str(path), 'station_lat': float(center_lat),
      'station_lon': float(tracks.wrap_longitude(center_lon)),
      'winds_vary_in_time': not data.time_invariant,
      'date': _world_date(data, start, bound.get('snapshot_time'))})


def _world_date(data: gridded.Era5Data, start: dt.datetime,
                snapshot_time: Any) -> str:
  """The world's start as ISO text: a snapshot's bound time (the sun's under
  realistic physics), else its file's, else the launch date."""
  if not data.time_invariant:
    return start.isoformat()
  if snapshot_time is None:
    return data.start.replace(tzinfo=None).isoformat()
  when = (dt.datetime.fromisoformat(snapshot_time)
          if isinstance(snapshot_time, str) else snapshot_time)
  return when.replace(tzinfo=None).isoformat()


# `GriddedWindField.*` bindings a launch applies; the others it sets itself.
LAUNCH_WIND_BINDINGS = ('path', 'center_lat', 'center_lon', 'add_noise',
                        'end_outside_domain', 'snapshot_time', 'noise_scale',
                        'truth_path', 'truth_members')
_SET_BY_LAUNCH = {'start_dates': '--date', 'episode_hours': '--hours and '
                  '--max_steps', 'stations': 'one station (--station_lat/'
                  '--station_lon)', 'station_margin_km': 'one station '
                  '(--station_lat/--station_lon)'}


def bound_wind_settings(path: Any) -> Dict[str, Any]:
  """The `GriddedWindField.*` gin bindings a launch world applies.

  A launch flies its wind file with the bound snapshot time, noise, truth
  file and station (the flags' station wins); a binding it sets itself is
  refused rather than ignored, and so is a bound path other than `path`.

  Returns:
    {name: value} of the bound `LAUNCH_WIND_BINDINGS` but `path`.

  Raises:
    errors.ConfigError: One line naming the binding.
  """
  bound = winds.bound_settings()  # Its old name's too.
  for name, flag in _SET_BY_LAUNCH.items():
    if name in bound:
      raise errors.ConfigError(
          f'gin binding GriddedWindField.{name} = {bound[name]!r} does not '
          f'apply to a launch (it sets that from {flag}); remove it')
  if 'path' in bound:
    bound_paths = gridded_checks.expand_paths(bound.pop('path'))
    if bound_paths != gridded_checks.expand_paths(path):
      raise errors.ConfigError(
          f'gin binding GriddedWindField.path {list(bound_paths)} is not the '
          f'launch\'s wind file {path!r}; bind one or give the same')
  return {k: v for k, v in bound.items() if k in LAUNCH_WIND_BINDINGS}


def domain_centre(data: gridded.Era5Data) -> Tuple[float, float]:
  """The default station of a wind file: its domain's centre, or a
  sounding's site where its file names one. # [deg]"""
  site = data.site
  if site is not None and site.latitude is not None and (
      site.longitude is not None):
    return float(site.latitude), float(site.longitude)
  lat = 0.5 * (float(data.latitude[0]) + float(data.latitude[-1]))
  lon = 0.5 * (float(data.longitude[0]) + float(data.longitude[-1]))
  return lat, (lon + 180.0) % 360.0 - 180.0


def _with_steps(params: env_types.EnvParams,
                steps: Optional[int]) -> env_types.EnvParams:
  if steps is None:
    return params
  gin_values.check_int('launch steps', steps, minimum=1, maximum=100_000)
  return params.replace(episode_steps=int(steps))


def noise_draws(world: World, draws: int) -> Tuple[Any, Any]:
  """The (u, v) noise of K draws, leading axis K (draw 0: the world's)."""
  gin_values.check_int('launch noise draws', draws, minimum=1,
                       maximum=10_000)
  keys = jnp.stack([world.noise_key] + [
      jax.random.fold_in(world.noise_key, k) for k in range(1, draws)])
  return jax.vmap(simplex.reset_uv_noise_params)(keys)


def launch_state(params: env_types.EnvParams, world: env_types.EnvState,
                 noise_u: Any, noise_v: Any, east_km: Array, north_km: Array,
                 hours: Array, altitude_m: Array) -> env_types.EnvState:
  """One launch's env state in a world: `jax_env`'s draw, placed there.

  `jax_env.place` (the env's own placement, as its `draw` places a start):
  the balloon at the launch's offset and altitude, its flight clock at the
  delay, in this draw's noise; measured. The burst draw's key (realistic
  physics) comes from the world's start time.

  Args:
    params: The env params.
    world: The world's state (`World.state`).
    noise_u: This draw's eastward noise.
    noise_v: This draw's northward noise.
    east_km: Offset east of the station. # [km]
    north_km: Offset north of the station. # [km]
    hours: Delay after the world's start. # [h]
    altitude_m: Start altitude. # [m]

  Returns:
    The env state, measured (its wind at the balloon set).
  """
  dtype = world.flight.x_m.dtype
  return jax_env.place(
      world.replace(noise_u=noise_u, noise_v=noise_v), params,
      x_m=jnp.asarray(east_km, dtype) * 1000.0,
      y_m=jnp.asarray(north_km, dtype) * 1000.0,
      altitude_m=jnp.asarray(altitude_m, dtype),
      time_s=jnp.asarray(hours, dtype) * 3600.0,
      burst_key=jax.random.fold_in(jax.random.PRNGKey(0),
                                   world.start_time_offset_s),
      wind=jax_env.LatexBalloonJaxEnv(normalize_actions=False).wind_for(
          params))


def launch_helium(world: World, ascent: ascent_lib.Ascent) -> float:
  """The launch fill of a launch from the ground in this world. # [mol]

  `ascent.launch_helium_mols` of the world's balloon in the realistic
  ascent's flight system, at the release height, in the world's atmosphere.
  """
  return ascent_lib.launch_helium_mols(
      ascent_lib.ascent_flight_params(world.params.flight),
      world.state.atmosphere, ascent.ascent_rate_mps,
      ascent.launch_altitude_m)


def _ascend(env: jax_env.LatexBalloonJaxEnv, ascent: ascent_lib.Ascent,
            params: env_types.EnvParams, world: env_types.EnvState,
            noise_u: Any, noise_v: Any, launch: Array,
            helium: Array) -> ascent_lib.Leg:
  """One launch from the ground (`ascent.fly`) in a world and noise draw.

  The launch's site (east, north [km]) and delay [h] are where and when the
  balloon leaves the ground; its altitude [m] is where it is stopped to
  float. The winds are the world's truth with this draw's noise; the burst
  draw's key is `launch_state`'s.
  """
  east_km, north_km, hours, altitude_m = launch
  state = launch_state(params, world, noise_u, noise_v, *launch)
  wind = env.wind_for(params)

  def wind_fn(x_m, y_m, pressure_pa, t_s):
    return wind.ground_truth(state, x_m, y_m, pressure_pa, t_s)

  dtype = state.flight.x_m.dtype
  return ascent_lib.fly(
      ascent_lib.ascent_flight_params(
          env_types.flight_params_of(params, state)),
      world.atmosphere, wind_fn, x_m=jnp.asarray(east_km, dtype) * 1000.0,
      y_m=jnp.asarray(north_km, dtype) * 1000.0,
      time_s=jnp.asarray(hours, dtype) * 3600.0, float_altitude_m=altitude_m,
      helium_mols=helium,
      burst_key=jax.random.fold_in(jax.random.PRNGKey(0),
                                   world.start_time_offset_s),
      ascent=ascent)


def _fly_one(env: jax_env.LatexBalloonJaxEnv,
             controller: controllers_lib.Controller, steps: int, record: bool,
             ascent: Optional[ascent_lib.Ascent],
             params: env_types.EnvParams, world: env_types.EnvState,
             noise_u: Any, noise_v: Any, launch: Array, helium: Array):
  """One launch's TW50 (and its [strides, 2] path [km] if `record`).

  With `ascent` the launch is from the ground: the float phase starts where
  and when the ascent reaches the launch's altitude (`_ascend`); a balloon
  that bursts first scores 0, and its path stays at the launch site.
  """
  wind = env.wind_for(params)
  floats = jnp.ones((), bool)
  afloat = launch
  if ascent is not None:
    leg = _ascend(env, ascent, params, world, noise_u, noise_v, launch,
                  helium)
    floats = leg.floats
    afloat = jnp.where(floats, jnp.stack([
        leg.float_x_m / 1000.0, leg.float_y_m / 1000.0,
        leg.float_time_s / 3600.0, launch[3]]).astype(launch.dtype), launch)
  state = launch_state(params, world, noise_u, noise_v, *afloat)
  obs = jax_env.observation(state, params, wind)
  radius = params.radius_km

  def stride(carry, i):
    state, obs, control, within = carry
    alive = state.flight.status == state_lib.FlightStatus.OK
    action, control = controller.act(control, obs, state, i)
    obs, state, _, _, info = env.step_env(None, state, action, params)
    within = within + (alive & floats & (info['distance_km'] <= radius) &
                       (state.steps <= steps))
    path = (jnp.where(floats, jnp.stack([state.flight.x_m, state.flight.y_m]),
                      jnp.stack([launch[0], launch[1]]) * 1000.0) / 1000.0
            if record else None)
    return (state, obs, control, within), path

  def period(carry, _):
    state, obs, control, within = carry
    control = controller.plan(control, obs, state, params, wind)
    return jax.lax.scan(stride, (state, obs, control, within),
                        jnp.arange(controller.period))

  periods = -(-steps // controller.period)
  carry = (state, obs, controller.init(obs, state), jnp.zeros((), jnp.int32))
  (_, _, _, within), path = jax.lax.scan(period, carry, None, length=periods)
  tw50 = within.astype(jnp.float32) / steps
  if not record:
    return tw50, None
  start = jnp.stack([launch[0], launch[1]]).astype(path.dtype)[None]
  return tw50, jnp.concatenate([start, path.reshape(-1, 2)[:steps]])


@functools.lru_cache(maxsize=8)
def _flier(env: jax_env.LatexBalloonJaxEnv,
           controller: controllers_lib.Controller, steps: int, record: bool,
           ascent: Optional[ascent_lib.Ascent] = None):
  """Jitted: (params, world, noise [K], launches [N, 4], helium) -> TW50
  [K, N] (and paths)."""
  one = functools.partial(_fly_one, env, controller, steps, record, ascent)
  over_launches = jax.vmap(one, in_axes=(None, None, None, None, 0, None))
  over_draws = jax.vmap(over_launches, in_axes=(None, None, 0, 0, None, None))
  return jax.jit(over_draws, compiler_options=jax_cache.fast_compile_options())


@dataclasses.dataclass(frozen=True)
class Scores:
  """Candidate launches and their TW50 over K noise draws.

  Attributes:
    launches: The N candidates.
    tw50: [K, N] TW50 per draw and candidate. # [.]
    steps: Strides of the scoring window.
  """
  launches: Launches
  tw50: np.ndarray
  steps: int

  @property
  def mean(self) -> np.ndarray:
    """[N] expected TW50 (mean over the draws)."""
    return self.tw50.mean(axis=0)

  @property
  def std(self) -> np.ndarray:
    """[N] std over the draws (ddof 1; 0 for one draw)."""
    if self.tw50.shape[0] < 2:
      return np.zeros(self.tw50.shape[1])
    return self.tw50.std(axis=0, ddof=1)

  @property
  def stderr(self) -> np.ndarray:
    """[N] standard error of the mean."""
    return self.std / math.sqrt(self.tw50.shape[0])

  def order(self) -> np.ndarray:
    """Candidate indices, best first (mean; then lower stderr; index)."""
    n = len(self.launches)
    return np.lexsort((np.arange(n), self.stderr, -self.mean))


def score(world: World, controller: controllers_lib.Controller,
          launches: Launches, *, draws: int = 4, chunk: int = CHUNK,
          progress: Any = None,
          ascent: Optional[ascent_lib.Ascent] = None) -> Scores:
  """Every launch flown under K noise draws, batched; their TW50s.

  Args:
    world: The world (`generative_world`, `era5_world`).
    controller: What flies them (`controllers.controller_for(agent)`).
    launches: The candidates.
    draws: K noise draws per candidate.
    chunk: Candidates per jitted call.
    progress: Called with the number of candidates done after each call.
    ascent: Launch from the ground (`_fly_one`): each launch's offset and
      delay are its site and time on the ground, its altitude its float;
      None: launched afloat at its altitude.

  Returns:
    The scores.

  Raises:
    errors.ConfigError: no candidates, or more balloons than MAX_BALLOONS.
  """
  n = len(launches)
  if n == 0:
    raise errors.ConfigError('launch planning needs at least one candidate')
  gin_values.check_int('launch noise draws', draws, minimum=1)
  check_balloons(n, draws)
  noise_u, noise_v = noise_draws(world, draws)
  gin_values.check_int('launch chunk', chunk, minimum=1)
  size = min(chunk, n)
  fly = _flier(world.env, controller, int(world.params.episode_steps), False,
               ascent)
  helium = jnp.float32(0.0 if ascent is None else
                       launch_helium(world, ascent))
  values = launches.array()
  out = []
  for start in range(0, n, size):
    part = values[start:start + size]
    padded = np.concatenate([part, np.repeat(part[-1:], size - len(part), 0)])
    tw50, _ = fly(world.params, world.state, noise_u, noise_v,
                  jnp.asarray(padded, jnp.float32), helium)
    out.append(np.asarray(tw50)[:, :len(part)])
    if progress is not None:
      progress(start + len(part))
  return Scores(launches, np.concatenate(out, axis=1).astype(np.float64),
                int(world.params.episode_steps))


def flight_paths(world: World, controller: controllers_lib.Controller,
                 launches: Launches, draws: int = 1,
                 ascent: Optional[ascent_lib.Ascent] = None) -> np.ndarray:
  """[K, N, steps + 1, 2] (east, north) paths [km] of a few launches (from
  the ground with `ascent`: the launch site, then the float phase)."""
  noise_u, noise_v = noise_draws(world, draws)
  fly = _flier(world.env, controller, int(world.params.episode_steps), True,
               ascent)
  helium = jnp.float32(0.0 if ascent is None else
                       launch_helium(world, ascent))
  _, paths = fly(world.params, world.state, noise_u, noise_v,
                 jnp.asarray(launches.array(), jnp.float32), helium)
  return np.asarray(paths, np.float64)


def ascent_legs(world: World, launches: Launches,
                ascent: ascent_lib.Ascent) -> Dict[str, np.ndarray]:
  """The launches' ways up in the world's own noise (draw 0), batched.

  Returns:
    `ascent.Leg`'s fields by name, each [N] (`ascent.leg_to_host`).
  """
  noise_u, noise_v = noise_draws(world, 1)
  one = functools.partial(_ascend, world.env, ascent)
  legs = jax.jit(jax.vmap(one, in_axes=(None, None, None, None, 0, None)))(
      world.params, world.state, jax.tree.map(lambda a: a[0], noise_u),
      jax.tree.map(lambda a: a[0], noise_v),
      jnp.asarray(launches.array(), jnp.float32),
      jnp.float32(launch_helium(world, ascent)))
  return ascent_lib.leg_to_host(legs)


def world_start(world: World) -> Optional[dt.datetime]:
  """The world's start (launch delay 0), UTC: its draw's start time (None
  where its wind file names no time, `tracks.known_start`)."""
  return tracks.known_start(world.params, env_types.START_EPOCH +
                            dt.timedelta(seconds=int(
                                world.state.start_time_offset_s)))


def ranked(scores: Scores, world: World, top: Optional[int] = None
           ) -> List[Dict[str, Any]]:
  """The launches best first, as records (JSON-ready).

  Each: rank, east_km, north_km, hours, altitude_m, distance_km (from the
  station), inside_radius, tw50_mean, tw50_std, tw50_stderr, the launch's
  lat/lon (lon in -180..180; from the world's station, on BLE's generative
  winds the nominal one: `tracks.stations`) and launch_utc (the world's
  start plus the delay, ISO 8601 UTC; on BLE's winds the date BLE draws;
  None where the wind file names no time).
  """
  order = scores.order()[:top]
  launches, radius = scores.launches, world.params.radius_km
  mean, std, stderr = scores.mean, scores.std, scores.stderr
  station, _ = tracks.stations(world.params, [world.describe['seed']])
  start = world_start(world)
  records = []
  for rank, i in enumerate(order):
    distance = math.hypot(launches.east_km[i], launches.north_km[i])
    lat, lon = tracks.point_lat_lon(station[0][0], station[0][1],
                                    float(launches.east_km[i]),
                                    float(launches.north_km[i]))
    record = {'rank': rank + 1, 'index': int(i),
              'east_km': float(launches.east_km[i]),
              'north_km': float(launches.north_km[i]),
              'hours': float(launches.hours[i]),
              'launch_utc': None if start is None else tracks.utc_text(
                  start + dt.timedelta(hours=float(launches.hours[i]))),
              'lat': lat, 'lon': lon,
              'altitude_m': float(launches.altitude_m[i]),
              'distance_km': distance, 'inside_radius': distance <= radius,
              'tw50_mean': float(mean[i]), 'tw50_std': float(std[i]),
              'tw50_stderr': float(stderr[i])}
    records.append(record)
  return records


def with_ascent(records: List[Dict[str, Any]], legs: Dict[str, np.ndarray],
                world: World) -> List[Dict[str, Any]]:
  """`ranked` records with their ways up (`ascent_legs` of the same
  launches, in order) under 'ascent' (JSON-ready).

  Each 'ascent': `floats`; where it floats, `float_lat`, `float_lon`,
  `float_utc`, `ascent_min` (launch to float) and `ascent_drift_km` (launch
  site to float point); where it bursts first, `burst_altitude_m`,
  `burst_lat`, `burst_lon`, `burst_utc`, and `landing_lat`, `landing_lon`,
  `landing_utc` (None where the descent did not end within its bound); each
  point also as `<name>_east_km`, `<name>_north_km` from the station.
  Latitudes and longitudes (-180..180) from the world's station; times
  None where the world names no time.
  """
  station, _ = tracks.stations(world.params, [world.describe['seed']])
  start = world_start(world)

  def place(x_m, y_m, t_s, name):
    if not (np.isfinite(x_m) and np.isfinite(y_m)):
      return {f'{name}_{key}': None for key in ('lat', 'lon', 'utc',
                                                'east_km', 'north_km')}
    lat, lon = tracks.point_lat_lon(station[0][0], station[0][1],
                                    float(x_m) / 1000.0, float(y_m) / 1000.0)
    utc = None if start is None or not np.isfinite(t_s) else tracks.utc_text(
        start + dt.timedelta(seconds=float(t_s)))
    return {f'{name}_lat': lat, f'{name}_lon': lon, f'{name}_utc': utc,
            f'{name}_east_km': float(x_m) / 1000.0,
            f'{name}_north_km': float(y_m) / 1000.0}

  out = []
  for k, record in enumerate(records):
    leg = {name: value[k] for name, value in legs.items()}
    site_x, site_y = record['east_km'] * 1000.0, record['north_km'] * 1000.0
    about: Dict[str, Any] = {'floats': bool(leg['floats'])}
    if about['floats']:
      about.update(place(leg['float_x_m'], leg['float_y_m'],
                         leg['float_time_s'], 'float'))
      about['ascent_min'] = float(leg['float_time_s'] -
                                  record['hours'] * 3600.0) / 60.0
      about['ascent_drift_km'] = math.hypot(
          float(leg['float_x_m']) - site_x,
          float(leg['float_y_m']) - site_y) / 1000.0
    elif bool(leg['bursts']):
      about['burst_altitude_m'] = float(leg['burst_altitude_m'])
      about.update(place(leg['burst_x_m'], leg['burst_y_m'],
                         leg['burst_time_s'], 'burst'))
      about.update(place(leg['land_x_m'], leg['land_y_m'],
                         leg['land_time_s'], 'landing'))
    out.append({**record, 'ascent': about})
  return out
