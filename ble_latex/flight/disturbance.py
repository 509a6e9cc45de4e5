# coding=utf-8
"""The free-lift disturbance W: a random walk or an Ornstein-Uhlenbeck process.

dW = -W / tau dt + sigma dB (sigma = `FlightParams.lift_walk_kg_per_sqrt_s`,
tau = `FlightParams.lift_walk_time_constant_s`; tau = 0: no reversion, the
random walk dW = sigma dB of ValBal's simulator, stanford-ssi/balloons-VALBAL
`hootl/lasagna/PastaSim.cpp`). Each sub-step draws the exact transition

  W(t + dt) = a W(t) + sigma sqrt(tau (1 - a^2) / 2) N(0, 1),  a = e^(-dt/tau)

(sigma sqrt(dt) N(0, 1) for tau = 0), so the process does not depend on the
sub-step length. Its stationary spread is sigma sqrt(tau / 2); over times
much shorter than tau it is the random walk.

Why the default sigma is 0.35 g/sqrt(s) (docs/physics.md, issue 44): ValBal's
1.4 g/sqrt(s) is its simulator's tuning value (0.67 g/sqrt(s) until a 2018
"constants name refactor"), standing in for its controller's estimation and
valve waste, not a measurement; a calm 2 h segment of SSI-71 (|dh| <~ 100 m,
no actuation) has probability ~1e-4 under 1.4 and is typical of 0.05-0.1;
the plausible range for a physical disturbance is 0.2-0.67. 0.35 is the
geometric middle of that range (sqrt(0.2 x 0.67) = 0.37), 4x below
ValBal's value, which is kept as `flight.params.LIFT_WALK_STRESS`.

Intermittent option (`FlightParams.lift_walk_intermittent`, off by default):
real lift noise comes in spells (issue 44: SSI-71 floated ~2 h with no
action and |dh| <~ 100 m, typical of 0.05-0.1 g/sqrt(s), between rougher
hours). The regime G (calm / gusty) is a two-state Markov chain with mean
dwell times tau_c (`lift_walk_calm_mean_s`) and tau_g
(`lift_walk_gusty_mean_s`); W walks with sigma_c
(`lift_walk_calm_kg_per_sqrt_s`) while calm and sigma
(`lift_walk_kg_per_sqrt_s`) while gusty. Each sub-step draws G's exact
transition (`switch`): with rates a = 1 / tau_c (calm -> gusty) and
b = 1 / tau_g,

  P(change within dt) = r / (a + b) (1 - e^(-(a + b) dt)),  r = a or b,

and W's transition with the regime held at the sub-step's start (sub-steps
<= 180 s, dwell times hours). Long-run share gusty tau_g / (tau_c + tau_g),
long-run variance rate of W (tau = 0) the shares' mean of sigma^2
(`mean_sigma`). `flight.params.LIFT_WALK_INTERMITTENT` is a setting with the
calibrated walk's long-run rate, 0.35 g/sqrt(s). A flight starts calm.
"""

import jax
import jax.numpy as jnp

Array = jax.Array


def transition(walk_kg: Array, duration_s: Array, *, sigma: Array,
               time_constant_s: Array, key: Array) -> Array:
  """W after `duration_s`, the exact OU (or random-walk) transition. # [kg]

  Args:
    walk_kg: W now. # [kg]
    duration_s: dt >= 0. # [s]
    sigma: Intensity sigma. # [kg/sqrt(s)]
    time_constant_s: tau; 0 = no reversion (random walk). # [s]
    key: PRNG key of this draw.

  Returns:
    W(t + dt). # [kg]
  """
  walk_kg = jnp.asarray(walk_kg)
  dtype = walk_kg.dtype
  decay, variance = decay_and_variance(duration_s, time_constant_s, dtype)
  noise = jax.random.normal(key, jnp.shape(walk_kg), dtype)
  return decay * walk_kg + sigma * jnp.sqrt(variance) * noise


def decay_and_variance(duration_s: Array, time_constant_s: Array,
                       dtype) -> tuple:
  """(a, v) of the exact transition W' = a W + sigma sqrt(v) N(0, 1).

  a = e^(-dt / tau), v = tau (1 - a^2) / 2; tau = 0 (the random walk):
  a = 1, v = dt. Also the moments an estimator predicts with (`estimator`).

  Args:
    duration_s: dt >= 0. # [s]
    time_constant_s: tau; 0 = no reversion. # [s]
    dtype: Of the results.

  Returns:
    (a [.], v [s]).
  """
  dt = jnp.asarray(duration_s, dtype)
  tau = jnp.asarray(time_constant_s, dtype)
  reverting = tau > 0.0
  tau_safe = jnp.where(reverting, tau, 1.0)
  decay = jnp.where(reverting, jnp.exp(-dt / tau_safe), 1.0)
  variance = jnp.where(reverting,
                       -0.5 * tau_safe * jnp.expm1(-2.0 * dt / tau_safe), dt)
  return decay, variance


def stationary_std_kg(sigma: Array, time_constant_s: Array) -> Array:
  """Stationary spread of W, sigma sqrt(tau / 2) (inf for tau = 0). # [kg]"""
  tau = jnp.asarray(time_constant_s)
  return jnp.where(tau > 0.0, sigma * jnp.sqrt(0.5 * tau), jnp.inf)


def switch(gusty: Array, duration_s: Array, *, calm_mean_s: Array,
           gusty_mean_s: Array, key: Array) -> Array:
  """The regime after `duration_s`, the two-state chain's exact transition.

  Args:
    gusty: The regime now (bool: gusty; False: calm).
    duration_s: dt >= 0. # [s]
    calm_mean_s: Mean dwell time tau_c of the calm regime. # [s]
    gusty_mean_s: Mean dwell time tau_g of the gusty regime. # [s]
    key: PRNG key of this draw.

  Returns:
    The regime at t + dt (bool).
  """
  gusty = jnp.asarray(gusty, bool)
  a = 1.0 / jnp.asarray(calm_mean_s, jnp.float32)  # calm -> gusty [1/s]
  b = 1.0 / jnp.asarray(gusty_mean_s, jnp.float32)  # gusty -> calm [1/s]
  total = a + b
  settle = -jnp.expm1(-total * jnp.asarray(duration_s, jnp.float32))
  change = jnp.where(gusty, b, a) / total * settle
  return gusty ^ (jax.random.uniform(key, jnp.shape(gusty)) < change)


def intermittent_transition(walk_kg: Array, gusty: Array, duration_s: Array,
                            *, sigma: Array, calm_sigma: Array,
                            time_constant_s: Array, calm_mean_s: Array,
                            gusty_mean_s: Array, key: Array):
  """(W, regime) after `duration_s`: W walks at the regime's sigma. # [kg]

  Args:
    walk_kg: W now. # [kg]
    gusty: The regime now (bool).
    duration_s: dt >= 0. # [s]
    sigma: Intensity while gusty. # [kg/sqrt(s)]
    calm_sigma: Intensity while calm. # [kg/sqrt(s)]
    time_constant_s: tau of W; 0 = a random walk. # [s]
    calm_mean_s: Mean calm dwell time. # [s]
    gusty_mean_s: Mean gusty dwell time. # [s]
    key: PRNG key of this sub-step (split here into W's and G's).

  Returns:
    (W(t + dt) [kg], regime at t + dt).
  """
  walk_key, switch_key = jax.random.split(key)
  walk_kg = jnp.asarray(walk_kg)
  held = jnp.where(gusty, sigma, calm_sigma).astype(walk_kg.dtype)
  new_walk = transition(walk_kg, duration_s, sigma=held,
                        time_constant_s=time_constant_s, key=walk_key)
  return new_walk, switch(gusty, duration_s, calm_mean_s=calm_mean_s,
                          gusty_mean_s=gusty_mean_s, key=switch_key)


def mean_sigma(sigma: float, calm_sigma: float, calm_mean_s: float,
               gusty_mean_s: float) -> float:
  """Long-run intensity sqrt(f sigma^2 + (1 - f) sigma_c^2). # [kg/sqrt(s)]

  f = tau_g / (tau_c + tau_g), the long-run share of gusty time.
  """
  share = gusty_mean_s / (calm_mean_s + gusty_mean_s)
  return float((share * sigma**2 + (1.0 - share) * calm_sigma**2) ** 0.5)
