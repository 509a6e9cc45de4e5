"""The SAC agent's checkpoints (`agents/sac/checkpoint.py`): round trips, atomic
files, and what a bad file is refused for."""

import os
import pickle

import jax
import numpy as np
import pytest

import ble_latex  # noqa: F401  pylint: disable=unused-import
from ble_latex import errors
from ble_latex import run_files
from ble_latex import safe_io
from ble_latex.agents.sac import agent as sac
from ble_latex.agents.sac import core as sac_core
from ble_latex.agents.sac import pretrained

from tests.agents.sac import agent_cases as cases
from tests.agents.sac.test_pretrained import _HIGH, _LOW, _sac  # pylint: disable=g-bad-import-order
from tests.agents.sac.test_pretrained import _crafted_pickle, _train_a_little  # pylint: disable=g-bad-import-order


def test_checkpoint_round_trip_resumes_identically(tmp_path):
  ckpt = str(tmp_path / 'checkpoints')
  env = cases.WalkEnv()
  probe = np.random.default_rng(0).uniform(-1, 1, (5, cases.OBS.size))
  original = cases.agent(seed=1)
  cases.run_episodes(original, env, 8)  # 32 transitions: updates have started.
  assert original.training_steps > original.min_replay_history
  original.save_checkpoint(ckpt, 0)
  original.set_mode('eval')
  eval_before = [original.begin_episode(o) for o in probe]
  original.set_mode('train')
  continued = cases.run_episodes(original, env, 3)

  restored = cases.agent(seed=99)  # Everything must come from the checkpoint.
  assert restored.reload_latest_checkpoint(ckpt) == 0
  assert restored.replay_size == 32
  assert restored.training_steps == 8 * 4
  restored.set_mode('eval')
  eval_after = [restored.begin_episode(o) for o in probe]
  restored.set_mode('train')
  np.testing.assert_array_equal(eval_before, eval_after)
  # Same replay, PRNG key, optimizer and temperature: identical training.
  np.testing.assert_array_equal(continued, cases.run_episodes(restored, env, 3))
  assert restored.training_steps == original.training_steps
  assert restored.temperature == original.temperature
  for x, y in zip(jax.tree.leaves(original.network_params),
                  jax.tree.leaves(restored.network_params)):
    np.testing.assert_array_equal(x, y)


def test_checkpoint_files_atomic_names_and_cleanup(tmp_path):
  ckpt = str(tmp_path)
  agent = cases.agent(seed=0, checkpoint_duration=1)
  assert agent.reload_latest_checkpoint(str(tmp_path / 'missing')) == -1
  assert agent.reload_latest_checkpoint(ckpt) == -1
  cases.run_episodes(agent, cases.WalkEnv(), 1)
  for iteration in range(4):
    agent.save_checkpoint(ckpt, iteration)
  # A write killed mid-way leaves only a temporary file, never a
  # checkpoint_*.msgpack; it is ignored on reload and removed on the next save.
  with open(os.path.join(ckpt, '.tmp-checkpoint_00009.msgpack-x'), 'wb') as f:
    f.write(b'partial')
  assert sorted(os.listdir(ckpt)) == [
      '.tmp-checkpoint_00009.msgpack-x', 'checkpoint_00002.msgpack',
      'checkpoint_00003.msgpack']
  assert cases.agent(seed=0).reload_latest_checkpoint(ckpt) == 3
  agent.save_checkpoint(ckpt, 4)
  assert sorted(os.listdir(ckpt)) == ['checkpoint_00003.msgpack',
                                      'checkpoint_00004.msgpack']
  with pytest.raises(FileNotFoundError):
    agent.load_checkpoint(ckpt, 7)
  with pytest.raises(ValueError, match='config'):
    cases.agent(seed=0, hidden_units=16).load_checkpoint(ckpt, 4)
  safe_io.write_tree(os.path.join(ckpt, 'checkpoint_00005.msgpack'),
                     {'not': 'sac'}, file_format='something else')
  with pytest.raises(ValueError, match='not a SAC checkpoint'):
    agent.load_checkpoint(ckpt, 5)


def _corrupted(tree, change):
  tree = dict(tree)
  change(tree)
  return tree


def _set_kernel_nan(tree):
  params = {k: dict(v) for k, v in tree['network_params']['params'].items()}
  kernel = np.array(params['_actor_final_layer']['kernel'])
  kernel.flat[:3] = np.nan
  params['_actor_final_layer']['kernel'] = kernel
  tree['network_params'] = {'params': params}


def _set_replay_reward_nan(tree):
  replay = dict(tree['replay'])
  reward = np.array(replay['$store$_reward'])
  reward[1] = np.nan
  replay['$store$_reward'] = reward
  tree['replay'] = replay


@pytest.mark.parametrize('change, message', [
    (_set_kernel_nan, 'network_params: leaf params/_actor_final_layer/kernel '
                      'has 3 non-finite values'),
    (_set_replay_reward_nan, r'replay \$store\$_reward has 1 non-finite value'),
    (lambda t: t.update(training_steps=-5),
     'training_steps must be >= 0, got -5'),
    (lambda t: t.update(log_alpha=np.array([0.5 + 1j], np.complex64)),
     'log_alpha has dtype complex64'),
    (lambda t: t.update(log_alpha=np.full(1000, np.nan, np.float32)),
     r'log_alpha has shape \(1000,\), expected \(1,\)'),
    (lambda t: t.update(config={**t['config'], 'hidden_units': 40000}),
     'config.hidden_units must be an integer >= 1 and <= 4096'),
])
def test_checkpoint_values_are_checked_on_load(tmp_path, change, message):
  """NaN weights or replay rewards, bad counters: refused, file and entry named.

  The agent keeps its state.
  """
  ckpt = str(tmp_path)
  agent = cases.agent(seed=0)
  cases.run_episodes(agent, cases.WalkEnv(), 2)
  agent.save_checkpoint(ckpt, 0)
  path = run_files.checkpoint_file(ckpt, 0)
  tree = safe_io.read_tree(path, file_format=sac_core.CHECKPOINT_FORMAT)
  safe_io.write_tree(path, _corrupted(tree, change),
                     file_format=sac_core.CHECKPOINT_FORMAT)
  fresh = cases.agent(seed=3)
  before = jax.tree.leaves(fresh.network_params)
  with pytest.raises(ValueError, match=message) as raised:
    fresh.reload_latest_checkpoint(ckpt)
  assert path in str(raised.value)
  assert fresh.training_steps == 0 and fresh.replay_size == 0
  for x, y in zip(before, jax.tree.leaves(fresh.network_params)):
    np.testing.assert_array_equal(x, y)


def test_diverged_agent_writes_no_checkpoint_or_policy(tmp_path):
  ckpt = str(tmp_path)
  agent = cases.agent(seed=0)
  agent.save_checkpoint(ckpt, 0)
  params = agent.network_params['params']
  params['_critic1']['Dense_0']['kernel'] = params['_critic1']['Dense_0'][
      'kernel'].at[0, 0].set(np.inf)
  with pytest.raises(sac_core.TrainingDiverged,
                     match=r'non-finite network_params \(1 values\)'):
    agent.save_checkpoint(ckpt, 1)
  with pytest.raises(sac_core.TrainingDiverged):
    agent.acting_bundle(1)
  assert run_files.iterations(ckpt) == [0]


def _eval_actions(agent, n=4):
  agent.set_mode('eval')
  obs = np.random.default_rng(3).uniform(-1, 1, (n, 71)).astype(np.float32)
  actions = [agent.begin_episode(o) for o in obs]
  agent.set_mode('train')
  return np.array(actions)


def test_checkpoint_iterations_ignore_unnumbered_names(tmp_path):
  for name in ('checkpoint_00003.msgpack', 'checkpoint_00010.msgpack',
               'checkpoint_backup.msgpack', 'checkpoint_00011 (copy).msgpack',
               'checkpoint_00012.pkl', '.tmp-checkpoint_00013.msgpack-1'):
    (tmp_path / name).write_bytes(b'')
  assert run_files.iterations(str(tmp_path)) == [3, 10]
  assert run_files.iterations(str(tmp_path),
                              run_files.LEGACY_CHECKPOINT_PATTERN) == [12]


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


def test_truncated_checkpoint_is_an_error_naming_it(tmp_path):
  agent = _sac()
  _train_a_little(agent)
  agent.save_checkpoint(str(tmp_path), 0)
  path = run_files.checkpoint_file(str(tmp_path), 0)
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
  safe_io.write_tree(run_files.checkpoint_file(str(tmp_path), 0), bundle,
                     file_format=sac_core.CHECKPOINT_FORMAT)
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
      format=sac_core.LEGACY_CHECKPOINT_FORMAT,
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
  with open(run_files.legacy_checkpoint_file(str(tmp_path), 3), 'wb') as f:
    pickle.dump(_legacy_bundle(agent), f)
  with pytest.raises(safe_io.UntrustedFileError):
    _sac(seed=4).reload_latest_checkpoint(str(tmp_path))
  restored = _sac(seed=4, trust_legacy_pickle=True)
  assert restored.reload_latest_checkpoint(str(tmp_path)) == 3
  assert restored.replay_size == agent.replay_size
  np.testing.assert_array_equal(_eval_actions(restored), _eval_actions(agent))
  # Converting the legacy checkpoint's policy gives a data-only file.
  out = tmp_path / 'policy.msgpack'
  pretrained.export_policy(run_files.legacy_checkpoint_file(str(tmp_path), 3),
                           str(out), trust_legacy_pickle=True)
  loaded = sac.SACPretrainedAgent(
      3, (71,), action_low=_LOW, action_high=_HIGH, hidden_units=16,
      policy_path=str(out))
  np.testing.assert_array_equal(_eval_actions(loaded), _eval_actions(agent))


@pytest.mark.parametrize('field, value, message', [
    ('add_count', np.array(999), r'add_count 999 in a buffer of capacity'),
    pytest.param('invalid_range', np.array([5, 6]),
                 r'replay invalid_range is \[5, 6\]', marks=pytest.mark.slow),
    pytest.param('episode_end_indices', np.array([500]),
                 r'replay episode_end_indices must be rows of the 21 filled',
                 marks=pytest.mark.slow),
])
def test_checkpoint_replay_counters_must_fit_its_arrays(tmp_path, field, value,
                                                        message):
  """add_count 999 over 21 stored rows was accepted (issue 48 item 5)."""
  agent = _sac()
  _train_a_little(agent)  # 21 transitions.
  agent.save_checkpoint(str(tmp_path), 0)
  tree = safe_io.read_tree(run_files.checkpoint_file(str(tmp_path), 0),
                           file_format=sac_core.CHECKPOINT_FORMAT)
  crafted_dir = tmp_path / 'crafted'
  path = run_files.checkpoint_file(str(crafted_dir), 0)
  os.makedirs(crafted_dir)
  safe_io.write_tree(path, {**tree, 'replay': {**tree['replay'], field: value}},
                     file_format=sac_core.CHECKPOINT_FORMAT)
  fresh = _sac()
  with pytest.raises(errors.BadFileError, match=message) as refused:
    fresh.load_checkpoint(str(crafted_dir), 0)
  assert path in str(refused.value) and '\n' not in str(refused.value)
  assert fresh.replay_size == 0  # Unchanged.
  fresh.load_checkpoint(str(tmp_path), 0)  # The file as written loads.
  assert fresh.replay_size == 21
