"""sac_ensemble: SAC policies whose critics choose among their actions."""

import contextlib
import functools
import os

import ble_latex  # noqa: F401
import gin
from hypothesis import given
from hypothesis import settings
from hypothesis import strategies as st
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex import configs
from ble_latex import errors
from ble_latex.agents.planning import config as plan_config
from ble_latex.agents.planning import objective as plan_objective
from ble_latex.agents.planning import value as plan_value
from ble_latex.agents.sac import agent as sac
from ble_latex.agents.sac import core as sac_core
from ble_latex.agents.sac import ensemble
from ble_latex.agents.sac import networks
from ble_latex.agents.sac import pretrained
from ble_latex.agents.sac import trainer as sac_trainer
from ble_latex.envs import env_params
from ble_latex.envs import jax_env
from ble_latex.flight import state as state_lib
from ble_latex.run import episode_log

_LOW = np.asarray(jax_env.ACTION_LOW, np.float32)
_HIGH = np.asarray(jax_env.ACTION_HIGH, np.float32)
_HIDDEN = 16


def _network(hidden=_HIDDEN):
  return networks.make_network(3, 2, hidden, 'mlp')


def _params(seed, hidden=_HIDDEN):
  net = _network(hidden)
  return net.init(jax.random.PRNGKey(seed), jnp.zeros((71,), jnp.float32),
                  jax.random.PRNGKey(0))


def _policy_file(tmp_path, seed, hidden=_HIDDEN, **observation):
  """A SAC policy file of a freshly initialised network."""
  config = {'observation_shape': [71], 'num_actions': 3,
            'action_low': _LOW.astype(np.float64).tolist(),
            'action_high': _HIGH.astype(np.float64).tolist(),
            'num_layers': 2, 'hidden_units': hidden, 'critic': 'mlp',
            'replay_capacity': 1000,
            **{k: 0 for k in env_params.OBSERVATION_FIELDS}, **observation}
  bundle = {'format': sac_core.CHECKPOINT_FORMAT, 'iteration': 0,
            'config': config, 'training_steps': 0,
            'network_params': sac_core.to_numpy(_params(seed, hidden)),
            'log_alpha': np.zeros((1,), np.float32)}
  path = str(tmp_path / f'policy_{seed}_{hidden}.msgpack')
  pretrained.write_policy(pretrained.policy_from_bundle(bundle, 'test'), path)
  return path


def _agent(paths, lookahead_strides=0):
  """The critics' choice where the balloon is (no lookahead) by default."""
  return ensemble.SACEnsembleAgent(3, (71,), action_low=_LOW,
                                   action_high=_HIGH, policy_paths=paths,
                                   hidden_units=_HIDDEN,
                                   lookahead_strides=lookahead_strides)


@settings(max_examples=20, deadline=None)
@given(members=st.integers(1, 4), seed=st.integers(0, 2**16),
       scale=st.floats(0.1, 3.0))
def test_critic_choice_is_the_proposal_the_critics_score_highest(
    members, seed, scale):
  net = _network()
  trees = [_params(seed + k) for k in range(members)]
  obs = scale * jax.random.normal(jax.random.PRNGKey(seed), (71,))
  means = np.stack([np.asarray(net.apply(
      p, obs, jax.random.PRNGKey(1), method=net.actor).mean_action)
                    for p in trees])
  score = np.zeros(members)
  for p in trees:  # Every member's critics score every proposal.
    for c in range(members):
      out = net.apply(p, obs, jnp.asarray(means[c]), method=net.critic)
      score[c] += min(float(out.q_value1[0]), float(out.q_value2[0]))
  score /= members
  stacked = sac_trainer.stack(trees)
  chosen = np.asarray(ensemble.critic_choice(net, stacked, obs))
  np.testing.assert_allclose(chosen, means[int(np.argmax(score))],
                             rtol=1e-5, atol=1e-6)
  np.testing.assert_allclose(
      np.asarray(ensemble.scores(net, stacked, obs, jnp.asarray(means))),
      score, rtol=1e-4, atol=1e-5)


def test_one_member_flies_as_sac_pretrained(tmp_path):
  path = _policy_file(tmp_path, 3)
  single = sac.SACPretrainedAgent(3, (71,), action_low=_LOW,
                                  action_high=_HIGH, policy_path=path)
  single.set_mode('eval')
  one = _agent([path])
  rng = np.random.default_rng(0)
  for _ in range(3):
    obs = rng.uniform(-1, 1, 71).astype(np.float32)
    np.testing.assert_allclose(one.begin_episode(obs),
                               single.begin_episode(obs), rtol=1e-6)


def test_batched_eval_and_launch_act_as_the_agent(tmp_path):
  from ble_latex.launch import controllers  # pylint: disable=g-import-not-at-top
  from ble_latex.run import batch_eval  # pylint: disable=g-import-not-at-top
  agent = _agent([_policy_file(tmp_path, k) for k in range(3)])
  rng = np.random.default_rng(1)
  observations = rng.uniform(-1, 1, (5, 71)).astype(np.float32)
  one_at_a_time = np.stack([agent.begin_episode(o) for o in observations])
  batched = batch_eval.core_policy(agent, None).begin(None, observations)
  np.testing.assert_array_equal(batched, one_at_a_time)
  controller = controllers.controller_for(agent)
  launch = np.stack([np.asarray(controller.act(None, jnp.asarray(o), None,
                                               0)[0])
                     for o in observations])
  np.testing.assert_allclose(launch, one_at_a_time, rtol=1e-5, atol=1e-3)
  # The choice is not always the first member's action.
  first = np.stack([agent._to_box(np.asarray(sac._mean_action(  # pylint: disable=protected-access
      agent.network_def, agent.network_params, jnp.asarray(o))))
                    for o in observations])
  assert not np.allclose(first, one_at_a_time)


def test_views_are_the_env_s_first_then_the_others():
  env = ensemble.view_of({'wind_memory': 16, 'wind_lookahead': 0})
  drifts = ensemble.view_of({'wind_memory': 0, 'wind_lookahead': 12})
  both = ensemble.view_of({'wind_memory': 16, 'wind_lookahead': 12})
  views, group = ensemble.views_of([drifts, env, both, drifts], env)
  assert views[0] == env and set(views) == {env, drifts, both}
  assert [views[g] for g in group] == [drifts, env, both, drifts]
  with pytest.raises(errors.ConfigError, match='no member'):
    ensemble.views_of([drifts], env)
  with pytest.raises(errors.ConfigError, match='remembers 0 winds'):
    ensemble.views_of([drifts, both], drifts)


def _fly(env, params, seed, strides):
  """The state of a balloon flown `strides` fixed actions from a seed."""
  obs, state = env.reset(jax.random.PRNGKey(seed), params)
  for i in range(strides):
    obs, state, *_ = env.step_env(
        None, state, jnp.asarray([16_000.0 + 1_000.0 * i, 1.0, -1.0]),
        params)
  return obs, state


@pytest.mark.slow
@pytest.mark.ci
def test_a_view_reads_the_column_its_settings_observe():
  """`observe` of a memory-holding state: its memory-free view is the
  observation of the env without a memory, the drift view that of the env
  with a lookahead, and the env's own view its observation."""
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  plain = env.default_params
  memory = plain.replace(wind_memory=16)
  obs, state = _fly(env, memory, 1_000_000, 3)
  views = (ensemble.view_of({'wind_memory': 16, 'wind_lookahead': 0}),
           ensemble.view_of({'wind_memory': 0, 'wind_lookahead': 0}),
           ensemble.view_of({'wind_memory': 0, 'wind_lookahead': 12}))
  rows = np.asarray(ensemble.observe(state, memory, env.wind, views))
  np.testing.assert_array_equal(rows[0], obs)
  np.testing.assert_allclose(rows[1], _fly(env, plain, 1_000_000, 3)[0],
                             atol=1e-6)
  np.testing.assert_allclose(
      rows[2], _fly(env, plain.replace(wind_lookahead=12), 1_000_000, 3)[0],
      atol=1e-6)
  assert not np.allclose(rows[0][:50], rows[1][:50])  # The memory matters.


def _batched_and_launch_fly(agent, env, obs, action):
  """The batched eval and the launch controller choose `action`, the
  attached agent's choice from `env`'s core state and observation `obs`."""
  from ble_latex.agents.planning import agents as planners  # pylint: disable=g-import-not-at-top
  from ble_latex.launch import controllers  # pylint: disable=g-import-not-at-top
  from ble_latex.run import batch_eval  # pylint: disable=g-import-not-at-top
  driver, wind = planners.core_of(env)
  states = jax.tree.map(lambda a: a[None], driver.state)
  batched = batch_eval.core_policy(agent, batch_eval.core_env(env)).step(
      states, obs[None], np.zeros(1))
  np.testing.assert_allclose(batched[0], action, rtol=1e-5, atol=1e-6)
  controller = controllers.controller_for(agent)
  carry = controller.plan(controller.init(jnp.asarray(obs), driver.state),
                          jnp.asarray(obs), driver.state, driver.params, wind)
  np.testing.assert_allclose(
      np.asarray(controller.act(carry, jnp.asarray(obs), driver.state, 0)[0]),
      action, rtol=1e-5, atol=1e-3)


def test_members_of_other_views_fly_from_the_env_s_state(tmp_path):
  """One balloon (BLE's gym env, `attach_env`), the batched eval and the
  launch controller choose the same action from the members' own views."""
  import gym  # pylint: disable=g-import-not-at-top
  from ble_latex.agents.planning import agents as planners  # pylint: disable=g-import-not-at-top
  paths = [_policy_file(tmp_path, 5, wind_lookahead=12),
           _policy_file(tmp_path, 6),
           _policy_file(tmp_path, 7, wind_lookahead=12)]
  env = gym.make('LatexBalloon-v0').unwrapped
  agent = _agent(paths)
  assert agent.needs_env and agent.group == (1, 0, 1)
  with pytest.raises(RuntimeError, match='attach_env'):
    agent.begin_episode(env.reset(seed=1_000_001))
  agent.attach_env(env)
  obs = env.reset(seed=1_000_001)
  obs, *_ = env.step(agent.begin_episode(obs))
  action = agent.step(0.0, obs)
  driver, wind = planners.core_of(env)
  rows = ensemble.observe(driver.state, driver.params, wind, agent.views)
  np.testing.assert_allclose(np.asarray(rows[0]), obs, atol=1e-6)
  expected = agent._to_box(np.asarray(ensemble.critic_choice(  # pylint: disable=protected-access
      agent.network_def, agent.members, rows, agent.group)))
  np.testing.assert_allclose(action, expected, rtol=1e-5, atol=1e-6)
  _batched_and_launch_fly(agent, env, obs, action)


@pytest.mark.slow
@pytest.mark.ci
def test_an_imagined_stride_is_the_env_s_stride_in_the_same_wind():
  """`imagine` in the ground truth is the env's own stride, but for the
  memory of measured winds, which an imagined wind does not join."""
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  params = env.default_params.replace(wind_memory=4)
  _, state = _fly(env, params, 1_000_002, 2)
  wind = env.wind_for(params)
  truth = functools.partial(wind.ground_truth, state)
  for action in ([0.3, -0.2, 0.5], [-0.9, 0.8, -0.5]):
    action = jnp.asarray(action, jnp.float32)
    imagined, reward = ensemble.imagine(params, truth, state, action)
    _, stepped, env_reward, _, _ = env.step_env(
        None, state, jax_env.to_box(action), params)
    assert _equal(imagined.replace(wind_memory=None),
                  stepped.replace(wind_memory=None))
    assert float(reward) == float(env_reward)
    assert _equal(imagined.wind_memory, state.wind_memory)
    assert not _equal(stepped.wind_memory, state.wind_memory)
  ended = state.replace(flight=state.flight.replace(
      status=jnp.asarray(state_lib.FlightStatus.OUT_OF_SAND,
                         state.flight.status.dtype)))
  assert float(ensemble.imagine(params, truth, ended, action)[1]) == 0.0


def _equal(a, b):
  return all(jax.tree.leaves(jax.tree.map(
      lambda x, y: bool(np.array_equal(x, y)), a, b)))


def _lookahead_setup(tmp_path, seeds=(5, 6, 7)):
  paths = [_policy_file(tmp_path, k, wind_memory=4 * (k % 2))
           for k in seeds]
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  params = env.default_params.replace(wind_memory=4)
  _, state = _fly(env, params, 1_000_003, 3)
  views, group = ensemble.views_of(
      [ensemble.view_of(pretrained.load_policy(p)['config']) for p in paths],
      ensemble.view_of(env_params.observation_of(params)))
  members = sac_trainer.stack([plan_value.load(p)[1] for p in paths])
  return _network(), members, group, views, env.wind_for(params), params, state


@pytest.mark.slow
@pytest.mark.ci
def test_lookahead_scores_are_the_rewards_and_the_members_value(tmp_path):
  """H = 1: score_k = r(s, a_k) + gamma V(s'_k), V the members' mean of
  min(Q1, Q2) at their mean actions on their own views of s'_k, s'_k the
  stride flown in the planning wind (forecast + the memory's correction),
  observed with the columns of s."""
  net, members, group, views, wind, params, state = _lookahead_setup(
      tmp_path)
  one = ensemble.Lookahead(1)
  actions, scores = ensemble.lookahead_scores(net, members, group, views, one,
                                              wind, params, state)
  rows = ensemble.observe(state, params, wind, views)[np.asarray(group)]
  np.testing.assert_array_equal(actions, ensemble.proposals(
      net, members, rows, per_member=True))
  blind = plan_objective.blind(state)
  wind_fn = plan_objective.planning_wind(plan_config.PlannerConfig(), wind,
                                         blind, memory=blind.wind_memory)
  columns = ensemble.view_columns(state, params, wind, views)
  for k in range(3):
    after, reward = ensemble.imagine(params, wind_fn, blind, actions[k])
    ends = ensemble.observe_columns(after, params, columns)
    value = np.mean([plan_value.state_value(
        net, jax.tree.map(lambda x: x[j], members), ends[group[j]])  # pylint: disable=cell-var-from-loop
                     for j in range(3)])
    np.testing.assert_allclose(scores[k], reward + one.discount * value,
                               rtol=1e-5)
  chosen = ensemble.lookahead_choice(net, members, group, views, one, wind,
                                     params, state)
  np.testing.assert_array_equal(chosen, actions[int(np.argmax(scores))])
  # One stride ahead, following the members is holding the proposal.
  followed = ensemble.lookahead_scores(
      net, members, group, views, ensemble.Lookahead(1, follow=True), wind,
      params, state)[1]
  np.testing.assert_array_equal(followed, scores)


@pytest.mark.slow
@pytest.mark.ci
def test_the_lookahead_reads_no_future_truth(tmp_path):
  """The scores do not move when the flight's future (its noise) does; they
  move with what it has measured (its memory)."""
  net, members, group, views, wind, params, state = _lookahead_setup(
      tmp_path)
  other = jax_env.LatexBalloonJaxEnv(normalize_actions=False).reset(
      jax.random.PRNGKey(7), params)[1]
  for lookahead in (ensemble.Lookahead(2), ensemble.Lookahead(2, True)):
    score = lambda s: np.asarray(ensemble.lookahead_scores(  # pylint: disable=cell-var-from-loop
        net, members, group, views, lookahead, wind, params, s)[1])
    base = score(state)
    np.testing.assert_array_equal(
        score(state.replace(noise_u=other.noise_u, noise_v=other.noise_v)),
        base)
    remembered = state.wind_memory.replace(du=state.wind_memory.du + 3.0)
    assert not np.allclose(score(state.replace(wind_memory=remembered)),
                           base)


def test_an_ensemble_with_a_lookahead_flies_from_the_env_s_state(tmp_path):
  """BLE's gym env (`attach_env`), the batched eval and the launch
  controller fly the same lookahead choice."""
  import gym  # pylint: disable=g-import-not-at-top
  from ble_latex.agents.planning import agents as planners  # pylint: disable=g-import-not-at-top
  paths = [_policy_file(tmp_path, k) for k in (8, 9)]
  env = gym.make('LatexBalloon-v0').unwrapped
  agent = ensemble.SACEnsembleAgent(
      3, (71,), action_low=_LOW, action_high=_HIGH, policy_paths=paths,
      hidden_units=_HIDDEN, lookahead_strides=2, lookahead_follow=True)
  assert len(agent.views) == 1 and agent.needs_env
  with pytest.raises(RuntimeError, match='attach_env'):
    agent.begin_episode(env.reset(seed=1_000_004))
  agent.attach_env(env)
  obs = env.reset(seed=1_000_004)
  obs, *_ = env.step(agent.begin_episode(obs))
  action = agent.step(0.0, obs)
  driver, wind = planners.core_of(env)
  expected = agent._to_box(np.asarray(ensemble.lookahead_choice(  # pylint: disable=protected-access
      agent.network_def, agent.members, agent.group, agent.views,
      ensemble.Lookahead(2, True), wind, driver.params, driver.state)))
  np.testing.assert_allclose(action, expected, rtol=1e-5, atol=1e-6)
  _batched_and_launch_fly(agent, env, obs, action)


def test_shipped_members_observe_the_drifts_and_the_memory():
  with pytest.raises(errors.ConfigError,
                     match='no member.*flies under .*latex_wind_memory.gin'):
    ensemble.SACEnsembleAgent(3, (71,), action_low=_LOW, action_high=_HIGH)
  assert os.path.isfile(configs.gin_file(ensemble.SHIPPED_GIN_FILE))
  gin.parse_config_file(configs.gin_file(ensemble.SHIPPED_GIN_FILE))
  try:
    agent = ensemble.SACEnsembleAgent(3, (71,), action_low=_LOW,
                                      action_high=_HIGH)
  finally:
    gin.clear_config()
  assert agent.policy_paths == pretrained.SHIPPED_ENSEMBLE
  assert all(os.path.isfile(p) for p in agent.policy_paths)
  configs_ = [pretrained.load_policy(p)['config'] for p in agent.policy_paths]
  assert [dict(agent.views[g]) for g in agent.group] == [
      {k: c[k] for k in env_params.OBSERVATION_FIELDS} for c in configs_]
  assert {dict(v)['wind_lookahead'] for v in agent.views} == {0, 12}
  assert agent.needs_env  # Its drift members read the env's state.
  with pytest.raises(errors.ConfigError, match='realistic'):
    pretrained.shipped_ensemble(True)


def test_bad_ensembles_are_refused(tmp_path):
  with pytest.raises(errors.ConfigError, match='1 to 16'):
    _agent([])
  path = _policy_file(tmp_path, 0)
  with pytest.raises(errors.ConfigError, match='1 to 16'):
    _agent([path] * 17)
  with pytest.raises(ValueError, match='hidden_units'):
    _agent([path, _policy_file(tmp_path, 1, hidden=8)])
  drifts = _policy_file(tmp_path, 2, wind_lookahead=12)
  with pytest.raises(errors.ConfigError, match='no member .* observes as'):
    _agent([drifts])
  with pytest.raises(errors.ConfigError, match='memory must be 0 or'):
    _agent([path, _policy_file(tmp_path, 4, wind_memory=8)])
  with pytest.raises(FileNotFoundError, match='missing.msgpack'):
    _agent([path, str(tmp_path / 'missing.msgpack')])
  with pytest.raises(errors.ConfigError, match='not policy_path'):
    ensemble.SACEnsembleAgent(3, (71,), action_low=_LOW, action_high=_HIGH,
                              policy_paths=[path], policy_path=path)
  for bad in (-1, 25, 1.5, True, '2'):
    with pytest.raises(errors.ConfigError, match='lookahead_strides must be'):
      ensemble.SACEnsembleAgent(3, (71,), action_low=_LOW, action_high=_HIGH,
                                policy_paths=[path], lookahead_strides=bad)
  with pytest.raises(errors.ConfigError, match='lookahead_follow must be'):
    ensemble.SACEnsembleAgent(3, (71,), action_low=_LOW, action_high=_HIGH,
                              policy_paths=[path], lookahead_follow='yes')
  agent = _agent([path])
  with pytest.raises(errors.ConfigError, match='only acts'):
    agent.set_mode('train')
  agent.set_mode('eval')


@contextlib.contextmanager
def _shipped_on_gym():
  """(`LatexBalloon-v0`, the shipped `sac_ensemble`) under its gin file."""
  import gym  # pylint: disable=g-import-not-at-top
  from ble_latex.run import gin_binding  # pylint: disable=g-import-not-at-top
  from ble_latex.run import runner  # pylint: disable=g-import-not-at-top
  gin.clear_config()
  try:
    gin_binding.bind_gin('sac_ensemble', None,
                         [configs.gin_file(ensemble.SHIPPED_GIN_FILE)], [])
    env = gym.make('LatexBalloon-v0').unwrapped
    yield env, runner.create_agent('sac_ensemble', env)
  finally:
    gin.clear_config()


def test_shipped_ensemble_flies_the_latex_env_under_its_gin_file():
  with _shipped_on_gym() as (env, agent):
    obs = env.reset(seed=1_000_000)
    action = agent.begin_episode(obs)
    for _ in range(3):
      assert env.action_space.contains(action.astype(np.float32))
      obs, reward, _, _ = env.step(action)
      action = agent.step(reward, obs)
  assert agent.get_name() == 'sac_ensemble'
  assert len(agent.policy_paths) == len(pretrained.SHIPPED_ENSEMBLE)


@pytest.mark.slow
def test_shipped_ensemble_reproduces_its_record():
  """README's `sac_ensemble` row: its committed eval record
  (benchmarks/records/ensemble/latex_small/sac_ensemble.json), all 100 seeds, within
  the shipped policy's row tolerance (`test_pretrained.ROW_TOLERANCE`)."""
  import json  # pylint: disable=g-import-not-at-top
  from ble_latex.run import eval_lib  # pylint: disable=g-import-not-at-top
  from ble_latex.run import metrics  # pylint: disable=g-import-not-at-top
  from ble_latex.run import suites  # pylint: disable=g-import-not-at-top
  from tests.agents.sac.test_pretrained import ROW_TOLERANCE  # pylint: disable=g-import-not-at-top
  recorded = metrics.summarize(json.loads(
      (episode_log.RECORDS_DIR / 'ensemble' / 'latex_small' /
       'sac_ensemble.json').read_text()))
  with _shipped_on_gym() as (env, agent):
    suite = suites.get_eval_suite('latex_small')
    s = metrics.summarize(eval_lib.evaluate(agent, env, suite.seeds,
                                            suite.max_episode_length))
  assert s['episodes'] == recorded['episodes'] == 100
  assert s['tw50_window_mean'] == pytest.approx(
      recorded['tw50_window_mean'], abs=ROW_TOLERANCE['tw50_window'])
  assert s['out_of_resources_pct'] == pytest.approx(
      recorded['out_of_resources_pct'],
      abs=ROW_TOLERANCE['out_of_resources_pct'])


def test_the_default_lookahead_is_a_declared_one():
  """`SACEnsembleAgent`'s default (strides, follow) was chosen among the
  lookaheads declared before any held-out flight, and is within bounds."""
  import inspect  # pylint: disable=g-import-not-at-top
  defaults = inspect.signature(ensemble.SACEnsembleAgent.__init__).parameters
  chosen = (defaults['lookahead_strides'].default,
            defaults['lookahead_follow'].default)
  assert chosen == (3, True)
  assert chosen in ensemble.DECLARED_LOOKAHEADS
  assert len(set(ensemble.DECLARED_LOOKAHEADS)) == len(
      ensemble.DECLARED_LOOKAHEADS)
  assert all(1 <= h <= ensemble.MAX_LOOKAHEAD
             for h, _ in ensemble.DECLARED_LOOKAHEADS)
