"""make_vec('ble_latex/LatexBalloon-v0'): N balloons in one batched core call."""

import datetime as dt
import subprocess
import sys

import gymnasium
from gymnasium.utils import seeding
from gymnasium.vector.vector_env import AutoresetMode
import jax
import numpy as np
import pytest

from ble_latex.envs import env_types
from ble_latex.envs import gymnasium_vector
from ble_latex.envs import jax_env
from ble_latex.flight import params as flight_params_lib
from ble_latex.flight import state as state_lib

from tests.envs import gymnasium_cases as cases

ID = 'ble_latex/LatexBalloon-v0'
N = 3
STEPS = 2  # Short episodes: the time limit ends them at the second step.
ACTIONS = np.array([[17000.0, 1.0, 1.0], [15000.0, 1.0, -1.0],
                    [20000.0, 3.0, -1.0]])
TOL = dict(rtol=1e-5, atol=1e-5)


@pytest.fixture(scope='module')
def single():
  """The single env (default params: shares the other tests' compilations)."""
  e = gymnasium.make(ID, normalize_actions=False)
  yield e
  e.close()


@pytest.fixture(scope='module')
def envs():
  e = gymnasium.make_vec(ID, num_envs=N, episode_steps=STEPS,
                         normalize_actions=False)
  yield e
  e.close()


def _flight(single, seed, steps):
  """obs/reward/info of the single env's flight of `seed` (per balloon)."""
  obs, info = single.reset(seed=int(seed))
  out = [(obs, None, info)]
  for action in ACTIONS[:steps]:
    obs, reward, _, _, info = single.step(action)
    out.append((obs, reward, info))
  return out


def _check_info(vector_info, i, info, mask_key=True):
  for key, value in info.items():
    assert vector_info[f'_{key}'][i] == mask_key, key
    got = vector_info[key][i]
    if isinstance(value, float):
      np.testing.assert_allclose(got, value, err_msg=key, **TOL)
    else:
      assert got == value, (key, got, value)


@pytest.mark.slow
@pytest.mark.ci
def test_equals_per_balloon_flights_and_autoresets(envs, single):
  """Balloon i flies seed s + i as the single env; time limit -> new flight."""
  assert isinstance(envs, gymnasium_vector.LatexBalloonVectorEnv)
  assert envs.metadata['autoreset_mode'] == AutoresetMode.SAME_STEP
  obs0, info0 = envs.reset(seed=7)
  assert obs0.shape == (N, 71) and obs0.dtype == np.float32
  assert envs.observation_space.contains(obs0)
  outs = []
  for _ in range(STEPS):
    outs.append(envs.step(ACTIONS))
  # Same action per balloon at both steps (row i of ACTIONS).
  for i in range(N):
    ref_obs, ref_info = single.reset(seed=7 + i)
    np.testing.assert_allclose(obs0[i], ref_obs, **TOL)
    _check_info(info0, i, ref_info)
    for step, (obs, reward, terminated, truncated, info) in enumerate(outs):
      ref_obs, ref_reward, ref_term, _, ref_info = single.step(ACTIONS[i])
      assert reward.dtype == np.float64 and reward.shape == (N,)
      np.testing.assert_allclose(reward[i], ref_reward, **TOL)
      assert not terminated[i] and not ref_term
      if step < STEPS - 1:
        np.testing.assert_allclose(obs[i], ref_obs, **TOL)
        _check_info(info, i, ref_info)
        assert not truncated[i] and 'final_obs' not in info
      else:  # Time limit: truncated, the new flight is in obs and info.
        assert truncated[i]
        assert info['_final_obs'][i] and info['_final_info'][i]
        np.testing.assert_allclose(info['final_obs'][i], ref_obs, **TOL)
        ref_info = dict(ref_info, time_limit=True)  # Core limit (2), not 216.
        _check_info(info['final_info'], i, ref_info)
  # The new flights' seeds come from np_random (seeded by reset(seed=7)) among
  # the training seeds, as the single env's unseeded resets.
  drawn = seeding.np_random(7)[0].integers(1_000_000, size=N)
  np.testing.assert_array_equal(envs.unwrapped.episode_seeds, drawn)
  obs, info = outs[-1][0], outs[-1][4]
  for i in range(N):
    ref_obs, ref_info = single.reset(seed=int(drawn[i]))
    np.testing.assert_allclose(obs[i], ref_obs, **TOL)
    _check_info(info, i, ref_info)
  # One compilation of the batched step (no retrace on the new state).
  assert envs.unwrapped._fns.step._cache_size() == 1  # pylint: disable=protected-access


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
def test_unseeded_resets_are_reproducible_training_seeds(envs):
  def starts():
    first, _ = envs.reset(seed=3)
    seeds = [envs.unwrapped.episode_seeds.copy()]
    envs.reset()
    seeds.append(envs.unwrapped.episode_seeds.copy())
    return first, seeds
  first, seeds1 = starts()
  again, seeds2 = starts()
  np.testing.assert_array_equal(first, again)
  np.testing.assert_array_equal(seeds1[0], [3, 4, 5])
  np.testing.assert_array_equal(seeds1[1], seeds2[1])
  assert np.all((seeds1[1] >= 0) & (seeds1[1] < 1_000_000))


@pytest.mark.parametrize('bad, match', [
    (np.zeros((N - 1, 3)), r'shape \(3, 3\)'),
    (np.zeros(3), r'shape \(3, 3\)'),
    (np.full((N, 3), 'a'), 'numbers'),
    (ACTIONS + [[0, 0, 0], [0, np.nan, 0], [0, 0, 0]],
     r'actions\[1\] a1 \(time factor\) must be finite'),
    (ACTIONS + [[0, 0, 0], [0, 0, 0], [2000, 0, 0]],
     r'actions\[2\] a0 \(desired altitude \[m\]\) must be in \[14000, 21000\]'),
])
def test_bad_actions_raise_and_change_nothing(envs, bad, match):
  envs.reset(seed=0)
  state = envs.unwrapped.state
  with pytest.raises(ValueError, match=match):
    envs.step(bad)
  assert envs.unwrapped.state is state  # The step count is the core's.


def test_normalize_actions_checks_the_unit_cube():
  norm = gymnasium_vector.LatexBalloonVectorEnv(N, normalize_actions=True)
  a = np.array([[0.5, -1.0, -0.2], [1.0, 1.0, 1.0], [-1.0, 0.0, 0.0]])
  np.testing.assert_array_equal(norm.check_action(a), a.astype(np.float32))
  with pytest.raises(ValueError, match=r'normalize_actions=True.*1\.5'):
    norm.check_action(a * 1.5)


@pytest.mark.slow
def test_normalize_actions_flies_like_the_single_env():
  """Both map [-1, 1]^3 with `jax_env.to_box` inside the compiled step."""
  norm = gymnasium_vector.LatexBalloonVectorEnv(N, normalize_actions=True)
  one = gymnasium.make(ID, normalize_actions=True)
  a = np.array([[0.5, -1.0, -0.2], [1.0, 1.0, 1.0], [-1.0, 0.0, 0.0]])
  norm.reset(seed=5)
  obs = norm.step(a)[0]
  for i in range(N):
    one.reset(seed=5 + i)
    np.testing.assert_allclose(obs[i], one.step(a[i])[0], **TOL)
  with pytest.raises(ValueError, match=r'normalize_actions=True.*1\.5'):
    norm.step(a * 1.5)
  norm.close()
  one.close()


def test_reset_refuses_bad_seeds_and_options(envs):
  for seed in (-1, 1.5, 'a', 2**32 - 2):  # 2**32 - 2 + i overflows for i = 2.
    with pytest.raises(ValueError, match='seed'):
      envs.reset(seed=seed)
  with pytest.raises(ValueError, match='options'):
    envs.reset(seed=0, options={'x': 1})
  with pytest.raises(ValueError, match='render'):
    gymnasium_vector.LatexBalloonVectorEnv(2, render_mode='rgb_array')


def test_reset_takes_one_seed_per_balloon(envs, single):
  """gymnasium's VectorEnv.reset takes a list (issue 48 item 23)."""
  seeds = [7, 2, 2**32 - 1]
  obs, _ = envs.reset(seed=seeds)
  np.testing.assert_array_equal(envs.unwrapped.episode_seeds, seeds)
  for i, seed in enumerate(seeds):
    np.testing.assert_allclose(obs[i], single.reset(seed=seed)[0], **TOL)
  # None: a training seed from np_random, which the given seeds seed.
  drawn = []
  for seed in ([None, 5, None], (None, 5, None), np.array([None, 5, None])):
    envs.reset(seed=seed)
    drawn.append(envs.unwrapped.episode_seeds.copy())
  np.testing.assert_array_equal(drawn[0], drawn[1])
  np.testing.assert_array_equal(drawn[0], drawn[2])
  assert drawn[0][1] == 5 and np.all(drawn[0] < 1_000_000)
  envs.reset(seed=np.array([1, 2, 3], np.uint32))
  np.testing.assert_array_equal(envs.unwrapped.episode_seeds, [1, 2, 3])


@pytest.mark.parametrize('seed, match', [
    ([1, 2], r'^seed must be None, an int or a list of one seed per balloon '
     r'\(3\)'),
    ([[1, 2, 3]], 'one seed per balloon'),
    ([1, -1, 2], r'^seed\[1\]: seed must be in \[0, 2\*\*32\)'),
    ([1, 2, 2**32], r'^seed\[2\]: seed must be in'),
    ([1, 1.5, 2], r'^seed\[1\]: seed must be None or an int'),
    ([True, 1, 2], r'^seed\[0\]: seed must be None or an int'),
    (['a', 1, 2], r'^seed\[0\]: '),
])
def test_reset_refuses_bad_seed_lists(envs, seed, match):
  envs.reset(seed=0)
  state = envs.unwrapped.state
  with pytest.raises(ValueError, match=match):
    envs.reset(seed=seed)
  assert envs.unwrapped.state is state


@pytest.mark.parametrize('options', [[1], 1, {'x': 1}])
def test_reset_refuses_options_in_one_line(envs, options):
  """Issue 48 item 20: options=[1] was an unrelated TypeError."""
  with pytest.raises(ValueError, match='^reset takes no options'):
    envs.reset(seed=0, options=options)


def test_keys_of_large_seeds_match_the_host_keys():
  """reset derives PRNGKey(seed) inside jit from uint32 seeds: same keys."""
  seeds = np.array([0, 7, 2**31 + 5, 2**32 - 1], np.uint32)
  traced = jax.jit(jax.vmap(jax.random.PRNGKey))(seeds)
  host = np.stack([np.asarray(jax.random.PRNGKey(int(s))) for s in seeds])
  np.testing.assert_array_equal(np.asarray(traced), host)


def _random_raw(rng, n):
  """Plausible step_info numbers of n balloons (every status and decision)."""
  statuses = [int(s) for s in state_lib.FlightStatus]
  decisions = [int(d) for d in state_lib.DecisionCode]
  status = rng.choice(statuses, n).astype(np.int32)
  time_limit = rng.random(n) < 0.3
  raw = {k: rng.random(n).astype(np.float32) * 100 for k in (
      'distance_km', 'altitude_m', 'ascent_rate_mps', 'helium_mols', 'sand_kg',
      'helium_vented_mols', 'sand_dropped_kg', 'volume_m3')}
  raw.update(status=status, decision=rng.choice(decisions, n).astype(np.int32),
             time_s=(rng.integers(0, 3, n) * 1200.0).astype(np.float32),
             steps=rng.integers(0, 3, n).astype(np.int32),
             time_limit=time_limit, truncated=time_limit & (status == 0))
  return raw


def test_info_arrays_are_info_dict_per_balloon():
  """The batched info is jax_env.info_dict of every balloon (one source)."""
  rng = np.random.default_rng(0)
  raw = _random_raw(rng, 64)
  mask = rng.random(64) < 0.5
  out = gymnasium_vector.info_arrays(raw, mask)
  for i in range(64):
    expected = jax_env.info_dict({k: v[i] for k, v in raw.items()})
    expected.pop('TimeLimit.truncated', None)
    assert {k for k in out if not k.startswith('_')} == set(expected)
    for key, value in expected.items():
      assert out[f'_{key}'][i] == mask[i]
      assert out[key][i] == value, (key, i)
      assert type(out[key][i]) in (type(value), np.float64, np.bool_)
  assert out['distance_km'].dtype == np.float64
  assert out['time_limit'].dtype == bool
  assert isinstance(out['time_elapsed'][0], dt.timedelta)


@pytest.mark.slow
def test_partial_resets_chunked_and_selected(monkeypatch, single):
  """Only the ended balloons get new flights (both reset paths)."""
  envs = gymnasium_vector.LatexBalloonVectorEnv(N, episode_steps=STEPS)
  for chunk in (N, 2):  # N: whole batch + select; 2: padded chunk + scatter.
    monkeypatch.setattr(gymnasium_vector, 'RESET_CHUNK', chunk)
    before, _ = envs.reset(seed=20)
    ended = np.array([False, True, False])
    # The step's host buffers, written in place where `ended`.
    _, obs, raw = envs._new_flights(np.array([7, 8, 9]))  # pylint: disable=protected-access
    obs, raw = np.array(obs), {k: np.array(v) for k, v in raw.items()}
    kept = obs[[0, 2]].copy()
    envs._reset_some(ended, np.array([42]), obs, raw)  # pylint: disable=protected-access
    np.testing.assert_allclose(obs[1], single.reset(seed=42)[0], **TOL)
    np.testing.assert_array_equal(obs[[0, 2]], kept)
    assert raw['steps'].shape == (N,) and raw['steps'][1] == 0
    state = jax.device_get(envs.state)
    start_x = np.asarray(state.flight.x_m)
    for i, seed in ((0, 20), (1, 42), (2, 22)):
      single.reset(seed=seed)
      np.testing.assert_allclose(
          start_x[i], float(single.unwrapped.state.flight.x_m),
          rtol=1e-6)
    del before


class _CountingEnv(gymnasium.Env):
  """A tiny env with the ble_latex envs' `check_action` (for atomicity)."""

  observation_space = gymnasium.spaces.Box(-1.0, 1.0, (1,), np.float32)
  action_space = gymnasium.spaces.Discrete(3)

  def __init__(self):
    self.steps = 0

  def check_action(self, action):
    if action not in (0, 1, 2):
      raise ValueError(f'action must be 0, 1 or 2, got {action!r}')

  def reset(self, *, seed=None, options=None):
    super().reset(seed=seed)
    return np.zeros(1, np.float32), {}

  def step(self, action):
    self.check_action(action)
    self.steps += 1
    return np.zeros(1, np.float32), 0.0, False, False, {}


@pytest.mark.parametrize('bad, match', [
    ([1, 5, 0], r'^actions\[1\]: action must be 0, 1 or 2, got .*5'),
    ([0, 1, -1], r'^actions\[2\]: '),
    ([0, 1], r'one action per balloon \(3\)'),
    (1, r'one action per balloon \(3\)'),
])
def test_checked_sync_vector_env_steps_no_balloon_on_a_bad_action(bad, match):
  """gymnasium's SyncVectorEnv would have stepped balloon 0 already."""
  envs = gymnasium_vector.CheckedSyncVectorEnv([_CountingEnv] * 3)
  envs.reset(seed=0)
  with pytest.raises(ValueError, match=match):
    envs.step(np.asarray(bad))
  assert [e.steps for e in envs.envs] == [0, 0, 0]
  envs.step(np.array([0, 1, 2]))
  assert [e.steps for e in envs.envs] == [1, 1, 1]


@pytest.mark.parametrize('change, binding', [
    (dict(radius_km=float('nan')),
     'latex_episode.station_keeping_radius_km'),
    (dict(radius_km=-1.0),
     'latex_episode.station_keeping_radius_km'),
    (dict(start_altitude_high_m=1e7),
     'latex_start.start_altitude_range_m'),
    (dict(episode_steps=0), 'latex_episode.episode_steps'),
])
def test_given_params_are_checked(change, binding):
  """params= is checked like gin's (`env_params.check_params`), before jit."""
  params = env_types.EnvParams(
      flight=flight_params_lib.FlightParams(), decoder=None)
  with pytest.raises(ValueError, match=f'^gin binding {binding} must be'):
    gymnasium_vector.LatexBalloonVectorEnv(2, params=params.replace(**change))


# -- Item 16: the Gymnasium vector env's num_envs is capped. ----------------
@pytest.mark.parametrize('kwargs', [{}, {'asynchronous': True}])
@pytest.mark.parametrize('num_envs', [10**9, 65_537])
def test_make_vec_caps_num_envs_before_allocating(kwargs, num_envs):
  import gymnasium  # pylint: disable=g-import-not-at-top
  import ble_latex  # pylint: disable=g-import-not-at-top,unused-import
  with pytest.raises(ValueError, match=r'num_envs must be an int in \[1, '
                     r'65536\]'):
    gymnasium.make_vec('ble_latex/LatexBalloon-v0', num_envs=num_envs,
                       **kwargs)


# -- Vector envs. -------------------------------------------------------------
def test_make_vec_is_the_batched_core_and_discrete_is_sync():
  """make_vec's default: one batched env (ID), SyncVectorEnv (DISCRETE_ID)."""
  envs = gymnasium.make_vec(cases.ID, num_envs=3, normalize_actions=True)
  assert isinstance(envs, gymnasium_vector.LatexBalloonVectorEnv)
  assert envs.num_envs == 3
  assert envs.single_action_space == gymnasium.spaces.Box(-1, 1, (3,),
                                                          np.float32)
  assert envs.action_space.shape == (3, 3)
  assert envs.observation_space.shape == (3, 71)
  envs.close()
  with pytest.raises(gymnasium.error.Error, match='vector_kwargs'):
    gymnasium.make_vec(cases.ID, num_envs=2, vector_kwargs={'copy': False})
  sync = gymnasium.make_vec(cases.ID, num_envs=2, vectorization_mode='sync')
  assert isinstance(sync, gymnasium.vector.SyncVectorEnv)
  sync.close()
  discrete = gymnasium.make_vec(cases.DISCRETE_ID, num_envs=1)
  assert isinstance(discrete, gymnasium.vector.SyncVectorEnv)
  discrete.close()


@pytest.mark.parametrize('env_id, kwargs', [
    (cases.DISCRETE_ID, {}), (cases.ID, {}),
    (cases.ID, {'asynchronous': True})])
@pytest.mark.parametrize('num_envs', [0, -2, 1.5, True])
def test_make_vec_refuses_bad_num_envs_in_one_line(env_id, kwargs, num_envs):
  """Issue 48 item 20: the discrete id's num_envs=0 was an IndexError."""
  with pytest.raises(ValueError,
                     match=r'^num_envs must be an int in \[1, 65536\], got '):
    gymnasium.make_vec(env_id, num_envs=num_envs, **kwargs)


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
  script.write_text(_ASYNC.format(id=cases.ID, how=how))
  result = subprocess.run([sys.executable, str(script)], cwd=cases.REPO,
                          capture_output=True, text=True, timeout=400)
  assert result.returncode == 0, result.stderr[-3000:]
  assert result.stdout.split() == ['AsyncVectorEnv', '(2,', '71)', '(2,)']
