"""The planners (`ble_latex.agents.planning`: BLE agents and pure modules):
registry, flight, determinism, noise-blindness of the forecast MPC, gradients
through the core, size limits, imports without TensorFlow.

Small configurations, compiled once per module (fixtures below).
"""

import dataclasses
import functools
import subprocess
import sys

import gin
from hypothesis import given
from hypothesis import settings
from hypothesis import strategies as st
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex import errors
from ble_latex.agents.planning import agents as planners
from ble_latex.agents.planning import beam
from ble_latex.agents.planning import config as plan_config
from ble_latex.agents.planning import objective as plan_objective
from ble_latex.agents.planning import planner as planning
from ble_latex.envs import jax_env
from ble_latex.envs import winds

SMALL = dict(num_samples=8, iterations=1, horizon=4, num_segments=2,
             replan_every=2, grid_levels=2)


@pytest.fixture(scope='module')
def world():
  """Env, params and the reset states of two suite seeds ([1] batches)."""
  env = jax_env.LatexBalloonJaxEnv()
  params = env.default_params
  reset = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))
  states = []
  for seed in (1_000_000, 1_000_003):
    _, state = reset(jax.random.PRNGKey(seed)[None], params)
    states.append(state)
  return env, params, states


def _config(mode=plan_config.FORECAST, **kw):
  return plan_config.PlannerConfig(mode=mode, **{**SMALL, **kw}).checked()


def _objectives(config, params, state, wind_fn, targets, floats):
  """`plan_objective.objective` of each plan (rows of targets and floats), in one
  jitted call."""
  score = jax.jit(jax.vmap(functools.partial(
      plan_objective.objective, config, params, state, wind_fn)))
  return np.asarray(score(jnp.asarray(targets, jnp.float32),
                          jnp.asarray(floats, jnp.float32)))


def _plan(config, params, state, seed=0):
  previous = planning.initial_plans(config, state)
  return jax.device_get(planning.plan_batch(config, params, state,
                                            jnp.int32(seed), previous))


def test_registered_as_box_agents():
  from balloon_learning_environment.agents import agent_registry  # pylint: disable=g-import-not-at-top
  from ble_latex import agents  # pylint: disable=g-import-not-at-top
  agents.register()
  for name in ('latex_mpc', 'latex_mpc_oracle', 'latex_mpc_grad'):
    assert name in agents.BOX_AGENTS and name in agents.PLANNER_AGENTS
    constructor, gin_file = agent_registry.REGISTRY[name]
    assert constructor is planners.AGENTS[name] and gin_file is None
    assert constructor.supports_box_actions and constructor.needs_env
  assert planners.LatexMpcOracleAgent.planner == 'latex_mpc_oracle'


class _Driver:
  """What `planners.core_of` reads of an env: the core state and params."""

  def __init__(self, state, params):
    self.state, self.params = state, params


@pytest.mark.slow
@pytest.mark.ci
def test_agent_replans_every_period(world):
  """The agent on a core state: the batched planner's plan, every 2 strides."""
  _, params, states = world
  state = jax.tree.map(lambda a: a[0], states[0])
  driver = _Driver(state, params)
  agent = planners.LatexMpcAgent(
      3, (71,), action_low=jax_env.ACTION_LOW,
      action_high=jax_env.ACTION_HIGH, seed=0, **SMALL)
  with pytest.raises(RuntimeError, match='attach_env'):
    agent.begin_episode(np.zeros(71))
  agent.attach_env(driver)
  actions = [agent.begin_episode(np.zeros(71))]
  for k in range(1, 5):
    driver.state = state.replace(steps=state.steps + k)
    actions.append(agent.step(0.0, np.zeros(71)))
  assert len(agent.decision_seconds) == 3  # Strides 0, 2 and 4.
  # Its first plan is the batched planner's under the agent's own config
  # (beam search with the wind memory by default): the program it compiled.
  plan = _plan(agent.config, params, states[0])
  segment_0 = [plan.targets_m[0, 0], SMALL.get('time_factor', 2.0),
               plan.floats[0, 0]]
  np.testing.assert_allclose(actions[0], segment_0)
  np.testing.assert_allclose(actions[1], actions[0])  # Same segment.
  with pytest.raises(errors.ConfigError, match='JAX core state'):
    agent.attach_env(object())


@pytest.mark.slow
def test_agent_flies_a_few_strides(world):
  """Through the runner (attach_env) on the Gymnasium env of the core."""
  from ble_latex.envs import gymnasium_env  # pylint: disable=g-import-not-at-top
  _, params, _ = world
  env = gymnasium_env.LatexBalloonGymnasiumEnv(params=params)
  agent = planners.LatexMpcAgent(
      3, (71,), action_low=jax_env.ACTION_LOW,
      action_high=jax_env.ACTION_HIGH, seed=0, **SMALL)
  with pytest.raises(RuntimeError, match='attach_env'):
    agent.begin_episode(np.zeros(71))
  agent.attach_env(env)
  obs, _ = env.reset(seed=1_000_000)
  actions = [agent.begin_episode(obs)]
  for _ in range(4):
    obs, reward, terminated, truncated, _ = env.step(actions[-1])
    assert np.isfinite(reward) and not terminated and not truncated
    actions.append(agent.step(reward, obs))
  actions = np.array(actions)
  assert np.all(actions >= jax_env.ACTION_LOW) and np.all(
      actions <= jax_env.ACTION_HIGH)
  assert np.all(actions[:, 1] == SMALL.get('time_factor', 2.0))
  assert len(agent.decision_seconds) == 3  # Replans every 2 strides.
  # The agent's plan is the batched planner's (same key rule).
  again = planners.LatexMpcAgent(
      3, (71,), action_low=jax_env.ACTION_LOW,
      action_high=jax_env.ACTION_HIGH, seed=0, **SMALL)
  again.attach_env(env)
  env.reset(seed=1_000_000)
  np.testing.assert_array_equal(again.begin_episode(obs), actions[0])


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
def test_deterministic_under_a_seed(world):
  _, params, states = world
  config = _config(grid_levels=0)  # Else a grid plan may win for any seed.
  a = _plan(config, params, states[0], seed=0)
  b = _plan(config, params, states[0], seed=0)
  jax.tree.map(np.testing.assert_array_equal, a, b)
  c = _plan(config, params, states[0], seed=1)
  assert not np.array_equal(a.targets_m, c.targets_m)
  assert np.all(a.targets_m >= config.altitude_low_m)
  assert np.all(a.targets_m <= config.altitude_high_m)
  assert set(np.unique(a.floats)) <= {-1.0, 1.0}


@pytest.mark.slow
@pytest.mark.ci
def test_altitude_grid_plans_are_scored(world):
  """With no random samples (num_samples = 2: the warm start and "float
  here"), the plan is the best of those and the grid's plans."""
  _, params, states = world
  config = _config(num_samples=2, grid_levels=2, grad_starts=0)
  state = jax.tree.map(lambda a: a[0], states[0])
  best = jax.tree.map(lambda a: a[0], _plan(config, params, states[0]))
  low, high = config.altitude_low_m, config.altitude_high_m
  wind_fn = plan_objective.planning_wind(config, winds.GENERATIVE_WIND, state)
  blind = plan_objective.blind(state)
  h = jnp.clip(state.flight.altitude_m, low, high)
  targets = [[h, h]] + [[level, level] for level in (low, high)
                        for _ in range(2)]
  floats = [[1.0, 1.0]] + [[-1.0, -1.0], [-1.0, 1.0]] * 2  # Hold, grid.
  scores = list(_objectives(config, params, blind, wind_fn, targets, floats))
  assert max(scores[1:]) > scores[0]  # A grid plan beats holding here,
  assert float(best.score) == pytest.approx(float(max(scores)), rel=1e-6)
  with pytest.raises(errors.ConfigError, match='grid_levels'):
    _config(grid_levels=-1)
  with pytest.raises(errors.ConfigError, match='num_samples'):
    _config(num_samples=1)


@pytest.mark.slow
@pytest.mark.ci
def test_beam_as_wide_as_the_tree_finds_the_best_plan(world):
  """Two segments, three choices each (low, high, float) and a beam of 9:
  the search is exhaustive, so its plan is the best of the 9 plans."""
  _, params, states = world
  config = _config(search=plan_config.BEAM, beam_width=9, grid_levels=2,
                   grad_starts=0)
  state = jax.tree.map(lambda a: a[0], states[0])
  best = jax.tree.map(lambda a: a[0], _plan(config, params, states[0]))
  low, high = config.altitude_low_m, config.altitude_high_m
  wind_fn = plan_objective.planning_wind(config, winds.GENERATIVE_WIND, state)
  blind = plan_objective.blind(state)
  h = float(jnp.clip(state.flight.altitude_m, low, high))
  choices = [(low, -1.0), (high, -1.0), (h, 1.0)]
  pairs = [(a, b) for a in choices for b in choices]
  scores = _objectives(config, params, blind, wind_fn,
                       [[a[0], b[0]] for a, b in pairs],
                       [[a[1], b[1]] for a, b in pairs])
  assert float(best.score) == pytest.approx(float(max(scores)), rel=1e-6)
  assert len(set(np.round(scores, 6))) > 1  # Not all tied.
  # A narrower search keeps fewer partial plans: never a better plan. The
  # narrow search is the one-cell (greedy) beam of the next test, so the
  # module compiles it once.
  narrow = jax.tree.map(lambda a: a[0], _plan(_greedy_config(), params,
                                              states[0]))
  assert float(narrow.score) <= float(best.score) + 1e-6
  with pytest.raises(errors.ConfigError, match='divisor of horizon'):
    _config(search=plan_config.BEAM, horizon=4, num_segments=3)
  with pytest.raises(errors.ConfigError, match='grid_levels'):
    _config(search=plan_config.BEAM, grid_levels=0)
  with pytest.raises(errors.ConfigError, match='search'):
    _config(search='bfs')


_best_per_cell = jax.jit(beam.best_per_cell, static_argnums=(4, 5))


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.integers(-3, 3), st.integers(-3, 3),
                          st.integers(0, 2),
                          st.one_of(st.floats(-5.0, 5.0, width=32),
                                    st.just(-np.inf))),
                min_size=1, max_size=24))
def test_best_per_cell_keeps_the_best_of_each_cell(entries):
  """Property: of the entries in one cell exactly the best-scored keeps
  its score (cells with only -inf keep none); every other gets -inf."""
  # Cells of 10 km x 10 km x 250 m; points near each cell's centre.
  x = np.array([e[0] * 10_000.0 + 5_000.0 for e in entries], np.float32)
  y = np.array([e[1] * 10_000.0 + 5_000.0 for e in entries], np.float32)
  h = np.array([14_000.0 + e[2] * 250.0 + 125.0 for e in entries], np.float32)
  scores = np.array([e[3] for e in entries], np.float32)
  out = np.asarray(_best_per_cell(x, y, h, scores, 10.0, 250.0))
  cells = {}
  for i, e in enumerate(entries):
    cells.setdefault(e[:3], []).append(i)
  for members in cells.values():
    kept = [i for i in members if out[i] > -np.inf]
    best = max(scores[members])
    if best == -np.inf:
      assert not kept
    else:
      assert len(kept) == 1 and out[kept[0]] == best
  assert np.all((out == scores) | (out == -np.inf))


def _greedy_config():
  """A beam of 9 whose one cell (larger than any flight's reach) keeps one
  partial plan per piece: a greedy search."""
  return _config(search=plan_config.BEAM, beam_width=9, grid_levels=2,
                 grad_starts=0, beam_cell_km=10_000.0, beam_cell_m=50_000.0)


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
def test_beam_with_one_cell_is_greedy(world):
  """A cell larger than any flight's reach (beam_cell_km, beam_cell_m)
  leaves one partial plan per piece: a greedy search, whose plan is scored
  (finite) and never better than the exhaustive beam's. Which entry of a
  cell survives is `test_best_per_cell_keeps_the_best_of_each_cell`."""
  _, params, states = world
  best = jax.tree.map(lambda a: a[0], _plan(_greedy_config(), params,
                                            states[0]))
  wide = jax.tree.map(lambda a: a[0], _plan(
      _config(search=plan_config.BEAM, beam_width=9, grid_levels=2,
              grad_starts=0), params, states[0]))
  # The exhaustive beam saw every plan, the greedy one among them.
  assert np.isfinite(float(best.score))
  assert float(best.score) <= float(wide.score) + 1e-6
  with pytest.raises(errors.ConfigError, match='beam_cell_km'):
    _config(search=plan_config.BEAM, beam_cell_km=-1.0)
  with pytest.raises(errors.ConfigError, match='beam_cell_m'):
    _config(search=plan_config.BEAM, beam_cell_m=0.0)


@pytest.mark.slow
@pytest.mark.ci
def test_beam_resource_value_keeps_the_frugal_plan(world):
  """One piece, a beam of 1: with beam_resource_value = 0 the kept choice
  is the best by the objective; with a large value, the one that keeps the
  most resources (`resource_margins`), here another choice."""
  _, params, states = world
  state = jax.tree.map(lambda a: a[0], states[0])
  config = _config(plan_config.ORACLE, search=plan_config.BEAM, horizon=6,
                   num_segments=1, replan_every=6, beam_width=1,
                   grid_levels=5)
  wind_fn = plan_objective.planning_wind(config, winds.GENERATIVE_WIND, state)
  h = jnp.clip(state.flight.altitude_m, config.altitude_low_m,
               config.altitude_high_m)
  targets = jnp.concatenate([jnp.linspace(config.altitude_low_m,
                                          config.altitude_high_m, 5), h[None]])
  floats = jnp.array([-1.0] * 5 + [1.0])
  scores = _objectives(config, params, state, wind_fn, targets[:, None],
                       floats[:, None])

  @jax.jit
  def margins(target, flag):
    actions = plan_objective.plan_actions(config, target[None], flag[None])
    f = plan_objective.fly(params, state, wind_fn, state.flight, actions)[0]
    return sum(plan_objective.resource_margins(params, f))

  kept_margins = np.asarray(jax.vmap(margins)(targets, floats))
  assert np.argmax(scores) != np.argmax(kept_margins)  # The test can fail.
  search = jax.jit(beam.beam_search, static_argnums=(0, 3))
  for value, best in ((0.0, np.argmax(scores)),
                      (1e4, np.argmax(kept_margins))):
    chosen, _ = search(dataclasses.replace(config, beam_resource_value=value),
                       params, state, wind_fn)
    assert float(chosen[0, 0]) == pytest.approx(float(targets[best]))
  with pytest.raises(errors.ConfigError, match='beam_resource_value'):
    _config(search=plan_config.BEAM, beam_resource_value=-1.0)


@pytest.mark.slow
@pytest.mark.ci
@pytest.mark.parametrize('scenarios, search, memory', [
    (0, plan_config.CEM, 0), (2, plan_config.CEM, 0), (0, plan_config.BEAM, 0),
    (0, plan_config.BEAM, 16)])  # The agent's defaults: its program.
def test_forecast_mpc_never_reads_the_noise(world, scenarios, search, memory):
  """Another flight's noise, same forecast and measurement: same plan (also
  when plans are scored over noise scenarios the planner draws itself, when
  they are searched by a beam, and with the Gaussian-process memory of
  measured winds)."""
  _, params, (state, other) = world
  swapped = state.replace(noise_u=other.noise_u, noise_v=other.noise_v)
  assert any(not np.array_equal(a, b) for a, b in zip(
      jax.tree.leaves(state.noise_u), jax.tree.leaves(other.noise_u)))
  config = _config(scenarios=scenarios, search=search, wind_memory=memory)
  plan = _plan(config, params, state)
  jax.tree.map(np.testing.assert_array_equal, plan,
               _plan(config, params, swapped))
  if scenarios:  # The scenarios change the scores (the plans' winds).
    assert plan.score != _plan(_config(), params, state).score
  if memory:  # The measurement went into the memory: the newest row.
    point, du, dv = plan_objective.measurement(winds.GENERATIVE_WIND,
                                         jax.tree.map(lambda a: a[0], state))
    np.testing.assert_array_equal(plan.memory.valid[0],
                                  [False] * (memory - 1) + [True])
    np.testing.assert_allclose(plan.memory.points[0, -1], point, rtol=1e-6)
    np.testing.assert_allclose([plan.memory.du[0, -1], plan.memory.dv[0, -1]],
                               [du, dv], rtol=1e-6)
    assert plan.score != _plan(_config(search=search), params, state).score


@pytest.mark.slow
def test_plans_under_realistic_physics(world):
  """Realistic latex physics: plans fly the expected dynamics (no new random
  walk steps, so no key is needed), the same plan as with the walk off."""
  from ble_latex.flight import params as params_lib  # pylint: disable=g-import-not-at-top
  _, params, (state, _) = world
  # The walk is a stress setting on top of the preset since issue 68.
  realistic = params.replace(flight=params_lib.realistic_flight_params(
      **params_lib.LIFT_WALK_RANDOM))
  assert realistic.flight.lift_walk
  no_walk = params.replace(flight=params_lib.realistic_flight_params())
  config = _config()
  a = _plan(config, realistic, state)
  b = _plan(config, no_walk, state)
  assert np.all(np.isfinite(a.score))
  jax.tree.map(np.testing.assert_array_equal, a, b)
  # And the realistic physics is what it plans with: not the paper's plan.
  assert not np.array_equal(a.score, _plan(config, params, state).score)


@pytest.mark.slow
def test_oracle_reads_the_noise(world):
  """The oracle's plan changes with the noise (the test above can fail)."""
  _, params, (state, other) = world
  swapped = state.replace(noise_u=other.noise_u, noise_v=other.noise_v)
  oracle = _config(plan_config.ORACLE)
  a = _plan(oracle, params, state)
  b = _plan(oracle, params, swapped)
  assert not np.array_equal(a.score, b.score)


@pytest.mark.slow
@pytest.mark.ci
def test_oracle_plan_is_the_flight(world):
  """Under the paper's physics the env flies the oracle's plan exactly: the
  distances its objective scores are the env's, stride by stride (why the
  oracle may plan the whole episode once)."""
  _, params, (_, state) = world
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  config = _config(plan_config.ORACLE, search=plan_config.BEAM, horizon=12,
                   num_segments=4, replan_every=12, beam_width=4,
                   grid_levels=3)
  plan = _plan(config, params, state)
  one = jax.tree.map(lambda a: a[0], state)
  actions = plan_objective.plan_actions(config, jnp.asarray(plan.targets_m[0]),
                                  jnp.asarray(plan.floats[0]))
  wind_fn = plan_objective.planning_wind(config, env.wind_for(params), one)

  @jax.jit
  def planned(s, a):
    return plan_objective.fly(params, s, wind_fn, s.flight, a)[1][0]

  @jax.jit
  def flown(s, a):
    def stride(s, action):
      s = env.step_env(None, s, action, params)[1]
      return s, jnp.hypot(s.flight.x_m, s.flight.y_m) / 1000.0
    return jax.lax.scan(stride, s, a)[1]

  expected = np.asarray(planned(one, actions))
  np.testing.assert_allclose(np.asarray(flown(one, actions)), expected,
                             rtol=1e-5)
  # The check can fail: another plan is another flight.
  other = actions.at[:, 0].set(actions[0, 0] + 3000.0)
  assert np.abs(np.asarray(flown(one, other)) - expected).max() > 0.1


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
def test_controller_gradient_matches_finite_differences(world):
  """d(sand dropped)/d(a0) of the controller (no scan: fast)."""
  from ble_latex.flight import atmosphere  # pylint: disable=g-import-not-at-top
  from ble_latex.flight import controller  # pylint: disable=g-import-not-at-top
  _, params, states = world
  state = jax.tree.map(lambda a: a[0], states[0])
  f0 = state.flight
  ambient = atmosphere.at_height(state.atmosphere, f0.altitude_m)

  def drop(a0):
    action = jnp.stack([a0, jnp.float32(2.0), jnp.float32(-1.0)])
    return controller.decide(params.flight.replace(min_drop_kg=0.0), f0,
                             action, ambient.temperature,
                             ambient.pressure).drop_kg

  a0 = f0.altitude_m + 1000.0  # Ballast branch, smooth in a0.
  g = float(jax.grad(drop)(a0))
  eps = 10.0
  fd = float((drop(a0 + eps) - drop(a0 - eps)) / (2 * eps))
  assert g > 0.0
  np.testing.assert_allclose(g, fd, rtol=0.02)


@pytest.mark.slow
def test_gradient_matches_finite_differences(world):
  """jax.grad of the objective through the core vs central differences.

  A smooth stretch: two strides towards targets far from the balloon (the
  controller's branch does not change within +-25 m of the targets).
  """
  _, params, states = world
  state = jax.tree.map(lambda a: a[0], states[0])
  config = _config(plan_config.GRADIENT, horizon=2, num_segments=2,
                   replan_every=1, radius_width_km=20.0)
  wind_fn = plan_objective.planning_wind(config, winds.GENERATIVE_WIND, state)
  floats = -jnp.ones(2)
  f = jax.jit(lambda x: plan_objective.objective(config, params,
                                           plan_objective.blind(state), wind_fn, x,
                                           floats))
  grad = jax.jit(jax.grad(lambda x: plan_objective.objective(
      config, params, plan_objective.blind(state), wind_fn, x, floats)))
  h0 = float(state.flight.altitude_m)
  x = jnp.asarray([h0 - 1500.0, h0 - 800.0], jnp.float32)
  g = np.asarray(grad(x))
  eps = 25.0
  fd = np.array([(f(x.at[i].add(eps)) - f(x.at[i].add(-eps))) / (2 * eps)
                 for i in range(2)])
  assert np.all(np.isfinite(g)) and np.any(np.abs(g) > 0)
  np.testing.assert_allclose(g, fd, rtol=0.05, atol=1e-3 * np.abs(fd).max())


def test_bad_config_is_one_line():
  with pytest.raises(errors.ConfigError, match='planner parameter horizon'):
    plan_config.PlannerConfig(horizon=0).checked()
  with pytest.raises(errors.ConfigError, match='num_segments'):
    plan_config.PlannerConfig(horizon=2, num_segments=3,
                           replan_every=1).checked()
  with pytest.raises(errors.ConfigError, match='mode'):
    plan_config.PlannerConfig(mode='magic').checked()
  with pytest.raises(errors.ConfigError, match='wind_memory'):
    plan_config.PlannerConfig(wind_memory=4, scenarios=2).checked()
  with pytest.raises(errors.ConfigError, match='wind_memory'):
    plan_config.PlannerConfig(wind_memory=-1).checked()
  with pytest.raises(errors.ConfigError, match='unknown parameter'):
    planners.LatexMpcAgent(3, (71,), action_low=jax_env.ACTION_LOW,
                           action_high=jax_env.ACTION_HIGH, samples=3)


def test_gin_configures_the_agent():
  import gin  # pylint: disable=g-import-not-at-top
  with gin.unlock_config():
    gin.parse_config(['LatexMpcAgent.num_samples = 16',
                      'LatexMpcGradAgent.grad_steps = 3'])
  try:
    mpc = planners.LatexMpcAgent(3, (71,), action_low=jax_env.ACTION_LOW,
                                 action_high=jax_env.ACTION_HIGH)
    grad = planners.LatexMpcGradAgent(3, (71,),
                                      action_low=jax_env.ACTION_LOW,
                                      action_high=jax_env.ACTION_HIGH)
  finally:
    gin.clear_config()
  assert mpc.config.num_samples == 16
  assert mpc.config.mode == plan_config.FORECAST
  assert grad.config.grad_steps == 3
  assert grad.config.mode == plan_config.GRADIENT
  # The gin module the agents always had names the same bindings.
  with gin.unlock_config():
    gin.parse_config(
        ['ble_latex.agents.planners.LatexMpcOracleAgent.beam_width = 7'])
  try:
    assert plan_config.from_gin('latex_mpc_oracle').beam_width == 7
  finally:
    gin.clear_config()


def test_pure_planning_imports_no_tensorflow():
  """The planning modules import neither TensorFlow, Dopamine nor BLE's
  agents (only `agents/planning/agents.py`, the BLE agents, does)."""
  code = ('import sys\n'
          'import ble_latex.agents.planning.planner\n'
          'import ble_latex.agents.planning.config\n'
          'import ble_latex.agents.planning.objective\n'
          'import ble_latex.agents.planning.beam\n'
          'heavy = ("tensorflow", "dopamine", '
          '"balloon_learning_environment.agents")\n'
          'print(sorted(h for h in heavy if h in sys.modules))\n')
  out = subprocess.run([sys.executable, '-c', code], check=True,
                       capture_output=True, text=True).stdout
  assert out.splitlines()[-1] == '[]'


def _agent(**config):
  return planners.LatexMpcAgent(3, (71,), action_low=jax_env.ACTION_LOW,
                                action_high=jax_env.ACTION_HIGH, **config)


@pytest.mark.parametrize('field', sorted(plan_config.MAX_SIZES))
def test_sizes_that_drive_memory_are_bounded(field):
  """Issue 48 item 15: each size has a stated maximum, checked when the
  agent is built (nothing compiled); the message names the binding."""
  maximum = plan_config.MAX_SIZES[field]
  with pytest.raises(errors.ConfigError) as e:
    _agent(**{field: maximum + 1})
  message = str(e.value)
  assert '\n' not in message
  assert message.startswith(f'gin binding LatexMpcAgent.{field} must be an '
                            f'int in [')
  assert message.endswith(f'{maximum}], got {maximum + 1}')


def test_beam_of_1e8_is_refused_before_compiling():
  """The issue's case (`LatexMpcAgent.beam_width=1e8`: compiled, then 2.26
  TB), and sizes each within bounds whose product is not: refused in one
  line naming the binding."""
  with pytest.raises(errors.ConfigError,
                     match=r'^gin binding LatexMpcAgent.beam_width must'):
    _agent(beam_width=10**8)
  config = dict(beam_width=plan_config.MAX_SIZES['beam_width'],
                grid_levels=plan_config.MAX_SIZES['grid_levels'])
  assert (config['beam_width'] * (config['grid_levels'] + 1) * 6 >
          plan_config.MAX_PLAN_STRIDES)
  with pytest.raises(errors.ConfigError,
                     match=r'^gin binding LatexMpcAgent.beam_width = 65536 '
                     r'.* would fly \d+ plan strides at once; at most'):
    _agent(**config)
  # The shipped planners fit with room (a batch of 100 oracles too).
  for name in plan_config.PLANNERS:
    assert plan_config.check_batch(plan_config.from_gin(name), 100) == 100


def test_an_oversized_batch_is_refused_before_compiling(world, monkeypatch):
  """`plan_batch` and `initial_plans` check N x plan strides first: the
  jitted call is never reached (so never compiled)."""
  _, _, states = world
  config = _config(search=plan_config.BEAM, beam_width=4096, grid_levels=15,
                   horizon=216, num_segments=216, replan_every=216)
  n = plan_config.MAX_PLAN_STRIDES // config.plan_strides() + 1
  many = jax.tree.map(lambda a: jnp.broadcast_to(a, (n,) + a.shape[1:]),
                      states[0])
  reached = []
  monkeypatch.setattr(planning, '_plan_batch',
                      lambda *a: reached.append('plan'))
  monkeypatch.setattr(planning, '_initial_plans',
                      lambda *a: reached.append('initial'))
  with pytest.raises(errors.ConfigError, match=f'balloons per call = {n} '):
    planning.initial_plans(config, many)
  with pytest.raises(errors.ConfigError, match='would fly'):
    planning.plan_batch(config, None, many, jnp.int32(0), None)
  assert not reached
  planning.initial_plans(config, states[0])  # One balloon: within bounds.
  assert reached == ['initial']


@pytest.mark.parametrize('field', [
    'sand_cost', 'helium_cost', 'terminal_cost', 'progress', 'shaping',
    'beam_resource_value', 'halflife_km', 'radius_width_km'])
def test_values_infinite_in_float32_are_refused(field):
  """Issue 48 item 3: `sand_cost=1e39` is finite in float64 but inf in the
  float32 core (every plan would score -inf); the project's number check
  refuses it, naming the binding."""
  with pytest.raises(errors.ConfigError,
                     match=f'^gin binding LatexMpcAgent.{field} must be'):
    _agent(**{field: 1e39})
  import gin  # pylint: disable=g-import-not-at-top
  with gin.unlock_config():
    gin.parse_config([f'LatexMpcAgent.{field} = 1e39'])
  try:
    with pytest.raises(errors.ConfigError, match=f'LatexMpcAgent.{field}'):
      plan_config.from_gin('latex_mpc')
  finally:
    gin.clear_config()


def test_planner_cost_beyond_float32_is_refused():
  from ble_latex.agents.planning import agents as planners  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import jax_env  # pylint: disable=g-import-not-at-top
  gin.clear_config()
  try:
    gin.parse_config('LatexMpcAgent.sand_cost = 1e39')
    with pytest.raises(ValueError, match='sand_cost'):
      planners.AGENTS['latex_mpc'](3, (71,), action_low=jax_env.ACTION_LOW,
                                   action_high=jax_env.ACTION_HIGH)
  finally:
    gin.clear_config()
