"""ble_latex/LatexBalloon-v0 and ble_latex/LatexBalloonDiscrete-v0: gymnasium API."""

import logging
import warnings

import gym
import gymnasium
from gymnasium.utils import env_checker as gymnasium_checker
import numpy as np
import pytest

from ble_latex import errors
from ble_latex.ble import gymnasium_discrete
from ble_latex.envs import env_types
from ble_latex.envs import gymnasium_env
from ble_latex.envs import jax_env

from tests.envs import gymnasium_cases as cases


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
  env = gymnasium.make(cases.ID, episode_steps=2, normalize_actions=False)
  env.reset(seed=1)
  action = np.array([17000.0, 1.0, 1.0])
  assert env.step(action)[2:4] == (False, False)
  *_, terminated, truncated, info = env.step(action)
  assert (terminated, truncated) == (False, True)
  assert info['time_limit']
  # A shorter TimeLimit from make() works too.
  env = gymnasium.make(cases.ID, max_episode_steps=1, normalize_actions=False)
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
  env = gymnasium.make(cases.ID, episode_steps=2, normalize_actions=False)
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
  env = gymnasium.make(cases.ID, normalize_actions=True)
  raw = gymnasium.make(cases.ID, normalize_actions=False)
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
    gymnasium.make(cases.DISCRETE_ID, normalize_actions=True)


# -- Rendering (the rest: test_gymnasium_render.py); needs the env reset above.
def test_render_modes(env):
  assert env.render() is None  # No render_mode.
  with pytest.raises(ValueError, match='render_mode'):
    gymnasium_env.LatexBalloonGymnasiumEnv(render_mode='human')



# -- Checkers. ----------------------------------------------------------------
# The only warnings allowed: the raw Box is not [-1, 1] (that is what
# normalize_actions is for), and BLE's Perciatelli features declare some
# unbounded (inf) observations.
_EXPECTED = {
    (cases.ID, False): ('symmetric and normalized',),
    (cases.ID, True): (),
    (cases.DISCRETE_ID, False): ('maximum value is infinity',),
}


@pytest.mark.parametrize('env_id, normalize', list(_EXPECTED))
def test_gymnasium_and_sb3_env_checkers(env_id, normalize):
  from stable_baselines3.common import env_checker as sb3_checker  # pylint: disable=g-import-not-at-top
  kwargs = ({} if env_id == cases.DISCRETE_ID else
            {'normalize_actions': normalize})
  env = gymnasium.make(env_id, **kwargs)
  with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter('always')
    gymnasium_checker.check_env(env.unwrapped, skip_render_check=False)
    sb3_checker.check_env(env, warn=True)
  messages = [str(w.message) for w in caught]
  unexpected = [m for m in messages
                if not any(e in m for e in _EXPECTED[(env_id, normalize)])]
  assert not unexpected


@pytest.mark.parametrize('radius', [-1.0, float('nan'), 0.0, 'abc', True])
def test_station_radius_must_be_a_positive_number(radius):
  """Refused before the env is built, naming the keyword."""
  with pytest.raises(ValueError, match='^station_keeping_radius_km must be'):
    gymnasium.make(cases.ID, station_keeping_radius_km=radius)


def test_gin_bound_station_radius_is_checked():
  import gin  # pylint: disable=g-import-not-at-top
  from ble_latex.ble import gym_env  # pylint: disable=g-import-not-at-top,unused-import
  gin.clear_config()
  try:
    gin.parse_config('latex_episode.station_keeping_radius_km = -5.0')
    with pytest.raises(ValueError, match='^gin binding latex_episode.'
                       'station_keeping_radius_km must be a finite number > 0'):
      gymnasium.make(cases.ID, normalize_actions=False)
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
    for make in (lambda: gymnasium.make(cases.ID),
                 lambda: gymnasium.make_vec(cases.ID, num_envs=2)):
      with pytest.raises(errors.ConfigError,
                         match='^gin binding latex_episode.wind_field_'
                         'factory = .*_HostField.*host_wind='):
        make()
  finally:
    gin.clear_config()
  with pytest.raises(ValueError, match='^host_wind must be None or a '
                     'gymnasium_env.HostWind'):
    gymnasium.make(cases.ID, host_wind=_HostField)


@pytest.mark.parametrize('options', [[1], 1, 'x', {'x': 1}])
def test_reset_refuses_options_in_one_line(env, discrete_env, options):
  """Issue 48 item 20: options=[1] was an unrelated TypeError."""
  for e in (env, discrete_env):  # Unwrapped: gymnasium's checker wrapper
    # breaks later steps when the first reset through it raises.
    with pytest.raises(ValueError, match='^reset takes no options'):
      e.unwrapped.reset(seed=0, options=options)
  envs = gymnasium.make_vec(cases.DISCRETE_ID, num_envs=1)
  try:
    with pytest.raises(ValueError, match='^reset takes no options'):
      envs.reset(seed=0, options=options)
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
    gymnasium.make(cases.ID, params=bad)


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
  result = cases.python(_BLE_ORDER.format(agent=agent))
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
  result = cases.python(_GIN_FILES_THEN_MAKE)
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
  result = cases.python(code, TF_CPP_MIN_LOG_LEVEL=None, JAX_PLATFORMS=None)
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
          f'gymnasium.make({cases.ID!r}, normalize_actions=True)\n'
          f'gymnasium.make_vec({cases.ID!r}, num_envs=2)\n'
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
  result = cases.python(code, timeout=120)
  assert result.returncode == 0, result.stderr[-3000:]


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
