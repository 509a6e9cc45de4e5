"""sac_pretrained: exporting a checkpoint's policy and flying it."""

import os
import pickle

import ble_latex  # noqa: F401
from hypothesis import given
from hypothesis import settings
from hypothesis import strategies as st
from ble_latex import errors
from ble_latex import run_files
from ble_latex import safe_io
from ble_latex.agents.sac import agent as sac
from ble_latex.agents.sac import core as sac_core
from ble_latex.agents.sac import pretrained
from ble_latex.run import episode_log
import numpy as np
import pytest

from tests import helpers

_LOW = np.array([14000.0, 1.0, -1.0], dtype=np.float32)
_HIGH = np.array([21000.0, 5.0, 1.0], dtype=np.float32)


def _sac(hidden=16, seed=0, **kwargs):
  kwargs = {'hidden_units': hidden, 'min_replay_history': 8, 'batch_size': 4,
            **kwargs}
  return sac.SACAgent(3, (71,), action_low=_LOW, action_high=_HIGH,
                      seed=seed, **kwargs)


def _train_a_little(agent):
  rng = np.random.default_rng(0)
  agent.begin_episode(rng.uniform(-1, 1, 71).astype(np.float32))
  for _ in range(20):
    agent.step(float(rng.uniform()), rng.uniform(-1, 1, 71).astype(np.float32))
  agent.end_episode(0.5, False)


class _Payload:
  """Pickles to a call that creates a marker file: proof that code ran."""

  def __init__(self, marker):
    self.marker = marker

  def __reduce__(self):
    return (open, (self.marker, 'w'))


def _crafted_pickle(path, marker):
  with open(path, 'wb') as f:
    pickle.dump({'format': sac_core.LEGACY_CHECKPOINT_FORMAT,
                 'payload': _Payload(str(marker))}, f)


@pytest.mark.slow
@pytest.mark.ci
def test_exported_policy_acts_like_the_checkpoint(tmp_path):
  agent = _sac()
  _train_a_little(agent)
  agent.save_checkpoint(str(tmp_path), 0)
  policy_file = str(tmp_path / 'policy.msgpack')
  pretrained.export_policy(run_files.checkpoint_file(str(tmp_path), 0),
                           policy_file, note='test')
  loaded = sac.SACPretrainedAgent(
      3, (71,), action_low=_LOW, action_high=_HIGH, seed=7, hidden_units=16,
      policy_path=policy_file)
  assert loaded.policy_info['note'] == 'test'
  agent.set_mode('eval')
  loaded.set_mode('eval')
  for obs in np.random.default_rng(1).uniform(-1, 1, (5, 71)):
    obs = obs.astype(np.float32)
    np.testing.assert_array_equal(agent.begin_episode(obs),
                                  loaded.begin_episode(obs))
  stored = safe_io.read_tree(policy_file, file_format=pretrained.POLICY_FORMAT)
  assert 'replay' not in stored  # Small: no replay buffer.


def test_bad_policy_files(tmp_path):
  with pytest.raises(FileNotFoundError):
    pretrained.load_policy(str(tmp_path / 'missing.msgpack'))
  bad = tmp_path / 'bad.msgpack'
  safe_io.write_tree(str(bad), {}, file_format='something else')
  with pytest.raises(ValueError, match='not a SAC policy'):
    pretrained.load_policy(str(bad))
  with pytest.raises(ValueError, match='not a SAC checkpoint'):
    pretrained.export_policy(str(bad), str(tmp_path / 'out.msgpack'))


def test_policy_for_other_shapes_is_rejected(tmp_path):
  agent = _sac(hidden=16)
  agent.save_checkpoint(str(tmp_path), 0)
  policy_file = str(tmp_path / 'policy.msgpack')
  pretrained.export_policy(run_files.checkpoint_file(str(tmp_path), 0),
                           policy_file)
  with pytest.raises(ValueError, match='observation_shape'):
    sac.SACPretrainedAgent(3, (70,), action_low=_LOW,
                                  action_high=_HIGH, policy_path=policy_file)


def test_shipped_policy_flies_the_latex_env():
  import gym
  from ble_latex.run import runner
  env = gym.make('LatexBalloon-v0').unwrapped
  agent = runner.create_agent('sac_pretrained', env)
  # The jitted trainer's run it came from (README "Results").
  # `source` is the training run's path as the policy file recorded it (before
  # the records moved to benchmarks/records/).
  assert agent.policy_info['source'].startswith('benchmarks/sac_jax/n32/seed_')
  agent.set_mode('eval')
  obs = env.reset(seed=1_000_000)
  first = agent.begin_episode(obs)
  assert env.action_space.contains(first.astype(np.float32))
  for _ in range(5):
    obs, reward, done, _ = env.step(first)
    action = agent.step(reward, obs)
    assert env.action_space.contains(action.astype(np.float32))
  # Deterministic in eval mode: the same observation, the same action.
  np.testing.assert_array_equal(agent.begin_episode(obs),
                                agent.begin_episode(obs))


@pytest.mark.parametrize('gin_files, source', [
    ((), 'benchmarks/sac_jax/n32/seed_'),
    (('latex_realistic.gin',), 'benchmarks/sac_jax/realistic_calibrated/seed_')])
def test_sac_pretrained_loads_the_policy_of_the_bound_physics(gin_files,
                                                              source):
  """The paper's policy by default; the realistic one under its gin file."""
  import gin  # pylint: disable=g-import-not-at-top
  from ble_latex import configs  # pylint: disable=g-import-not-at-top
  from ble_latex.run import gin_binding  # pylint: disable=g-import-not-at-top
  gin.clear_config()
  try:
    gin_binding.bind_gin('sac_pretrained', None,
                         [configs.gin_file(f) for f in gin_files], [])
    agent = sac.SACPretrainedAgent(3, (71,), action_low=_LOW,
                                   action_high=_HIGH)
  finally:
    gin.clear_config()
  assert agent.policy_info['source'].startswith(source)
  expected = pretrained.shipped_policy(bool(gin_files))
  assert os.path.basename(expected) == (
      'sac_latex_realistic.msgpack' if gin_files else 'sac_latex.msgpack')


# How far the shipped policy's row may move between machines: XLA's CPU float
# paths differ (e.g. 61.25 % recorded on the machine of 2026-11-24, 61.16 %
# on that of 2026-11-25, the same file), and 3-day flights are chaotic.
ROW_TOLERANCE = {'tw50_window': 0.015, 'tw50': 0.015, 'reward_rel': 0.03,
                 'out_of_resources_pct': 3.0}


@pytest.mark.slow
def test_shipped_policy_reproduces_its_results_row():
  """README's sac_pretrained row (benchmarks/records/results_table.json), all 100 seeds.

  Equal within `ROW_TOLERANCE` (the row is re-made on the machine that
  ships a policy), and the issue's targets hold here too: TW50 over the
  window >= 60 % with <= 5 % of the flights out of resources.
  """
  import json
  import gym
  from ble_latex.run import eval_lib
  from ble_latex.run import metrics
  from ble_latex.run import runner
  from ble_latex.run import suites
  rows = json.loads(
      (episode_log.RECORDS_DIR / 'results_table.json').read_text())
  (row,) = [r for r in rows if r['agent'] == 'sac_pretrained']
  env = gym.make('LatexBalloon-v0').unwrapped
  agent = runner.create_agent('sac_pretrained', env)
  suite = suites.get_eval_suite('latex_small')
  s = metrics.summarize(eval_lib.evaluate(agent, env, suite.seeds,
                                          suite.max_episode_length))
  assert s['episodes'] == row['episodes'] == 100
  assert s['tw50_window_mean'] == pytest.approx(
      row['tw50_window'][0], abs=ROW_TOLERANCE['tw50_window'])
  assert s['tw50_mean'] == pytest.approx(row['tw50'][0],
                                         abs=ROW_TOLERANCE['tw50'])
  assert s['reward_mean'] == pytest.approx(row['reward'][0],
                                           rel=ROW_TOLERANCE['reward_rel'])
  assert s['out_of_resources_pct'] == pytest.approx(
      row['out_of_resources_pct'], abs=ROW_TOLERANCE['out_of_resources_pct'])
  assert s['tw50_window_mean'] >= 0.60 and s['out_of_resources_pct'] <= 5.0


# -- Crafted policy files: refused before anything is built from them. --------
@pytest.fixture(scope='module')
def small_policy(tmp_path_factory):
  """A valid small policy (16 units) as the stored tree."""
  folder = tmp_path_factory.mktemp('policy')
  agent = _sac(hidden=16)
  agent.save_checkpoint(str(folder), 0)
  path = str(folder / 'policy.msgpack')
  pretrained.export_policy(run_files.checkpoint_file(str(folder), 0), path)
  return safe_io.read_tree(path, file_format=pretrained.POLICY_FORMAT)


def _write_policy(path, tree, **changes):
  config = {**tree['config'], **changes.pop('config', {})}
  tree = {**tree, **changes, 'config': config}
  safe_io.write_tree(str(path), tree, file_format=pretrained.POLICY_FORMAT)
  return str(path)


def _kernel_path(tree):
  params = tree['network_params']['params']
  layer = sorted(params)[0]
  return params[layer], layer


@pytest.mark.parametrize('config, message', [
    ({'hidden_units': 40000}, r'config.hidden_units must be an integer >= 1 '
                              r'and <= 4096, got 40000'),
    ({'num_layers': 2000}, r'config.num_layers must be an integer >= 1 and '
                           r'<= 16, got 2000'),
    ({'hidden_units': 4000},
     r'network_params: array \d+ \(params/.*\) has shape'),
    ({'num_layers': 16}, r"network_params: leaves differ .*missing "
                         r"\['params/_actor_layers_10/bias'"),
    ({'critic': 'big'}, r'config.critic must be one of'),
    ({'observation_shape': [100000]},
     r'config.observation_shape must be a list of integers >= 1 with at most'),
    ({'action_low': [0.0, 1.0]}, r'config.action_low has shape'),
])
def test_policy_config_is_checked_before_building(small_policy, tmp_path,
                                                  config, message):
  """Sizes bounded, then the arrays must have the shapes the config implies.

  A ~1 MB policy saying hidden_units=40000 made the agent allocate 6.4 GB
  before any shape check; num_layers=2000 took 73 s.
  """
  import time
  path = _write_policy(tmp_path / 'p.msgpack', small_policy, config=config)
  began = time.monotonic()
  with pytest.raises(ValueError, match=message) as raised:
    sac.SACPretrainedAgent(3, (71,), action_low=_LOW,
                                  action_high=_HIGH, policy_path=path)
  assert time.monotonic() - began < 10.0
  assert path in str(raised.value)


def test_policy_arrays_must_be_finite_real_floats(small_policy, tmp_path):
  params = small_policy['network_params']
  _, layer = _kernel_path(small_policy)
  leaf = f'params/{layer}/kernel'

  def with_kernel(kernel):
    tree = {'params': {**params['params'], layer: {
        **params['params'][layer], 'kernel': kernel}}}
    return _write_policy(tmp_path / 'p.msgpack', small_policy,
                         network_params=tree)

  kernel = np.asarray(params['params'][layer]['kernel'])
  # A complex kernel loaded with a warning (imaginary part dropped).
  path = with_kernel(kernel.astype(np.complex64) + 1j)
  with pytest.raises(ValueError, match=f'{leaf} has dtype complex64'):
    pretrained.load_policy(path)
  path = with_kernel(kernel.astype(np.int32))
  with pytest.raises(ValueError, match=f'{leaf} has dtype int32'):
    pretrained.load_policy(path)
  bad = kernel.copy()
  bad.flat[:12] = np.nan
  path = with_kernel(bad)
  with pytest.raises(ValueError, match=f'SAC policy {path}: network_params: '
                     f'leaf {leaf} has 12 non-finite values'):
    sac.SACPretrainedAgent(3, (71,), action_low=_LOW,
                                  action_high=_HIGH, policy_path=path)


@pytest.mark.parametrize('changes, message', [
    ({'log_alpha': np.full(1000, np.nan, np.float32)},
     r'log_alpha has shape \(1000,\), expected \(1,\)'),
    ({'log_alpha': np.array([np.inf], np.float32)}, 'log_alpha has 1 non'),
    ({'iteration': -5}, 'iteration must be >= 0, got -5'),
    ({'training_steps': 1.5}, 'training_steps must be an integer'),
])
def test_policy_scalars_are_checked(small_policy, tmp_path, changes, message):
  path = _write_policy(tmp_path / 'p.msgpack', small_policy, **changes)
  with pytest.raises(ValueError, match=message):
    pretrained.load_policy(path)


@settings(max_examples=15, deadline=None)
@given(data=st.data())
def test_any_corrupted_leaf_is_named(small_policy, tmp_path_factory, data):
  """NaN / inf anywhere in the parameters: refused, the leaf and count named."""
  import jax
  paths_and_leaves = jax.tree_util.tree_flatten_with_path(
      small_policy['network_params'])[0]
  index = data.draw(st.integers(0, len(paths_and_leaves) - 1))
  path, leaf = paths_and_leaves[index]
  leaf = np.array(leaf)
  spots = data.draw(st.sets(st.integers(0, leaf.size - 1), min_size=1,
                            max_size=min(20, leaf.size)))
  value = data.draw(st.sampled_from([np.nan, np.inf, -np.inf]))
  leaf.flat[sorted(spots)] = value
  leaves = [np.asarray(x) for _, x in paths_and_leaves]
  leaves[index] = leaf
  tree = jax.tree_util.tree_unflatten(
      jax.tree_util.tree_structure(small_policy['network_params']), leaves)
  file = _write_policy(tmp_path_factory.mktemp('h') / 'p.msgpack',
                       small_policy, network_params=tree)
  name = safe_io.leaf_name(path)
  count = len(spots)
  with pytest.raises(ValueError, match=f'leaf {name} has {count} non-finite '
                     f'value{"s" if count > 1 else ""}'):
    pretrained.load_policy(file)


def test_export_policy_refuses_a_nan_checkpoint(tmp_path, capsys):
  from ble_latex.cli import export_policy as export_cli
  agent = _sac(hidden=16)
  agent.save_checkpoint(str(tmp_path), 0)
  path = run_files.checkpoint_file(str(tmp_path), 0)
  tree = safe_io.read_tree(path, file_format=sac_core.CHECKPOINT_FORMAT)
  tree['log_alpha'] = np.array([np.nan], np.float32)
  safe_io.write_tree(path, tree, file_format=sac_core.CHECKPOINT_FORMAT)
  out = str(tmp_path / 'out.msgpack')
  assert export_cli.main([f'--checkpoint={path}', f'--output={out}']) == 1
  err = capsys.readouterr().err.strip().splitlines()
  assert err == [f'ble-latex-export-policy: {path}: log_alpha has 1 '
                 'non-finite value (NaN/inf)']
  assert not os.path.exists(out)


def test_crafted_pickle_policy_runs_no_code(tmp_path):
  marker = tmp_path / 'pwned'
  policy = tmp_path / 'policy.pkl'
  _crafted_pickle(policy, marker)
  with pytest.raises(safe_io.UntrustedFileError):
    sac.SACPretrainedAgent(3, (71,), action_low=_LOW, action_high=_HIGH,
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


def test_shipped_policy_is_a_data_file():
  with open(pretrained.DEFAULT_POLICY, 'rb') as f:
    head = f.read(2)
  assert head[:1] != b'\x80' or head[1:2] not in (b'\x02', b'\x03', b'\x04',
                                                  b'\x05')
  policy = pretrained.load_policy(pretrained.DEFAULT_POLICY)
  assert policy['format'] == pretrained.POLICY_FORMAT


# -- Items 18, 19: policy files hold only what write_tree stores. -----------
_SHIPPED_POLICY = (helpers.ROOT / 'ble_latex' /
                   'agents' / 'policies' / 'sac_latex.msgpack')


def _crafted_policy(tmp_path, name, extra):
  """The shipped policy's bytes with `extra` entries added (msgpack)."""
  import msgpack  # pylint: disable=g-import-not-at-top
  # flax's arrays stay msgpack ext types here: repacked byte for byte.
  raw = msgpack.unpackb(_SHIPPED_POLICY.read_bytes(), raw=False,
                        strict_map_key=False)
  raw.update(extra)
  path = tmp_path / name
  path.write_bytes(msgpack.packb(raw))
  return path


@pytest.mark.parametrize('extra', [
    {'note': 'EXT'}, {7: 'an int key'}])
def test_policy_with_ext_type_or_int_key_is_refused_naming_it(
    extra, tmp_path, capsys):
  import msgpack  # pylint: disable=g-import-not-at-top
  from ble_latex.agents.sac import pretrained  # pylint: disable=g-import-not-at-top
  from ble_latex.cli import export_policy  # pylint: disable=g-import-not-at-top
  if extra.get('note') == 'EXT':
    extra = {'note': msgpack.ExtType(42, b'x')}
  path = _crafted_policy(tmp_path, 'crafted.msgpack', extra)
  with pytest.raises(errors.BadFileError, match=str(path)):
    pretrained.load_policy(str(path))
  out = tmp_path / 'out.msgpack'
  assert export_policy.main([f'--checkpoint={path}', f'--output={out}']) == 1
  assert str(path) in helpers.one_line(capsys, 'ble-latex-export-policy')
  assert not out.exists()


def test_export_policy_to_a_pickle_name_is_a_usage_error(tmp_path, capsys):
  from ble_latex.cli import export_policy  # pylint: disable=g-import-not-at-top
  out = tmp_path / 'x.pkl'
  assert export_policy.main([
      f'--checkpoint={_SHIPPED_POLICY}',
      f'--output={out}']) == 2
  assert 'msgpack' in helpers.one_line(capsys, 'ble-latex-export-policy')
  assert not out.exists()


# -- Item 15: policy and checkpoint files are size-bounded before reading. ---
def test_a_huge_policy_is_refused_before_it_is_read(tmp_path):
  from ble_latex.agents.sac import pretrained  # pylint: disable=g-import-not-at-top
  path = tmp_path / 'huge.msgpack'
  with open(path, 'wb') as f:
    f.truncate(2**30)  # Sparse: 1 GiB on no disk.
  with pytest.raises(errors.BadFileError, match='more than the most a SAC'):
    pretrained.load_policy(str(path))


def test_a_huge_checkpoint_is_refused_before_it_is_read(tmp_path, capsys):
  from ble_latex.cli import export_policy  # pylint: disable=g-import-not-at-top
  path = tmp_path / 'checkpoint_00001.msgpack'
  with open(path, 'wb') as f:
    f.truncate(2**43)  # Sparse: 8 TiB, more than any memory here.
  out = tmp_path / 'p.msgpack'
  assert export_policy.main([f'--checkpoint={path}', f'--output={out}']) == 1
  assert 'memory available' in helpers.one_line(capsys, 'ble-latex-export-policy')
  assert not out.exists()
