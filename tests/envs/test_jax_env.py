"""The batched JAX env (issue 11) against the gym env and the golden data."""

import functools

import gin
import gym
from hypothesis import given
from hypothesis import settings
from hypothesis import strategies as st
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import ble_latex  # noqa: F401
from ble_latex import configs
from ble_latex import errors
from ble_latex.envs import env_params
from ble_latex.envs import env_types
from ble_latex.envs import jax_env
from ble_latex.envs import reset_pool
from ble_latex.flight import atmosphere as atmosphere_lib
from ble_latex.flight import params as flight_params_lib
from ble_latex.flight import state as state_lib
from tests.ble import test_golden

_KEY = jax.random.PRNGKey(0)


@functools.lru_cache(maxsize=None)
def _setup():
  """The env, its gin-bound params and jitted functions (built once)."""
  gin.clear_config()
  gin.parse_config_files_and_bindings(configs.env_gin_files(), [])
  try:
    env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
    params = env.default_params
  finally:
    gin.clear_config()
  batch_reset = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))
  batch_step = jax.jit(jax.vmap(env.step_env, in_axes=(0, 0, 0, None)))
  return env, params, batch_reset, batch_step


@functools.lru_cache(maxsize=None)
def _single():
  """One balloon, jitted once for the module: (reset, step_env, step)."""
  env = _setup()[0]
  return jax.jit(env.reset), jax.jit(env.step_env), jax.jit(env.step)


def _keys(seeds):
  return jnp.stack([jax.random.PRNGKey(s) for s in seeds])


def _flight_dict(flight, i):
  """Balloon i of a batched FlightState as test_golden's state dict."""
  f = jax.tree.map(lambda a: np.asarray(a[i], np.float64), flight)
  return {
      'x_m': float(f.x_m), 'y_m': float(f.y_m),
      'altitude_m': float(f.altitude_m),
      'ascent_rate_mps': float(f.ascent_rate_mps),
      'helium_mols': float(f.helium_mols), 'sand_kg': float(f.sand_kg),
      'helium_vented_mols': float(f.helium_vented_mols),
      'sand_dropped_kg': float(f.sand_dropped_kg),
      'pending_vent_mols': float(f.pending_vent_mols),
      'pending_drop_kg': float(f.pending_drop_kg),
      'time_elapsed_s': float(f.time_s),
      'latex_status': int(f.status), 'last_decision': int(f.last_decision),
  }


def _fly_golden(source):
  """All 20 golden seeds of `source`, batched, with the recorded actions."""
  _, params, batch_reset, batch_step = _setup()
  golden = test_golden.load_golden(source)
  actions = np.nan_to_num(golden.arrays['action'], nan=17_500.0)
  actions[..., 1:] = np.nan_to_num(actions[..., 1:], nan=1.0)
  keys = _keys(golden.seeds)
  obs, state = batch_reset(keys, params)
  # Host copies: indexing device arrays balloon by balloon, step by step,
  # would dispatch ~90 000 small ops.
  host = lambda flight: jax.tree.map(np.asarray, flight)
  states, observations, done = [host(state.flight)], [np.asarray(obs)], []
  for t in range(actions.shape[1]):
    obs, state, _, terminated, info = batch_step(
        keys, state, jnp.asarray(actions[:, t], jnp.float32), params)
    states.append(host(state.flight))
    observations.append(np.asarray(obs))
    done.append(np.asarray(terminated | info['time_limit']))
  return golden, states, np.stack(observations, 1), np.stack(done, 1)


@pytest.mark.slow
@pytest.mark.ci
def test_gym_env_is_the_batched_env():
  """`gym.make('LatexBalloon-v0')` flies the core: same world, same steps."""
  _, params, batch_reset, batch_step = _setup()
  seeds = [0, 7, 1_000_003]
  keys = _keys(seeds)
  obs, state = batch_reset(keys, params)
  gym_env = gym.make('LatexBalloon-v0', seed=0).unwrapped
  actions = np.array([[18_500.0, 1.0, -1.0], [15_000.0, 2.0, -1.0],
                      [16_000.0, 1.0, 1.0]], np.float32)
  gym_obs = [[gym_env.reset(seed=seed)] for seed in seeds]
  gym_rewards = [[] for _ in seeds]
  batch_obs, batch_rewards = [np.asarray(obs)], []
  for t in range(4):
    action = np.roll(actions, t, axis=0)
    obs, state, reward, _, _ = batch_step(keys, state, jnp.asarray(action),
                                          params)
    batch_obs.append(np.asarray(obs))
    batch_rewards.append(np.asarray(reward))
  # Fly each seed through the gym env with the same actions.
  for i, seed in enumerate(seeds):
    gym_env.reset(seed=seed)
    for t in range(4):
      o, r, _, _ = gym_env.step(np.roll(actions, t, axis=0)[i])
      gym_obs[i].append(o)
      gym_rewards[i].append(r)
  batch_obs = np.stack(batch_obs, 1)
  # The same code. Batched, XLA decodes the VAE forecasts with
  # matrix-matrix kernels (another float32 summation order, <= ~2e-4 m/s
  # of wind, see wind.generative), so features differ by <= ~1e-4.
  np.testing.assert_allclose(np.array(gym_obs), batch_obs, atol=1e-4, rtol=0)
  np.testing.assert_allclose(np.array(gym_rewards),
                             np.stack(batch_rewards, 1), atol=1e-5, rtol=0)
  # One balloon of the functional env, jitted alone: the gym env's numbers.
  reset, step, _ = _single()
  for i, seed in enumerate(seeds):
    obs, one = reset(jax.random.PRNGKey(seed), params)
    single = [np.asarray(obs)]
    for t in range(4):
      obs, one, _, _, _ = step(keys[i], one, np.roll(actions, t, axis=0)[i],
                               params)
      single.append(np.asarray(obs))
    np.testing.assert_allclose(np.array(gym_obs[i]), np.array(single),
                               atol=1e-6, rtol=0, err_msg=f'seed {seed}')
  s = gym_env.arena.get_balloon_state()
  assert s.x.meters == pytest.approx(float(state.flight.x_m[2]), abs=0.05)


_TRAJECTORY_TOL_M = 100.0  # [m] (the issue asks 1 km for 18 of 20 seeds)


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
@pytest.mark.parametrize('source', [
    'random', pytest.param('scripted', marks=pytest.mark.slow)])
def test_golden_trajectories(source):
  """All 20 seeds, every step: within 100 m, the same decisions and ends."""
  golden, states, observations, done = _fly_golden(source)
  deviations = []
  for i, seed in enumerate(golden.seeds):
    episode, n = golden.episode(i), golden.lengths[i]
    context = f'{source} seed {seed}'
    flown = [_flight_dict(s, i) for s in states[:n + 1]]
    simulated = {f'state_{k}': np.array([f[k] for f in flown])
                 for k in ('x_m', 'y_m', 'altitude_m')}
    simulated['done'] = done[i, :n]
    deviations.append(test_golden.max_deviation_m(episode, simulated))
    assert done[i, n - 1] and not done[i, :n - 1].any(), context
    np.testing.assert_array_equal(
        [f['last_decision'] for f in flown[1:]],
        episode['state_last_decision'][1:n + 1], err_msg=context)
    np.testing.assert_array_equal(
        [f['latex_status'] for f in flown[1:]],
        episode['state_latex_status'][1:n + 1], err_msg=context)
    np.testing.assert_allclose(observations[i, :n + 1], episode['obs'],
                               atol=5e-3, rtol=0, err_msg=context)
  assert max(deviations) <= _TRAJECTORY_TOL_M, deviations
  within = sum(d <= test_golden.TRAJECTORY_TOL_M for d in deviations)
  assert within >= test_golden.MIN_SEEDS_WITHIN, deviations


def _restored(state, i, before, step):
  """Balloon i's env state with its flight replaced by a recorded one."""
  _, params, _, _ = _setup()
  one = jax.tree.map(lambda a: a[i], state)
  f = one.flight
  dtype = f.altitude_m.dtype
  value = lambda k: jnp.asarray(before[k], dtype)
  ambient = atmosphere_lib.at_height(one.atmosphere, value('altitude_m'))
  f = f.replace(
      x_m=value('x_m'), y_m=value('y_m'), altitude_m=value('altitude_m'),
      ascent_rate_mps=value('ascent_rate_mps'),
      pending_vent_mols=value('pending_vent_mols'),
      pending_drop_kg=value('pending_drop_kg'),
      helium_vented_mols=value('helium_vented_mols'),
      sand_dropped_kg=value('sand_dropped_kg'),
      time_s=value('time_elapsed_s'),
      status=jnp.asarray(before['latex_status'], jnp.int32),
      last_decision=jnp.asarray(before['last_decision'], jnp.int32),
      pressure_pa=ambient.pressure, temperature_k=ambient.temperature)
  f = state_lib.with_resources(params.flight, f,
                               helium_mols=before['helium_mols'],
                               sand_kg=before['sand_kg'])
  return one.replace(flight=f, steps=jnp.asarray(step, jnp.int32))


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
@pytest.mark.parametrize('source', [
    'random', pytest.param('scripted', marks=pytest.mark.slow)])
def test_single_steps_from_recorded_states(source):
  """Given the recorded state and action, one step matches the recording."""
  _, params, batch_reset, _ = _setup()
  _, step, _ = _single()
  golden = test_golden.load_golden(source)
  _, state = batch_reset(_keys(golden.seeds), params)
  checked = 0
  for i in range(0, len(golden.seeds), 4):
    episode, n = golden.episode(i), golden.lengths[i]
    for t in sorted({0, 1, n // 4, n // 2, (3 * n) // 4, n - 1}):
      before = test_golden.state_at(episode, t)
      action = episode['action'][t]
      one = _restored(state, i, before, t)
      _, after, _, terminated, info = step(
          _KEY, one, jnp.asarray(action, jnp.float32), params)
      done = terminated | info['time_limit']
      simulated = _flight_dict(jax.tree.map(lambda a: a[None], after.flight),
                               0)
      test_golden.assert_step_matches(
          before, test_golden.state_at(episode, t + 1), simulated,
          context=f'{source} seed {golden.seeds[i]} step {t}')
      assert bool(done) == bool(episode['done'][t])
      checked += 1
  assert checked >= 20


@pytest.mark.slow
@pytest.mark.ci
def test_batched_equals_single_and_auto_reset():
  """(A batch of 3: test_gym_env_is_the_batched_env's compilation.)"""
  _, params, batch_reset, batch_step = _setup()
  reset, step_env, step = _single()
  seeds = [3, 4, 5]
  keys = _keys(seeds)
  obs, state = batch_reset(keys, params)
  action = jnp.array([[20_000.0, 1.0, -1.0], [14_000.0, 2.0, -1.0],
                      [17_000.0, 3.0, 1.0]])
  b_obs, b_state, b_reward, _, _ = batch_step(keys, state, action, params)
  for i, seed in enumerate(seeds):
    o, s = reset(jax.random.PRNGKey(seed), params)
    # vmap decodes the VAE with batched products (~1e-4 m/s apart).
    np.testing.assert_allclose(o, obs[i], atol=5e-5, rtol=0)
    o, s, r, _, _ = step_env(keys[i], s, action[i], params)
    np.testing.assert_allclose(o, b_obs[i], atol=5e-5)
    assert float(r) == pytest.approx(float(b_reward[i]), abs=1e-5)
  # A finished episode is replaced by the flight of the step key's reset
  # half (gymnax's split: key, key_reset = jax.random.split(key)), not by
  # the flight of the key that `step_env` got.
  short = params.replace(episode_steps=1)
  o, s = reset(keys[0], short)
  new_key = jax.random.PRNGKey(99)
  o2, s2, _, terminated, truncated, info = step(new_key, s, action[0], short)
  assert bool(truncated) and not bool(terminated)
  fresh_obs, fresh = reset(jax.random.split(new_key)[1], short)
  np.testing.assert_array_equal(o2, fresh_obs)
  assert not np.array_equal(o2, reset(new_key, short)[0])
  # gymnax 1.0: the finished step's observation is in the info.
  last, _, _, _, _ = step_env(new_key, s, action[0], short)
  np.testing.assert_array_equal(info['final_observation'], last)
  assert int(s2.steps) == 0
  assert float(s2.flight.x_m) == float(fresh.flight.x_m)


@pytest.mark.slow
@pytest.mark.ci
def test_rollout_many_balloons_in_one_call():
  env, params, _, _ = _setup()
  n, steps = 64, 6
  keys = jax.random.split(_KEY, n)
  actions = jnp.tile(jnp.array([18_000.0, 2.0, -1.0]), (n, 1))
  obs, rewards, done = jax_env.rollout(env, keys, actions, params, steps)
  assert obs.shape == (steps + 1, n, 71)
  assert rewards.shape == done.shape == (steps, n)
  assert np.all(np.isfinite(obs)) and np.all(np.abs(obs) <= 1.0)
  assert np.all((rewards <= 1.0) & (rewards >= 0.0))


# -- NaN actions: the float action, flagged (issue 24). ------------------------
_KINDS = ('finite', 'nan', 'inf', '-inf')


@settings(max_examples=8, deadline=None, derandomize=True)
@given(kinds=st.lists(st.tuples(*[st.sampled_from(_KINDS)] * 3), min_size=3,
                      max_size=3))
def test_nan_actions_fly_the_float_action(kinds):
  """Any NaN component: the step flies (clip(h), 1, +1) and says so in
  info['invalid_action']; +-inf clip onto the Box; never NaN in the state
  or the features (batch of 3: test_gym_env_is_the_batched_env's
  compilation)."""
  _, params, batch_reset, batch_step = _setup()
  keys = _keys([3, 4, 5])
  _, state = batch_reset(keys, params)
  base = np.array([[20_000.0, 2.0, -1.0], [15_000.0, 3.0, 0.5],
                   [17_000.0, 1.0, 1.0]], np.float32)
  action = base.copy()
  expected = base.copy()
  h = np.asarray(state.flight.altitude_m)
  for i, balloon in enumerate(kinds):
    for j, kind in enumerate(balloon):
      if kind != 'finite':
        action[i, j] = {'nan': np.nan, 'inf': np.inf, '-inf': -np.inf}[kind]
        expected[i, j] = np.clip(action[i, j], jax_env.ACTION_LOW[j],
                                 jax_env.ACTION_HIGH[j])
    if 'nan' in balloon:
      expected[i] = [np.clip(h[i], 14_000.0, 21_000.0), 1.0, 1.0]
  obs, s, reward, _, info = batch_step(keys, state, jnp.asarray(action),
                                       params)
  want_obs, want, want_reward, _, want_info = batch_step(
      keys, state, jnp.asarray(expected), params)
  np.testing.assert_array_equal(obs, want_obs)
  np.testing.assert_array_equal(reward, want_reward)
  jax.tree.map(np.testing.assert_array_equal, s, want)
  assert np.all(np.isfinite(obs))
  assert np.all(np.isfinite(s.history.float_action))
  np.testing.assert_array_equal(info['invalid_action'],
                                ['nan' in b for b in kinds])
  assert not np.any(want_info['invalid_action'])


# -- One check of every env value, naming the gin binding (issue 24). ----------
_BAD_BINDINGS = [
    ('latex_start.start_altitude_range_m', '(15000.0, 1e7)',
     'must be'),
    ('latex_start.start_altitude_range_m', '(-100.0, 20000.0)',
     'above the ground'),
    ('latex_start.start_altitude_range_m', '(20000.0, 15000.0)',
     'low <= high'),
    ('latex_start.start_altitude_range_m', '17000.0', r'\(low, high\)'),
    ('latex_start.start_altitude_range_m', '(15000.0, 40000.0)',
     r'would start at 17\d\d m\^3 at 40000 m, above '
     r'latex_launch.burst_volume_m3 = 336.5'),
    ('latex_launch.helium_mols', '1e6',
     r'= 1000000.0: the balloon would start at .* m\^3 at 20000 m, above '
     r'latex_launch.burst_volume_m3 = 336.5'),
    ('latex_episode.episode_steps', '0', 'an int in'),
    ('latex_episode.episode_steps', '-5', 'an int in'),
    ('latex_episode.episode_steps', 'True', 'an int in'),
    ('latex_episode.episode_steps', '2.5', 'an int in'),
    ('latex_start.max_start_distance_km', '-1.0', '> 0'),
    ('latex_start.max_start_distance_km', "'far'", '> 0'),
    ('latex_start.stride', '0.1', '>= 1 s'),
    ('latex_start.stride', 'None', '>= 1 s'),
    ('latex_flight.max_substep', '1e-9', '>= 1 s'),
    ('latex_flight.actuation_chunk', '5000.0',
     'cannot be longer than latex_start.stride'),
    ('latex_launch.sand_kg', 'True', 'a finite number >= 0'),
    ('latex_launch.payload_kg', "'abc'", 'a finite number >= 0.05'),
    ('latex_launch.payload_kg', 'None', 'a finite number >= 0.05'),
    ('latex_episode.station_keeping_radius_km', '-1.0', '> 0'),
    ('balloon_env.perciatelli_reward_function.station_keeping_radius_km',
     '-1.0', 'the station radius has one home'),
    ('latex_reward.sand_penalty_per_kg', 'None', '>= 0'),
]


@pytest.fixture
def all_configurables():
  """Every configurable registered (gym env, arena, balloon); gin cleared."""
  import ble_latex.ble.gym_env  # pylint: disable=g-import-not-at-top,unused-import
  gin.clear_config()
  yield
  gin.clear_config()


@pytest.mark.parametrize('binding, value, match', _BAD_BINDINGS)
def test_params_from_gin_refuses_bad_values_naming_the_binding(
    all_configurables, binding, value, match):
  """Checked on the host before anything compiles (fast)."""
  del all_configurables
  gin.parse_config(f'{binding} = {value}')
  name = binding.split('.', 1)[1] if binding.startswith('balloon_env.') else (
      binding)
  with pytest.raises(ValueError, match=f'^gin binding {name}.*{match}'):
    env_params.params_from_gin()


@settings(max_examples=10, deadline=None, derandomize=True)
@given(low=st.floats(1_000.0, 25_000.0), width=st.floats(0.0, 5_000.0),
       steps=st.integers(1, 10_000), distance=st.floats(1.0, 1_000.0))
def test_check_params_keeps_valid_values(low, width, steps, distance):
  """Valid values pass unchanged (as Python floats / int)."""
  params = env_types.EnvParams(
      flight=flight_params_lib.FlightParams(), decoder=None,
      start_altitude_low_m=low, start_altitude_high_m=low + width,
      episode_steps=np.int64(steps), max_start_distance_km=distance)
  checked = env_params.check_params(params)
  assert checked.start_altitude_low_m == low
  assert checked.start_altitude_high_m == low + width
  assert checked.episode_steps == steps
  assert isinstance(checked.episode_steps, int)
  assert checked.max_start_distance_km == distance


def test_valid_gin_config_unchanged():
  """The shipped env gin files give the defaults, checked (as before)."""
  gin.clear_config()
  gin.parse_config_files_and_bindings(configs.env_gin_files(), [])
  try:
    params = env_params.params_from_gin()
  finally:
    gin.clear_config()
  default = env_types.EnvParams(flight=params.flight, decoder=params.decoder)
  assert params == default
  assert params.flight == flight_params_lib.FlightParams()


@pytest.mark.slow
@pytest.mark.ci
def test_gymnax_client_loop_without_a_wrapper():
  """A purejaxrl-style loop: spaces, default params, scan of vmapped step."""
  env = jax_env.LatexBalloonJaxEnv()
  params = env.default_params.replace(episode_steps=2)
  assert params.max_steps_in_episode == 2
  assert env.num_actions == env.action_space(params).shape[0] == 3
  assert env.observation_space(params).shape == (env.num_features,)
  low = jnp.asarray(env.action_space(params).low)
  high = jnp.asarray(env.action_space(params).high)
  n = 2

  def one(carry, key):
    obs, state = carry
    act_key, step_key = jax.random.split(key)
    action = jax.random.uniform(act_key, (n, 3), minval=low, maxval=high)
    obs, state, reward, terminated, truncated, info = jax.vmap(
        env.step, in_axes=(0, 0, 0, None))(
            jax.random.split(step_key, n), state, action, params)
    return (obs, state), (reward, terminated, truncated, info['steps'])

  # Jitted, as such loops are (op by op, the reset costs ~340 compiles).
  obs, state = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(
      jax.random.split(jax.random.PRNGKey(0), n), params)
  (obs, state), (reward, terminated, truncated, steps) = jax.jit(
      lambda c, k: jax.lax.scan(one, c, k))(
          (obs, state), jax.random.split(jax.random.PRNGKey(1), 4))
  assert obs.shape == (n, 71) and reward.shape == (4, n)
  # Truncated at the limit, auto-reset (the step count restarts).
  np.testing.assert_array_equal(np.asarray(truncated | terminated),
                                np.asarray(steps) == 2)
  np.testing.assert_array_equal(np.asarray(state.steps), [0, 0])


# -- Reset pool and normalized actions (issue 31). ----------------------------
@pytest.mark.slow
def test_reset_pool_gives_pool_worlds_and_only_resets_the_ended():
  """`step` with a pool: ended balloons get world pool_index(key), small
  leaves at once, the large ones installed by the next step; the others
  fly on exactly as `step_env` flies them; one balloon (a real cond) too."""
  env, params, batch_reset, _ = _setup()
  short = params.replace(episode_steps=3)
  pooled = env.with_reset_pool(jax.random.PRNGKey(7), short, 4)
  pool = pooled.reset_pool
  assert pool.size == 4 and pool.obs.shape == (4, 71)
  # World k is the explicit reset of key k of the pool's split.
  o, _ = jax.jit(env.reset)(jax.random.split(jax.random.PRNGKey(7), 4)[2],
                            short)
  np.testing.assert_allclose(pool.obs[2], o, atol=5e-5)
  keys = _keys([3, 4, 5])
  _, state = batch_reset(keys, short)
  state = state.replace(steps=jnp.array([0, 2, 1], jnp.int32))
  action = jnp.tile(jnp.array([18_000.0, 2.0, -1.0]), (3, 1))
  step_keys = _keys([11, 12, 13])
  step = jax.jit(jax.vmap(env.step, in_axes=(0, 0, 0, None)))
  step_env = jax.jit(jax.vmap(env.step_env, in_axes=(0, 0, 0, None)))
  install = jax.jit(jax.vmap(reset_pool.install_world, in_axes=(0, None)))
  obs, new, _, terminated, truncated, info = step(step_keys, state, action,
                                                  pooled)
  flown, flown_state, _, _, _ = step_env(step_keys, state, action, pooled)
  np.testing.assert_array_equal(info['final_observation'], flown)
  assert list(np.asarray(terminated | truncated)) == [False, True, False]
  # The world of the step key's reset half (gymnax's key split).
  k = int(reset_pool.pool_index(jax.random.split(step_keys[1])[1], 4))
  assert list(np.asarray(new.pending_world)) == [-1, k, -1]
  np.testing.assert_array_equal(obs[1], pool.obs[k])
  installed = install(new, pooled)
  for i in (0, 2):
    np.testing.assert_array_equal(obs[i], flown[i])
    jax.tree.map(lambda a, b: np.testing.assert_array_equal(a[i], b[i]),
                 new, flown_state)
  jax.tree.map(lambda a, b: np.testing.assert_array_equal(a[1], b[k]),
               installed, pool.state)
  # The next step flies the installed world (the pending one is installed).
  nxt = step_env(step_keys, new, action, pooled)
  jax.tree.map(np.testing.assert_array_equal, nxt,
               step_env(step_keys, installed, action, pooled))
  # One balloon, unbatched: the same world.
  one = jax.tree.map(lambda a: a[1], state)
  o1, s1, *_ = jax.jit(env.step)(step_keys[1], one, action[1], pooled)
  np.testing.assert_array_equal(o1, pool.obs[k])
  assert int(s1.pending_world) == k


def test_reset_pool_size_is_bounded_before_anything_is_drawn(monkeypatch):
  """Issue 48 item 15: K beyond `reset_pool.MAX_POOL_SIZE` (10**8 worlds
  asked for terabytes, 10**4 aborted under an 8 GB cap) is one ConfigError
  before any reset is traced, compiled or allocated."""
  env, params, _, _ = _setup()

  def traced(*args):
    del args
    raise AssertionError('the pool was drawn before its size was checked')

  monkeypatch.setattr(env, 'reset', traced)
  for size in (10**8, reset_pool.MAX_POOL_SIZE + 1, 0, 2.0):
    with pytest.raises(errors.ConfigError,
                       match=r'^reset pool size must be an int in \[1, '
                       rf'{reset_pool.MAX_POOL_SIZE}\], got') as e:
      env.with_reset_pool(_KEY, params, size)
    assert '\n' not in str(e.value)


def test_rollout_sizes_are_bounded_before_anything_is_compiled(monkeypatch):
  """`rollout`'s batch and length are checked against their stated maxima
  (`jax_env.MAX_ROLLOUT_BALLOONS`, `MAX_ROLLOUT_VALUES`) before tracing."""
  env, params, _, _ = _setup()

  def compiled(*args):
    del args
    raise AssertionError('rollout was traced before its sizes were checked')

  monkeypatch.setattr(jax_env, '_rollout', compiled)
  keys = _keys([0, 1])
  action = jnp.array([[17_500.0, 2.0, 1.0]] * 2)
  most = jax_env.MAX_ROLLOUT_VALUES // (2 * 71) - 1
  for steps in (10**12, most + 1, 0):
    with pytest.raises(errors.ConfigError,
                       match=r'^rollout num_steps \(x 2 balloons\) must be '
                       rf'an int in \[1, {most}\], got {steps}$'):
      jax_env.rollout(env, keys, action, params, steps)
  many = jax.ShapeDtypeStruct((jax_env.MAX_ROLLOUT_BALLOONS + 1, 2),
                              jnp.uint32)
  with pytest.raises(errors.ConfigError, match=r'^rollout balloons'):
    jax_env.rollout(env, many, action, params, 1)
  with pytest.raises(AssertionError, match='traced'):  # Within the bounds.
    jax_env.rollout(env, keys, action, params, most)


@pytest.mark.slow
def test_reset_pool_step_where_no_episode_ended_is_step_env():
  """The pooled `step`'s skipped branches: a batch where no balloon ended
  gives exactly `step_env`'s observation and state (nothing pending); a
  state with one pending world gets exactly that balloon's large leaves."""
  env, params, batch_reset, _ = _setup()
  pooled = env.with_reset_pool(jax.random.PRNGKey(7),
                               params.replace(episode_steps=3), 4)
  _, state = batch_reset(_keys([3, 4, 5]), pooled)
  state = state.replace(steps=jnp.array([0, 1, 0], jnp.int32))
  action = jnp.tile(jnp.array([18_000.0, 2.0, -1.0]), (3, 1))
  step_keys = _keys([11, 12, 13])
  step = jax.jit(jax.vmap(env.step, in_axes=(0, 0, 0, None)))
  step_env = jax.jit(jax.vmap(env.step_env, in_axes=(0, 0, 0, None)))
  obs, new, _, terminated, truncated, info = step(step_keys, state, action,
                                                  pooled)
  assert not np.any(np.asarray(terminated | truncated))
  flown, flown_state, *_ = step_env(step_keys, state, action, pooled)
  np.testing.assert_array_equal(obs, flown)
  np.testing.assert_array_equal(info['final_observation'], flown)
  jax.tree.map(np.testing.assert_array_equal, new, flown_state)
  assert list(np.asarray(new.pending_world)) == [-1, -1, -1]
  # One pending world (2, balloon 1): only its row of the large leaves.
  install = jax.jit(jax.vmap(reset_pool.install_world, in_axes=(0, None)))
  pending = state.replace(pending_world=jnp.array([-1, 2, -1], jnp.int32))
  installed = install(pending, pooled)
  assert list(np.asarray(installed.pending_world)) == [-1, -1, -1]
  pool = pooled.reset_pool.state
  large = lambda s: (s.forecast.grid, s.noise_u.perm, s.noise_v.perm)
  for got, was, world in zip(large(installed), large(state), large(pool)):
    np.testing.assert_array_equal(got[0], was[0])
    np.testing.assert_array_equal(got[2], was[2])
    np.testing.assert_array_equal(got[1], world[2])
    assert not np.array_equal(was[1], world[2])
  def rest(s):  # The other leaves, unchanged.
    return s.replace(
        forecast=state.forecast,
        noise_u=s.noise_u.replace(perm=state.noise_u.perm),
        noise_v=s.noise_v.replace(perm=state.noise_v.perm),
        pending_world=state.pending_world)
  jax.tree.map(np.testing.assert_array_equal, rest(installed), rest(pending))


@pytest.mark.slow
def test_normalized_actions_are_the_one_to_box_mapping():
  """The default env flies to_box(a) of a in [-1, 1]^3, bit for bit."""
  from ble_latex.agents.sac import trainer as sac_trainer  # pylint: disable=g-import-not-at-top
  raw_env, params, batch_reset, batch_step = _setup()
  env = jax_env.LatexBalloonJaxEnv()
  assert sac_trainer.to_box is jax_env.to_box
  assert env.action_space(params) == gymnasium_box(-1.0, 1.0)
  assert raw_env.action_space(params).low[0] == 14_000.0
  unit = jnp.array([[-1.0, 1.0, 0.3], [0.25, -0.5, -1.0], [2.0, -3.0, 0.0]])
  np.testing.assert_allclose(jax_env.to_box(unit[0]), [14_000.0, 5.0, 0.3],
                             rtol=1e-6)  # float32
  keys = _keys([3, 4, 5])
  _, state = batch_reset(keys, params)
  norm_step = jax.jit(jax.vmap(env.step_env, in_axes=(0, 0, 0, None)))
  jax.tree.map(np.testing.assert_array_equal,
               norm_step(keys, state, unit, params),
               batch_step(keys, state, jax_env.to_box(unit), params))
  assert env.env_action(unit) is unit
  np.testing.assert_array_equal(raw_env.env_action(unit),
                                jax_env.to_box(unit))


def gymnasium_box(low, high):
  import gymnasium  # pylint: disable=g-import-not-at-top
  return gymnasium.spaces.Box(low, high, (3,), np.float32)


def test_equal_envs_share_one_compiled_function():
  """Envs are compared by value (wind, action convention), so a function
  jitted with the env static compiles once for equal envs (e.g. two
  training runs in one process)."""
  a, b = jax_env.LatexBalloonJaxEnv(), jax_env.LatexBalloonJaxEnv()
  raw = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  assert a == b and hash(a) == hash(b) and a != raw

  @functools.partial(jax.jit, static_argnums=0)
  def low(env, x):
    return x + env.action_low[0]

  for env in (a, b, raw):
    low(env, 1.0)
  assert low._cache_size() == 2  # pylint: disable=protected-access
