# coding=utf-8
"""Vent/ballast altitude controller (Eq. fullcontroller) in JAX.

Paper section "Altitude Controller" (settings: `flight.params.controller`,
gin `latex_controller.*`). Once per action (a0 desired altitude [m], a1
time factor [.], a2 float flag [.]):

  hdot_des = (a0 - h) / (a1 Delta t)                          (Eq. hdot_des)
  Float      if a2 > 0                  -> neutral buoyancy   (Eq. float)
  Ballast    if hdot_des > hdot         -> sand from Eq. ballast
  Vent       if hdot_des < hdot         -> helium from Eq. vent
  Do nothing if vent < n_min or drop < m_s_min

then the altitude-band guard (`band_guard`, an explicit filter of the
actuation): outside [band_low_m, band_high_m] the decision is replaced by a
float unless it moves the balloon back into the band. Float takes precedence
and is exact (no thresholds, no guard). Amounts never exceed what is aboard.

The amounts come from the free lift carried in the state (vent =
(L - L_vent) / (M_air - M_He), drop = L_ballast - L, float: L -> 0), which is
the NumPy controller's n - n_calc and m_s - m_s_calc without their float32
cancellation; the target lift itself is returned (`lift_after_kg`) so that
the state reaches it exactly. Nothing is validated (no exceptions under
jit): actions are expected inside `ACTION_LOW`..`ACTION_HIGH` (see
`clip_action`); an action with a NaN component cannot be clipped and is
replaced as a whole by the float action (`float_if_nan`).
"""

import functools
from typing import Optional, Tuple

from flax import struct
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex.flight import envelope
from ble_latex.flight import params as params_lib
from ble_latex.flight import physics
from ble_latex.flight import state as state_lib

Array = jax.Array
DecisionCode = state_lib.DecisionCode

# Action bounds (a0 [m], a1 [.], a2 [.]), paper "Method".
ACTION_LOW = np.array([14_000.0, 1.0, -1.0], dtype=np.float32)
ACTION_HIGH = np.array([21_000.0, 5.0, 1.0], dtype=np.float32)
# |free lift| below this counts as neutral for the in-stride guard. # [kg]
NEUTRAL_LIFT_KG = 1e-9


@struct.dataclass
class Actuation:
  """The controller's output for one action (`controller.Actuation`).

  Attributes:
    decision: `DecisionCode` (int32).
    desired_ascent_rate: hdot_des (0 for float). # [m/s]
    vent_mols: Helium to vent, 0 <= vent_mols <= helium aboard. # [mol]
    drop_kg: Sand to drop, 0 <= drop_kg <= sand aboard. # [kg]
    guarded: Whether the altitude-band guard replaced the decision (bool).
    lift_after_kg: Free lift once the amounts are released: the decision's
      exact target (0 for float, Eq. vent's / Eq. ballast's steady lift),
      or, where an amount was capped at what is aboard, the lift then. # [kg]
  """
  decision: Array
  desired_ascent_rate: Array
  vent_mols: Array
  drop_kg: Array
  guarded: Array
  lift_after_kg: Array


def select(condition: Array, on_true, on_false):
  """`jnp.where` over two pytrees of the same structure."""
  return jax.tree.map(lambda a, b: jnp.where(condition, a, b), on_true,
                      on_false)


def clip_action(action: Array) -> Array:
  """Clips (a0, a1, a2) into the action Box [ACTION_LOW, ACTION_HIGH]."""
  action = jnp.asarray(action)
  return jnp.clip(action, ACTION_LOW.astype(action.dtype),
                  ACTION_HIGH.astype(action.dtype))


def float_if_nan(action: Array, altitude_m: Array) -> Tuple[Array, Array]:
  """The action, or the float action where any of its components is NaN.

  A NaN component has no place in the Box (clipping keeps NaN), so such an
  action is replaced as a whole by the float (hold) action (clip(h) [m], 1,
  +1): Eq. float, what the discrete env's STAY does; a0 and a1 do not
  matter when a2 > 0. +-inf are not replaced (they clip onto the Box's
  edges). Finite actions pass unchanged, bit for bit.

  Args:
    action: (a0 [m], a1 [.], a2 [.]), shape (..., 3).
    altitude_m: The balloon's altitude h, shape (...). # [m]

  Returns:
    (action, invalid): the action to apply and whether it was replaced
    (bool, shape (...)).
  """
  action = jnp.asarray(action)
  invalid = jnp.any(jnp.isnan(action), axis=-1)
  dtype = action.dtype
  a0 = jnp.clip(jnp.asarray(altitude_m, dtype), ACTION_LOW[0].astype(dtype),
                ACTION_HIGH[0].astype(dtype))
  one = jnp.ones_like(a0)
  hold = jnp.stack([a0, one, one], axis=-1)
  return jnp.where(invalid[..., None], hold, action), invalid


def desired_ascent_rate(params: params_lib.FlightParams, altitude_m: Array,
                        a0: Array, a1: Array) -> Array:
  """Implements Eq. hdot_des = (a0 - h) / (a1 Delta t). # [m/s]"""
  return (a0 - altitude_m) / (a1 * params.stride_s)


def float_actuation(state: state_lib.FlightState,
                    guarded: Array = False, *,
                    lift_kg: Optional[Array] = None,
                    lift_per_mol: Optional[Array] = None) -> Actuation:
  """Implements Eq. float: vent or drop to neutral buoyancy (drag 0).

  With free lift L > 0 vents n - (m_p + m_s)/(M_air - M_He) = L/(M_air -
  M_He); with L < 0 drops m_s - (n (M_air - M_He) - m_p) = -L; capped at
  what is aboard.

  Args:
    state: The balloon (helium, sand, free lift).
    guarded: Whether the band guard asked for this float.
    lift_kg: The realistic free lift (`envelope.free_lift_kg`); None = the
      paper's, `state.free_lift_kg`. # [kg]
    lift_per_mol: Its lift per mol of helium (with lift_kg). # [kg/mol]

  Returns:
    The FLOAT actuation; with lift_kg, `lift_after_kg` is the paper's
    ledger after the release (the state's `settled_lift_kg`).
  """
  realistic = lift_kg is not None
  lift = state.free_lift_kg if lift_kg is None else lift_kg  # [kg]
  per_mol = physics.LIFT_PER_MOL if lift_per_mol is None else lift_per_mol
  n, sand = state.helium_mols, state.sand_kg
  zero = jnp.zeros_like(lift)
  vent_needed = lift / per_mol  # [mol]
  vent = jnp.where(lift > 0.0, jnp.minimum(vent_needed, n), zero)
  drop = jnp.where(lift < 0.0, jnp.minimum(-lift, sand), zero)
  if realistic:
    lift_after = (state.free_lift_kg - vent * physics.LIFT_PER_MOL +
                  drop)
  else:
    lift_after = jnp.where(
        (lift > 0.0) & (vent_needed > n), lift - n * physics.LIFT_PER_MOL,
        jnp.where((lift < 0.0) & (-lift > sand), lift + sand, zero))
  return Actuation(
      decision=jnp.full(lift.shape, DecisionCode.FLOAT, jnp.int32),
      desired_ascent_rate=zero,
      vent_mols=jnp.maximum(vent, 0.0),
      drop_kg=jnp.maximum(drop, 0.0),
      guarded=jnp.broadcast_to(jnp.asarray(guarded, bool), lift.shape),
      lift_after_kg=lift_after)


def outside_band_moving_out(params: params_lib.FlightParams,
                            altitude_m: Array, rate: Array) -> Array:
  """True when h is outside the band and `rate` does not point back in."""
  return (((altitude_m < params.band_low_m) & (rate <= 0.0)) |
          ((altitude_m > params.band_high_m) & (rate >= 0.0)))


def band_guard(params: params_lib.FlightParams, state: state_lib.FlightState,
               actuation: Actuation,
               floated: Optional[Actuation] = None) -> Actuation:
  """The altitude-band guard as an action filter (Eq. fullcontroller).

  Inside [band_low_m, band_high_m] the actuation stands. Outside, it stands
  only if the rate it leads to (hdot for "nothing", else hdot_des) points
  back into the band; otherwise it is replaced by a guarded float.

  Args:
    params: The flight system (band).
    state: The balloon at the action.
    actuation: The controller's non-float decision.
    floated: The guarded float to substitute; None =
      `float_actuation(state, guarded=True)` (the paper's lift).

  Returns:
    The actuation to apply.
  """
  if floated is None:
    floated = float_actuation(state, guarded=True)
  h = state.altitude_m
  in_band = (params.band_low_m <= h) & (h <= params.band_high_m)
  resulting = jnp.where(actuation.decision == DecisionCode.NOTHING,
                        state.ascent_rate_mps, actuation.desired_ascent_rate)
  stands = in_band | ~outside_band_moving_out(params, h, resulting)
  return select(stands, actuation, floated)


def heading_out_of_band(params: params_lib.FlightParams,
                        state: state_lib.FlightState,
                        lift_kg: Optional[Array] = None) -> Array:
  """In-stride guard test: outside the band, steady motion pointing out.

  The direction is that of the free lift (the terminal velocity), or of the
  current velocity when |L| <= 1e-9 kg, so a balloon still decelerating after
  a command back into the band is not floated; never while a finite-rate
  release is pending (`LatexBalloon._heading_out_of_band`). `lift_kg`: the
  realistic free lift (None = the paper's `state.free_lift_kg`).
  """
  lift = state.free_lift_kg if lift_kg is None else lift_kg
  pending = (state.pending_vent_mols > 0.0) | (state.pending_drop_kg > 0.0)
  direction = jnp.where(jnp.abs(lift) > NEUTRAL_LIFT_KG, lift,
                        state.ascent_rate_mps)
  return ~pending & outside_band_moving_out(params, state.altitude_m,
                                            direction)


def decide(params: params_lib.FlightParams, state: state_lib.FlightState,
           action: Array, temperature: Array, pressure: Array) -> Actuation:
  """Implements Eq. fullcontroller for one action.

  With any realistic switch on (`params.realistic`) the equations use the
  same gas temperature and pressure, lift and drag as the integrator
  (`decide_realistic`).

  Args:
    params: The flight system.
    state: The balloon at the action (h, hdot, n, m_s, L, time).
    action: (a0 [m], a1 [.], a2 [.]), shape (3,), inside the action Box.
    temperature: Ambient T at the balloon. # [K]
    pressure: Ambient P at the balloon. # [Pa]

  Returns:
    The actuation (amounts capped at what is aboard).
  """
  if params.realistic:
    return decide_realistic(params, state, action, temperature, pressure)
  action = jnp.asarray(action)
  a0, a1, a2 = action[..., 0], action[..., 1], action[..., 2]
  h, v = state.altitude_m, state.ascent_rate_mps
  n, sand, lift = state.helium_mols, state.sand_kg, state.free_lift_kg
  rate = desired_ascent_rate(params, h, a0, a1)

  # Ballast (Eq. ballast): drop = m_s - m_s_calc = L_ballast - L.
  lift_ballast = physics.ballast_target_lift_kg(
      n, rate, params.drag_coefficient, temperature, pressure)
  drop_needed = lift_ballast - lift  # [kg]
  drop = jnp.minimum(drop_needed, sand)
  ballast = (rate > v) & (drop >= params.min_drop_kg) & (drop > 0.0)
  lift_after_ballast = jnp.where(drop_needed > sand, lift + sand,
                                 lift_ballast)
  # Vent (Eq. vent): vent = n - n_calc = (L - L_vent) / (M_air - M_He).
  lift_vent = physics.vent_target_lift_kg(params.payload_kg, sand, rate,
                                          params.drag_coefficient,
                                          temperature, pressure)
  vent_needed = (lift - lift_vent) / physics.LIFT_PER_MOL  # [mol]
  vent = jnp.minimum(vent_needed, n)
  venting = (rate < v) & (vent >= params.min_vent_mols) & (vent > 0.0)
  lift_after_vent = jnp.where(vent_needed > n,
                              lift - n * physics.LIFT_PER_MOL, lift_vent)

  zero = jnp.zeros_like(rate)
  decision = jnp.where(ballast, DecisionCode.BALLAST,
                       jnp.where(venting, DecisionCode.VENT,
                                 DecisionCode.NOTHING)).astype(jnp.int32)
  actuation = Actuation(decision=decision, desired_ascent_rate=rate,
                        vent_mols=jnp.where(venting, vent, zero),
                        drop_kg=jnp.where(ballast, drop, zero),
                        guarded=jnp.zeros(rate.shape, bool),
                        lift_after_kg=jnp.where(
                            ballast, lift_after_ballast,
                            jnp.where(venting, lift_after_vent, lift)))
  actuation = band_guard(params, state, actuation)
  return select(a2 > 0.0, float_actuation(state), actuation)


def decide_realistic(params: params_lib.FlightParams,
                     state: state_lib.FlightState, action: Array,
                     temperature: Array, pressure: Array) -> Actuation:
  """Eq. fullcontroller with the realistic gas, lift and drag (`envelope`).

  The same decisions as `decide`, with
    * the free lift L = `envelope.free_lift_kg` (helium at T_gas, P_gas, the
      random walk W) and its lift per mol M_air beta - M_He;
    * Eq. ballast: drop = k(n, hdot_des) |hdot_des| hdot_des / g - L, k with
      c_d(Re) at hdot_des and A of V = n R T_gas / P_gas;
    * Eq. vent: `envelope.vent_target` (the cubic with these a3, b, c; c_d
      at the new helium's diameter), vent = (L - L_vent) / (M_air beta -
      M_He);
    * Eq. float: L -> 0 with this L.
  Under `gas_state` the targets are for the gas as it settles under the
  commanded rate (`envelope.settled`: T_g = T + f(sun) - the adiabatic lag
  of steady motion), so that Eq. ballast / vent hold hdot_des once the gas
  has settled and Eq. float nulls the lift of a gas at rest: L, its lift
  per mol and the targets are all taken in that gas (computed from the
  air's T and P, the sun and the command; not from the heating disturbance).
  `lift_after_kg` is the paper's ledger after the release (the state's
  `settled_lift_kg`): L_paper - vent (M_air - M_He) + drop.

  Args:
    params: The flight system.
    state: The balloon at the action (its time_s sets the sun).
    action: (a0 [m], a1 [.], a2 [.]) inside the action Box.
    temperature: Ambient T at the balloon. # [K]
    pressure: Ambient P at the balloon. # [Pa]

  Returns:
    The actuation.
  """
  action = jnp.asarray(action)
  a0, a1, a2 = action[..., 0], action[..., 1], action[..., 2]
  h, v = state.altitude_m, state.ascent_rate_mps
  n, sand = state.helium_mols, state.sand_kg
  g = envelope.of_state(params, state, temperature, pressure, state.time_s)
  rate = desired_ascent_rate(params, h, a0, a1)
  rest = g
  if params.gas_state:  # The gas as it settles (see above).
    forcing = envelope.forcing_k(params, state.time_s, state.x_m, state.y_m)
    rest = envelope.settled(params, g, forcing, jnp.zeros_like(rate))
    g = envelope.settled(params, g, forcing, rate)
  lift = envelope.free_lift_kg(params, state, g)
  per_mol = envelope.lift_per_mol(params, g)

  lift_ballast = envelope.steady_lift_kg(params, n, g, rate)
  drop_needed = lift_ballast - lift  # [kg]
  drop = jnp.minimum(drop_needed, sand)
  ballast = (rate > v) & (drop >= params.min_drop_kg) & (drop > 0.0)
  lift_vent = envelope.vent_target(params, params.payload_kg, sand,
                                   state.lift_walk_kg, n, g, rate)
  vent_needed = (lift - lift_vent) / per_mol  # [mol]
  vent = jnp.minimum(vent_needed, n)
  venting = (rate < v) & (vent >= params.min_vent_mols) & (vent > 0.0)

  zero = jnp.zeros_like(rate)
  vent = jnp.where(venting & ~ballast, vent, zero)
  drop = jnp.where(ballast, drop, zero)
  decision = jnp.where(ballast, DecisionCode.BALLAST,
                       jnp.where(venting, DecisionCode.VENT,
                                 DecisionCode.NOTHING)).astype(jnp.int32)
  actuation = Actuation(
      decision=decision, desired_ascent_rate=rate,
      vent_mols=jnp.maximum(vent, 0.0), drop_kg=jnp.maximum(drop, 0.0),
      guarded=jnp.zeros(rate.shape, bool),
      lift_after_kg=(state.free_lift_kg - vent * physics.LIFT_PER_MOL +
                     drop))
  floated = functools.partial(
      float_actuation, lift_kg=envelope.free_lift_kg(params, state, rest),
      lift_per_mol=envelope.lift_per_mol(params, rest))
  actuation = band_guard(params, state, actuation,
                         floated=floated(state, guarded=True))
  return select(a2 > 0.0, floated(state), actuation)
