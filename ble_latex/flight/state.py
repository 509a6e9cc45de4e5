# coding=utf-8
"""`FlightState`: the latex balloon's state as a frozen pytree.

The JAX counterpart of `ble_latex.ble.balloon.LatexBalloonState` without BLE's
bookkeeping (lat/lng, date): position, vertical state, resources, pending
finite-rate releases, cumulative releases, time, status and what the
controller did at the last action. The flight-system constants (payload,
c_d, burst volume, ...) live in `FlightParams`.

Integer codes: `FlightStatus` follows `balloon.LatexBalloonStatus` (same
values), `DecisionCode` the order of `controller.Decision`.
"""

import enum
from typing import Optional

from flax import struct
import jax
import jax.numpy as jnp

from ble_latex.flight import atmosphere as atmosphere_lib
from ble_latex.flight import estimator
from ble_latex.flight import params as params_lib
from ble_latex.flight import physics
from ble_latex.flight import thermal

Array = jax.Array


class FlightStatus(enum.IntEnum):
  """`FlightState.status` (values of `balloon.LatexBalloonStatus`)."""
  OK = 0
  OUT_OF_SAND = 1
  OUT_OF_HELIUM = 2
  BURST = 3
  GROUNDED = 4
  # Set by the env, not the flight core: the balloon left the area of its
  # wind source's data (`envs.winds.Wind.outside`, issue 45).
  LEFT_WIND_DOMAIN = 5


# The statuses that end a flight for want of sand or helium.
OUT_OF_RESOURCES = frozenset({FlightStatus.OUT_OF_SAND,
                              FlightStatus.OUT_OF_HELIUM})


class DecisionCode(enum.IntEnum):
  """`FlightState.last_decision` (order of `controller.Decision`)."""
  NOTHING = 0
  FLOAT = 1
  VENT = 2
  BALLAST = 3


@struct.dataclass
class FlightState:
  """The state of one latex balloon (all leaves are arrays).

  Attributes:
    x_m: Offset east of the station. # [m]
    y_m: Offset north of the station. # [m]
    altitude_m: Altitude h. # [m]
    ascent_rate_mps: Ascent rate hdot. # [m/s]
    helium_mols: Helium in the envelope n. # [mol]
    sand_kg: Sand aboard m_s. # [kg]
    settled_lift_kg: Free lift once the pending releases are done; the
      current free lift is the property `free_lift_kg` = settled +
      pending_vent (M_air - M_He) - pending_drop. Carried instead of being
      recomputed as n (M_air - M_He) - m_p - m_s, which cancels to ~4e-7 kg
      in float32 (a spurious ~4 mm/s terminal velocity of a "neutral"
      balloon): the controller sets it to its exact target (0 for a float),
      so neutral buoyancy is exact in float32 too. Build states with
      `initial_state` or `with_resources` to keep it consistent. # [kg]
    pending_vent_mols: Helium still to vent (finite valve flow only). # [mol]
    pending_drop_kg: Sand still to drop (finite ballast rate only). # [kg]
    helium_vented_mols: Cumulative helium vented. # [mol]
    sand_dropped_kg: Cumulative sand dropped. # [kg]
    time_s: Simulated time since the start. # [s]
    status: `FlightStatus` code (int32); terminal codes freeze the state.
    last_action: The last (a0 [m], a1 [.], a2 [.]) applied, shape (3,).
    last_decision: `DecisionCode` of the last action (int32).
    desired_ascent_rate_mps: hdot_des of the last action (0 when floating).
      # [m/s]
    guard_engaged: Whether the altitude-band guard floated the balloon
      during the last step (bool).
    pressure_pa: Ambient pressure at the balloon. # [Pa]
    temperature_k: Ambient temperature at the balloon (the helium's in the
      paper's model; `envelope.gas` gives the helium's). # [K]
    lift_walk_kg: Free lift of the random walk W (0 unless
      `FlightParams.lift_walk`; `envelope.free_lift_kg`). # [kg]
    lift_walk_gusty: The disturbance's regime, gusty (True) or calm (bool;
      False unless `FlightParams.lift_walk_intermittent`; a flight starts
      calm; `disturbance.switch`).
    burst_volume_m3: This flight's burst volume (`FlightParams.
      burst_volume_m3` unless `burst_spread`: drawn at launch). # [m^3]
    gas_temperature_k: The helium's temperature T_g, a state under
      `FlightParams.gas_state` (`gas`); otherwise the air's at the start
      and not advanced. # [K]
    heating_k: The heating disturbance dT_h (0 unless
      `FlightParams.heating_noise`; `gas.heating_transition`). # [K]
    estimated_heating_k: The balloon's estimate of dT_h from what it
      measures (`estimator`; 0 unless heating_noise). # [K]
    heating_variance_k2: Its variance (`estimator`). # [K^2]
    estimated_lift_kg: The balloon's estimate of W (`estimator`; 0 unless
      lift_walk). # [kg]
    lift_variance_kg2: Its variance (`estimator`). # [kg^2]

  Hidden from every controller (`estimator.planning_view`): heating_k,
  lift_walk_kg, lift_walk_gusty and, under burst_spread, burst_volume_m3.
  """
  x_m: Array
  y_m: Array
  altitude_m: Array
  ascent_rate_mps: Array
  helium_mols: Array
  sand_kg: Array
  settled_lift_kg: Array
  pending_vent_mols: Array
  pending_drop_kg: Array
  helium_vented_mols: Array
  sand_dropped_kg: Array
  time_s: Array
  status: Array
  last_action: Array
  last_decision: Array
  desired_ascent_rate_mps: Array
  guard_engaged: Array
  pressure_pa: Array
  temperature_k: Array
  lift_walk_kg: Array
  lift_walk_gusty: Array
  burst_volume_m3: Array
  gas_temperature_k: Array
  heating_k: Array
  estimated_heating_k: Array
  heating_variance_k2: Array
  estimated_lift_kg: Array
  lift_variance_kg2: Array

  @property
  def free_lift_kg(self) -> Array:
    """Current free lift L = n (M_air - M_He) - m_p - m_s. # [kg]"""
    return (self.settled_lift_kg +
            self.pending_vent_mols * physics.LIFT_PER_MOL -
            self.pending_drop_kg)

  def volume_m3(self) -> Array:
    """Envelope volume nRT/P at the balloon. # [m^3]"""
    return physics.volume(self.helium_mols, self.temperature_k,
                          self.pressure_pa)


def _float(value) -> Array:
  return jnp.asarray(value, jnp.asarray(0.0).dtype)


def initial_state(params: params_lib.FlightParams,
                  altitude_m: Array,
                  x_m: Array = 0.0,
                  y_m: Array = 0.0,
                  *,
                  atm_params: atmosphere_lib.AtmosphereParams,
                  ascent_rate_mps: Array = 0.0,
                  sand_kg: Optional[Array] = None,
                  helium_mols: Optional[Array] = None,
                  time_s: Array = 0.0,
                  key: Optional[Array] = None) -> FlightState:
  """A new balloon as `balloon.create_state` builds it.

  The helium's temperature (`gas_temperature_k`) starts at the air's plus
  the lagged solar forcing at the balloon (`thermal.gas_excess_k`: a gas at
  rest in the sun since the infinite past) under `gas_superheat`, else at
  the air's.

  Sand defaults to `params.initial_sand_kg`; helium to
  `params.initial_helium_mols`, or, when that is None, neutral buoyancy
  (Eq. float: n = (m_p + m_s) / (M_air - M_He), free lift exactly 0).
  Pressure and temperature are BLE's atmosphere at the altitude.

  Args:
    params: The flight system.
    altitude_m: Start altitude h. # [m]
    x_m: Start offset east of the station. # [m]
    y_m: Start offset north of the station. # [m]
    atm_params: The atmosphere (for the ambient fields).
    ascent_rate_mps: Start ascent rate. # [m/s]
    sand_kg: Initial sand; None = params.initial_sand_kg. # [kg]
    helium_mols: Initial helium; None = params.initial_helium_mols. # [mol]
    time_s: Start time. # [s]
    key: PRNG key of the burst diameter's draw; needed (and used) only
      when `params.burst_spread`.

  Returns:
    The state (jittable; no validation).

  Raises:
    ValueError: `params.burst_spread` without a key.
  """
  # The lift is formed before the inputs are cast, so Python / NumPy float64
  # inputs give a float64-accurate lift in float32 too.
  sand = params.initial_sand_kg if sand_kg is None else sand_kg
  if helium_mols is None:
    helium_mols = params.initial_helium_mols
  if helium_mols is None:
    helium = physics.neutral_helium_mols(params.payload_kg, sand)
    lift = 0.0
  else:
    helium = helium_mols
    lift = physics.free_lift(helium_mols, params.payload_kg, sand)
  sand, helium, lift = _float(sand), _float(helium), _float(lift)
  h = _float(altitude_m)
  ambient = atmosphere_lib.at_height(atm_params, h)
  zero = jnp.zeros_like(h)
  if params.burst_spread:
    if key is None:
      raise ValueError('FlightParams.burst_spread (create_state.'
                       'burst_weibull_scale_m) draws the burst diameter: '
                       'initial_state needs a PRNG key')
    burst = physics.burst_volume_of_diameter(physics.draw_burst_diameter(
        key, params.burst_weibull_scale_m + zero,
        params.burst_weibull_shape)).astype(h.dtype)
  else:
    burst = _float(params.burst_volume_m3) + zero
  heat, heat_var, walk, walk_var = estimator.initial(params, h)
  return FlightState(
      x_m=_float(x_m) + zero,
      y_m=_float(y_m) + zero,
      altitude_m=h,
      ascent_rate_mps=_float(ascent_rate_mps) + zero,
      helium_mols=helium + zero,
      sand_kg=sand + zero,
      settled_lift_kg=lift + zero,
      pending_vent_mols=zero,
      pending_drop_kg=zero,
      helium_vented_mols=zero,
      sand_dropped_kg=zero,
      time_s=_float(time_s) + zero,
      status=jnp.full(h.shape, int(FlightStatus.OK), jnp.int32),
      last_action=jnp.zeros(h.shape + (3,), h.dtype),
      last_decision=jnp.full(h.shape, int(DecisionCode.NOTHING), jnp.int32),
      desired_ascent_rate_mps=zero,
      guard_engaged=jnp.zeros(h.shape, bool),
      pressure_pa=ambient.pressure,
      temperature_k=ambient.temperature,
      lift_walk_kg=zero,
      lift_walk_gusty=jnp.zeros(h.shape, bool),
      burst_volume_m3=burst,
      gas_temperature_k=ambient.temperature + _excess(params, time_s, x_m,
                                                      y_m, h),
      heating_k=zero,
      estimated_heating_k=heat,
      heating_variance_k2=heat_var,
      estimated_lift_kg=walk,
      lift_variance_kg2=walk_var)


def _excess(params: params_lib.FlightParams, time_s, x_m, y_m,
            like: Array) -> Array:
  """The lagged solar T_g - T at launch (0 without gas_superheat). # [K]"""
  if not params.gas_superheat:
    return jnp.zeros_like(like)
  return thermal.gas_excess_k(params, _float(time_s) + jnp.zeros_like(like),
                              _float(x_m) + jnp.zeros_like(like),
                              _float(y_m) + jnp.zeros_like(like)
                              ).astype(like.dtype)


def with_resources(params: params_lib.FlightParams, state: FlightState, *,
                   helium_mols: Optional[Array] = None,
                   sand_kg: Optional[Array] = None) -> FlightState:
  """The state with new helium / sand and the free lift recomputed from them.

  Args:
    params: The flight system (payload).
    state: The state to change.
    helium_mols: New helium n; None keeps it. # [mol]
    sand_kg: New sand m_s; None keeps it. # [kg]

  Returns:
    The state with n, m_s and the free lift n (M_air - M_He) - m_p - m_s
    (pending releases kept).
  """
  n = state.helium_mols if helium_mols is None else _float(helium_mols)
  s = state.sand_kg if sand_kg is None else _float(sand_kg)
  lift = physics.free_lift(n, params.payload_kg, s)
  return state.replace(
      helium_mols=n, sand_kg=s,
      settled_lift_kg=(lift - state.pending_vent_mols * physics.LIFT_PER_MOL +
                       state.pending_drop_kg))
