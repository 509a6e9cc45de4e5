"""`ble_latex.agents.planning.value`: the planners' learned value beyond the
horizon (`PlannerConfig.value_policy`, issue 47 item 2).

Planning compiles (~20-60 s): those tests run in CI (`make test-ci`); the
default suite checks the config's refusals."""

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex import errors
from ble_latex.agents.planning import config as plan_config
from ble_latex.agents.planning import objective as plan_objective
from ble_latex.agents.planning import planner as planning
from ble_latex.agents.planning import value as plan_value
from ble_latex.agents.sac import pretrained
from ble_latex.envs import jax_env
from ble_latex.envs import jax_features
from ble_latex.envs import winds

SMALL = dict(num_samples=8, iterations=1, horizon=4, num_segments=2,
             replan_every=2, grid_levels=2, search=plan_config.BEAM,
             beam_width=4, wind_memory=2)


@pytest.fixture(scope='module')
def world():
  env = jax_env.LatexBalloonJaxEnv()
  params = env.default_params
  _, state = jax.jit(env.reset)(jax.random.PRNGKey(1_000_000), params)
  return params, state


def _config(**kw):
  return plan_config.PlannerConfig(**{**SMALL, **kw}).checked()


def _critic_value(obs):
  """min(Q1, Q2) at the actor's mean action, by the network's own methods."""
  network, weights, _ = plan_value.load(plan_value.SHIPPED)
  mean = network.apply(weights, obs, jax.random.PRNGKey(0),
                       method=network.actor).mean_action
  q = network.apply(weights, obs, mean, method=network.critic)
  return float(jnp.minimum(q.q_value1, q.q_value2)[0])


@pytest.mark.slow
@pytest.mark.ci  # Compiles the objective twice.
def test_value_beyond_the_horizon_is_weight_discount_v(world):
  """A plan's score with the value is its score without plus value_weight x
  discount^horizon x V where the plan ends; V read from the observation
  there (the plan's wind as the measured wind, the history filled)."""
  params, state = world
  config = _config(value_policy=plan_value.SHIPPED, value_weight=0.5)
  blind = plan_objective.blind(state)
  wind_fn = plan_objective.planning_wind(config, winds.GENERATIVE_WIND,
                                         state)
  terminal = plan_value.terminal_fn(config.value_policy, params, blind,
                                    winds.GENERATIVE_WIND, wind_fn)
  targets = jnp.array([16_000.0, 19_000.0])
  floats = jnp.array([-1.0, -1.0])
  def score(state, terminal=None):
    return float(jax.jit(functools.partial(
        plan_objective.objective, config, params, state, wind_fn,
        terminal=terminal))(targets, floats))

  without = score(blind)
  with_value = score(blind, terminal)
  f_end, _ = plan_objective.fly(
      params, blind, wind_fn, blind.flight,
      plan_objective.plan_actions(config, targets, floats))
  u, v = wind_fn(f_end.x_m, f_end.y_m, f_end.pressure_pa, f_end.time_s)
  obs = jax_env.observation(blind.replace(
      flight=f_end, wind_u=u, wind_v=v,
      history=jax_features.init_history(f_end.altitude_m,
                                        f_end.ascent_rate_mps)), params)
  value = _critic_value(obs)
  assert abs(value) > 1.0  # The critic says something here.
  assert with_value - without == pytest.approx(
      0.5 * config.discount ** config.horizon * value, rel=1e-4, abs=1e-4)
  # Nothing follows the episode's end.
  last = blind.replace(steps=jnp.asarray(params.episode_steps - 2,
                                         blind.steps.dtype))
  assert score(last, terminal) == pytest.approx(score(last), abs=1e-6)


@pytest.mark.slow
@pytest.mark.ci  # Compiles two planners.
def test_value_changes_the_plan_and_weight_zero_does_not(world):
  """The beam search with value_weight 0 plans as without a value; with a
  heavy weight the plan's score carries the value."""
  params, state = world
  states = jax.tree.map(lambda a: a[None], state)
  plan_value.load.cache_clear()  # First read inside the planner's trace.

  def plan(config):
    previous = planning.initial_plans(config, states)
    return jax.device_get(planning.plan_batch(config, params, states,
                                              jnp.int32(0), previous))

  plain = plan(_config())
  zero = plan(_config(value_policy=plan_value.SHIPPED, value_weight=0.0))
  np.testing.assert_array_equal(zero.targets_m, plain.targets_m)
  np.testing.assert_array_equal(zero.floats, plain.floats)
  np.testing.assert_allclose(zero.score, plain.score, rtol=1e-6)
  heavy = plan(_config(value_policy=plan_value.SHIPPED, value_weight=10.0))
  assert abs(float(heavy.score[0]) - float(plain.score[0])) > 1.0


@pytest.mark.slow
@pytest.mark.ci  # Builds the observation at trace time.
def test_a_policy_of_another_observation_is_refused(world, tmp_path):
  params, state = world
  shipped = pretrained.load_policy(pretrained.shipped_policy(False))
  path = str(tmp_path / 'drifts.msgpack')
  pretrained.write_policy(
      dict(shipped, config=dict(shipped['config'], wind_lookahead=12)), path)
  with pytest.raises(errors.ConfigError,
                     match="value_policy.*'wind_lookahead': 12"):
    plan_value.terminal_fn(path, params, state, winds.GENERATIVE_WIND,
                           lambda *a: (0.0, 0.0))


@pytest.mark.parametrize('field,value', [
    ('value_policy', '/nonexistent/policy.msgpack'), ('value_policy', 3),
    ('value_weight', -0.5), ('value_weight', float('nan'))])
def test_bad_value_settings_are_one_line(field, value):
  with pytest.raises(errors.ConfigError, match=field) as error:
    _config(**{field: value})
  assert '\n' not in str(error.value)
