"""ble-latex-train / ble-latex-eval: CLI smoke tests, resume after a kill."""

import json
import os
import re
import signal
import subprocess
import sys
import time

import ble_latex  # noqa: F401
from ble_latex import safe_io
from ble_latex.cli import eval as eval_command
from ble_latex.cli import train
from ble_latex.run import episode_log
from ble_latex.run import eval_lib
from ble_latex.run import suites
import jax
import numpy as np
import pytest

from tests import helpers

# A tiny SAC so the test is fast; the schedule is the real one.
_TINY_SAC = [
    '--gin_bindings=ble_latex.agents.sac.SACAgent.min_replay_history=30',
    '--gin_bindings=ble_latex.agents.sac.SACAgent.batch_size=16',
    '--gin_bindings=ble_latex.agents.sac.SACAgent.hidden_units=16']
_TINY = [*_TINY_SAC, '--max_episode_length=12', '--episodes_per_iteration=2']
_ENV = dict(os.environ, TF_CPP_MIN_LOG_LEVEL='3', JAX_PLATFORMS='cpu')


def _train_args(base_dir, iterations):
  return [f'--base_dir={base_dir}', f'--num_iterations={iterations}',
          '--collectors=episodes', '--collectors=pickle',
          '--collectors=tensorboard', *_TINY]


def _train_cmd(base_dir, iterations):
  return [sys.executable, '-m', 'ble_latex.cli.train',
          *_train_args(base_dir, iterations)]


def _run(cmd):
  out = subprocess.run(cmd, env=_ENV, capture_output=True, text=True,
                       timeout=600)
  assert out.returncode == 0, out.stderr[-3000:]
  return out


def _command(main, argv, capsys):
  """Runs a command's `main(argv)` in this process (no interpreter start).

  Returns:
    (exit status, stdout, stderr) of the command.
  """
  capsys.readouterr()
  status = main(argv)
  out, err = capsys.readouterr()
  return status, out, err


def _ok(main, argv, capsys):
  status, out, err = _command(main, argv, capsys)
  assert status == 0, err[-3000:]
  return out


def _comparable(records):
  return [{k: v for k, v in r.items() if k != 'wall_time_s'} for r in records]


@pytest.mark.slow  # Three training processes (~45 s): CI runs it in `make test-ci`.
@pytest.mark.ci
def test_train_killed_and_resumed_equals_uninterrupted_run(tmp_path):
  full, killed = tmp_path / 'full', tmp_path / 'killed'
  _run(_train_cmd(full, 4))
  reference = episode_log.read(str(full / episode_log.EPISODE_LOG))
  assert [r['episode'] for r in reference] == list(range(8))
  assert [r['seed'] for r in reference] == [suites.train_seed(i)
                                            for i in range(8)]

  # Kill the second run once its checkpoint 1 exists (mid iteration 2).
  proc = subprocess.Popen(_train_cmd(killed, 4), env=_ENV,
                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
  checkpoint = killed / 'checkpoints' / 'checkpoint_00001.msgpack'
  deadline = time.time() + 300
  while not checkpoint.exists() and proc.poll() is None:
    assert time.time() < deadline
    time.sleep(0.05)
  proc.send_signal(signal.SIGKILL)
  proc.wait()
  logged = episode_log.read(str(killed / episode_log.EPISODE_LOG))
  assert len(logged) < 8  # It really was interrupted.

  _run(_train_cmd(killed, 4))
  resumed = episode_log.read(str(killed / episode_log.EPISODE_LOG))
  assert [r['episode'] for r in resumed] == list(range(8))  # None lost/twice.
  assert _comparable(resumed) == _comparable(reference)
  assert sorted(os.listdir(killed / 'metrics')) == ['episodes', 'pickle',
                                                    'tensorboard']


def _train_short(base_dir, iterations, capsys, per_iteration=2):
  return _command(train.main, [
      f'--base_dir={base_dir}', f'--num_iterations={iterations}',
      f'--episodes_per_iteration={per_iteration}', *_TINY_SAC,
      '--max_episode_length=6', '--collectors=episodes'], capsys)


@pytest.mark.slow
@pytest.mark.ci
def test_resume_finds_numbered_checkpoints_among_stray_files(tmp_path, capsys):
  run = tmp_path / 'run'
  status, _, err = _train_short(run, 2, capsys)
  assert status == 0, err[-2000:]
  log_path = run / episode_log.EPISODE_LOG
  before = episode_log.read(str(log_path))
  assert len(before) == 4
  for stray in ('checkpoint_backup.pkl', 'checkpoint_00002 (copy).pkl',
                'checkpoint_00009 (copy).msgpack', 'checkpoint_.msgpack'):
    (run / 'checkpoints' / stray).write_bytes(b'junk')
  status, _, err = _train_short(run, 3, capsys)
  assert status == 0, err[-2000:]
  after = episode_log.read(str(log_path))
  assert [r['episode'] for r in after] == list(range(6))
  assert after[:4] == before  # Resumed after checkpoint 1, kept the log.

  # Another --episodes_per_iteration is refused, naming both values, and the
  # run directory is left exactly as it was.
  snapshot = log_path.read_bytes()
  status, _, err = _train_short(run, 4, capsys, per_iteration=3)
  assert status != 0
  assert 'episodes_per_iteration=2' in err
  assert 'episodes_per_iteration=3' in err
  assert log_path.read_bytes() == snapshot


@pytest.mark.slow
@pytest.mark.ci
def test_train_and_eval_refuse_what_another_process_writes(tmp_path):
  """The agent loop's run directory and an eval's output file, held by this
  process: `ble-latex-train` and `ble-latex-eval` exit with status 1 and one
  line naming the holder, and write nothing."""
  run, output_dir = tmp_path / 'run', tmp_path / 'eval'
  path = eval_lib.output_path(str(output_dir), 'latex_tiny', 'latex_random',
                              1, 0)
  code = (
      'from ble_latex.cli import eval as eval_command\n'
      'from ble_latex.cli import train\n'
      f'print(train.main(["--base_dir={run}", "--num_iterations=1"]))\n'
      'print(eval_command.main(["--agent=latex_random", '
      f'"--output_dir={output_dir}"]))\n')
  with safe_io.locked_dir(run), eval_lib.lock_output(path):
    out = subprocess.run([sys.executable, '-c', code], env=_ENV,
                         capture_output=True, text=True, timeout=600)
  assert out.stdout.split() == ['1', '1'], out.stderr[-3000:]
  holder = (rf'is in use by pid {os.getpid()} on host \S+ \(since '
            r'[0-9T:-]+Z\); one writer per')
  lines = out.stderr.splitlines()
  assert len(lines) == 2, out.stderr[-3000:]
  assert re.fullmatch(rf'ble-latex-train: run directory {re.escape(str(run))} '
                      rf'{holder} run directory', lines[0])
  assert re.fullmatch(rf'ble-latex-eval: eval output {re.escape(path)} '
                      rf'{holder} eval output', lines[1])
  assert os.listdir(run) == [safe_io.LOCK_FILE]
  assert os.listdir(os.path.dirname(path)) == ['.latex_random.json.lock']


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
def test_eval_writes_per_episode_json_with_flight_path(tmp_path, capsys):
  # In this process, as the other commands here: no interpreter start and
  # imports of its own (~10 s of the 28 s a subprocess took alone).
  out = _ok(eval_command.main, [
      '--agent=latex_station_seeker', '--suite=latex_micro',
      f'--output_dir={tmp_path}', '--max_episode_length=6'], capsys)
  summary = json.loads(out.strip().splitlines()[-1])
  path = tmp_path / 'latex_micro' / 'latex_station_seeker.json'
  assert summary['output'] == str(path)
  (record,) = json.loads(path.read_text())
  assert record['seed'] == suites.EVAL_SEED_OFFSET
  assert record['steps'] == 6 and len(record['flight_path']) == 7
  assert record['terminal_reason'] == 'max_episode_length'
  assert set(record) >= {'reward', 'tw50', 'helium_vented_mols',
                         'sand_dropped_kg', 'final_distance_km'}
  # The window is the step cap when it is shorter than the episode.
  assert record['window_steps'] == 6
  assert record['tw50_window'] == record['tw50']
  # Each point also says where and when it is (`tracks.locate`): on BLE's
  # winds from the nominal station, and the date BLE drew.
  assert set(record['flight_path'][0]) == {
      't_s', 'x_km', 'y_km', 'altitude_m', 'ascent_rate_mps', 'decision',
      'helium_mols', 'sand_kg', 'lat', 'lon', 'utc'}
  assert record['station_source'] == 'nominal'
  assert (record['station_lat'], record['station_lon']) == (1.0, -113.0)


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
def test_eval_loads_a_trained_checkpoint_and_shards(tmp_path, capsys):
  run = tmp_path / 'run'
  _ok(train.main, _train_args(run, 1), capsys)
  _ok(eval_command.main, [
      '--agent=sac', '--suite=latex_tiny', f'--output_dir={tmp_path}',
      '--num_shards=5', '--shard_idx=1',
      f'--checkpoint_dir={run / "checkpoints"}', '--checkpoint_idx=0',
      '--max_episode_length=3', *_TINY[:3]], capsys)
  records = json.loads((tmp_path / 'latex_tiny' / 'sac_0_1.json').read_text())
  assert [r['seed'] for r in records] == [suites.EVAL_SEED_OFFSET + 2,
                                          suites.EVAL_SEED_OFFSET + 3]


def test_missing_checkpoint_is_an_error(tmp_path, capsys):
  status, _, err = _command(eval_command.main, [
      '--agent=sac', '--suite=latex_micro', f'--output_dir={tmp_path}',
      f'--checkpoint_dir={tmp_path}', '--checkpoint_idx=3'], capsys)
  assert status != 0
  assert len(err.splitlines()) == 1 and 'checkpoint' in err.lower(), err


def test_discrete_agent_on_box_env_is_a_clear_error(tmp_path, capsys):
  status, _, err = _command(train.main, [
      '--agent=station_seeker', f'--base_dir={tmp_path}',
      '--num_iterations=1'], capsys)
  assert status != 0
  assert len(err.splitlines()) == 1 and 'LatexBalloonDiscrete-v0' in err, err


def test_ble_agent_trains_on_discrete_latex_env(tmp_path, capsys):
  _ok(train.main, [
      '--agent=random', '--env_name=LatexBalloonDiscrete-v0',
      f'--base_dir={tmp_path}', '--num_iterations=1',
      '--episodes_per_iteration=1', '--max_episode_length=3',
      '--collectors=episodes'], capsys)
  (record,) = episode_log.read(str(tmp_path / episode_log.EPISODE_LOG))
  assert record['steps'] == 3


def test_torn_last_line_is_ignored(tmp_path):
  path = tmp_path / episode_log.EPISODE_LOG
  path.write_text('{"episode": 0}\n{"episode": 1}\n{"epis')
  assert episode_log.read(str(path)) == [{'episode': 0},
                                                 {'episode': 1}]
  path.write_text('{"episode": 0}\nnot json\n{"episode": 2}\n')
  with pytest.raises(ValueError, match='line 2 is not valid JSON'):
    episode_log.read(str(path))


def test_latex_validation_suite_is_disjoint_from_training_and_held_out():
  validation = set(suites.get_eval_suite('latex_validation').seeds)
  assert len(validation) == 100
  held_out = set()
  for name in suites.SUITE_SIZES:
    held_out |= set(suites.get_eval_suite(name).seeds)
  assert not validation & held_out
  assert min(validation) >= suites.EVAL_SEED_OFFSET  # Never a training seed.
  with pytest.raises(ValueError, match='held-out'):
    suites.train_seed(min(validation))


def test_suites_are_registered_explicitly_not_at_import():
  code = (
      'from balloon_learning_environment.eval import suites as ble\n'
      'from ble_latex.run import suites\n'
      'assert "latex_small" not in ble.available_suites()\n'
      'assert "latex_small" in suites.available_suites()\n'
      'assert len(ble.get_eval_suite("latex_small").seeds) == 100\n')
  result = subprocess.run([sys.executable, '-c', code], capture_output=True,
                          text=True, timeout=300)
  assert result.returncode == 0, result.stderr[-2000:]


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
def test_policy_snapshots_and_validation_selection(tmp_path, capsys,
                                                  benchmark_script):
  from ble_latex.agents.sac import pretrained  # pylint: disable=g-import-not-at-top
  run = tmp_path / 'run'
  _ok(train.main, _train_args(run, 2) + ['--policy_snapshot_period=1'], capsys)
  for iteration in (0, 1):
    policy = pretrained.load_policy(
        str(run / 'policies' / f'policy_{iteration:05d}.msgpack'))
    assert policy['iteration'] == iteration
  # The newest snapshot is exactly the newest checkpoint's network.
  bundle = pretrained.read_checkpoint(
      str(run / 'checkpoints' / 'checkpoint_00001.msgpack'))
  for a, b in zip(*(jax.tree_util.tree_leaves(p['network_params'])
                    for p in (bundle, policy))):
    np.testing.assert_array_equal(a, b)

  output = tmp_path / 'best.msgpack'
  out = _ok(benchmark_script('train_sac.py').main, [
      'select', f'--base_dir={run}', '--every=1', '--include_newest',
      '--validation_episodes=1', f'--output={output}'], capsys)
  results = json.loads((run / 'validation.json').read_text())
  assert sorted(results) == ['policy_00000.msgpack', 'policy_00001.msgpack']
  assert all(r['seeds'] == [suites.VALIDATION_SEED_OFFSET] * 2
             for r in results.values())
  chosen = max(results, key=lambda k: (results[k]['tw50_window_mean'],
                                       results[k]['reward_mean']))
  assert f'best: {chosen}' in out
  best = pretrained.load_policy(str(output))
  assert best['iteration'] == results[chosen]['iteration']
  assert 'latex_validation' in best['note']


def test_policy_snapshots_need_a_sac_agent(tmp_path, capsys):
  status, _, err = _command(train.main, [
      f'--base_dir={tmp_path}', '--agent=latex_random', '--num_iterations=1',
      '--policy_snapshot_period=1', '--collectors=episodes'], capsys)
  assert status == 2
  assert err == ("ble-latex-train: policy snapshots need a SAC agent, not "
                 "'latex_random'\n"), err


def test_snapshot_candidates_and_the_best_named(tmp_path):
  """run_dir.snapshot_candidates and selection.best_named (train_sac.py
  select's)."""
  from ble_latex.run import run_dir  # pylint: disable=g-import-not-at-top
  from ble_latex.run import selection  # pylint: disable=g-import-not-at-top
  with pytest.raises(FileNotFoundError, match='no exported policies'):
    run_dir.snapshot_candidates(str(tmp_path), 2, False)
  (tmp_path / 'policies').mkdir()
  for i in range(5):
    (tmp_path / 'policies' / f'policy_{i:05d}.msgpack').write_bytes(b'')
  (tmp_path / 'policies' / 'policy_00005.msgpack.tmp').write_bytes(b'')
  (tmp_path / 'policies' / 'policy_00006.pkl').write_bytes(b'')
  names = lambda paths: [os.path.basename(p) for p in paths]
  assert names(run_dir.snapshot_candidates(str(tmp_path), 2, False)) == [
      'policy_00001.msgpack', 'policy_00003.msgpack']
  assert names(run_dir.snapshot_candidates(str(tmp_path), 2, True)) == [
      'policy_00001.msgpack', 'policy_00003.msgpack', 'policy_00004.msgpack']

  def r(tw50, oor, reward=0.0):
    return {'tw50_window_mean': tw50, 'out_of_resources_pct': oor,
            'reward_mean': reward}
  results = {'a': r(0.5, 20.0), 'b': r(0.3, 10.0), 'c': r(0.3, 0.0, 5.0),
             'd': r(0.1, 0.0)}
  assert selection.best_named(results, 10.0) == 'c'  # 'a' is over the cap.
  assert selection.best_named(results, 100.0) == 'a'
  assert selection.best_named({'a': r(0.5, 20.0)}, 10.0) is None


# -- Items 4, 12: training seeds in [0, 2**32). ---------------------------
@pytest.mark.parametrize('argv', [
    ['--trainer=jax', '--seed=4294967296'],
    ['--seed=-1'],
    ['--trainer=jax', '--seeds=0,99999999999999999999'],
    ['--seeds=4294967296'],
])
def test_train_refuses_seeds_beyond_2_32(argv, tmp_path, capsys):
  from ble_latex.cli import train  # pylint: disable=g-import-not-at-top
  base = tmp_path / 'run'
  assert train.main([f'--base_dir={base}', *argv]) == 2
  assert '[0, 4294967295]' in helpers.one_line(capsys, 'ble-latex-train')
  assert not base.exists()  # No stray run or seed_ directory.


# -- Items 8-11: the eval command. ------------------------------------------
@pytest.mark.parametrize('argv, needle', [
    (['--agent=latex_mpc', '--env_name=LatexBalloonDiscrete-v0'],
     "Agent 'latex_mpc' acts in the Box"),
    (['--agent=latex_station_seeker', '--env_name=LatexBalloonDiscrete-v0'],
     "Agent 'latex_station_seeker' acts in the Box"),
    (['--num_shards=2', '--shard_idx=5'], '--shard_idx must be in [0, '),
    (['--max_episode_length=0'], 'max_episode_length'),
    (['--max_episode_length=-3'], 'max_episode_length'),
    (['--agent=latex_station_seeker', '--era5_path=/nonexistent.nc',
      '--era5_dates=0001-01-01T00:00+01:00,2022-01-01'],
     'years 1..9999'),
])
def test_eval_refusals_are_one_line(argv, needle, tmp_path, capsys):
  from ble_latex.cli import eval as eval_cli  # pylint: disable=g-import-not-at-top
  out = tmp_path / 'out'
  assert eval_cli.main([f'--output_dir={out}', *argv]) == 2
  assert needle in helpers.one_line(capsys, 'ble-latex-eval')
  assert not out.exists() or not list(out.rglob('*'))  # No lock file left.


# -- Item 21: output names stay inside the output folder. -------------------
@pytest.mark.parametrize('name', ['../../x', '/tmp/abs', '..', 'a/b', ''])
def test_eval_name_override_stays_inside_output_dir(name, tmp_path, capsys):
  from ble_latex.cli import eval as eval_cli  # pylint: disable=g-import-not-at-top
  out = tmp_path / 'a' / 'b' / 'out'
  rc = eval_cli.main([f'--output_dir={out}', f'--name_override={name}',
                      '--agent=latex_station_seeker', '--suite=latex_micro'])
  if name == '':  # absl: an empty override is no override; nothing checked.
    capsys.readouterr()
    return
  assert rc == 2
  assert '--name_override must be a plain file name' in helpers.one_line(
      capsys, 'ble-latex-eval')
  assert not list(tmp_path.rglob('*.json'))
