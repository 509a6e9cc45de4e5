"""The jitted SAC trainer's driver (ble_latex/run/jax_train.py): resumes,
vmapped seeds, run-directory locks, checkpoints refused on resume, divergence."""

import json
import os
import re
import signal
import socket
import subprocess
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex import errors
from ble_latex import run_files
from ble_latex import safe_io
from ble_latex.agents.sac import trainer as sac_trainer
from ble_latex.envs import jax_env
from ble_latex.run import episode_log
from ble_latex.run import jax_train
from ble_latex.run import records as records_lib
from ble_latex.run import run_dir
from ble_latex.run import suites


# Small enough to compile and run in seconds; the capacity makes the replay
# ring wrap within three rounds (3 balloons x 8 steps per round).
CONFIG = sac_trainer.TrainerConfig(
    num_envs=3, updates_per_step=2, batch_size=16, min_replay_history=8,
    replay_capacity=40, hidden_units=16)


STEPS = 8


VALIDATION = range(suites.VALIDATION_SEED_OFFSET,
                   suites.VALIDATION_SEED_OFFSET + 2)


def _params():
  return jax_env.LatexBalloonJaxEnv().default_params.replace(
      episode_steps=STEPS)


def _train(base_dir, iterations, **kwargs):
  kwargs = {'seed': 5, 'config': CONFIG, 'collectors': ['episodes'],
            'validation_seeds': VALIDATION, 'env_params': _params(),
            **kwargs}
  return jax_train.train(base_dir=str(base_dir), num_iterations=iterations,
                           **kwargs)


def _lines(path, drop):
  return [{k: v for k, v in r.items() if k not in drop}
          for r in episode_log.read(str(path))]


@pytest.fixture(scope='module')
def straight_run(tmp_path_factory):
  """One run of 3 rounds straight: (its directory, its final learner)."""
  straight = tmp_path_factory.mktemp('straight')
  return straight, _train(straight, 3)


@pytest.fixture(scope='module')
def runs(straight_run, tmp_path_factory):
  """One run of 3 rounds straight, one killed after 2 and resumed."""
  straight, final = straight_run
  resumed = tmp_path_factory.mktemp('resumed')
  _train(resumed, 2)
  # A killed run may have logged a round after its last checkpoint.
  log = resumed / episode_log.EPISODE_LOG
  extra = _lines(log, ())[-3:]
  with open(log, 'a', encoding='utf-8') as f:
    for i, r in enumerate(extra):
      f.write(json.dumps({**r, 'episode': 6 + i}) + '\n')
  os.remove(resumed / 'checkpoints' / 'checkpoint_00001.msgpack')
  resumed_final = _train(resumed, 3)
  return straight, final, resumed, resumed_final


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
def test_resumed_run_equals_straight_run(runs):
  straight, final, resumed, resumed_final = runs
  drop = ('wall_time_s',)
  episodes = _lines(straight / episode_log.EPISODE_LOG, drop)
  assert episodes == _lines(resumed / episode_log.EPISODE_LOG, drop)
  assert [e['episode'] for e in episodes] == list(range(9))
  assert [e['seed'] for e in episodes] == [suites.train_seed(i)
                                           for i in range(9)]
  assert all(e['window_steps'] == STEPS for e in episodes)
  assert _lines(straight / episode_log.VALIDATION_LOG, ('elapsed_s',)) == (
      _lines(resumed / episode_log.VALIDATION_LOG, ('elapsed_s',)))
  for a, b in zip(jax.tree_util.tree_leaves(final),
                  jax.tree_util.tree_leaves(resumed_final)):
    np.testing.assert_array_equal(a, b)
  # Learning happened, and the ring wrapped around.
  assert int(final.updates) > 0
  assert int(final.env_steps) == 3 * 3 * STEPS > CONFIG.replay_capacity
  assert int(final.replay.size) == CONFIG.replay_capacity
  # The two newest checkpoints are kept.
  assert sorted(os.listdir(straight / 'checkpoints')) == [
      'checkpoint_00001.msgpack', 'checkpoint_00002.msgpack']


def _close_lines(a, b):
  """Two logs with the same records, numbers equal to float rounding."""
  assert len(a) == len(b) > 0
  for x, y in zip(a, b):
    assert x.keys() == y.keys()
    for k, v in x.items():
      if isinstance(v, float):
        assert y[k] == pytest.approx(v, rel=1e-4, abs=1e-5), k
      else:
        assert y[k] == v, k


@pytest.mark.slow
@pytest.mark.ci
def test_vmapped_seeds_equal_one_after_another(runs, tmp_path, monkeypatch):
  """`train_seeds(vmap=True)` writes what one run per seed writes.

  Seed 5's straight run is `runs`'; seed 6 runs alone here. Vmapped: seed 5
  has one round done alone (a run killed early) and seed 6 none, so seed 6
  first catches up one round alone, then rounds 1-2 run vmapped.
  """
  straight, final5, _, _ = runs
  alone6 = tmp_path / 'alone6'
  final6 = _train(alone6, 3, seed=6)
  both5, both6 = tmp_path / 'vmap5', tmp_path / 'vmap6'
  _train(both5, 1)
  vmapped_rounds = []
  vmapped_call = sac_trainer.train_round_seeds

  def counted(*args):
    vmapped_rounds.append(args[2].updates.shape)
    return vmapped_call(*args)

  monkeypatch.setattr(sac_trainer, 'train_round_seeds', counted)
  finals = jax_train.train_seeds(
      runs=[(5, str(both5)), (6, str(both6))], num_iterations=3,
      config=CONFIG, collectors=['episodes'], validation_seeds=VALIDATION,
      env_params=_params(), vmap=True)
  assert vmapped_rounds == [(2,), (2,)]  # Rounds 1 and 2, both seeds.
  for alone, both, final, vmapped in ((straight, both5, final5, finals[0]),
                                      (alone6, both6, final6, finals[1])):
    _close_lines(_lines(alone / episode_log.EPISODE_LOG, ('wall_time_s',)),
                 _lines(both / episode_log.EPISODE_LOG, ('wall_time_s',)))
    _close_lines(_lines(alone / episode_log.VALIDATION_LOG, ('elapsed_s',)),
                 _lines(both / episode_log.VALIDATION_LOG, ('elapsed_s',)))
    assert int(vmapped.updates) == int(final.updates) > 0
    for a, b in zip(jax.tree_util.tree_leaves(final),
                    jax.tree_util.tree_leaves(vmapped)):
      np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-5)
    assert sorted(os.listdir(both / 'checkpoints')) == sorted(
        os.listdir(alone / 'checkpoints'))
    assert sorted(os.listdir(both / 'policies')) == sorted(
        os.listdir(alone / 'policies'))
  # The two seeds learned different things.
  assert not np.allclose(
      jax.tree_util.tree_leaves(finals[0].network_params)[0],
      jax.tree_util.tree_leaves(finals[1].network_params)[0])


def test_train_seeds_needs_distinct_seeds(tmp_path):
  with pytest.raises(ValueError, match='distinct training seeds'):
    jax_train.train_seeds(runs=[(1, str(tmp_path / 'a')),
                                  (1, str(tmp_path / 'b'))],
                            num_iterations=1, config=CONFIG)


def test_one_run_directory_twice_in_one_process_is_refused(tmp_path):
  """Two runs of one `train_seeds` call (or two trainers in one process)
  on one directory: refused before any training."""
  with pytest.raises(safe_io.InUseError,
                     match=f'run directory {tmp_path} is in use by pid '
                     f'{os.getpid()} .*this process'):
    jax_train.train_seeds(runs=[(1, str(tmp_path)), (2, str(tmp_path))],
                            num_iterations=1, config=CONFIG,
                            env_params=_params())
  assert not (tmp_path / episode_log.EPISODE_LOG).exists()
  with safe_io.locked_dir(tmp_path):  # Released.
    pass


@pytest.mark.slow
@pytest.mark.ci  # 60 s on the idle 2-core machine (2026-11-28): CI runs it.
def test_stale_temporary_files_are_removed_at_start(tmp_path):
  """What a killed checkpoint or policy write left (up to ~0.6 GB each) is
  removed when the trainer starts; other files stay."""
  stale = [tmp_path / 'checkpoints' / '.tmp-checkpoint_00007.msgpack-41-ab12',
           tmp_path / 'policies' / '.tmp-policy_00007.msgpack-41-cd34']
  kept = [tmp_path / 'policies' / 'notes.txt',
          tmp_path / 'checkpoints' / '.tmp-other']
  for path in stale + kept:
    path.parent.mkdir(exist_ok=True)
    path.write_bytes(b'partial')
  _train(tmp_path, 1)  # The straight run's settings: its compiled programs.
  assert not any(path.exists() for path in stale)
  assert all(path.exists() for path in kept)


# The jitted trainer's command, as cheap as it gets: 2 balloons x 4 steps,
# a 1x16 network, 1 validation seed.
_JAX_TRAIN = [
    '-m', 'ble_latex.cli.train', '--trainer=jax', '--num_iterations=2',
    '--policy_snapshot_period=1', '--validation_episodes=1',
    '--collectors=episodes',
    '--gin_bindings=latex_episode.episode_steps = 4',
    '--gin_bindings=sac_trainer_config.num_envs = 2',
    '--gin_bindings=sac_trainer_config.num_layers = 1',
    '--gin_bindings=sac_trainer_config.hidden_units = 16',
    '--gin_bindings=sac_trainer_config.batch_size = 8',
    '--gin_bindings=sac_trainer_config.min_replay_history = 8',
    '--gin_bindings=sac_trainer_config.updates_per_step = 1']


_ENV = dict(os.environ, TF_CPP_MIN_LOG_LEVEL='3', JAX_PLATFORMS='cpu')


@pytest.mark.slow  # Two trainer processes (~40 s); in-process refusal stays in the default suite: CI runs it in `make test-ci`.
@pytest.mark.ci
def test_second_trainer_process_on_a_run_directory_is_refused(tmp_path):
  """Two `ble-latex-train --trainer=jax` on one --base_dir: the second exits
  with status 1 and one line naming the first, whose logs stay whole."""
  run = tmp_path / 'run'
  command = [sys.executable, *_JAX_TRAIN, f'--base_dir={run}']
  with open(tmp_path / 'first.err', 'w', encoding='utf-8') as err:
    first = subprocess.Popen(command, env=_ENV, stdout=subprocess.DEVNULL,
                             stderr=err)
  try:
    deadline = time.monotonic() + 300
    lock = run / safe_io.LOCK_FILE
    while not (lock.exists() and f'"pid": {first.pid},' in lock.read_text()):
      assert first.poll() is None, (tmp_path / 'first.err').read_text()[-3000:]
      assert time.monotonic() < deadline
      time.sleep(0.05)
    first.send_signal(signal.SIGSTOP)  # Holds the lock while the second runs.
    try:
      second = subprocess.run(command, env=_ENV, capture_output=True,
                              text=True, timeout=600)
    finally:
      first.send_signal(signal.SIGCONT)
    assert first.wait(timeout=600) == 0, (
        (tmp_path / 'first.err').read_text()[-3000:])
  finally:
    if first.poll() is None:
      first.kill()
      first.wait()
  assert second.returncode == 1, second.stderr[-3000:]
  lines = second.stderr.splitlines()
  assert len(lines) == 1 and lines[-1].startswith(
      f'ble-latex-train: run directory {run} is in use by pid {first.pid} on '
      f'host {socket.gethostname()} (since '), second.stderr[-3000:]
  assert lines[-1].endswith('; one writer per run directory')
  assert 'Traceback' not in second.stderr
  episodes = episode_log.read(str(run / episode_log.EPISODE_LOG))
  assert [e['episode'] for e in episodes] == list(range(4))
  assert [e['seed'] for e in episodes] == [suites.train_seed(i)
                                           for i in range(4)]
  assert [r['iteration'] for r in episode_log.read(
      str(run / episode_log.VALIDATION_LOG))] == [0, 1]


@pytest.mark.slow
@pytest.mark.ci
def test_snapshot_flies_in_the_gym_env_as_validated(runs):
  """The exported policy, loaded by `sac_pretrained`, flies the gym env."""
  import gym  # pylint: disable=g-import-not-at-top
  from ble_latex.agents.sac import agent as sac  # pylint: disable=g-import-not-at-top
  from ble_latex.run import eval_lib  # pylint: disable=g-import-not-at-top
  straight, final, _, _ = runs
  path = straight / 'policies' / 'policy_00002.msgpack'
  env = gym.make('LatexBalloon-v0').unwrapped
  space = env.action_space
  agent = sac.SACPretrainedAgent(
      3, env.observation_space.shape, action_low=space.low,
      action_high=space.high, policy_path=str(path))
  for a, b in zip(jax.tree_util.tree_leaves(agent.network_params),
                  jax.tree_util.tree_leaves(final.network_params)):
    np.testing.assert_array_equal(a, b)
  records = eval_lib.evaluate(agent, env, list(VALIDATION), STEPS)
  learner = sac_trainer.learner_for(CONFIG)
  result = jax.device_get(sac_trainer.validate(
      learner, jax_env.LatexBalloonJaxEnv(), final.network_params,
      jnp.asarray(list(VALIDATION), jnp.int32), STEPS, _params()))
  assert [r['steps'] for r in records] == result['steps'].tolist()
  assert [round(r['tw50'] * r['steps']) for r in records] == (
      result['within_steps'].tolist())
  # The trainer's records are those of the validation schema.
  logged = records_lib.load_validation(
      str(straight / episode_log.VALIDATION_LOG))
  assert logged[-1]['tw50_window_mean'] == pytest.approx(
      np.mean([r['tw50_window'] for r in records]))


def test_resume_with_other_settings_is_refused(straight_run):
  straight = straight_run[0]
  before = (straight / episode_log.EPISODE_LOG).read_text()
  other = sac_trainer.TrainerConfig(**{**CONFIG.__dict__, 'num_envs': 4})
  with pytest.raises(ValueError, match='num_envs'):
    _train(straight, 4, config=other)
  assert (straight / episode_log.EPISODE_LOG).read_text() == before


def test_run_started_before_critics_resumes_and_other_critic_is_refused(
    tmp_path):
  _train(tmp_path, 1)
  # run.json as written before `critic` existed: resumes as 'mlp'.
  path = tmp_path / run_dir.RUN_INFO
  info = json.loads(path.read_text())
  del info['config']['critic']
  path.write_text(json.dumps(info))
  _train(tmp_path, 2)
  assert json.loads(path.read_text())['config']['critic'] == 'mlp'
  other = sac_trainer.TrainerConfig(**{**CONFIG.__dict__,
                                       'critic': 'layernorm'})
  with pytest.raises(ValueError, match="critic': 'layernorm'"):
    _train(tmp_path, 3, config=other)


def test_corrupt_checkpoint_is_named(straight_run, tmp_path):
  learner, template = sac_trainer.make_learner(CONFIG, jax.random.PRNGKey(0))
  del learner
  path = straight_run[0] / 'checkpoints' / 'checkpoint_00002.msgpack'
  bad = tmp_path / 'checkpoint_00002.msgpack'
  bad.write_bytes(path.read_bytes()[:1000])
  with pytest.raises(ValueError, match='checkpoint_00002'):
    jax_train.load_checkpoint(str(bad), template)
  wrong = sac_trainer.TrainerConfig(**{**CONFIG.__dict__, 'hidden_units': 8})
  _, small = sac_trainer.make_learner(wrong, jax.random.PRNGKey(0))
  with pytest.raises(ValueError, match='network_params'):
    jax_train.load_checkpoint(str(path), small)


# -- NaN and bad values: refused on resume, stopped while training. ----------
def _set_first_leaf(tree, name, value):
  """Puts `value` into 2 entries of the first floating-point leaf."""
  leaves = [np.array(x) for x in tree[name]]
  first = next(x for x in leaves if x.dtype.kind == 'f')
  first.flat[:2] = value
  tree[name] = leaves


def _set_replay(tree, name, index, value):
  replay = dict(tree['replay'])
  array = np.array(replay[name])
  array.flat[index] = value
  replay[name] = array
  tree['replay'] = replay


@pytest.mark.parametrize('change, message', [
    (lambda t: _set_first_leaf(t, 'network_params', np.nan),
     'network_params: leaf params/.*/bias has 2 non-finite values'),
    (lambda t: _set_first_leaf(t, 'optimizer_state', np.inf),
     'optimizer_state: leaf .* has 2 non-finite values'),
    (lambda t: _set_replay(t, 'reward', 3, np.nan),
     'replay reward has 1 non-finite value'),
    (lambda t: _set_replay(t, 'obs', 7, -np.inf),
     'replay obs has 1 non-finite value'),
    (lambda t: t.update(updates=-5), 'updates must be >= 0 .*got -5'),
    (lambda t: t.update(iteration=2.5), 'iteration must be an integer'),
    (lambda t: t.update(replay={**t['replay'], 'size': 41}),
     'replay size must be >= 0 and <= 40, got 41'),
    (lambda t: t.update(log_alpha=np.full(1000, np.nan, np.float32)),
     r'log_alpha has shape \(1000,\), expected \(1,\)'),
    (lambda t: t.update(key=np.zeros(2, np.float32)),
     'key has dtype float32; expected integer'),
])
def test_checkpoint_values_are_checked_on_resume(runs, tmp_path, change,
                                                 message):
  _, template = sac_trainer.make_learner(CONFIG, jax.random.PRNGKey(0))
  path = runs[0] / 'checkpoints' / 'checkpoint_00002.msgpack'
  tree = safe_io.read_tree(str(path),
                           file_format=jax_train.CHECKPOINT_FORMAT)
  change(tree)
  bad = tmp_path / 'checkpoint_00002.msgpack'
  safe_io.write_tree(str(bad), tree, file_format=jax_train.CHECKPOINT_FORMAT)
  with pytest.raises(ValueError, match=message) as raised:
    jax_train.load_checkpoint(str(bad), template)
  assert str(bad) in str(raised.value)


def test_train_command_refuses_a_nan_checkpoint_in_one_line(runs, tmp_path,
                                                            capsys):
  import shutil
  import gin
  from ble_latex.cli import train as train_cli
  run = tmp_path / 'run'
  shutil.copytree(runs[0], run)
  os.remove(run / run_dir.RUN_INFO)  # Settings come from the flags.
  newest = run / 'checkpoints' / 'checkpoint_00002.msgpack'
  tree = safe_io.read_tree(str(newest),
                           file_format=jax_train.CHECKPOINT_FORMAT)
  _set_replay(tree, 'reward', 0, np.nan)
  safe_io.write_tree(str(newest), tree,
                     file_format=jax_train.CHECKPOINT_FORMAT)
  bindings = [f'--gin_bindings=sac_trainer_config.{k} = {getattr(CONFIG, k)}'
              for k in ('num_envs', 'updates_per_step', 'batch_size',
                        'min_replay_history', 'replay_capacity',
                        'hidden_units')]
  try:
    status = train_cli.main(['--trainer=jax', f'--base_dir={run}',
                             '--num_iterations=4', '--validation_episodes=0',
                             '--collectors=episodes', *bindings])
  finally:
    gin.clear_config()
  err = capsys.readouterr().err.strip().splitlines()
  assert status == 1
  assert err == [f'ble-latex-train: {newest}: replay reward has 1 '
                 'non-finite value (NaN/inf)']


def test_diverged_round_stops_before_anything_of_it_is_written(
    tmp_path, monkeypatch):
  """A round that goes NaN: one error, the last good checkpoint the newest.

  NaN is put into the network at the start of round 1 (as an update that
  diverged would leave it); the round itself counts the NaN it produces.
  """
  real = sac_trainer.train_round
  rounds = []

  def poisoned(learner, env, state, seeds, num_steps, params):
    rounds.append(len(rounds))
    if len(rounds) == 2:
      leaves, treedef = jax.tree.flatten(state.network_params)
      leaves[0] = leaves[0].at[0].set(jnp.nan)
      state = state.replace(network_params=jax.tree.unflatten(treedef,
                                                              leaves))
    return real(learner, env, state, seeds, num_steps, params)

  monkeypatch.setattr(sac_trainer, 'train_round', poisoned)
  kept = run_files.checkpoint_path(str(tmp_path), 0)
  with pytest.raises(FloatingPointError,
                     match=r'^training diverged at round 1: non-finite .*'
                     r'network parameters.*; last good checkpoint: '
                     f'{re.escape(kept)} kept$') as raised:
    _train(tmp_path, 3)
  assert isinstance(raised.value, sac_trainer.sac_core.TrainingDiverged)
  assert rounds == [0, 1]
  assert run_files.iterations(
      str(tmp_path / 'checkpoints')) == [0]
  assert sorted(os.listdir(tmp_path / 'policies')) == ['policy_00000.msgpack']
  assert len(episode_log.read(str(tmp_path / episode_log.EPISODE_LOG))) == 3
  assert [r['iteration'] for r in episode_log.read(
      str(tmp_path / episode_log.VALIDATION_LOG))] == [0]
  # What was written is the last good round's, and finite.
  from ble_latex.agents.sac import pretrained
  pretrained.load_policy(str(tmp_path / 'policies' / 'policy_00000.msgpack'))
  _, template = sac_trainer.make_learner(CONFIG, jax.random.PRNGKey(0))
  jax_train.load_checkpoint(run_files.checkpoint_path(str(tmp_path), 0),
                              template)


# -- The replay's counters must fit its arrays (issue 48 item 5). -------------
@pytest.mark.slow
def test_checkpoint_replay_cursor_must_fit_its_size(runs, tmp_path):
  """cursor=39, size=6 was accepted: rows 6-38 zeros sampled, real ones lost."""
  _, template = sac_trainer.make_learner(CONFIG, jax.random.PRNGKey(0))
  path = runs[0] / 'checkpoints' / 'checkpoint_00002.msgpack'
  tree = safe_io.read_tree(str(path), file_format=jax_train.CHECKPOINT_FORMAT)
  replay = dict(tree['replay'])
  for name in ('obs', 'action', 'reward', 'next_obs', 'terminal'):
    replay[name] = np.asarray(replay[name])[:6]

  def crafted(cursor):
    out = tmp_path / f'checkpoint_cursor_{cursor}.msgpack'
    safe_io.write_tree(str(out), {**tree, 'replay': {**replay, 'size': 6,
                                                     'cursor': cursor}},
                       file_format=jax_train.CHECKPOINT_FORMAT)
    return str(out)

  state, _ = jax_train.load_checkpoint(crafted(6), template)  # Consistent.
  assert int(state.replay.size) == int(state.replay.cursor) == 6
  bad = crafted(CONFIG.replay_capacity - 1)
  with pytest.raises(errors.BadFileError) as refused:
    jax_train.load_checkpoint(bad, template)
  message = str(refused.value)
  assert bad in message and 'replay cursor is 39 but size 6' in message
  assert '\n' not in message
