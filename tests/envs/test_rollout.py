"""The one batched flight (ble_latex/envs/rollout.py)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex.envs import jax_env
from ble_latex.envs import rollout


# An equivalence of two compiled flights (~26 s on the idle 2-core machine,
# 2026-12-05, benchmarks/suite_time.sh): with the default suite's longest
# tests in `make test-ci` (pytest.ini's `ci` marker).
@pytest.mark.slow
@pytest.mark.ci
def test_fly_is_the_strides_flown_one_by_one():
  # A closed-loop policy (it reads the observation and the per-stride
  # input) flown by `fly` in one scan gives, bit for bit, the strides flown
  # one after another with `step_batch`.
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  params = env.default_params
  keys = jax.vmap(jax.random.PRNGKey)(jnp.arange(2))
  obs, states = rollout.reset_batch(env, keys, params)
  xs = jnp.linspace(0.0, 1.0, 4, dtype=jnp.float32)

  def policy(carry, states, obs, x):
    del states
    base = jnp.asarray(jax_env.ACTION_LOW, jnp.float32)
    return base + x + 0.0 * obs[:, :3], carry + 1

  def record(carry, x, obs, actions, step):
    del x, obs, actions
    _, states, reward, _, _ = step
    return carry, (reward, states.flight.altitude_m)

  (end, end_obs, count), (rewards, altitudes) = jax.jit(
      lambda s, o: rollout.fly(env, params, s, o, policy, record, carry=0,
                               xs=xs))(states, obs)
  assert int(count) == 4
  step = jax.jit(lambda s, a: rollout.step_batch(env, s, a, params))
  want_rewards, want_altitudes = [], []
  for i, x in enumerate(xs):
    actions, _ = policy(i, states, obs, x)
    obs, states, reward, _, _ = step(states, actions)
    want_rewards.append(reward)
    want_altitudes.append(states.flight.altitude_m)
  np.testing.assert_array_equal(rewards, np.stack(want_rewards))
  np.testing.assert_array_equal(altitudes, np.stack(want_altitudes))
  np.testing.assert_array_equal(end_obs, obs)
  np.testing.assert_array_equal(end.flight.x_m, states.flight.x_m)
