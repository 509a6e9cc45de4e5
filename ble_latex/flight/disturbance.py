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
  dt = jnp.asarray(duration_s, dtype)
  tau = jnp.asarray(time_constant_s, dtype)
  reverting = tau > 0.0
  tau_safe = jnp.where(reverting, tau, 1.0)
  decay = jnp.where(reverting, jnp.exp(-dt / tau_safe), 1.0)
  variance = jnp.where(reverting,
                       -0.5 * tau_safe * jnp.expm1(-2.0 * dt / tau_safe), dt)
  noise = jax.random.normal(key, jnp.shape(walk_kg), dtype)
  return decay * walk_kg + sigma * jnp.sqrt(variance) * noise


def stationary_std_kg(sigma: Array, time_constant_s: Array) -> Array:
  """Stationary spread of W, sigma sqrt(tau / 2) (inf for tau = 0). # [kg]"""
  tau = jnp.asarray(time_constant_s)
  return jnp.where(tau > 0.0, sigma * jnp.sqrt(0.5 * tau), jnp.inf)
