# coding=utf-8
"""The balloon's onboard estimate of its hidden disturbances, and what a
controller may know (issue 63 item 3).

Under realistic physics the flight carries disturbances no balloon can read:
the heating disturbance dT_h of the gas's relaxation target
(`FlightState.heating_k`, `gas.heating_transition`), the free-lift
disturbance W (`FlightState.lift_walk_kg`, `disturbance`) and this flight's
drawn burst volume (`FlightState.burst_volume_m3`). The flight core carries
an estimate of the first two in the state (`estimated_heating_k`,
`heating_variance_k2`, `estimated_lift_kg`, `lift_variance_kg2`), updated by
two scalar Kalman filters after every vertical chunk of the integrator
(`dynamics`, 20 s under the realistic preset) from what the balloon measures:
its altitude and ascent rate, the air's temperature and pressure there, the
gas's temperature (a thermometer in the envelope), the sun (its clock and
position) and its own helium and sand (its actions).

Prediction (each chunk of length dt; the processes' own laws):

  dT_h:  x <- a x,  P <- a^2 P + s_h^2 (1 - a^2),  a = e^(-dt / tau_h)
  W:     x <- b x,  P <- b^2 P + sigma^2 v(dt),    b = e^(-dt / tau_W)

(v(dt) = tau_W (1 - b^2) / 2, or dt for the random walk tau_W = 0; s_h =
`heating_noise_k`, sigma = `lift_walk_kg_per_sqrt_s`, the gusty one of the
intermittent option).

Correction on the gas temperature (`heating_innovation`). The integrator's
chunk (Strang splitting of Eq. (1) of `gas`) is affine in dT_h once the path
is measured:

  T_g1 = (1 - c) (T_1 + f + dT_h) + c r [(1 - c) (T_0 + f + dT_h) + c T_g0]

with c = e^(-dt / (2 tau)), r = (P_g1 / P_g0)^kappa, T_0, T_1 the air's
temperature at the chunk's start and end, f the sun's forcing. The
innovation is the measured T_g1 minus this with the estimate, its
sensitivity H = (1 - c) (1 + c r) [K/K]: no model error, so no linearisation
of a stride (a jacfwd of the whole step would cost a second stride).

Correction on the ascent rate (`lift_innovation`). The chunk's final rate is
Eq. fullN2L solved exactly with the forces frozen at the end altitude
(`physics.relax`, as `physics.vertical_step_varying`'s last solve):
v_1 = relax(v_0, dt; F_known + W g, m, k). F_known is the free lift without
W in the gas at the end altitude (the gas's temperature there from the
measured T_g0 and the estimate of dT_h), k the drag factor at the mean rate;
H = g dv_1/dF by forward-mode differentiation of the closed form [m/s/kg].

Measurement noise: R = sigma_1Hz^2 (1 s) / dt, a 1 Hz sensor averaged over
the chunk, so the filter does not depend on the chunk's length
(`THERMOMETER_NOISE_K`, `RATE_NOISE_MPS`: assumptions, the simulator's
measurements are exact).

`controller_view` is the state the onboard altitude controller (Eq.
fullcontroller and the in-stride guard in `dynamics`) acts on: W's estimate
for W. `planning_view` is the one function every controller's lookahead
flies through: noiseless parameters (no new draws), the estimates in place of the
hidden disturbances, and the burst volume at a low quantile of its Weibull
law (`BURST_QUANTILE`). Under the paper's physics it changes nothing, and
the flight core never runs the filters (`FlightParams.stochastic` False:
skipped at trace time).

Pure, jittable, vmappable functions; units in the docstrings.
"""

import functools
from typing import Tuple

import jax
import jax.numpy as jnp

from ble_latex.flight import disturbance
from ble_latex.flight import envelope
from ble_latex.flight import gas as gas_lib
from ble_latex.flight import params as params_lib
from ble_latex.flight import physics

Array = jax.Array

# rms of one 1 Hz reading of the envelope's thermometer (a thermistor;
# assumption): 0.011 K averaged over a 20 s chunk. # [K]
THERMOMETER_NOISE_K = 0.05
# rms of one 1 Hz reading of the ascent rate (GPS vertical velocity;
# assumption). # [m/s]
RATE_NOISE_MPS = 0.1
# The sensors' sampling period (R = sigma^2 SAMPLE_S / dt). # [s]
SAMPLE_S = 1.0
# The burst volume a controller plans with: the Weibull law's 1 % quantile
# of the diameter (99 % of envelopes burst above it; 181 m^3 for ASTRA's
# TA-1200, against a median of 439 m^3; ~20-100 m^3 in the 13-22 km band).
# A burst ends the flight, so a planner keeps a margin on the envelope it
# cannot see, rather than the median. # [.]
BURST_QUANTILE = 0.01


def initial(params: params_lib.FlightParams, like: Array
            ) -> Tuple[Array, Array, Array, Array]:
  """The estimates at launch: (dT_h, its variance, W, its variance).

  dT_h's prior is its stationary law (mean 0, variance `heating_noise_k`^2
  under `heating_noise`); W is the free lift gained since the launch, where
  the balloon is trimmed to neutral (known: 0, variance 0).

  Args:
    params: The flight system.
    like: An array of the state's shape and dtype.

  Returns:
    ([K], [K^2], [kg], [kg^2]).
  """
  zero = jnp.zeros_like(like)
  variance = (zero + jnp.asarray(params.heating_noise_k, zero.dtype) ** 2
              if params.heating_noise else zero)
  return zero, variance, zero, zero


def _ou_predict(mean: Array, variance: Array, duration: Array, *,
                sigma: Array, time_constant_s: Array) -> Tuple[Array, Array]:
  """Mean and variance of dX = -X / tau dt + sigma dB after `duration`.

  a = e^(-dt / tau): (a x, a^2 P + sigma^2 tau (1 - a^2) / 2); tau = 0: the
  random walk, (x, P + sigma^2 dt).
  """
  decay, added = disturbance.decay_and_variance(duration, time_constant_s,
                                                mean.dtype)
  return decay * mean, decay * decay * variance + sigma * sigma * added


def kalman_update(mean: Array, variance: Array, innovation: Array,
                  sensitivity: Array, noise_variance: Array
                  ) -> Tuple[Array, Array]:
  """The scalar Kalman filter's correction.

  K = P H / (H^2 P + R); x + K y, (1 - K H) P.

  Args:
    mean: The prior estimate x. # [unit]
    variance: Its variance P. # [unit^2]
    innovation: y, the measurement minus its prediction. # [measured unit]
    sensitivity: H = d(measurement) / dx. # [measured unit / unit]
    noise_variance: R > 0. # [measured unit^2]

  Returns:
    (posterior estimate, posterior variance).
  """
  gain = variance * sensitivity / (sensitivity * sensitivity * variance +
                                   noise_variance)
  return (mean + gain * innovation,
          jnp.maximum((1.0 - gain * sensitivity) * variance, 0.0))


def _noise(sigma: float, duration: Array) -> Array:
  """R = sigma^2 SAMPLE_S / dt of a 1 Hz sensor averaged over dt."""
  return sigma * sigma * SAMPLE_S / jnp.maximum(duration, 1e-3)


def heating_innovation(params: params_lib.FlightParams, *, estimate: Array,
                       gas_start_k: Array, gas_end_k: Array,
                       air_start_k: Array, air_end_k: Array,
                       gas_pressure_start: Array, gas_pressure_end: Array,
                       forcing_k: Array, duration: Array
                       ) -> Tuple[Array, Array, Array]:
  """The gas thermometer's innovation on dT_h over one chunk (see above).

  Args:
    params: The flight system (gas_thermal_lag_s).
    estimate: The prior estimate of dT_h. # [K]
    gas_start_k: The measured T_g at the chunk's start. # [K]
    gas_end_k: The measured T_g at its end. # [K]
    air_start_k: The air's T at the start altitude. # [K]
    air_end_k: The air's T at the end altitude. # [K]
    gas_pressure_start: P_g at the start altitude. # [Pa]
    gas_pressure_end: P_g at the end altitude. # [Pa]
    forcing_k: The sun's forcing f over the chunk. # [K]
    duration: dt. # [s]

  Returns:
    (innovation [K], sensitivity H [K/K], the gas's temperature on the
    path at the end altitude under the estimate (before the second
    relaxation) [K]).
  """
  tau = params.gas_thermal_lag_s
  half = 0.5 * duration
  t0 = gas_lib.relax(gas_start_k, air_start_k + forcing_k + estimate, half,
                     tau)
  path = gas_lib.adiabatic(t0, gas_pressure_start, gas_pressure_end)
  t1 = gas_lib.relax(path, air_end_k + forcing_k + estimate, half, tau)
  # c = e^(-dt / 2 tau): relax(0 -> target 1) = 1 - c.
  one_minus_c = gas_lib.relax(jnp.zeros_like(half), jnp.ones_like(half),
                              half, tau)
  ratio = (gas_pressure_end / gas_pressure_start) ** gas_lib.KAPPA_HELIUM
  sensitivity = one_minus_c * (1.0 + (1.0 - one_minus_c) * ratio)
  return gas_end_k - t1, sensitivity, path


def lift_innovation(*, estimate: Array, rate_start: Array, rate_end: Array,
                    duration: Array, known_lift_kg: Array, mass: Array,
                    drag_k: Array) -> Tuple[Array, Array]:
  """The ascent rate's innovation on W over one chunk (see above).

  Args:
    estimate: The prior estimate of W. # [kg]
    rate_start: The measured hdot at the chunk's start. # [m/s]
    rate_end: The measured hdot at its end. # [m/s]
    duration: dt. # [s]
    known_lift_kg: The free lift without W at the end altitude. # [kg]
    mass: The total mass. # [kg]
    drag_k: The drag factor k there. # [kg/m]

  Returns:
    (innovation [m/s], sensitivity H [m/s/kg]).
  """
  def rate(walk):
    return physics.relax(rate_start, duration,
                         lift_force=(known_lift_kg + walk) * physics.GRAVITY,
                         mass=mass, drag_k=drag_k)[1]

  predicted, sensitivity = jax.jvp(rate, (estimate,),
                                   (jnp.ones_like(estimate),))
  return rate_end - predicted, sensitivity


def observe_chunk(params: params_lib.FlightParams, before, after,
                  duration: Array, *, air_start_k: Array,
                  gas_pressure_start: Array, gas_end: envelope.Gas,
                  forcing_k: Array = None):
  """The estimates after one chunk of flight from `before` to `after`.

  Predicts both disturbances over the chunk, corrects dT_h on the gas's
  temperature (under `heating_noise`), then W on the ascent rate (under
  `lift_walk`). Reads of the states only what the balloon measures or
  knows: altitude, ascent rate, T_g, helium, sand, the lift ledger and the
  estimates; never `heating_k`, `lift_walk_kg` or `burst_volume_m3`.

  Args:
    params: The flight system (stochastic: else `after` is returned).
    before: The `FlightState` at the chunk's start.
    after: The state at its end (the estimates still `before`'s).
    duration: dt. # [s]
    air_start_k: The air's T at the start altitude. # [K]
    gas_pressure_start: P_g at the start altitude. # [Pa]
    gas_end: The air's T, P and P_g at the end altitude (`envelope.Gas`;
      its gas temperature is used without `gas_state` only).
    forcing_k: The sun's forcing f (under `gas_state`). # [K]

  Returns:
    `after` with its estimates and variances updated.
  """
  if not params.stochastic:
    return after
  heat, heat_var = before.estimated_heating_k, before.heating_variance_k2
  walk, walk_var = before.estimated_lift_kg, before.lift_variance_kg2
  thermometer = functools.partial(
      heating_innovation, params, gas_start_k=before.gas_temperature_k,
      gas_end_k=after.gas_temperature_k, air_start_k=air_start_k,
      air_end_k=gas_end.air_temperature,
      gas_pressure_start=gas_pressure_start,
      gas_pressure_end=gas_end.pressure, forcing_k=forcing_k,
      duration=duration)
  if params.heating_noise:
    heat, heat_var = _ou_predict(
        heat, heat_var, duration, sigma=params.heating_noise_k * jnp.sqrt(
            2.0 / params.heating_noise_time_s),
        time_constant_s=params.heating_noise_time_s)
    innovation, sensitivity, _ = thermometer(estimate=heat)
    heat, heat_var = kalman_update(heat, heat_var, innovation, sensitivity,
                                   _noise(THERMOMETER_NOISE_K, duration))
  if params.lift_walk:
    walk, walk_var = _ou_predict(
        walk, walk_var, duration, sigma=params.lift_walk_kg_per_sqrt_s,
        time_constant_s=params.lift_walk_time_constant_s)
    g = gas_end
    if params.gas_state:  # T_g on the path under the updated estimate.
      g = gas_end._replace(temperature=thermometer(estimate=heat)[2])
    mean_rate = 0.5 * (before.ascent_rate_mps + after.ascent_rate_mps)
    innovation, sensitivity = lift_innovation(
        estimate=walk, rate_start=before.ascent_rate_mps,
        rate_end=after.ascent_rate_mps, duration=duration,
        known_lift_kg=envelope.free_lift_kg(params.noiseless(), before, g),
        mass=physics.total_mass(params.payload_kg, before.sand_kg,
                                before.helium_mols),
        drag_k=envelope.drag_factor(params, before.helium_mols, g,
                                    mean_rate))
    walk, walk_var = kalman_update(walk, walk_var, innovation, sensitivity,
                                   _noise(RATE_NOISE_MPS, duration))
  dtype = after.altitude_m.dtype
  return after.replace(
      estimated_heating_k=heat.astype(dtype),
      heating_variance_k2=heat_var.astype(dtype),
      estimated_lift_kg=walk.astype(dtype),
      lift_variance_kg2=walk_var.astype(dtype))


def controller_view(params: params_lib.FlightParams, state):
  """The state as the onboard altitude controller reads it (Eq.
  fullcontroller and the in-stride guard, `dynamics`): W is its estimate
  (under `lift_walk`); the rest it reads is measured or known (its targets
  take the gas settled from the air, the sun and the command, not dT_h;
  the burst volume it never reads). `state` itself without a lift walk.

  Args:
    params: The flight system (lift_walk).
    state: The `FlightState`.
  """
  if not params.lift_walk:
    return state
  return state.replace(lift_walk_kg=state.estimated_lift_kg)


def conservative_burst_volume_m3(params: params_lib.FlightParams) -> Array:
  """The burst volume at `BURST_QUANTILE` of the drawn diameter. # [m^3]

  The Weibull law's quantile d_p = lambda (-ln(1 - p))^(1/k)
  (`physics.draw_burst_diameter`), as a sphere's volume pi d^3 / 6.

  Args:
    params: The flight system (burst_weibull_scale_m, burst_weibull_shape).
  """
  scale = jnp.asarray(params.burst_weibull_scale_m)
  diameter = scale * (-jnp.log1p(-BURST_QUANTILE)) ** (
      1.0 / jnp.asarray(params.burst_weibull_shape))
  return physics.burst_volume_of_diameter(diameter)


def planning_view(params: params_lib.FlightParams, state
                  ) -> Tuple[params_lib.FlightParams, 'object']:
  """What a controller may fly ahead: (params, state) without hidden truth.

  * params: `params.noiseless()` (no new disturbance draws; the estimator
    does not run in a plan);
  * dT_h (`heating_noise`): the estimate (held through the plan, as the
    disturbance was);
  * W (`lift_walk`): the estimate, folded into the lift ledger
    (`settled_lift_kg`, which the noiseless params read without a W term)
    and 0 in `lift_walk_kg` (the vent target's weight then leaves it out: a
    change of the vented helium's drag area of W / (M_air beta - M_He) mol,
    ~1 % per 50 g); the regime reads calm;
  * the burst volume (`burst_spread`): `conservative_burst_volume_m3`.

  Idempotent (a view's view is the view), so plans may apply it to the
  flights they fly on. Under the paper's physics (none of the switches) it
  returns `state` itself.

  Args:
    params: The flight system as the env flies it (e.g. `flight_params_of`).
    state: The `FlightState` the controller starts from.

  Returns:
    (noiseless params, the state a controller may read).
  """
  if params.heating_noise:
    state = state.replace(heating_k=state.estimated_heating_k)
  if params.lift_walk:
    state = state.replace(
        settled_lift_kg=state.settled_lift_kg + state.estimated_lift_kg,
        estimated_lift_kg=jnp.zeros_like(state.estimated_lift_kg),
        lift_walk_kg=jnp.zeros_like(state.lift_walk_kg),
        lift_walk_gusty=jnp.zeros_like(state.lift_walk_gusty))
  if params.burst_spread:
    state = state.replace(burst_volume_m3=(
        conservative_burst_volume_m3(params) +
        jnp.zeros_like(state.burst_volume_m3)).astype(
            state.burst_volume_m3.dtype))
  return params.noiseless(), state
