"""ble_latex/LatexBalloon-v0 and ble_latex/LatexBalloonDiscrete-v0: gymnasium API."""

import json
import logging
import os
import subprocess
import sys
import threading
import warnings

import gym
import gymnasium
from gymnasium.utils import env_checker as gymnasium_checker
import jax
import numpy as np
import pytest

from ble_latex import errors
from ble_latex import jax_cache
from ble_latex import quiet
from ble_latex.ble import gymnasium_discrete
from ble_latex.envs import env_params
from ble_latex.envs import env_types
from ble_latex.envs import gymnasium_compile
from ble_latex.envs import gymnasium_env
from ble_latex.envs import gymnasium_registration
from ble_latex.envs import gymnasium_render
from ble_latex.envs import gymnasium_vector
from ble_latex.envs import jax_env

from tests import helpers

ID = 'ble_latex/LatexBalloon-v0'
DISCRETE_ID = 'ble_latex/LatexBalloonDiscrete-v0'
REPO = str(helpers.ROOT)


def _python(code: str, timeout: float = 300, **env_changes):
  env = dict(os.environ)
  for key, value in env_changes.items():
    if value is None:
      env.pop(key, None)
    else:
      env[key] = value
  return subprocess.run([sys.executable, '-c', code], env=env, cwd=REPO,
                        capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope='module')
def env():
  e = gymnasium.make(ID, normalize_actions=False)
  yield e
  e.close()


@pytest.fixture(scope='module')
def discrete_env():
  e = gymnasium.make(DISCRETE_ID)
  yield e
  e.close()


# -- Registration. ------------------------------------------------------------
@pytest.mark.parametrize('order', ['ble_latex first', 'gymnasium first'])
def test_import_registers_ids_cheaply(order):
  imports = ('import ble_latex, sys\n'
             "assert 'gymnasium' not in sys.modules, 'imported gymnasium'\n"
             'import gymnasium\n' if order == 'ble_latex first' else
             'import gymnasium, ble_latex, sys\n')
  code = imports + (
      "print(sorted(k for k in gymnasium.registry if k.startswith('ble_latex/'"
      ')))\n'
      "heavy = [m for m in ('gym', 'jax', 'tensorflow', 'balloon_learning_"
      "environment') if m in sys.modules]\n"
      "assert not heavy, heavy\n"
      'gymnasium.register_envs(ble_latex)\n')
  result = _python(code, timeout=60)
  assert result.returncode == 0, result.stderr
  assert result.stdout.strip() == str(sorted(gymnasium_registration.ENV_IDS))


def test_make_gives_gymnasium_envs(env, discrete_env):
  assert isinstance(env.unwrapped, gymnasium_env.LatexBalloonGymnasiumEnv)
  assert isinstance(discrete_env.unwrapped,
                    gymnasium_discrete.LatexBalloonDiscreteGymnasiumEnv)
  # The continuous env flies the functional env's state; the discrete one
  # owns BLE's gym env.
  env.reset(seed=0)
  assert isinstance(env.unwrapped.state, env_types.EnvState)
  assert isinstance(discrete_env.unwrapped.gym_env, gym.Env)
  assert env.action_space == gymnasium.spaces.Box(
      np.array([14000, 1, -1], np.float32), np.array([21000, 5, 1], np.float32))
  assert env.observation_space == gymnasium.spaces.Box(-1, 1, (71,),
                                                       np.float32)
  assert discrete_env.action_space == gymnasium.spaces.Discrete(3)
  assert discrete_env.observation_space.shape == (1099,)


# -- reset / step. ------------------------------------------------------------
def test_reset_and_step_follow_gymnasium_api(env):
  obs, info = env.reset(seed=5)
  assert obs.shape == (71,) and obs.dtype == np.float32
  assert env.observation_space.contains(obs)
  assert {'distance_km', 'altitude_m', 'terminal_reason'} <= set(info)
  out = env.step(np.array([18000.0, 2.0, -1.0], np.float32))
  assert len(out) == 5
  obs, reward, terminated, truncated, info = out
  assert env.observation_space.contains(obs)
  assert isinstance(reward, float)
  assert terminated is False and truncated is False
  assert 'TimeLimit.truncated' not in info


def test_same_flight_as_the_gym_env(env):
  """Seed s flies the same balloon as gym's LatexBalloon-v0 (and eval) seed s."""
  gym_env = gym.make('LatexBalloon-v0').unwrapped
  actions = [np.array([15000.0, 1.0, -1.0]), np.array([20000.0, 3.0, -1.0]),
             np.array([17000.0, 1.0, 1.0])]
  obs, _ = env.reset(seed=11)
  np.testing.assert_array_equal(obs, gym_env.reset(seed=11))
  for action in actions:
    obs, reward, *_ = env.step(action)
    gym_obs, gym_reward, _, _ = gym_env.step(action)
    np.testing.assert_array_equal(obs, gym_obs)
    assert reward == gym_reward


def test_seeding_np_random_and_unseeded_resets(env):
  """reset(seed) seeds np_random; later unseeded resets are reproducible."""
  def episode_starts():
    first, _ = env.reset(seed=3)
    state = env.unwrapped.np_random.bit_generator.state
    return [first] + [env.reset()[0] for _ in range(2)], state

  starts1, rng1 = episode_starts()
  starts2, rng2 = episode_starts()
  assert rng1 == rng2
  for a, b in zip(starts1, starts2):
    np.testing.assert_array_equal(a, b)
  assert not np.array_equal(starts1[1], starts1[2])
  # The derived seeds are training seeds, never held-out eval seeds.
  env.unwrapped.np_random = np.random.default_rng(0)
  drawn = env.unwrapped.np_random.integers(1_000_000, size=1)
  env.unwrapped.np_random = np.random.default_rng(0)
  obs, _ = env.reset()
  np.testing.assert_array_equal(obs, env.reset(seed=int(drawn[0]))[0])


@pytest.mark.parametrize('seed', [-1, 2**32, 1.5, 'a'])
def test_bad_seed_is_refused(env, seed):
  with pytest.raises(ValueError, match='seed'):
    env.reset(seed=seed)


def test_reset_refuses_options(env):
  env.reset(seed=0, options={})  # Empty is fine (gymnasium's checker).
  with pytest.raises(ValueError, match='options'):
    env.reset(seed=0, options={'start_altitude': 1})


def test_time_limit_is_truncation():
  env = gymnasium.make(ID, episode_steps=2, normalize_actions=False)
  env.reset(seed=1)
  action = np.array([17000.0, 1.0, 1.0])
  assert env.step(action)[2:4] == (False, False)
  *_, terminated, truncated, info = env.step(action)
  assert (terminated, truncated) == (False, True)
  assert info['time_limit']
  # A shorter TimeLimit from make() works too.
  env = gymnasium.make(ID, max_episode_steps=1, normalize_actions=False)
  env.reset(seed=1)
  assert env.step(action)[2:4] == (False, True)


@pytest.mark.parametrize('done, info, expected', [
    (False, {}, (False, False)),
    (True, {'terminal_reason': 'out_of_sand'}, (True, False)),
    (True, {'time_limit': True, 'TimeLimit.truncated': True}, (False, True)),
    # Out of sand on the last step: a real end, not a truncation.
    (True, {'time_limit': True, 'terminal_reason': 'out_of_sand'},
     (True, False)),
])
def test_done_maps_to_terminated_or_truncated(done, info, expected):
  terminated, truncated, out_info = gymnasium_discrete.split_done(done, info)
  assert (terminated, truncated) == expected
  assert 'TimeLimit.truncated' not in out_info


def test_step_after_the_end_raises():
  env = gymnasium.make(ID, episode_steps=2, normalize_actions=False)
  env.reset(seed=1)
  action = np.array([17000.0, 1.0, 1.0])
  env.step(action)
  assert env.step(action)[3]
  with pytest.raises(RuntimeError, match='reset'):
    env.step(action)
  with pytest.raises(ValueError, match='a0'):  # Checked as the gym env does.
    env.step(np.array([30000.0, 1.0, 1.0]))


# -- normalize_actions. -------------------------------------------------------
def test_normalize_actions_maps_unit_cube_onto_the_box():
  """[-1, 1]^3 flies as the raw env flies `jax_env.to_box` of it."""
  env = gymnasium.make(ID, normalize_actions=True)
  raw = gymnasium.make(ID, normalize_actions=False)
  box = raw.action_space
  assert env.action_space == gymnasium.spaces.Box(-1, 1, (3,), np.float32)
  np.testing.assert_allclose(jax_env.to_box(-np.ones(3)), box.low)
  np.testing.assert_allclose(jax_env.to_box(np.ones(3)), box.high)
  np.testing.assert_allclose(jax_env.to_box(np.zeros(3)),
                             (box.low + box.high) / 2, rtol=1e-6)
  obs, _ = env.reset(seed=2)
  np.testing.assert_array_equal(obs, raw.reset(seed=2)[0])
  for a in (np.array([0.5, -1.0, -0.2]), np.array([1.0, 1.0, 1.0])):
    mapped = np.asarray(jax_env.to_box(a.astype(np.float32)))
    np.testing.assert_allclose(env.step(a)[0], raw.step(mapped)[0],
                               atol=1e-6, rtol=0)
    np.testing.assert_allclose(env.unwrapped.flight['altitude_m'],
                               raw.unwrapped.flight['altitude_m'],
                               atol=1e-3, rtol=0)
  for bad in (np.array([1.01, 0.0, 0.0]), np.array([np.nan, 0, 0]),
              np.zeros(2)):
    with pytest.raises(ValueError, match='normalize_actions'):
      env.step(bad)
  with pytest.raises(ValueError, match='Discrete'):
    gymnasium.make(DISCRETE_ID, normalize_actions=True)


# -- Conventional defaults of the ids (issue 31). ---------------------------
def test_ids_default_to_normalized_actions_and_a_216_step_spec():
  env = gymnasium.make(ID)
  assert env.action_space == gymnasium.spaces.Box(-1, 1, (3,), np.float32)
  assert env.unwrapped.normalize_actions
  assert env.spec.max_episode_steps == 216
  assert env.spec.kwargs == {'normalize_actions': True}
  assert gymnasium.spec(DISCRETE_ID).max_episode_steps == 216
  raw = gymnasium.make(ID, normalize_actions=False)
  assert raw.action_space.low[0] == 14000.0
  # CleanRL's form: the module is imported by gymnasium itself.
  assert gymnasium.make(f'ble_latex:{ID}').spec.id == ID


@pytest.mark.slow
@pytest.mark.ci
def test_spec_time_limit_ends_with_the_core_not_twice():
  """make()'s TimeLimit(216) and the core's 216 strides end one episode."""
  env = gymnasium.make(ID, episode_steps=3)  # The core's own limit.
  assert env.spec.max_episode_steps == 216
  env.reset(seed=1)
  ends = [env.step(np.zeros(3, np.float32))[2:4] for _ in range(3)]
  assert ends == [(False, False), (False, False), (False, True)]
  env.reset(seed=1)  # The wrapper's count restarts with the core's.
  assert env.step(np.zeros(3, np.float32))[2:4] == (False, False)
  # make_vec hands the spec's limit to the batched core (no wrapper).
  envs = gymnasium.make_vec(ID, num_envs=2, max_episode_steps=2)
  assert envs.unwrapped.params.episode_steps == 2
  envs.reset(seed=0)
  envs.step(np.zeros((2, 3), np.float32))
  assert np.all(envs.step(np.zeros((2, 3), np.float32))[3])
  envs.close()


def test_render_keeps_the_station_visible_far_away():
  """A path 3 000 km wide: the 50 km circle gets a zoomed inset."""
  from matplotlib import patches  # pylint: disable=g-import-not-at-top
  near = [(0.0, 10.0, 0.0, 15.0), (1.0, 20.0, 5.0, 15.0)]
  far = near + [(2.0, 1500.0, -900.0, 16.0)]
  fig = gymnasium_render.draw_flight(None, near, 50.0)
  assert len(fig.axes) == 2  # No inset needed.
  fig = gymnasium_render.draw_flight(fig, far, 50.0)
  inset = [a for a in fig.axes[0].child_axes]
  assert len(inset) == 1
  assert inset[0].get_xlim() == (-150.0, 150.0)
  assert any(isinstance(p, patches.Circle) and p.get_radius() == 50.0
             for p in inset[0].patches)
  assert gymnasium_render.figure_rgb(fig).shape == (320, 640, 3)


# -- Rendering. ---------------------------------------------------------------
def test_render_rgb_array_draws_the_flight():
  env = gymnasium.make(ID, render_mode='rgb_array', normalize_actions=False)
  env.reset(seed=4)
  first = env.render()
  assert first.dtype == np.uint8 and first.shape == (320, 640, 3)
  for _ in range(3):
    env.step(np.array([20000.0, 1.0, -1.0]))
  later = env.render()
  assert later.shape == first.shape
  assert np.any(later != first)  # The path and altitude curve grew.
  assert len(env.unwrapped._path) == 4  # pylint: disable=protected-access
  env.close()


def test_render_modes(env):
  assert env.render() is None  # No render_mode.
  with pytest.raises(ValueError, match='render_mode'):
    gymnasium_env.LatexBalloonGymnasiumEnv(render_mode='human')


# -- Checkers. ----------------------------------------------------------------
# The only warnings allowed: the raw Box is not [-1, 1] (that is what
# normalize_actions is for), and BLE's Perciatelli features declare some
# unbounded (inf) observations.
_EXPECTED = {
    (ID, False): ('symmetric and normalized',),
    (ID, True): (),
    (DISCRETE_ID, False): ('maximum value is infinity',),
}


@pytest.mark.parametrize('env_id, normalize', list(_EXPECTED))
def test_gymnasium_and_sb3_env_checkers(env_id, normalize):
  from stable_baselines3.common import env_checker as sb3_checker  # pylint: disable=g-import-not-at-top
  kwargs = {} if env_id == DISCRETE_ID else {'normalize_actions': normalize}
  env = gymnasium.make(env_id, **kwargs)
  with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter('always')
    gymnasium_checker.check_env(env.unwrapped, skip_render_check=False)
    sb3_checker.check_env(env, warn=True)
  messages = [str(w.message) for w in caught]
  unexpected = [m for m in messages
                if not any(e in m for e in _EXPECTED[(env_id, normalize)])]
  assert not unexpected


# -- Vector envs. -------------------------------------------------------------
def test_make_vec_is_the_batched_core_and_discrete_is_sync():
  """make_vec's default: one batched env (ID), SyncVectorEnv (DISCRETE_ID)."""
  envs = gymnasium.make_vec(ID, num_envs=3, normalize_actions=True)
  assert isinstance(envs, gymnasium_vector.LatexBalloonVectorEnv)
  assert envs.num_envs == 3
  assert envs.single_action_space == gymnasium.spaces.Box(-1, 1, (3,),
                                                          np.float32)
  assert envs.action_space.shape == (3, 3)
  assert envs.observation_space.shape == (3, 71)
  envs.close()
  with pytest.raises(gymnasium.error.Error, match='vector_kwargs'):
    gymnasium.make_vec(ID, num_envs=2, vector_kwargs={'copy': False})
  sync = gymnasium.make_vec(ID, num_envs=2, vectorization_mode='sync')
  assert isinstance(sync, gymnasium.vector.SyncVectorEnv)
  sync.close()
  discrete = gymnasium.make_vec(DISCRETE_ID, num_envs=1)
  assert isinstance(discrete, gymnasium.vector.SyncVectorEnv)
  discrete.close()


def test_discrete_make_vec_checks_every_action_before_stepping_any():
  """A bad action for balloon 1 leaves balloon 0 unstepped (was stepped)."""
  envs = gymnasium.make_vec(DISCRETE_ID, num_envs=2)
  try:
    envs.reset(seed=0)
    inner = [e.unwrapped.gym_env for e in envs.envs]
    states = [e.arena.driver.state for e in inner]
    for bad in ([1, 5], [1, 1.5], [None, 1]):
      with pytest.raises(ValueError, match=r'^actions\[\d\]: action must be 0'):
        envs.step(np.array(bad, dtype=object) if None in bad else
                  np.array(bad))
      assert [int(e.arena.driver.state.steps) for e in inner] == [0, 0]
      assert all(e.arena.driver.state is s for e, s in zip(inner, states))
    envs.step(np.array([1, 2]))
    assert [int(e.arena.driver.state.steps) for e in inner] == [1, 1]
  finally:
    envs.close()


@pytest.mark.parametrize('radius', [-1.0, float('nan'), 0.0, 'abc', True])
def test_station_radius_must_be_a_positive_number(radius):
  """Refused before the env is built, naming the keyword."""
  with pytest.raises(ValueError, match='^station_keeping_radius_km must be'):
    gymnasium.make(ID, station_keeping_radius_km=radius)


def test_gin_bound_station_radius_is_checked():
  import gin  # pylint: disable=g-import-not-at-top
  from ble_latex.ble import gym_env  # pylint: disable=g-import-not-at-top,unused-import
  gin.clear_config()
  try:
    gin.parse_config('latex_episode.station_keeping_radius_km = -5.0')
    with pytest.raises(ValueError, match='^gin binding latex_episode.'
                       'station_keeping_radius_km must be a finite number > 0'):
      gymnasium.make(ID, normalize_actions=False)
  finally:
    gin.clear_config()


class _HostField:
  """A wind field the core cannot fly in JAX (never built here)."""


def test_gin_bound_host_wind_field_is_refused_not_ignored():
  """The Gymnasium envs never import ble/: a BLE field bound in gin is a
  one-line error (it was flown through ble.wind's callbacks), not dropped."""
  import gin  # pylint: disable=g-import-not-at-top
  gin.clear_config()
  try:
    gin.bind_parameter('latex_episode.wind_field_factory', _HostField)
    for make in (lambda: gymnasium.make(ID),
                 lambda: gymnasium.make_vec(ID, num_envs=2)):
      with pytest.raises(errors.ConfigError,
                         match='^gin binding latex_episode.wind_field_'
                         'factory = .*_HostField.*host_wind='):
        make()
  finally:
    gin.clear_config()
  with pytest.raises(ValueError, match='^host_wind must be None or a '
                     'gymnasium_env.HostWind'):
    gymnasium.make(ID, host_wind=_HostField)


@pytest.mark.parametrize('options', [[1], 1, 'x', {'x': 1}])
def test_reset_refuses_options_in_one_line(env, discrete_env, options):
  """Issue 48 item 20: options=[1] was an unrelated TypeError."""
  for e in (env, discrete_env):  # Unwrapped: gymnasium's checker wrapper
    # breaks later steps when the first reset through it raises.
    with pytest.raises(ValueError, match='^reset takes no options'):
      e.unwrapped.reset(seed=0, options=options)
  envs = gymnasium.make_vec(DISCRETE_ID, num_envs=1)
  try:
    with pytest.raises(ValueError, match='^reset takes no options'):
      envs.reset(seed=0, options=options)
  finally:
    envs.close()


@pytest.mark.parametrize('env_id, kwargs', [
    (DISCRETE_ID, {}), (ID, {}), (ID, {'asynchronous': True})])
@pytest.mark.parametrize('num_envs', [0, -2, 1.5, True])
def test_make_vec_refuses_bad_num_envs_in_one_line(env_id, kwargs, num_envs):
  """Issue 48 item 20: the discrete id's num_envs=0 was an IndexError."""
  with pytest.raises(ValueError,
                     match=r'^num_envs must be an int in \[1, 65536\], got '):
    gymnasium.make_vec(env_id, num_envs=num_envs, **kwargs)


def test_discrete_make_vec_takes_gymnasiums_seeds():
  """An int (NumPy's too) or one seed or None per balloon (issue 48 item 23);
  each checked by the single env's seed rule."""
  envs = gymnasium.make_vec(DISCRETE_ID, num_envs=2)
  try:
    by_list, _ = envs.reset(seed=[8, 3])
    by_int, _ = envs.reset(seed=np.int64(3))
    np.testing.assert_array_equal(by_list[1], by_int[0])
    envs.reset(seed=[None, 4])
    for bad, match in (([1], 'one seed per balloon'),
                       ([1, 2, 3], 'one seed per balloon'),
                       ([1, -1], r'seed must be in \[0, 2\*\*32\)'),
                       ([1, 1.5], 'seed must be None or an int'),
                       (True, 'seed must be None or an int')):
      with pytest.raises(ValueError, match=match):
        envs.reset(seed=bad)
  finally:
    envs.close()


@pytest.mark.parametrize('change, binding', [
    (dict(radius_km=float('nan')),
     'latex_episode.station_keeping_radius_km'),
    (dict(start_altitude_low_m=-10.0),
     'latex_start.start_altitude_range_m'),
    (dict(start_altitude_high_m=95_000.0),
     'latex_start.start_altitude_range_m'),
])
def test_given_params_are_checked(env, change, binding):
  """params= goes through the one check (`env_params.check_params`)."""
  bad = env.unwrapped.params.replace(**change)
  with pytest.raises(ValueError, match=f'^gin binding {binding} must be'):
    gymnasium.make(ID, params=bad)


def test_forked_worker_fails_loudly_instead_of_hanging(monkeypatch):
  jax = pytest.importorskip('jax')
  jax.numpy.zeros(1).block_until_ready()  # JAX has started here.
  monkeypatch.setattr(gymnasium_compile, '_forked_after_jax', False)
  gymnasium_compile._note_fork_in_child()  # pylint: disable=protected-access
  assert gymnasium_compile._forked_after_jax  # pylint: disable=protected-access
  with pytest.raises(RuntimeError, match="spawn"):
    gymnasium.make(ID, normalize_actions=False)


_ASYNC = '''
import numpy as np
import ble_latex, gymnasium

if __name__ == '__main__':
  envs = gymnasium.make_vec('{id}', num_envs=2, {how})
  obs, _ = envs.reset(seed=3)
  obs, reward, *_ = envs.step(np.zeros((2, 3), np.float32))
  print(type(envs).__name__, obs.shape, reward.shape)
  envs.close()
'''


@pytest.mark.slow
@pytest.mark.parametrize('how', [
    'normalize_actions=True, asynchronous=True',
    "normalize_actions=True, vectorization_mode='async', "
    "vector_kwargs={'context': 'spawn'}",
])
def test_async_vector_env_with_spawn(tmp_path, how):
  script = tmp_path / 'run_async.py'  # spawn re-imports __main__: a file.
  script.write_text(_ASYNC.format(id=ID, how=how))
  result = subprocess.run([sys.executable, str(script)], cwd=REPO,
                          capture_output=True, text=True, timeout=400)
  assert result.returncode == 0, result.stderr[-3000:]
  assert result.stdout.split() == ['AsyncVectorEnv', '(2,', '71)', '(2,)']


# -- BLE's order, quiet start, feature warning. -------------------------------
_BLE_ORDER = '''
import gym
from balloon_learning_environment.utils import run_helpers
run_helpers.bind_gin_variables({agent!r})
import gin
assert gin.config_is_locked()
for name in ('LatexBalloonDiscrete-v0', 'LatexBalloon-v0'):
  gym.make(name).reset(seed=0)
import ble_latex, gymnasium
for name in ('ble_latex/LatexBalloonDiscrete-v0', 'ble_latex/LatexBalloon-v0'):
  gymnasium.make(name).reset(seed=0)
print('ok')
'''


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
@pytest.mark.parametrize('agent', [
    'perciatelli44', pytest.param('dqn', marks=pytest.mark.slow),
    pytest.param('quantile', marks=pytest.mark.slow)])
def test_ble_gin_order_then_make(agent):
  """BLE binds the agent's gin (locking the config) before making the env."""
  result = _python(_BLE_ORDER.format(agent=agent))
  assert result.returncode == 0, result.stderr[-3000:]
  assert result.stdout.strip().endswith('ok')


_GIN_FILES_THEN_MAKE = '''
import gin, gym
import ble_latex
from ble_latex import configs
from ble_latex import errors
gin.parse_config_files_and_bindings(configs.env_gin_files(), [])
assert gin.config_is_locked()
# gym.make imports the gym env's module (declaring its configurables), then
# the env refuses episode_steps=0 before it draws or compiles a flight.
for name in ('LatexBalloon-v0', 'LatexBalloonDiscrete-v0'):
  try:
    gym.make(name, episode_steps=0)
  except errors.ConfigError as e:
    print(name, str(e).split()[0])
print('ok')
'''


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
def test_env_gin_files_then_gym_make_in_a_fresh_process():
  """A script parses the env gin files (gin locks) then makes the gym envs.

  The gin files name only the core's settings, so the gym env's
  configurables are declared after the lock (`gym_registration._gym_env`);
  without that, gym.make raised gin's 'Attempted to add a new configurable
  after the config was locked'. Each make gets as far as the env's first
  check of its arguments (episode_steps=0, refused): past the import, not
  drawing or compiling a flight (half of this process's ~20 s).
  """
  result = _python(_GIN_FILES_THEN_MAKE)
  assert result.returncode == 0, result.stderr[-3000:]
  assert result.stdout.strip().splitlines()[-3:] == [
      'LatexBalloon-v0 latex_episode.episode_steps',
      'LatexBalloonDiscrete-v0 latex_episode.episode_steps', 'ok']


def test_first_make_is_quiet():
  """A normal run prints nothing to stderr: no gym/BLE/TF start-up noise."""
  code = ('import time; t = time.perf_counter()\n'
          'import ble_latex, gymnasium\n'
          "env = gymnasium.make('ble_latex/LatexBalloon-v0')\n"
          "print(f'{time.perf_counter() - t:.1f}')\n"
          'env.reset(seed=0)\n'
          'env.step(env.action_space.sample())\n'
          "import sys; print('tensorflow' in sys.modules)\n")
  result = _python(code, TF_CPP_MIN_LOG_LEVEL=None, JAX_PLATFORMS=None)
  assert result.returncode == 0, result.stderr
  assert result.stderr == ''
  made_s, tensorflow = result.stdout.split()
  assert tensorflow == 'False'  # Not needed by the continuous env.
  print('time to first gymnasium.make [s]:', made_s)


def test_core_imports_no_tensorflow_dopamine_or_ble_agents():
  """No TF, Dopamine, BLE agents/balloon/features in the env and trainer.

  Importing the functional env, the Gymnasium envs and the jitted trainer,
  and making the continuous env and its vector env.
  """
  code = ('import sys, ble_latex, gymnasium\n'
          'import ble_latex.envs.jax_env, ble_latex.envs.gymnasium_env\n'
          'import ble_latex.envs.gymnasium_vector\n'
          'import ble_latex.agents.sac.trainer, ble_latex.run.jax_train\n'
          f'gymnasium.make({ID!r}, normalize_actions=True)\n'
          f'gymnasium.make_vec({ID!r}, num_envs=2)\n'
          "ble = 'balloon_learning_environment.'\n"
          "banned = ('tensorflow', 'dopamine', ble + 'agents', "
          "ble + 'env.features')\n"
          "heavy = [m for m in sys.modules if m.startswith(ble + 'env.balloon')"
          " or m in banned or m.startswith(tuple(b + '.' for b in banned))]\n"
          # BLE's package imports gym, whose entry point is the light
          # ble_latex.ble.gym_registration; nothing else of ble_latex.ble.
          "heavy += [m for m in sys.modules if m.startswith('ble_latex.ble.') "
          "and m != 'ble_latex.ble.gym_registration']\n"
          'assert not heavy, heavy\n')
  result = _python(code, timeout=120)
  assert result.returncode == 0, result.stderr[-3000:]


def test_quiet_passes_other_output_through(capfd):
  with quiet.third_party_noise():
    warnings.warn('ours', UserWarning)
    warnings.warn('Please import `interp1d` from the `scipy.interpolate` '
                  'namespace', DeprecationWarning)
    sys.stderr.write('an error of ours\n')
    os.write(2, b'I0000 00:00:1795331363.160793   18478 cudart_stub.cc:31] '
             b'Could not find cuda drivers on your machine, GPU will not be '
             b'used.\nE0000 native error\n')
  err = capfd.readouterr().err
  assert 'ours' in err and 'an error of ours' in err
  assert 'E0000 native error' in err
  assert 'interp1d' not in err and 'cuda drivers' not in err


def test_feature_range_message_dropped(discrete_env, caplog):
  """BLE logs at every step above its 5000 Pa top; the latex env, never.

  The reason (BLE's features saturate there, its winds are clipped there):
  `discrete_features.LatexPerciatelliFeatureConstructor.get_features`.
  """
  base = discrete_env.unwrapped
  outside_steps = []
  with caplog.at_level(logging.WARNING, logger='absl'):
    for episode in range(2):
      caplog.clear()
      discrete_env.reset(seed=3)
      outside = 0
      for i in range(30):
        discrete_env.step(i % 3)
        constructor = base.arena.feature_constructor
        pressure = base.arena.get_balloon_state().pressure
        outside += not (constructor.min_pressure <= pressure <=
                        constructor.max_pressure)
      outside_steps.append(outside)
      warned = [r for r in caplog.records
                if 'not fully represented' in r.getMessage()]
      assert not warned, (episode, outside, len(warned))
  assert min(outside_steps) >= 2  # BLE alone would have warned more often.


# -- SB3 SAC (examples/sb3_sac.py). ------------------------------------------
def test_sb3_sac_trains_and_evaluates_with_eval_json(tmp_path, capsys):
  """SB3 SAC, a few hundred steps on ble_latex/LatexBalloon-v0, then eval."""
  import importlib.util  # pylint: disable=g-import-not-at-top
  from ble_latex.run import records as records_lib  # pylint: disable=g-import-not-at-top
  spec = importlib.util.spec_from_file_location(
      'sb3_sac', os.path.join(REPO, 'examples', 'sb3_sac.py'))
  example = importlib.util.module_from_spec(spec)
  spec.loader.exec_module(example)
  threads = example.torch.get_num_threads()
  try:
    code = example.main([
        '--total_timesteps=300', '--learning_starts=100', '--batch_size=64',
        '--max_episode_length=20', '--num_eval_seeds=2', '--suite=latex_tiny',
        f'--output_dir={tmp_path}', f'--model_out={tmp_path / "sac.zip"}'])
  finally:
    example.torch.set_num_threads(threads)  # The example sets 1.
  assert code == 0
  path = tmp_path / 'latex_tiny' / 'sb3_sac.json'
  summary = json.loads(capsys.readouterr().out.splitlines()[-1])
  assert summary['output'] == str(path) and summary['episodes'] == 2
  records = records_lib.load_eval(str(path))  # ble-latex-eval's schema, checked.
  assert [r['seed'] for r in records] == [1_000_000, 1_000_001]
  assert all(r['steps'] == 20 and len(r['flight_path']) == 21
             for r in records)
  assert (tmp_path / 'sac.zip').is_file()
  with pytest.raises(SystemExit) as exit_info:
    example.main(['--suite=nope'])
  assert exit_info.value.code == 2
  assert 'latex_tiny' in capsys.readouterr().err


_PARAMS_FROM_GIN = '''
import sys
import ble_latex, gin, jax, numpy as np
from ble_latex.envs import env_params

def same(a, b):
  leaves = jax.tree.map(lambda x, y: bool(np.array_equal(x, y)), a, b)
  return (jax.tree.structure(a) == jax.tree.structure(b) and
          all(jax.tree.leaves(leaves)))

light = env_params.params_from_gin()
# Every gin name of the env is the core's own: bound without BLE or gym.
gin.parse_config(['latex_controller.min_vent_mols = 0.3',
                  'latex_launch.sand_kg = 1.5', 'latex_episode.episode_steps = 9',
                  'latex_start.max_start_distance_km = 150.0',
                  'latex_reward.helium_penalty_per_mol = 0.1',
                  'latex_flight.guard_within_stride = False'])
p = env_params.params_from_gin()
assert float(p.flight.min_vent_mols) == np.float32(0.3)
assert (p.flight.initial_sand_kg, p.episode_steps, p.max_start_distance_km,
        p.helium_penalty_per_mol, p.flight.guard_within_stride) == (
            1.5, 9, 150.0, 0.1, False)
heavy = [m for m in ('tensorflow', 'ble_latex.ble.gym_env',
                     'ble_latex.ble.balloon', 'balloon_learning_environment.env.balloon_env')
         if m in sys.modules]
assert not heavy, heavy
gin.clear_config()
import ble_latex.ble.gym_env  # The gin-file import (BLE, TF) changes nothing.
assert same(light, env_params.params_from_gin()), 'defaults differ'
gin.parse_config([
    'latex_episode.episode_steps = 7',
    'latex_start.start_altitude_range_m = (16000.0, 17000.0)',
    'latex_start.max_start_distance_km = 100.0',
    'latex_launch.payload_kg = 2.5',
    'latex_reward.sand_penalty_per_kg = 0.5',
    'latex_reward.reward_dropoff = 0.3',
    'balloon_env.perciatelli_reward_function.reward_dropoff = 0.3',  # Repeats.
])
p = env_params.params_from_gin()
print(p.episode_steps, p.start_altitude_low_m, p.start_altitude_high_m,
      p.max_start_distance_km, float(p.flight.payload_kg),
      p.sand_penalty_per_kg, p.reward_dropoff)
gin.parse_config('latex_reward.sand_penalty_per_kg = -1.0')
try:
  env_params.params_from_gin()
except ValueError as e:
  print('refused:', 'latex_reward.sand_penalty_per_kg' in str(e))
'''


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
def test_params_from_gin_without_the_gym_modules():
  """Unimported configurables read as defaults; imported ones as bound."""
  result = _python(_PARAMS_FROM_GIN, timeout=300)
  assert result.returncode == 0, result.stderr[-3000:]
  lines = result.stdout.strip().splitlines()
  assert lines[-2].split() == ['7', '16000.0', '17000.0', '100.0', '2.5',
                               '0.5', '0.3']
  assert lines[-1] == 'refused: True'


# -- Compilation (issue 26). --------------------------------------------------
def _fresh_env():
  """A single env whose programs are new to jit (compiled by this test)."""
  env = gymnasium_env.LatexBalloonGymnasiumEnv()
  env._fns = gymnasium_compile.Compiled(  # pylint: disable=protected-access
      jax_env.LatexBalloonJaxEnv(normalize_actions=False), batched=False)
  return env


@pytest.mark.skipif(jax.default_backend() != 'cpu', reason='CPU options')
def test_programs_compile_with_the_fast_cpu_options(monkeypatch):
  monkeypatch.setattr(jax_cache, 'CPU_FAST_COMPILE',
                      {'ble_latex_no_such_option': True})
  env = _fresh_env()
  key = jax_env.arena_key(jax.random.PRNGKey(0))
  with pytest.raises(Exception, match='ble_latex_no_such_option'):
    env._fns.draw.lower(key, env.params).compile()  # pylint: disable=protected-access


def test_first_reset_compiles_start_and_step_ahead_once():
  compiles = []

  def listen(event, seconds, **kwargs):
    del seconds
    if event == '/jax/core/compile/backend_compile_duration':
      compiles.append((str(kwargs.get('fun_name')),
                       threading.current_thread().name))

  env = _fresh_env()
  # Normalized actions (gymnasium.make's default) on the same programs.
  unit = gymnasium_env.LatexBalloonGymnasiumEnv(normalize_actions=True)
  unit._fns = env._fns  # pylint: disable=protected-access
  unit.compile_step_ahead = False
  jax.monitoring.register_event_duration_secs_listener(listen)
  try:
    env.reset(seed=0)
    env._fns.wait('step')  # pylint: disable=protected-access
    before_step = list(compiles)
    env.step(np.array([16_000.0, 1.0, 0.0], np.float32))
    after_step = list(compiles)
    unit.reset(seed=0)
    unit.step(np.array([0.5, 0.0, -1.0], np.float32))
  finally:
    jax.monitoring.unregister_event_duration_listener(listen)
  # `normalized` is an argument of the one step program, not a constant.
  assert compiles == after_step, 'normalized actions compiled another step'
  del compiles[len(after_step):]
  programs = {name: [t for f, t in compiles if f == f'jit({name})']
              for name in ('draw', 'start', 'step')}
  assert programs['draw'] == ['MainThread'], compiles
  assert len(programs['start']) == 1, compiles
  assert len(programs['step']) == 1, compiles
  assert programs['step'][0].startswith('ble_latex-compile'), compiles
  assert compiles == before_step, 'the first step compiled again'
