# coding=utf-8
"""Batched flights of the functional env: the one rollout (pure JAX).

N balloons fly together: `reset_batch` starts them (`vmap` of
`LatexBalloonJaxEnv.reset`), `step_batch` flies one stride of all of them
(`vmap` of `step_env`), and `fly` flies strides one after another in one
`lax.scan` under a policy. Every batched flight of the package goes through
these: `jax_env.rollout` (open-loop actions), the SAC trainer's validation
(`agents.sac.trainer.fly_policy`), DAgger's rounds (`agents.dagger`), the
planners' batched flights (`run.planner_batch`), `benchmarks/mpc_teacher.py`;
the SAC trainer's rounds (`train_round`, learning inside its own scan) and
`run.batch_eval` (host-side policies) step with `step_batch`.

Episodes that end are not reset (`step_env`): callers mask them.
"""

from typing import Any, Callable, Optional, Tuple

import jax

from ble_latex.envs import env_types

Array = jax.Array
# policy(carry, states, observations, x) -> (actions [N, A] in the env's
# action space, carry). x: this stride's slice of `xs` (None without xs).
Policy = Callable[[Any, env_types.EnvState, Any, Any], Tuple[Array, Any]]
# record(carry, x, observations, actions, step) -> (carry, y), step being
# `step_batch`'s (next observations, states, reward, terminated, info).
Record = Callable[[Any, Any, Any, Array, Tuple[Any, ...]], Tuple[Any, Any]]


def reset_batch(env: Any, keys: Array, params: env_types.EnvParams
                ) -> Tuple[Array, env_types.EnvState]:
  """(observations [N, F], states) of N new flights, one per reset key."""
  return jax.vmap(env.reset, in_axes=(0, None))(keys, params)


def step_batch(env: Any, states: env_types.EnvState, actions: Array,
               params: env_types.EnvParams, keys: Optional[Array] = None
               ) -> Tuple[Array, env_types.EnvState, Array, Array, Any]:
  """One stride of N balloons: `step_env` vmapped over the balloons.

  Args:
    env: The functional env.
    states: [N] env states.
    actions: [N, A] actions.
    params: The env parameters (shared).
    keys: [N] step keys, or None (`step_env` draws nothing from its key).

  Returns:
    `step_env`'s (observations, states, reward, terminated, info), each [N].
  """
  if keys is None:
    return jax.vmap(env.step_env, in_axes=(None, 0, 0, None))(
        None, states, actions, params)
  return jax.vmap(env.step_env, in_axes=(0, 0, 0, None))(
      keys, states, actions, params)


def fly(env: Any, params: env_types.EnvParams, states: env_types.EnvState,
        observations: Any, policy: Policy, record: Record, carry: Any = None,
        xs: Any = None, length: Optional[int] = None,
        keys: Optional[Array] = None) -> Tuple[Tuple[Any, Any, Any], Any]:
  """Flies N balloons stride after stride in one `lax.scan` (traceable).

  Each stride: `policy` chooses the actions from the states and the
  observations, `step_batch` flies them, `record` updates the carry and
  gives the stride's output.

  Args:
    env: The functional env.
    params: The env parameters.
    states: [N] env states to fly from.
    observations: What `policy` reads first (the flights' observations);
      None: no observation is carried (the strides' own are still given to
      `record`).
    policy: See `Policy`.
    record: See `Record`.
    carry: The policy's and the record's state (any pytree).
    xs: Per-stride inputs (leading axis: strides), e.g. planned actions or
      PRNG keys; None with `length`.
    length: Strides, without `xs`.
    keys: [N] step keys for `step_batch` (the same each stride), or None.

  Returns:
    ((states, observations, carry) after the last stride, the strides'
    outputs stacked).
  """
  def stride(loop, x):
    states, observations, carry = loop
    actions, carry = policy(carry, states, observations, x)
    step = step_batch(env, states, actions, params, keys)
    carry, y = record(carry, x, observations, actions, step)
    next_observations = None if observations is None else step[0]
    return (step[1], next_observations, carry), y

  return jax.lax.scan(stride, (states, observations, carry), xs,
                      length=length)


def planned(carry: Any, states: Any, observations: Any, x: Array
            ) -> Tuple[Array, Any]:
  """The `Policy` that flies `xs` as they are (open loop)."""
  del states, observations
  return x, carry
