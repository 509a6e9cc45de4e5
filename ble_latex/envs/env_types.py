# coding=utf-8
"""The functional env's types: `EnvParams`, `EnvState`, `ResetPool`.

gymnax's `EnvParams`/`EnvState` split (jumanji's `types.py`): the frozen
pytrees every part of the env reads (`jax_env`, `winds`, `reset_pool`,
`env_params`), and the two small functions of a state that the step and the
reset share (`flight_params_of`, `walk_key`). `EnvParams` is the one home of
every env default (flight system, controller, reward, task, episode); gin
fills it through `env_params.params_from_gin`.
"""

import datetime as dt
from typing import Any, Optional

import flax
import jax
import jax.numpy as jnp

from ble_latex.envs import jax_features
from ble_latex.envs import task
from ble_latex.flight import atmosphere as atmosphere_lib
from ble_latex.flight import params as flight_params_lib
from ble_latex.flight import solar
from ble_latex.flight import state as state_lib
from ble_latex.wind import generative
from ble_latex.wind import gridded_jax
from ble_latex.wind import noise_gp
from ble_latex.wind import simplex

Array = jax.Array
# BLE's sampling.sample_time starts on this date (a flight's
# `start_time_offset_s` counts from it).
START_EPOCH = dt.datetime(2011, 1, 1, tzinfo=dt.timezone.utc)
# Realistic physics (issue 28): the key of the lift random walk (from the
# step count) is folded in with this, so the paper's draws stay as they were.
_WALK_KEY_DATA = 28_002
# START_EPOCH's day for the sun's clock (`FlightParams.start_day_j2000`).
_EPOCH_DAY_J2000 = solar.solar_clock(START_EPOCH, 'START_EPOCH')[0]


@flax.struct.dataclass
class EnvParams:
  """Everything that configures the env (gymnax's `EnvParams`).

  Attributes:
    flight: The flight system and controller (`flight.params`).
    decoder: BLE's VAE decoder variables (`generative.decoder_params()`).
    radius_km: The station-keeping radius rho, one home for the reward,
      TW50 (the trainers' scores, the metrics, BLE's view) and the drawn
      circle; gin `latex_episode.station_keeping_radius_km`. # [km]
    reward_dropoff: Reward just outside the radius. # [.]
    reward_halflife_km: Half-life of the reward outside the radius. # [km]
    reward_tanh_scale_km: 0: the paper's flat reward inside the radius; w >
      0: the follow-up paper's tanh shape there (`jax_features.tanh_inside`,
      gin `latex_reward.reward_tanh_scale_km`). # [km]
    helium_penalty_per_mol: Reward penalty per mol vented. # [1/mol]
    sand_penalty_per_kg: Reward penalty per kg dropped. # [1/kg]
    start_altitude_low_m: Start altitude band, low edge. # [m]
    start_altitude_high_m: Start altitude band, high edge. # [m]
    max_start_distance_km: Scale of the Beta start distance. # [km]
    episode_steps: Strides per episode (216 = 3 days); traced, so a new
      length does not recompile.
    stride_s: Simulated time per action (the arena's stride). Static. # [s]
    wind_grid: None: the winds are the env's `winds.Wind` (BLE's generative
      field by default); a `gridded_jax.Era5Grid`: ERA5 winds plus BLE's
      simplex noise (`winds.era5_wind`), the grid shared by every balloon.
    reset_pool: None: `step` auto-resets a finished flight with the world
      of its reset key (`reset(key_reset)`, a full reset computed at every
      step); a `ResetPool` (`LatexBalloonJaxEnv.with_reset_pool`): `step`
      auto-resets from the pool's pre-drawn worlds, shared by every balloon
      (cheap, `reset_pool`).
    wind_memory: 0 (default): the paper's observation, the forecast column
      (features 0-49). K > 0: that column corrected by the balloon's last K
      measured winds, forecast + the Gaussian-process posterior mean of
      BLE's noise given them (`noise_gp`, Eq. (2); what `latex_mpc` plans
      in, and what BLE's Perciatelli features read through its wind GP);
      the state keeps them (`EnvState.wind_memory`). Static (it sizes the
      state); gin `latex_observation.wind_memory`.
    wind_lookahead: 0 (default): the column is the wind at the balloon's
      position now. N > 0: at each level, the mean wind of a drift that
      stays at that level for N strides from the balloon's position, on
      the same (forecast or corrected) winds (`observed_winds.column`).
      Static (it sizes the drift's loop); gin
      `latex_observation.wind_lookahead`.
    sun: False (default): the paper's observation. True: two features
      appended, the sun's elevation at the balloon and its rate of change
      (`jax_features.option_features`, `observed_sun_gas`), on the flight's
      own clock and place (`sun_params_of`). Static (it sizes the
      observation); gin `latex_observation.sun`.
    gas_temperature: False (default): the paper's observation. True: one
      feature appended after the sun's, the helium's temperature minus the
      air's at the balloon (`observed_sun_gas`; 0 under the paper's physics,
      where the helium is at the air's temperature). Static; gin
      `latex_observation.gas_temperature`.
  """
  flight: flight_params_lib.FlightParams
  decoder: Any
  radius_km: float = task.STATION_RADIUS_KM
  reward_dropoff: float = 0.4
  reward_halflife_km: float = 100.0
  reward_tanh_scale_km: float = 0.0
  helium_penalty_per_mol: float = 0.0
  sand_penalty_per_kg: float = 0.0
  start_altitude_low_m: float = 15_000.0
  start_altitude_high_m: float = 20_000.0
  max_start_distance_km: float = 200.0
  episode_steps: int = task.EPISODE_STEPS
  stride_s: float = flax.struct.field(pytree_node=False, default=1200.0)
  wind_grid: Optional[gridded_jax.Era5Grid] = None
  reset_pool: Optional['ResetPool'] = None
  wind_memory: int = flax.struct.field(pytree_node=False, default=0)
  wind_lookahead: int = flax.struct.field(pytree_node=False, default=0)
  sun: bool = flax.struct.field(pytree_node=False, default=False)
  gas_temperature: bool = flax.struct.field(pytree_node=False, default=False)

  @property
  def max_steps_in_episode(self) -> int:
    """gymnax's name of `episode_steps`."""
    return self.episode_steps


@flax.struct.dataclass
class EnvState:
  """One balloon's world and flight (gymnax's `EnvState`; frozen pytree).

  Attributes:
    flight: The balloon (`flight.state.FlightState`).
    atmosphere: This flight's atmosphere.
    forecast: This flight's forecast wind field (None on ERA5 winds).
    noise_u: Noise of the eastward wind component.
    noise_v: Noise of the northward wind component.
    initial: References of the resource features.
    history: Feature history (altitude, ascent rate, float action).
    wind_u: Measured (ground-truth) eastward wind at the balloon. # [m/s]
    wind_v: Measured (ground-truth) northward wind at the balloon. # [m/s]
    start_time_offset_s: Start time after `START_EPOCH` (BLE's date; on
      ERA5 winds the flight's start in the data). # [s]
    steps: Strides flown in this episode (the one step count).
    pending_world: -1; after an auto-reset from `EnvParams.reset_pool`, the
      pool world whose large leaves (forecast grid, noise permutations)
      `step_env` installs first (`reset_pool.install_world`).
    station: None (BLE's winds, or a wind grid's fixed target); per-seed
      stations (`Era5Grid.station_box`): [2] this flight's station
      (latitude [deg N], longitude [deg E]), drawn at reset. # [deg]
    truth_member: None; on an ensemble's member truths
      (`GriddedWindField.truth_members`): this flight's truth member, an index
      into `Era5Grid.truth_uv`'s members, drawn at reset (int32).
    wind_memory: None (`EnvParams.wind_memory` 0); else the last K
      measured-minus-forecast winds at the balloon, one per measurement
      (reset and every stride), that the observation's column is corrected
      by (`noise_gp.Measurements`).
  """
  flight: state_lib.FlightState
  atmosphere: atmosphere_lib.AtmosphereParams
  forecast: generative.ForecastField
  noise_u: simplex.NoiseParams
  noise_v: simplex.NoiseParams
  initial: jax_features.InitialResources
  history: jax_features.History
  wind_u: Array
  wind_v: Array
  start_time_offset_s: Array
  steps: Array
  pending_world: Array
  station: Optional[Array] = None
  truth_member: Optional[Array] = None
  wind_memory: Optional[noise_gp.Measurements] = None


@flax.struct.dataclass
class ResetPool:
  """K pre-drawn worlds that `step` auto-resets from (`EnvParams.reset_pool`).

  Built by `LatexBalloonJaxEnv.with_reset_pool(key, params, size)`: world k
  is `reset(jax.random.split(key, size)[k], params)` (vmapped), i.e. the
  world of an explicit reset with that key. A pytree of arrays with a
  leading axis K, read by every balloon (pass the params unbatched,
  `in_axes=None`: one copy, not one per balloon).

  Attributes:
    obs: [K, 71] the worlds' first observations.
    state: `EnvState` with a leading axis K (measured, `steps` = 0).
  """
  obs: Array
  state: EnvState

  @property
  def size(self) -> int:
    """K, the number of worlds."""
    return self.obs.shape[0]


def walk_key(state: EnvState) -> Array:
  """The key of this stride's lift random walk (`FlightParams.lift_walk`).

  A function of the flight's world (its start time and atmosphere, drawn at
  reset) and the step count, so a seed's flight is the same whoever steps
  it (the trainer's and the Gymnasium wrapper's step keys are shared by a
  batch, or None).
  """
  alpha_bits = jax.lax.bitcast_convert_type(
      state.atmosphere.alpha.astype(jnp.float32), jnp.uint32)
  key = jax.random.fold_in(jax.random.PRNGKey(_WALK_KEY_DATA),
                           state.start_time_offset_s)
  return jax.random.fold_in(jax.random.fold_in(key, alpha_bits), state.steps)


def sun_params_of(params: EnvParams, state: EnvState
                  ) -> flight_params_lib.FlightParams:
  """`params.flight` with the sun's clock and place of this flight.

  The clock set to the flight's start (`start_time_offset_s` after
  `START_EPOCH`: BLE's drawn date, or the flight's start in the ERA5 data),
  the place to the flight's station where it has its own
  (`EnvState.station`), else `FlightParams.latitude_deg` /
  `longitude_deg`. What the helium's sun (`flight_params_of`) and the
  observation's sun (`EnvParams.sun`) read, under any physics.

  Args:
    params: The env parameters (their `flight` system).
    state: The env state (its `start_time_offset_s`, int32 seconds after
      `START_EPOCH`, and `station`).

  Returns:
    The flight parameters with `start_day_j2000`, `start_second_of_day`
    (and the station's latitude / longitude) of this flight.
  """
  flight = params.flight
  offset = state.start_time_offset_s  # [s] int32
  days = offset // 86_400
  dtype = state.flight.time_s.dtype
  if state.station is not None:
    flight = flight.replace(
        latitude_deg=state.station[0].astype(dtype),
        longitude_deg=(state.station[1] + 180.0) % 360.0 - 180.0)
  return flight.replace(
      start_day_j2000=_EPOCH_DAY_J2000 + days.astype(dtype),
      start_second_of_day=(offset - days * 86_400).astype(dtype))


def flight_params_of(params: EnvParams, state: EnvState
                     ) -> flight_params_lib.FlightParams:
  """The flight system of this flight: `sun_params_of` (the sun's clock and
  place of the flight) when the helium follows the sun
  (`FlightParams.gas_superheat`); else `params.flight` itself.

  Args:
    params: The env parameters (their `flight` system).
    state: The env state (its `start_time_offset_s`, int32 seconds after
      `START_EPOCH`).

  Returns:
    The flight parameters to fly this flight with.
  """
  if not params.flight.gas_superheat:
    return params.flight
  return sun_params_of(params, state)
