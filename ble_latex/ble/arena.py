# coding=utf-8
"""The latex balloon arena: BLE's arena interface over the flight core.

`LatexBalloonArena` implements BLE's `BalloonArenaInterface` (what
`BalloonEnv`, BLE's `eval_lib` and renderers use) on one
`ble_latex.envs.gymnasium_env.LatexBalloonGymnasiumEnv` (`driver`), i.e. on
the same jitted core as `ble_latex/LatexBalloon-v0` and the batched env.
What it adds for BLE's side:

- the world of BLE's `BalloonArena.reset(key)`: atmosphere, start time,
  start distance (Beta(1.2, 2) x 200 km) and angle, station location, the
  latex balloon neutral at an altitude uniform in the start band, and the
  wind (by default BLE's generative field drawn inside the core,
  `ble.wind.CoreGenerativeWindField`; any other BLE `WindField`, e.g.
  ERA5, is flown through host callbacks, and one that chooses its own start
  time sets the flight's date);
- one step is one 20-minute controller action; the core re-queries the
  ground-truth wind at every sub-step of at most 3 simulated minutes;
- BLE objects only when asked (`get_balloon_state`, `get_simulator_state`,
  `get_measurements`, a BLE feature constructor): the `LatexBalloonState`
  view is built from the host copy of the flight the last reset/step
  brought back (`flight`, `balloon.write_flight`), BLE's `Atmosphere` from
  the arena key; nothing is mirrored per step;
- observations: the core's 71 features for `features.LatexFeatureConstructor`
  (the continuous env), or any BLE feature constructor fed with BLE's
  measurements (the discrete env's Perciatelli features).

`set_simulator_state` / `set_balloon_state` are not supported (the core's
state is not rebuilt from BLE objects); they raise NotImplementedError.
"""

import datetime as dt
import secrets
from typing import Any, Callable, Dict, Optional, Tuple, Union

from balloon_learning_environment.env import balloon_arena
from balloon_learning_environment.env import features
from balloon_learning_environment.env import simulator_data
from balloon_learning_environment.env import wind_field
from balloon_learning_environment.env.balloon import standard_atmosphere
from balloon_learning_environment.utils import sampling
from balloon_learning_environment.utils import units
import jax
import jax.numpy as jnp
import numpy as np
import s2sphere as s2

from ble_latex.ble import balloon as balloon_lib
from ble_latex.ble import features as latex_features
from ble_latex.ble import gridded_field
from ble_latex.ble import wind as ble_wind
from ble_latex.envs import env_params
from ble_latex.envs import env_types
from ble_latex.envs import gymnasium_env
from ble_latex.envs import gymnasium_render
from ble_latex.flight import physics as core_physics
from ble_latex.wind import gridded_jax


class LatexBalloonArena(balloon_arena.BalloonArenaInterface):
  """BLE's arena interface over one balloon of the flight core."""

  def __init__(self,
               feature_constructor_factory: Callable[
                   [wind_field.WindField, standard_atmosphere.Atmosphere],
                   features.FeatureConstructor],
               wind_field_instance: Optional[wind_field.WindField] = None,
               seed: Optional[int] = None,
               *,
               start_altitude_range_m: Optional[Tuple[float, float]] = None,
               max_start_distance_km: Optional[float] = None,
               stride: Optional[dt.timedelta] = None,
               episode_steps: Optional[int] = None,
               station_keeping_radius_km: Optional[float] = None):
    """Constructor.

    Args:
      feature_constructor_factory: Builds the feature constructor;
        `features.LatexFeatureConstructor` means the core's 71 features.
      wind_field_instance: The wind field to fly in; None or a
        `CoreGenerativeWindField`: BLE's generative field inside the core
        (ERA5 if gin binds `latex_episode.wind_field_factory =
        @GriddedWindField`); a `gridded_field.GriddedWindField` or
        `gridded.Era5Settings`: its grid, in the core; any other BLE
        `WindField`: host callbacks.
      seed: Optional seed (BLE semantics).
      start_altitude_range_m: Start altitude is uniform in this range;
        None: gin's `latex_start.start_altitude_range_m`. # [m]
      max_start_distance_km: Start distance is BLE's Beta(1.2, 2) times this;
        None: gin's. # [km]
      stride: Simulated time per action (paper: 20 minutes); None: gin's.
      episode_steps: Strides per episode (the env's); None: gin's.
      station_keeping_radius_km: The station radius (`EnvParams.radius_km`:
        the core's reward and TW50); None: gin's. # [km]
    """
    # Checked with every other value by the driver (`env_params.check_params`,
    # the one validator of the env's values).
    given = {k: v for k, v in (
        ('start_altitude_range_m', start_altitude_range_m),
        ('max_start_distance_km', max_start_distance_km),
        ('stride', stride)) if v is not None}
    params = env_params.params_from_gin().replace(**env_params.start(**given))
    if episode_steps is not None:
      params = params.replace(episode_steps=episode_steps)
    if station_keeping_radius_km is not None:
      params = params.replace(radius_km=station_keeping_radius_km)
    era5_settings = gridded_field.grid_settings(wind_field_instance)
    if era5_settings is not None:
      # ERA5 flies in JAX (its grid in the params); BLE's consumers read it
      # through the core's field, as the generative one.
      params = params.replace(
          wind_grid=gridded_jax.grid_from_settings(era5_settings))
      wind_field_instance = None
    if wind_field_instance is None:
      wind_field_instance = ble_wind.CoreGenerativeWindField()
    core_wind = isinstance(wind_field_instance,
                           ble_wind.CoreGenerativeWindField)
    self._env = gymnasium_env.LatexBalloonGymnasiumEnv(
        params=params, host_wind=(
            None if core_wind else ble_wind.host_wind(wind_field_instance)))
    if core_wind:
      wind_field_instance.attach(lambda: self._env.state,
                                 lambda: self._env.params)
    self._wind_field = wind_field_instance
    self._feature_constructor_factory = feature_constructor_factory
    self._core_features = (
        feature_constructor_factory is latex_features.LatexFeatureConstructor)
    self.info: Dict[str, Any] = {}  # The gym env's info of the last step.
    self.reward = float('nan')  # The core's reward of the last step.
    # The core's flight that `driver.flight` (its host copy) was copied from.
    self._flight_of = None
    # Built when asked, for the flight of the last reset (the atmosphere)
    # or the flight state they were built from (the view).
    self._atmosphere: Optional[standard_atmosphere.Atmosphere] = None
    self._atmosphere_key: Optional[jax.Array] = None
    self._center_latlng: Optional[s2.LatLng] = None
    self._view: Optional[balloon_lib.LatexBalloonState] = None
    self._view_of = None
    self._feature_constructor: Optional[features.FeatureConstructor] = None
    self.reset(seed)

  @property
  def driver(self) -> gymnasium_env.LatexBalloonGymnasiumEnv:
    """The core balloon this arena flies (`state`, `params`, `flight`)."""
    return self._env

  @property
  def params(self) -> env_types.EnvParams:
    return self._env.params

  @property
  def feature_constructor(self) -> features.FeatureConstructor:
    """This episode's BLE feature constructor (built when first asked)."""
    if self._feature_constructor is None:
      self._feature_constructor = self._feature_constructor_factory(
          self._wind_field, self._ble_atmosphere())
    return self._feature_constructor

  def reset(self, seed: Union[int, jnp.ndarray, None] = None) -> np.ndarray:
    """A new flight from BLE's arena key (int seed, key, or None: random)."""
    if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
      key = jax.random.PRNGKey(int(seed))
    elif isinstance(seed, (np.ndarray, jnp.ndarray)):
      key = jnp.asarray(seed)
    else:
      key = jax.random.PRNGKey(secrets.randbits(32))
    observation, self.info = self._env.start(key)
    self.reward = float('nan')
    self._flight_of = self._env.state.flight
    self._atmosphere_key = key  # BLE's atmosphere key is split from it.
    self._center_latlng = None
    self._view = None
    self._feature_constructor = None
    return self._observe(observation)

  def step(self, action: np.ndarray) -> np.ndarray:
    """Applies one controller action (a0, a1, a2) for one stride.

    The driver's step checks it (ValueError, nothing changed).
    """
    observation, self.reward, _, truncated, self.info = self._env.step(action)
    if truncated:  # gym's info says it.
      self.info['TimeLimit.truncated'] = True
    self._flight_of = self._env.state.flight
    return self._observe(observation)

  def flight(self) -> Dict[str, np.ndarray]:
    """The balloon's `FlightState` as NumPy values by field name.

    The host copy the last reset/step brought back; read from the device
    only if the core's state was set from outside since.
    """
    flight = self._env.state.flight
    if flight is self._flight_of:
      return self._env.flight
    return gymnasium_render.flight_values(jax.device_get(flight))

  def _observe(self, core_observation: np.ndarray) -> np.ndarray:
    if self._core_features:
      return core_observation
    self.feature_constructor.observe(self.get_measurements())
    return self.feature_constructor.get_features()

  def _ble_atmosphere(self) -> standard_atmosphere.Atmosphere:
    """BLE's atmosphere of this flight (one object, reset when asked)."""
    if self._atmosphere_key is not None:
      key = jax.random.split(self._atmosphere_key, 3)[1]  # BLE's arena.
      if self._atmosphere is None:
        self._atmosphere = standard_atmosphere.Atmosphere(key)
      else:
        self._atmosphere.reset(key)
      self._atmosphere_key = None
    return self._atmosphere

  def get_simulator_state(self) -> simulator_data.SimulatorState:
    """BLE's `SimulatorState` view: balloon state, wind field, atmosphere."""
    return simulator_data.SimulatorState(self.get_balloon_state(),
                                         self._wind_field,
                                         self._ble_atmosphere())

  def set_simulator_state(self,
                          new_state: simulator_data.SimulatorState) -> None:
    """Unsupported: raises `NotImplementedError` (the flight is the core's)."""
    raise NotImplementedError(
        'LatexBalloonArena cannot restore a SimulatorState: the flight lives '
        "in the JAX core (the arena's driver.state).")

  def get_balloon_state(self) -> balloon_lib.LatexBalloonState:
    """The BLE view of the flight now (built from `flight()` when asked)."""
    flight_of = self._env.state.flight
    if self._view is None or self._view_of is not flight_of:
      if self._center_latlng is None:
        self._center_latlng = sampling.sample_location(self._env.location_key)
      flight = self.flight()
      system = self.params.flight
      view = balloon_lib.LatexBalloonState(
          center_latlng=self._center_latlng,
          date_time=self._env.start_date_time,
          x=units.Distance(m=0.0), y=units.Distance(m=0.0),
          altitude_m=float(flight['altitude_m']),
          payload_kg=system.payload_kg, sand_kg=float(flight['sand_kg']),
          helium_mols=float(flight['helium_mols']),
          drag_coefficient=system.drag_coefficient,
          burst_volume_m3=system.burst_volume_m3)
      # nRT/P in the core's precision (its `FlightState.volume_m3`).
      volume = core_physics.volume(flight['helium_mols'],
                                   flight['temperature_k'],
                                   flight['pressure_pa'])
      balloon_lib.write_flight(view, flight,
                               start_date_time=self._env.start_date_time,
                               volume_m3=float(volume))
      self._view, self._view_of = view, flight_of
    return self._view

  def set_balloon_state(self, new_state: balloon_lib.LatexBalloonState
                        ) -> None:
    """Unsupported: raises `NotImplementedError` (the flight is the core's)."""
    raise NotImplementedError(
        'LatexBalloonArena cannot restore a balloon state: the flight lives '
        "in the JAX core (the arena's driver.state).")

  def get_measurements(self) -> simulator_data.SimulatorObservation:
    """BLE's `SimulatorObservation`: the balloon state and the measured wind."""
    u, v = self._env.measured_wind()
    return simulator_data.SimulatorObservation(
        balloon_observation=self.get_balloon_state(),
        wind_at_balloon=wind_field.WindVector(units.Velocity(mps=u),
                                              units.Velocity(mps=v)))
