# coding=utf-8
"""A learned value beyond the plan's horizon (issue 47, item 2).

A plan of `horizon` strides sees nothing after its end; its progress term
pulls towards the station but knows nothing of the winds there. With
`PlannerConfig.value_policy` set, a plan's score also gets

  value_weight * discount^n * V(s_n),   V(s) = min_i Q_i(o(s), mu(o(s))),

at the state s_n where the plan (or the beam's partial plan) ends, n
strides ahead: the twin critics Q_1, Q_2 of a SAC policy file at its
actor's mean action mu, on the 71 features o(s) the env would observe
there (the state-value of a SAC policy, as in "Learning off-policy with
online planning", Sikchi et al. 2022, and FOMPC's distilled Q-network as
the terminal cost of a first-order MPC). Nothing is added where the plan
reaches the episode's end (nothing follows it) or ends the flight (its
terminal cost counts). Q is in the policy's reward units (BLE's reward per
stride, discounted by its gamma), so `value_weight` sets the exchange rate
against the objective's per-stride terms.

What o(s_n) reads: the plan's flight at its end, the wind of the plan's
wind there as the measured wind (features 52-53), the forecast column at
its position (features 0-49, the env's own observation function), and
the altitude history filled with the end state (as after a reset: the
plan's last three strides are not kept). The policy must have observed
under the env's `latex_observation.*` settings; a planner refuses one of
other settings. The policy's weights are read once per file and enter the
planner's compiled program as constants.
"""

import functools
from typing import Any, Callable, Tuple

import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import errors
from ble_latex.agents.sac import core as sac_core
from ble_latex.agents.sac import networks
from ble_latex.agents.sac import pretrained
from ble_latex.envs import env_params
from ble_latex.envs import env_types
from ble_latex.envs import jax_env
from ble_latex.envs import jax_features
from ble_latex.envs import winds

Array = jax.Array
# `PlannerConfig.value_policy`'s name of the shipped policy.
SHIPPED = 'shipped'


@functools.lru_cache(maxsize=8)
def load(path: str) -> Tuple[Any, Any, Tuple[Tuple[str, int], ...]]:
  """A policy file's network, its parameters and its observation settings.

  Args:
    path: A SAC policy file, or `SHIPPED`.

  Returns:
    (network definition, parameters, ((setting, value), ...) of
    `env_params.OBSERVATION_FIELDS`).

  Raises:
    ValueError: A bad file (`pretrained.load_policy`'s message).
  """
  file = pretrained.shipped_policy(False) if path == SHIPPED else path
  policy = pretrained.load_policy(file)
  config = policy['config']
  network = networks.make_network(config['num_actions'], config['num_layers'],
                                  config['hidden_units'], config['critic'])
  # Concrete arrays even when first asked inside a planner's trace (they
  # are cached across traces).
  with jax.ensure_compile_time_eval():
    obs = jnp.zeros(tuple(config['observation_shape']), jnp.float32)
    like = network.init(jax.random.PRNGKey(0), obs, jax.random.PRNGKey(0))
    params = jax.tree.map(np.asarray, sac_core.restore_like(
        like, policy['network_params'], f'{path}: network_params'))
  observation = tuple((k, int(config[k]))
                      for k in env_params.OBSERVATION_FIELDS)
  return network, params, observation


def state_value(network: Any, params: Any, obs: Array) -> Array:
  """V(o) = min of the twin critics at the actor's mean action (scalar)."""
  out = network.apply(params, obs, jax.random.PRNGKey(0), mean_action=True)
  return jnp.minimum(out.critic.q_value1, out.critic.q_value2).reshape(())


def terminal_fn(path: str, params: env_types.EnvParams,
                state: env_types.EnvState, wind: winds.Wind,
                wind_fn: Callable[..., Any]) -> Callable[[Any], Array]:
  """V at the end of a plan from `state`: f_end -> V(o(f_end)).

  Args:
    path: The policy file (`PlannerConfig.value_policy`).
    params: The env parameters (the observation's settings).
    state: The state the plans start from (its forecast, initial
      resources, memory).
    wind: The env's wind (its forecast column).
    wind_fn: The plan's wind (x, y, pressure, t) -> (u, v), read as the
      measured wind at the plan's end.

  Returns:
    A function of a plan's final `FlightState`: V there (scalar).

  Raises:
    errors.ConfigError: The policy observed under other
      `latex_observation.*` settings than the env's.
  """
  network, weights, observation = load(path)
  mine = env_params.observation_of(params)
  if dict(observation) != mine:
    raise errors.ConfigError(
        f'value_policy = {path!r}: the policy observed with '
        f'latex_observation {dict(observation)}, this env with {mine}')

  def value(f_end: Any) -> Array:
    u, v = wind_fn(f_end.x_m, f_end.y_m, f_end.pressure_pa, f_end.time_s)
    end = state.replace(
        flight=f_end, wind_u=u, wind_v=v,
        history=jax_features.init_history(f_end.altitude_m,
                                          f_end.ascent_rate_mps))
    obs = jax_env.observation(end, params, wind)
    return state_value(network, weights, obs).astype(f_end.altitude_m.dtype)

  return value
