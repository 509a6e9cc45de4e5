# coding=utf-8
"""The latex balloon's 71 observation features (and the optional ones) and
its reward, in JAX.

Pure, jittable and vmappable: `features` (with the history bookkeeping as
`init_history` / `push_history` and the reset-time references as
`initial_resources`), `bearing_errors`, and `reward` (BLE's
`perciatelli_reward_function` for a latex balloon plus the optional resource
penalty). BLE's interfaces over them: `ble_latex.ble.features`
(`LatexFeatureConstructor`) and `ble_latex.ble.reward` (`latex_reward`).
`NamedLatexFeatures` decodes an observation.

Every input is a plain array (or a NamedTuple of arrays), so nothing here
depends on a flight-state class: the caller passes the balloon's position,
altitude, ascent rate, resources, the ambient temperature and pressure at
its altitude, the forecast column at `PRESSURE_LEVELS` (for the generative
field, `ble_latex.wind.generative.forecast_column`) and the measured wind at
the balloon (BLE's ground truth: forecast at the balloon's pressure + simplex
noise).

Every feature is scaled to [-1, 1] (clipped); `NamedLatexFeatures`
decodes them. squash(x, c) = x / (x + c) is BLE's
`transforms.squash_to_unit_interval`. Index map (N_LEVELS = 25; the docs
site's observation table is generated from this table):

| index   | feature                                                            | scaling                  |
|---------|--------------------------------------------------------------------|--------------------------|
| 0-24    | forecast wind speed |v| at 25 pressure levels, 5000..14000 Pa      | 1 - exp(-|v| / 30 m/s)   |
| 25-49   | bearing error theta of that wind to the target, same levels        | theta / pi               |
| 50      | altitude h                                                         | (h - 17.5 km) / 3.5 km   |
| 51      | ascent rate hdot                                                   | hdot / 5 m/s             |
| 52      | measured wind speed at the balloon |v_h|                           | squash(|v_h|, 30 m/s)    |
| 53      | bearing error at the balloon theta_h                               | theta_h / pi             |
| 54      | drag area A                                                        | A / 25 m^2               |
| 55      | envelope volume V                                                  | V / 100 m^3              |
| 56      | total system mass m_T                                              | m_T / initial m_T        |
| 57      | distance to the target |x|                                        | squash(|x|, 250 km)      |
| 58, 59  | heading to the target sin(theta_x), cos(theta_x)                   | as is                    |
| 60-62   | altitudes at t-1, t-2, t-3                                         | as index 50              |
| 63-65   | ascent rates at t-1, t-2, t-3                                      | as index 51              |
| 66-68   | float actions a2 at t-1, t-2, t-3                                  | as is ([-1, 1])          |
| 69      | sand mass m_s                                                      | m_s / initial m_s        |
| 70      | helium n                                                           | n / initial n            |

71 features: exactly the items the paper lists (its text says 74 and 77 in
different places; the listed items add up to 71). Options (gin
`latex_observation.sun`, `.gas_temperature`) append features after index 70
(`option_features`, whose docstring holds their index map). The wind column is BLE's
forecast (the agent's view); the balloon moves in forecast + simplex noise
(BLE's ground truth), and features 52-53 use that measured wind. At reset the
history slots hold the current values and float actions 0.

Precision: computed in the floating dtype of the inputs (float32 by default);
features are returned as float32 like `get_features`, rewards in the input
dtype. In float32 the features agree with BLE-object computations within ~1e-6
and the reward with BLE's within ~1e-7 (tests/envs/test_jax_features.py). Bearing
errors are computed as atan2(|cross|, dot), not arccos(cos): the same angle,
without arccos's loss of precision near 0 and pi.
"""

import math
from typing import Any, NamedTuple

import jax.numpy as jnp
import numpy as np

from ble_latex import dtypes
from ble_latex.envs import task
from ble_latex.flight import physics

N_LEVELS = 25
NUM_FEATURES = 2 * N_LEVELS + 21
HISTORY = 3
# Pressure levels of the forecast column (LatexFeatureConstructor's
# defaults: np.linspace(5000, 14000, 25)). # [Pa]
PRESSURE_LEVELS = np.linspace(5000.0, 14000.0, N_LEVELS)
_TOLERANCE = 1e-5  # [m], [m/s]
# Feature scales (the module's index map; `NamedLatexFeatures`
# undoes them).
SPEED_SQUASH_MPS = 30.0  # [m/s]
DISTANCE_SQUASH_KM = 250.0  # [km]
ALTITUDE_CENTER_M = 17_500.0  # [m]
ALTITUDE_SCALE_M = 3_500.0  # [m]
ASCENT_RATE_SCALE_MPS = 5.0  # [m/s]
DRAG_AREA_SCALE_M2 = 25.0  # [m^2]
VOLUME_SCALE_M3 = 100.0  # [m^3]
# The optional features' scales (`option_features`).
SUN_ELEVATION_SCALE_DEG = 90.0  # [deg]
# The sun's elevation changes by at most 15.04 deg/h (the sidereal rate, at
# the equator at the equinoxes near the horizon). # [deg/h]
SUN_RATE_SCALE_DEG_PER_H = 15.0
# The gas-air difference: +8.1 K by day, -3.3 K at night (the realistic
# physics), and a climb at w cools the gas by ~8 K per m/s below its target
# (`flight.gas.steady_lag_k` at tau = 600 s): +-20 K holds climbs and
# descents up to ~1.5 m/s unclipped. # [K]
GAS_EXCESS_SCALE_K = 20.0
# Sizes of the options (features each appends).
SUN_FEATURES = 2
GAS_TEMPERATURE_FEATURES = 1
# BLE's perciatelli_reward_function writes ln(2) as this literal.
_LN2_BLE = 0.69314718056


class History(NamedTuple):
  """The last HISTORY steps of the balloon, newest first (t-1, t-2, t-3).

  Attributes:
    altitude_m: [..., 3] altitudes. # [m]
    ascent_rate_mps: [..., 3] ascent rates. # [m/s]
    float_action: [..., 3] float actions a2. # [.]
  """
  altitude_m: jnp.ndarray
  ascent_rate_mps: jnp.ndarray
  float_action: jnp.ndarray


class InitialResources(NamedTuple):
  """The references of features 56, 69, 70, fixed at the episode's reset.

  Attributes:
    mass_kg: Initial total system mass. # [kg]
    sand_kg: Initial sand, at least 1e-5. # [kg]
    helium_mols: Initial helium, at least 1e-5. # [mol]
  """
  mass_kg: jnp.ndarray
  sand_kg: jnp.ndarray
  helium_mols: jnp.ndarray


def initial_resources(payload_kg: Any, sand_kg: Any,
                      helium_mols: Any) -> InitialResources:
  """`LatexFeatureConstructor.observe`'s references at the first observation.

  Args:
    payload_kg: Payload m_p, including the envelope. # [kg]
    sand_kg: Sand aboard at reset. # [kg]
    helium_mols: Helium at reset. # [mol]

  Returns:
    InitialResources(total mass, max(sand, 1e-5), max(helium, 1e-5)).
  """
  dtype = dtypes.float_dtype(payload_kg, sand_kg, helium_mols)
  payload_kg, sand_kg, helium_mols = (jnp.asarray(v, dtype) for v in
                                      (payload_kg, sand_kg, helium_mols))
  return InitialResources(
      mass_kg=physics.total_mass(payload_kg, sand_kg, helium_mols),
      sand_kg=jnp.maximum(sand_kg, _TOLERANCE),
      helium_mols=jnp.maximum(helium_mols, _TOLERANCE))


def init_history(altitude_m: Any, ascent_rate_mps: Any) -> History:
  """`LatexFeatureConstructor.observe`'s history at the first observation.

  Every slot holds the current altitude and ascent rate; float actions 0.

  Args:
    altitude_m: Altitude at reset. # [m]
    ascent_rate_mps: Ascent rate at reset. # [m/s]

  Returns:
    The History ([..., 3] each).
  """
  dtype = dtypes.float_dtype(altitude_m, ascent_rate_mps)
  altitude_m = jnp.asarray(altitude_m, dtype)
  ascent_rate_mps = jnp.asarray(ascent_rate_mps, dtype)
  slots = altitude_m.shape + (HISTORY,)
  return History(
      altitude_m=jnp.broadcast_to(altitude_m[..., None], slots),
      ascent_rate_mps=jnp.broadcast_to(ascent_rate_mps[..., None], slots),
      float_action=jnp.zeros(slots, dtype))


def push_history(history: History, altitude_m: Any, ascent_rate_mps: Any,
                 float_action: Any) -> History:
  """`LatexFeatureConstructor.observe` after a step: a new slot t-1.

  The deques' `appendleft` with maxlen 3: the given values become slot 0 and
  the oldest slot is dropped.

  Which altitude and ascent rate to push: the features' documentation says
  the previous step's (t-1). The gym env (as BLE's features did) pushes
  the altitude of BLE's live balloon state object, already updated by
  the step: it pushes the state *after* the step,
  so slot t-1 equals the current value (features 60 = 50, 63 = 51). Pass the
  current values to reproduce it, the pre-step values for the documented
  features. The float action pushed is the one just applied (a2 of the
  step's action) either way.

  Args:
    history: The History before the step.
    altitude_m: Altitude for slot t-1. # [m]
    ascent_rate_mps: Ascent rate for slot t-1. # [m/s]
    float_action: a2 of the action just applied. # [.]

  Returns:
    The History after the step.
  """
  def push(slots: jnp.ndarray, value: Any) -> jnp.ndarray:
    value = jnp.broadcast_to(jnp.asarray(value, slots.dtype),
                             slots.shape[:-1])
    return jnp.concatenate([value[..., None], slots[..., :-1]], axis=-1)

  return History(
      altitude_m=push(history.altitude_m, altitude_m),
      ascent_rate_mps=push(history.ascent_rate_mps, ascent_rate_mps),
      float_action=push(history.float_action, float_action))


def bearing_errors(u: Any, v: Any, x_m: Any, y_m: Any) -> jnp.ndarray:
  """Bearing errors: wind vs direction to the target.

  The angle between the wind (u, v) and the direction from the balloon to
  the target (-x, -y): 0 when the wind blows straight at the target, pi when
  straight away; 0 at the target (distance < 1e-5 m), pi in calm air (speed
  < 1e-5 m/s). Inputs broadcast.

  Args:
    u: Eastward wind. # [m/s]
    v: Northward wind. # [m/s]
    x_m: Balloon x offset from the target. # [m]
    y_m: Balloon y offset from the target. # [m]

  Returns:
    Bearing errors in [0, pi]. # [rad]
  """
  dtype = dtypes.float_dtype(u, v, x_m, y_m)
  u, v, x_m, y_m = (jnp.asarray(a, dtype) for a in (u, v, x_m, y_m))
  dot = -x_m * u - y_m * v
  cross = -x_m * v + y_m * u
  error = jnp.arctan2(jnp.abs(cross), dot)
  error = jnp.where(jnp.hypot(u, v) < _TOLERANCE, math.pi, error)
  return jnp.where(jnp.hypot(x_m, y_m) < _TOLERANCE, 0.0, error)


def _squash(value: jnp.ndarray, constant: float) -> jnp.ndarray:
  """BLE's `transforms.squash_to_unit_interval`: x / (x + c) for x >= 0."""
  return value / (value + constant)


def _scale_altitude(altitude_m: jnp.ndarray) -> jnp.ndarray:
  return (altitude_m - ALTITUDE_CENTER_M) / ALTITUDE_SCALE_M


def features(column_u: Any, column_v: Any, x_m: Any, y_m: Any,
             altitude_m: Any, ascent_rate_mps: Any, wind_u: Any, wind_v: Any,
             helium_mols: Any, sand_kg: Any, payload_kg: Any,
             temperature_k: Any, pressure_pa: Any,
             initial: InitialResources, history: History) -> jnp.ndarray:
  """`LatexFeatureConstructor.get_features`: the 71 features, in [-1, 1].

  For one balloon; vmap for a batch. Index map: the module's.

  Args:
    column_u: [25] forecast eastward wind at PRESSURE_LEVELS. # [m/s]
    column_v: [25] forecast northward wind at PRESSURE_LEVELS. # [m/s]
    x_m: Balloon x offset from the target (east). # [m]
    y_m: Balloon y offset from the target (north). # [m]
    altitude_m: Altitude h. # [m]
    ascent_rate_mps: Ascent rate hdot. # [m/s]
    wind_u: Measured eastward wind at the balloon (ground truth). # [m/s]
    wind_v: Measured northward wind at the balloon (ground truth). # [m/s]
    helium_mols: Helium n. # [mol]
    sand_kg: Sand m_s. # [kg]
    payload_kg: Payload m_p, including the envelope. # [kg]
    temperature_k: Ambient temperature at the balloon's altitude
      (BLE's `atmosphere.at_height(h).temperature`). # [K]
    pressure_pa: Ambient pressure at the balloon's altitude
      (BLE's `atmosphere.at_height(h).pressure`). # [Pa]
    initial: The episode's `initial_resources`.
    history: The `History` (t-1, t-2, t-3).

  Returns:
    float32 [71] features, clipped to [-1, 1].
  """
  dtype = dtypes.float_dtype(
      column_u, column_v, x_m, y_m, altitude_m, ascent_rate_mps, wind_u,
      wind_v, helium_mols, sand_kg, payload_kg, temperature_k, pressure_pa)
  (column_u, column_v, x_m, y_m, altitude_m, ascent_rate_mps, wind_u, wind_v,
   helium_mols, sand_kg, payload_kg, temperature_k, pressure_pa) = (
       jnp.asarray(a, dtype) for a in (
           column_u, column_v, x_m, y_m, altitude_m, ascent_rate_mps, wind_u,
           wind_v, helium_mols, sand_kg, payload_kg, temperature_k,
           pressure_pa))
  initial = InitialResources(*(jnp.asarray(a, dtype) for a in initial))
  history = History(*(jnp.asarray(a, dtype) for a in history))

  speeds = jnp.hypot(column_u, column_v)
  volume = physics.volume(helium_mols, temperature_k, pressure_pa)
  distance_km = jnp.hypot(x_m, y_m) / 1000.0
  heading = jnp.arctan2(-x_m, -y_m)
  scalars = [
      _scale_altitude(altitude_m),                                      # 50
      ascent_rate_mps / ASCENT_RATE_SCALE_MPS,                         # 51
      _squash(jnp.hypot(wind_u, wind_v), SPEED_SQUASH_MPS),            # 52
      bearing_errors(wind_u, wind_v, x_m, y_m) / math.pi,               # 53
      physics.drag_area(volume) / DRAG_AREA_SCALE_M2,                  # 54
      volume / VOLUME_SCALE_M3,                                        # 55
      physics.total_mass(payload_kg, sand_kg, helium_mols) /
      initial.mass_kg,                                                  # 56
      _squash(distance_km, DISTANCE_SQUASH_KM),                        # 57
      jnp.sin(heading),                                                 # 58
      jnp.cos(heading),                                                 # 59
  ]
  f = jnp.concatenate([
      1.0 - jnp.exp(-speeds / SPEED_SQUASH_MPS),                       # 0-24
      bearing_errors(column_u, column_v, x_m, y_m) / math.pi,           # 25-49
      jnp.stack(scalars),                                               # 50-59
      _scale_altitude(history.altitude_m),                              # 60-62
      history.ascent_rate_mps / ASCENT_RATE_SCALE_MPS,                 # 63-65
      history.float_action,                                             # 66-68
      jnp.stack([sand_kg / initial.sand_kg,                             # 69
                 helium_mols / initial.helium_mols]),                   # 70
  ])
  return jnp.clip(f, -1.0, 1.0).astype(jnp.float32)


def num_features(*, sun: bool = False, gas_temperature: bool = False) -> int:
  """The observation's size: `NUM_FEATURES` plus the options switched on."""
  return (NUM_FEATURES + SUN_FEATURES * bool(sun) +
          GAS_TEMPERATURE_FEATURES * bool(gas_temperature))


def option_features(*, sun_elevation_deg: Any = None,
                    sun_rate_deg_per_h: Any = None,
                    gas_excess_k: Any = None) -> jnp.ndarray:
  """The optional features, appended after index 70, in [-1, 1].

  The sun's two when its elevation and rate are given (gin
  `latex_observation.sun`), then the gas's when its excess temperature is
  given (`latex_observation.gas_temperature`); the values are
  `envs.observed_sun_gas`'s. Index map (the docs site's table of the
  options is generated from this table):

  | index               | feature                           | scaling          |
  |---------------------|-----------------------------------|------------------|
  | 71 (sun)            | sun elevation el at the balloon   | el / 90 deg      |
  | 72 (sun)            | its rate of change d(el)/dt       | d(el)/dt / 15 deg/h |
  | 73, or 71 if no sun | helium minus air temperature dT   | dT / 20 K        |

  Elevation and rate together tell morning from evening (the same
  elevation rises before noon and sinks after it) and how soon the sun
  crosses the horizon (about el / |d(el)/dt| hours); clipped to [-1, 1]
  like the rest (the rate's bound is the sidereal 15.04 deg/h; the gas's
  scale: `GAS_EXCESS_SCALE_K`).

  Args:
    sun_elevation_deg: The sun's elevation above the horizon; None: no sun
      features. # [deg]
    sun_rate_deg_per_h: Its rate of change (with the elevation). # [deg/h]
    gas_excess_k: T_gas - T at the balloon; None: no gas feature. # [K]

  Returns:
    float32 [0..3] features, clipped to [-1, 1].
  """
  parts = []
  if sun_elevation_deg is not None:
    parts += [jnp.asarray(sun_elevation_deg) / SUN_ELEVATION_SCALE_DEG,
              jnp.asarray(sun_rate_deg_per_h) / SUN_RATE_SCALE_DEG_PER_H]
  if gas_excess_k is not None:
    parts.append(jnp.asarray(gas_excess_k) / GAS_EXCESS_SCALE_K)
  if not parts:
    return jnp.zeros((0,), jnp.float32)
  return jnp.clip(jnp.stack(parts), -1.0, 1.0).astype(jnp.float32)


def distance_km(x_m: Any, y_m: Any) -> jnp.ndarray:
  """BLE's `units.relative_distance(x, y)` in km (the 2-norm). # [km]"""
  dtype = dtypes.float_dtype(x_m, y_m)
  return jnp.hypot(jnp.asarray(x_m, dtype), jnp.asarray(y_m, dtype)) / 1000.0


def tanh_inside(distance_km: Any, radius_km: Any, dropoff: Any,
                tanh_scale_km: Any) -> jnp.ndarray:
  """The tanh-shaped reward inside the circle (off where the scale is 0).

  Saunders et al. 2024 (arXiv 2403.10784) replace the flat reward inside the
  station circle, which SAC learns to exploit by skirting the circle's edge,
  with a tanh of the distance that pulls the balloon towards the centre.
  Their exact constants were not available to us; this form keeps the
  paper's (2023) Perciatelli reward outside the circle and makes the inside
  fall from 1 at the station to the drop-off c at the edge, continuous
  there, with the tanh's knee at scale w:

    r(d) = 1 - (1 - c) tanh(d / w) / tanh(rho / w),  d <= rho, w > 0

  (w -> infinity: a straight line from 1 to c; small w: c except near the
  station). w = 0 gives 1 (the flat, paper reward).

  Args:
    distance_km: Distance of the balloon from the station. # [km]
    radius_km: Station-keeping radius rho. # [km]
    dropoff: Reward just outside the radius c. # [.]
    tanh_scale_km: w; 0 = off (the flat reward 1). # [km]

  Returns:
    The reward inside the circle (meaningful where d <= rho).
  """
  dtype = dtypes.float_dtype(distance_km, radius_km, dropoff, tanh_scale_km)
  distance_km, radius_km, dropoff, scale = (
      jnp.asarray(a, dtype) for a in (distance_km, radius_km, dropoff,
                                      tanh_scale_km))
  on = scale > 0.0
  safe = jnp.where(on, scale, 1.0)  # No NaN (nor NaN gradient) when off.
  shaped = 1.0 - (1.0 - dropoff) * (jnp.tanh(distance_km / safe) /
                                    jnp.tanh(radius_km / safe))
  return jnp.where(on, shaped, jnp.ones_like(shaped))


def reward(distance_km: Any,  # pylint: disable=redefined-outer-name
           radius_km: Any = task.STATION_RADIUS_KM,
           dropoff: Any = 0.4,
           halflife_km: Any = 100.0,
           vented: Any = 0.0,
           dropped: Any = 0.0,
           helium_penalty: Any = 0.0,
           sand_penalty: Any = 0.0,
           tanh_scale_km: Any = 0.0) -> jnp.ndarray:
  """BLE's Perciatelli reward - penalties (`ble_latex.ble.reward.latex_reward`).

  BLE's `perciatelli_reward_function` for a latex balloon (its power term
  never applies: no air pump): 1 within the radius, else dropoff *
  exp(-0.69314718056 / halflife * (d - radius)) (BLE's literal for ln 2),
  minus helium_penalty * vented and sand_penalty * dropped. With
  `tanh_scale_km` > 0 the inside is `tanh_inside` (the follow-up paper's
  tanh shape) instead of 1. The defaults are BLE's and `latex_reward`'s
  defaults. Inputs broadcast; no gin.

  Args:
    distance_km: Distance of the balloon from the target (`distance_km`).
      # [km]
    radius_km: Station-keeping radius (BLE's station_keeping_radius_km).
      # [km]
    dropoff: Reward just outside the radius (BLE's reward_dropoff). # [.]
    halflife_km: Distance over which it halves (BLE's reward_halflife).
      # [km]
    vented: Helium vented during the step. # [mol]
    dropped: Sand dropped during the step. # [kg]
    helium_penalty: Penalty per mol of helium vented. # [1/mol]
    sand_penalty: Penalty per kg of sand dropped. # [1/kg]
    tanh_scale_km: The inside's tanh scale w; 0: flat (the paper's). # [km]

  Returns:
    The step reward, in (-inf, 1].
  """
  dtype = dtypes.float_dtype(distance_km, radius_km, dropoff, halflife_km,
                              vented, dropped, helium_penalty, sand_penalty,
                              tanh_scale_km)
  (distance_km, radius_km, dropoff, halflife_km, vented, dropped,
   helium_penalty, sand_penalty) = (
       jnp.asarray(a, dtype) for a in (
           distance_km, radius_km, dropoff, halflife_km, vented, dropped,
           helium_penalty, sand_penalty))
  outside = dropoff * jnp.exp(-_LN2_BLE / halflife_km *
                              (distance_km - radius_km))
  inside = tanh_inside(distance_km, radius_km, dropoff, tanh_scale_km)
  base = jnp.where(distance_km <= radius_km, inside, outside)
  return base - helium_penalty * vented - sand_penalty * dropped


class NamedLatexFeatures:
  """The features decoded back into named quantities (the decoder).

  The inverse of the scalings in the module's index map, as BLE's
  `features.NamedPerciatelliFeatures` is of its Perciatelli features. Values
  that the encoder clipped to [-1, 1] decode to the edge of their range (an
  altitude above 21 km reads as 21 km); squashed magnitudes near 1 decode to
  large finite values.

  Attributes:
    wind_speeds_mps: [25] forecast wind speed |v| at PRESSURE_LEVELS. # [m/s]
    bearing_errors_rad: [25] angle between that wind and the direction to
      the target. # [rad]
    altitude_m: Altitude h. # [m]
    ascent_rate_mps: Ascent rate hdot. # [m/s]
    wind_speed_mps: Measured wind speed at the balloon. # [m/s]
    bearing_error_rad: Bearing error of the measured wind. # [rad]
    drag_area_m2: Drag area A. # [m^2]
    volume_m3: Envelope volume V. # [m^3]
    mass_fraction: Total system mass / its value at reset. # [.]
    distance_km: Distance to the target. # [km]
    sin_heading, cos_heading: Heading to the target. # [.]
    altitude_history_m: [3] altitudes at t-1, t-2, t-3. # [m]
    ascent_rate_history_mps: [3] ascent rates at t-1, t-2, t-3. # [m/s]
    float_action_history: [3] float actions a2 at t-1, t-2, t-3. # [.]
    sand_fraction: Sand / sand at reset. # [.]
    helium_fraction: Helium / helium at reset. # [.]
    sun_elevation_deg: The sun's elevation at the balloon (option `sun`;
      None without it). # [deg]
    sun_rate_deg_per_h: Its rate of change (option `sun`). # [deg/h]
    gas_excess_k: Helium minus air temperature (option `gas_temperature`;
      None without it). # [K]
  """

  def __init__(self, observation: np.ndarray):
    """Decodes one observation.

    The options it holds follow from its size (`num_features`: 71 none, 72
    the gas's, 73 the sun's, 74 both).

    Args:
      observation: [71..74] features of `LatexBalloon-v0`.

    Raises:
      ValueError: If the observation is not one of those sizes.
    """
    f = np.asarray(observation)
    sizes = {num_features(sun=sun, gas_temperature=gas): (sun, gas)
             for sun in (False, True) for gas in (False, True)}
    if f.ndim != 1 or f.shape[0] not in sizes:
      raise ValueError(f'NamedLatexFeatures needs {NUM_FEATURES} features '
                       f'(LatexBalloon-v0), or {sorted(sizes)[1:]} with its '
                       f'observation options, got shape {f.shape}')
    sun, gas = sizes[f.shape[0]]
    extra = f[NUM_FEATURES:].astype(np.float64)
    self.sun_elevation_deg = self.sun_rate_deg_per_h = None
    self.gas_excess_k = None
    if sun:
      self.sun_elevation_deg = float(extra[0]) * SUN_ELEVATION_SCALE_DEG
      self.sun_rate_deg_per_h = float(extra[1]) * SUN_RATE_SCALE_DEG_PER_H
    if gas:
      self.gas_excess_k = float(extra[-1]) * GAS_EXCESS_SCALE_K
    f = f[:NUM_FEATURES]
    n = N_LEVELS
    # Features 0-24 are 1 - exp(-|v| / c).
    squashed = np.clip(f[:n], 0.0, 1.0 - 1e-6)
    self.wind_speeds_mps = -SPEED_SQUASH_MPS * np.log1p(-squashed)
    self.bearing_errors_rad = f[n:2 * n] * math.pi
    scalars = [float(x) for x in f[2 * n:2 * n + 10]]
    self.altitude_m = _altitude_m(scalars[0])
    self.ascent_rate_mps = scalars[1] * ASCENT_RATE_SCALE_MPS
    self.wind_speed_mps = _unsquash(scalars[2], SPEED_SQUASH_MPS)
    self.bearing_error_rad = scalars[3] * math.pi
    self.drag_area_m2 = scalars[4] * DRAG_AREA_SCALE_M2
    self.volume_m3 = scalars[5] * VOLUME_SCALE_M3
    self.mass_fraction = scalars[6]
    self.distance_km = _unsquash(scalars[7], DISTANCE_SQUASH_KM)
    self.sin_heading, self.cos_heading = scalars[8], scalars[9]
    h = 2 * n + 10
    self.altitude_history_m = np.array(
        [_altitude_m(float(x)) for x in f[h:h + HISTORY]])
    self.ascent_rate_history_mps = (
        f[h + HISTORY:h + 2 * HISTORY].astype(np.float64) *
        ASCENT_RATE_SCALE_MPS)
    self.float_action_history = f[h + 2 * HISTORY:h + 3 * HISTORY].copy()
    self.sand_fraction, self.helium_fraction = float(f[-2]), float(f[-1])


def _altitude_m(scaled: float) -> float:
  """Undoes (h - 17.5 km) / 3.5 km. # [m]"""
  return ALTITUDE_CENTER_M + ALTITUDE_SCALE_M * scaled


def _unsquash(squashed: float, constant: float) -> float:
  """Undoes `_squash` (x / (x + c)): c y / (1 - y), y kept inside [0, 1)."""
  y = min(max(squashed, 0.0), 1.0 - 1e-6)
  return y * constant / (1.0 - y)
