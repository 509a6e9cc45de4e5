"""Issue 10: resume safety, data files that cannot run code, env contract."""

import json
import os
import pickle
import subprocess
import sys

import ble_latex  # noqa: F401
from ble_latex.agents import pretrained
from ble_latex.agents import sac
from ble_latex.ble import gym_env as env_lib
from ble_latex.run import episode_log
from ble_latex.run import train_lib
from ble_latex import safe_io
import gin
import gym
import jax
import numpy as np
import pytest
from test_pretrained import _train_a_little  # pylint: disable=g-bad-import-order

_LOW = np.array([14000.0, 1.0, -1.0], dtype=np.float32)
_HIGH = np.array([21000.0, 5.0, 1.0], dtype=np.float32)
_ENV = dict(os.environ, TF_CPP_MIN_LOG_LEVEL='3', JAX_PLATFORMS='cpu')
_TINY = ['--gin_bindings=ble_latex.agents.sac.SACAgent.min_replay_history=30',
         '--gin_bindings=ble_latex.agents.sac.SACAgent.batch_size=16',
         '--gin_bindings=ble_latex.agents.sac.SACAgent.hidden_units=16',
         '--max_episode_length=6', '--collectors=episodes']


def _train(base_dir, iterations, per_iteration=2):
  return subprocess.run(
      [sys.executable, '-m', 'ble_latex.cli.train', f'--base_dir={base_dir}',
       f'--num_iterations={iterations}',
       f'--episodes_per_iteration={per_iteration}', *_TINY],
      env=_ENV, capture_output=True, text=True, timeout=600)


def _sac(seed=0, **kwargs):
  kwargs = {'hidden_units': 16, 'min_replay_history': 8, 'batch_size': 4,
            **kwargs}
  return sac.SACAgent(3, (71,), action_low=_LOW, action_high=_HIGH, seed=seed,
                      **kwargs)


def _eval_actions(agent, n=4):
  agent.set_mode('eval')
  obs = np.random.default_rng(3).uniform(-1, 1, (n, 71)).astype(np.float32)
  actions = [agent.begin_episode(o) for o in obs]
  agent.set_mode('train')
  return np.array(actions)


class _Payload:
  """Pickles to a call that creates a marker file: proof that code ran."""

  def __init__(self, marker):
    self.marker = marker

  def __reduce__(self):
    return (open, (self.marker, 'w'))


def _crafted_pickle(path, marker):
  with open(path, 'wb') as f:
    pickle.dump({'format': sac.LEGACY_CHECKPOINT_FORMAT,
                 'payload': _Payload(str(marker))}, f)


# --- 1. Resume never loses the log -------------------------------------------


def test_resume_finds_numbered_checkpoints_among_stray_files(tmp_path):
  run = tmp_path / 'run'
  first = _train(run, 2)
  assert first.returncode == 0, first.stderr[-2000:]
  log_path = run / episode_log.EPISODE_LOG
  before = episode_log.read(str(log_path))
  assert len(before) == 4
  for stray in ('checkpoint_backup.pkl', 'checkpoint_00002 (copy).pkl',
                'checkpoint_00009 (copy).msgpack', 'checkpoint_.msgpack'):
    (run / 'checkpoints' / stray).write_bytes(b'junk')
  second = _train(run, 3)
  assert second.returncode == 0, second.stderr[-2000:]
  after = episode_log.read(str(log_path))
  assert [r['episode'] for r in after] == list(range(6))
  assert after[:4] == before  # Resumed after checkpoint 1, kept the log.

  # Another --episodes_per_iteration is refused, naming both values, and the
  # run directory is left exactly as it was.
  snapshot = log_path.read_bytes()
  third = _train(run, 4, per_iteration=3)
  assert third.returncode != 0
  assert 'episodes_per_iteration=2' in third.stderr
  assert 'episodes_per_iteration=3' in third.stderr
  assert log_path.read_bytes() == snapshot


def _write_log(path, n):
  with open(path, 'w') as f:
    for i in range(n):
      f.write(json.dumps({'episode': i}) + '\n')


@pytest.mark.parametrize('logged,start_iteration,ok', [
    (0, 0, True), (1, 0, True), (2, 0, True),  # Killed in iteration 0.
    (4, 2, True), (5, 2, True), (6, 2, True),  # Up to one iteration past it.
    (7, 2, False),  # Checkpoints missing: would drop 3 logged episodes.
    (9, 0, False),  # No checkpoint at all but several iterations logged.
    (2, 2, False),  # Log shorter than the checkpoint: a gap.
])
def test_check_resume_protects_the_episode_log(tmp_path, logged,
                                               start_iteration, ok):
  log_path = tmp_path / episode_log.EPISODE_LOG
  _write_log(log_path, logged)
  snapshot = log_path.read_bytes()
  info = {'agent': 'sac', 'episodes_per_iteration': 2}
  if ok:
    train_lib._check_resume(str(tmp_path), info, start_iteration, True)
  else:
    with pytest.raises(train_lib.ResumeError, match='Nothing was changed'):
      train_lib._check_resume(str(tmp_path), info, start_iteration, True)
  assert log_path.read_bytes() == snapshot


def test_check_resume_refuses_other_settings(tmp_path):
  (tmp_path / train_lib.RUN_INFO).write_text(
      json.dumps({'agent': 'sac', 'episodes_per_iteration': 10}))
  with pytest.raises(train_lib.ResumeError,
                     match='episodes_per_iteration=10.*episodes_per_iteration=5'):
    train_lib._check_resume(str(tmp_path), {'agent': 'sac',
                                            'episodes_per_iteration': 5}, 0,
                            False)
  (tmp_path / train_lib.RUN_INFO).write_text('{torn')
  with pytest.raises(train_lib.ResumeError, match='unreadable'):
    train_lib._check_resume(str(tmp_path), {'agent': 'sac'}, 0, False)


def test_checkpoint_iterations_ignore_unnumbered_names(tmp_path):
  for name in ('checkpoint_00003.msgpack', 'checkpoint_00010.msgpack',
               'checkpoint_backup.msgpack', 'checkpoint_00011 (copy).msgpack',
               'checkpoint_00012.pkl', '.tmp-checkpoint_00013.msgpack-1'):
    (tmp_path / name).write_bytes(b'')
  assert sac.checkpoint_iterations(str(tmp_path)) == [3, 10]
  assert sac.checkpoint_iterations(str(tmp_path),
                                   sac.LEGACY_CHECKPOINT_PATTERN) == [12]


# --- 3. No code runs from a data file ----------------------------------------


def test_crafted_pickle_checkpoint_runs_no_code(tmp_path):
  marker = tmp_path / 'pwned'
  ckpt = tmp_path / 'checkpoints'
  ckpt.mkdir()
  _crafted_pickle(ckpt / 'checkpoint_00000.pkl', marker)
  with pytest.raises(safe_io.UntrustedFileError, match='trust_legacy_pickle'):
    _sac().reload_latest_checkpoint(str(ckpt))
  with pytest.raises(safe_io.UntrustedFileError):
    _sac().load_checkpoint(str(ckpt), 0)
  # Even with the opt-in, only data classes are resolved.
  with pytest.raises(ValueError, match='refusing to load'):
    _sac(trust_legacy_pickle=True).load_checkpoint(str(ckpt), 0)
  # A pickle under a msgpack name is recognised and refused.
  os.rename(ckpt / 'checkpoint_00000.pkl', ckpt / 'checkpoint_00000.msgpack')
  with pytest.raises(safe_io.UntrustedFileError, match='pickle'):
    _sac().load_checkpoint(str(ckpt), 0)
  assert not marker.exists()


def test_crafted_pickle_policy_runs_no_code(tmp_path):
  marker = tmp_path / 'pwned'
  policy = tmp_path / 'policy.pkl'
  _crafted_pickle(policy, marker)
  with pytest.raises(safe_io.UntrustedFileError):
    pretrained.SACPretrainedAgent(3, (71,), action_low=_LOW, action_high=_HIGH,
                                  policy_path=str(policy))
  with pytest.raises(ValueError, match='refusing to load'):
    pretrained.load_policy(str(policy), trust_legacy_pickle=True)
  assert not marker.exists()


@pytest.mark.parametrize('content,message', [
    (b'', 'truncated or corrupt'),
    (b'\x00\x01garbage', 'truncated or corrupt'),
    ('cut', 'truncated or corrupt'),
    ('no_config', "misses \\['config'"),
])
def test_corrupt_policy_files_name_the_path(tmp_path, content, message):
  path = tmp_path / 'policy.msgpack'
  if content == 'cut':
    safe_io.write_tree(str(path), {'x': np.zeros(1000)}, file_format='f')
    path.write_bytes(path.read_bytes()[:500])
  elif content == 'no_config':
    safe_io.write_tree(str(path), {'source': '', 'note': ''},
                       file_format=pretrained.POLICY_FORMAT)
  else:
    path.write_bytes(content)
  with pytest.raises(ValueError, match=message) as e:
    pretrained.load_policy(str(path))
  assert str(path) in str(e.value)
  with pytest.raises(ValueError, match='is a directory'):
    pretrained.load_policy(str(tmp_path))


def test_truncated_checkpoint_is_an_error_naming_it(tmp_path):
  agent = _sac()
  _train_a_little(agent)
  agent.save_checkpoint(str(tmp_path), 0)
  path = sac.checkpoint_path(str(tmp_path), 0)
  data = open(path, 'rb').read()
  with open(path, 'wb') as f:
    f.write(data[:len(data) // 2])
  fresh = _sac(seed=5)
  before = _eval_actions(fresh)
  with pytest.raises(ValueError, match='truncated') as e:
    fresh.reload_latest_checkpoint(str(tmp_path))
  assert path in str(e.value)
  np.testing.assert_array_equal(_eval_actions(fresh), before)  # Unchanged.


def test_checkpoint_with_wrong_shapes_leaves_agent_unchanged(tmp_path):
  agent = _sac()
  _train_a_little(agent)
  bundle = agent.bundle_and_checkpoint(str(tmp_path), 0)
  bundle['optimizer_state'] = bundle['optimizer_state'][:-1]
  safe_io.write_tree(sac.checkpoint_path(str(tmp_path), 0), bundle,
                     file_format=sac.CHECKPOINT_FORMAT)
  fresh = _sac(seed=5)
  before = _eval_actions(fresh)
  with pytest.raises(ValueError, match='optimizer_state'):
    fresh.load_checkpoint(str(tmp_path), 0)
  np.testing.assert_array_equal(_eval_actions(fresh), before)


def _legacy_bundle(agent):
  """What ble_latex 0.1 pickled: optax named tuples, tuples, a set."""
  bundle = agent.bundle_and_checkpoint('', 0)
  to_numpy = lambda t: jax.tree.map(np.asarray, jax.device_get(t))
  bundle.update(
      format=sac.LEGACY_CHECKPOINT_FORMAT,
      optimizer_state=to_numpy(agent.optimizer_state),
      alpha_optimizer_state=to_numpy(agent.alpha_optimizer_state))
  bundle['config']['observation_shape'] = tuple(
      bundle['config']['observation_shape'])
  bundle['replay']['episode_end_indices'] = set(
      int(i) for i in bundle['replay']['episode_end_indices'])
  return bundle


def test_legacy_pickles_load_only_with_the_opt_in(tmp_path):
  agent = _sac()
  _train_a_little(agent)
  with open(sac.legacy_checkpoint_path(str(tmp_path), 3), 'wb') as f:
    pickle.dump(_legacy_bundle(agent), f)
  with pytest.raises(safe_io.UntrustedFileError):
    _sac(seed=4).reload_latest_checkpoint(str(tmp_path))
  restored = _sac(seed=4, trust_legacy_pickle=True)
  assert restored.reload_latest_checkpoint(str(tmp_path)) == 3
  assert restored.replay_size == agent.replay_size
  np.testing.assert_array_equal(_eval_actions(restored), _eval_actions(agent))
  # Converting the legacy checkpoint's policy gives a data-only file.
  out = tmp_path / 'policy.msgpack'
  pretrained.export_policy(sac.legacy_checkpoint_path(str(tmp_path), 3),
                           str(out), trust_legacy_pickle=True)
  loaded = pretrained.SACPretrainedAgent(
      3, (71,), action_low=_LOW, action_high=_HIGH, hidden_units=16,
      policy_path=str(out))
  np.testing.assert_array_equal(_eval_actions(loaded), _eval_actions(agent))


def test_shipped_policy_is_a_data_file():
  with open(pretrained.DEFAULT_POLICY, 'rb') as f:
    head = f.read(2)
  assert head[:1] != b'\x80' or head[1:2] not in (b'\x02', b'\x03', b'\x04',
                                                  b'\x05')
  policy = pretrained.load_policy(pretrained.DEFAULT_POLICY)
  assert policy['format'] == pretrained.POLICY_FORMAT


# --- 4. A failed reset changes nothing ---------------------------------------


@pytest.fixture(scope='module')
def latex_env():
  return gym.make('LatexBalloon-v0').unwrapped


@pytest.mark.parametrize('seed', [2**64, 2**32, -1, 1.5, True, '3'])
def test_bad_seed_is_refused_before_anything_changes(latex_env, seed):
  action = [17000.0, 2.0, -1.0]
  latex_env.reset(seed=3)
  latex_env.step(action)
  before = repr(latex_env.arena.get_balloon_state())
  steps = int(latex_env.arena.driver.state.steps)
  with pytest.raises(ValueError, match='seed'):
    latex_env.reset(seed=seed)
  assert int(latex_env.arena.driver.state.steps) == steps
  assert repr(latex_env.arena.get_balloon_state()) == before


def test_largest_seed_is_accepted(latex_env):
  assert latex_env.reset(seed=2**32 - 1).shape == (71,)
  assert latex_env.reset(seed=np.uint32(7)).shape == (71,)


# --- 5. Only shape (3,) is an action; discrete errors are ValueError ---------


@pytest.mark.parametrize('bad', [
    np.array([[18000.0, 1.0, 0.0]]), np.array([[18000.0], [1.0], [0.0]]),
    [[18000.0, 1.0, 0.0]], np.array(['18000', '1', '0']), [18000.0, None, 0.0],
    None])
def test_wrong_shape_or_type_actions_are_refused(latex_env, bad):
  latex_env.reset(seed=5)
  before = repr(latex_env.arena.get_balloon_state())
  with pytest.raises(ValueError, match='action'):
    latex_env.step(bad)
  assert repr(latex_env.arena.get_balloon_state()) == before


@pytest.fixture(scope='module')
def discrete_env():
  return gym.make('LatexBalloonDiscrete-v0').unwrapped


@pytest.mark.parametrize('bad', [None, [1], 1e30, float('nan'), float('inf'),
                                 1.5, 3, -1, True, '1', np.array([2])])
def test_bad_discrete_actions_are_value_errors(discrete_env, bad):
  discrete_env.reset(seed=0)
  before = repr(discrete_env.arena.get_balloon_state())
  with pytest.raises(ValueError, match='0 \\(DOWN\\), 1 \\(STAY\\) or 2'):
    discrete_env.step(bad)
  assert repr(discrete_env.arena.get_balloon_state()) == before


def test_good_discrete_actions(discrete_env):
  discrete_env.reset(seed=0)
  for action in (0, 1, 2, np.int64(1), 2.0, np.array(1)):
    discrete_env.step(action)


# --- 7. Gin values that break the contract -----------------------------------


@pytest.mark.parametrize('binding,value', [
    ('latex_reward.helium_penalty_per_mol', -1.0),
    ('latex_reward.sand_penalty_per_kg', float('nan')),
    ('latex_reward.sand_penalty_per_kg', float('inf')),
    ('perciatelli_reward_function.reward_halflife', 0.0),
    ('perciatelli_reward_function.reward_dropoff', 1.5),
    ('perciatelli_reward_function.station_keeping_radius_km', -5.0),
])
def test_bad_reward_bindings_are_refused_at_construction(binding, value):
  try:
    gin.bind_parameter(binding, value)  # Gin has no NaN literal.
    with pytest.raises(ValueError, match=binding.replace('.', '\\.')):
      env_lib.LatexBalloonEnv()
  finally:
    gin.clear_config()


def test_bad_reward_binding_from_gin_text():
  try:
    gin.parse_config('latex_reward.helium_penalty_per_mol = -0.5')
    with pytest.raises(ValueError, match='helium_penalty_per_mol'):
      gym.make('LatexBalloon-v0')
  finally:
    gin.clear_config()


@pytest.mark.parametrize('name,value', [
    ('gamma', -5.0), ('gamma', 1.5), ('gamma', float('nan')),
    ('actor_learning_rate', 0.0), ('critic_learning_rate', -1e-3),
    ('alpha_learning_rate', float('inf')), ('batch_size', 0),
    ('target_smoothing_coefficient', 0.0), ('reward_scale_factor', -1.0),
    ('update_period', 0), ('hidden_units', 2.5), ('target_entropy', float('nan')),
])
def test_bad_sac_hyperparameters_name_the_binding(name, value):
  with pytest.raises(ValueError, match=f'SACAgent.{name} must be'):
    _sac(**{name: value})
