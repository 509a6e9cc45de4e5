"""Ray: eval seeds as Ray tasks equal the serial eval; sweeps on Ray Tune run,
write their table and resume after a kill (README "Scaling out on Ray").

Runs a local Ray on 2 CPUs (as CI has).
"""

import csv
import json
import os
import signal
import subprocess
import sys
import time

import pytest

ray = pytest.importorskip('ray')

from ble_latex import safe_io  # noqa: E402
from ble_latex.cli import sweep as sweep_command  # noqa: E402
from ble_latex.run import distributed  # noqa: E402
from ble_latex.run import eval_lib  # noqa: E402
from ble_latex.run import sweep_lib  # noqa: E402

from tests import helpers

REPO = str(helpers.ROOT)
TINY = list(range(1_000_000, 1_000_010))  # latex_tiny's held-out seeds.


@pytest.fixture(scope='module')
def local_ray():
  distributed.connect('local', num_cpus=2)
  yield
  distributed.shutdown()


@pytest.mark.slow
@pytest.mark.ci
@pytest.mark.parametrize('agent', ['latex_station_seeker', 'sac_pretrained'])
def test_ray_eval_equals_serial_eval(local_ray, agent):
  del local_ray
  spec = eval_lib.EvalSpec(agent=agent)
  seeds = TINY[::2]
  # Ray tasks of one seed (`batch_size` 1) against the same one-at-a-time
  # flights here: bit for bit. Unbatched, this process flies the step its
  # env's reset compiles anyway (batched, it compiled a second one: the
  # seeker's case alone 31 compiles, 20 now). Batched flights equal these
  # within the stated tolerances: tests/run/test_batch_eval.py.
  serial = eval_lib.evaluate(*eval_lib.build(spec), seeds, 72, batched=False)
  remote = distributed.evaluate(spec, seeds, 72)
  assert [r['seed'] for r in remote] == seeds
  assert json.dumps(remote) == json.dumps(serial)


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
def test_failed_seed_is_reported_by_seed(local_ray):
  del local_ray
  spec = eval_lib.EvalSpec(agent='latex_station_seeker')
  with pytest.raises(distributed.SeedsFailedError) as raised:
    distributed.evaluate(spec, [TINY[0], -7], 3)
  assert list(raised.value.failures) == [-7]
  assert 'seed -7:' in str(raised.value)
  assert [r['seed'] for r in raised.value.completed] == [TINY[0]]


def test_ray_missing_and_unreachable_cluster_are_named(monkeypatch):
  with pytest.raises(ValueError, match='HOST:PORT'):
    distributed.check_address('nowhere')
  distributed.check_address('ray://head:10001')
  began = time.monotonic()
  with pytest.raises(distributed.RayUnavailableError, match='127.0.0.1:9'):
    distributed.connect('127.0.0.1:9')
  assert time.monotonic() - began < 30
  monkeypatch.setitem(sys.modules, 'ray', None)
  with pytest.raises(distributed.RayUnavailableError,
                     match=r"pip install 'ble_latex\[ray\]'"):
    distributed.require_ray()


@pytest.mark.slow  # Two eval processes, one starting Ray (~40 s); Ray eval in-process stays in the default suite: CI runs it in `make test-ci`.
@pytest.mark.ci
def test_eval_command_writes_the_same_file_on_ray(tmp_path):
  base = [sys.executable, '-m', 'ble_latex.cli.eval',
          '--agent=latex_station_seeker', '--suite=latex_tiny',
          '--num_shards=5', '--shard_idx=3', '--max_episode_length=48']
  for extra in ([f'--output_dir={tmp_path}/serial'],
                [f'--output_dir={tmp_path}/ray', '--ray_address=local',
                 '--ray_num_cpus=2']):
    result = subprocess.run(base + extra, cwd=REPO, capture_output=True,
                            text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-3000:]
  files = [tmp_path / k / 'latex_tiny' / 'latex_station_seeker_3.json'
           for k in ('serial', 'ray')]
  assert files[0].read_bytes() == files[1].read_bytes()
  assert [r['seed'] for r in json.loads(files[0].read_text())] == TINY[6:8]


# -- Space files. -------------------------------------------------------------
def test_space_file_kinds_and_points(tmp_path):
  path = tmp_path / 'space.yaml'
  path.write_text(
      'num_samples: 3\n'
      'bindings:\n'
      '  sac_trainer_config.updates_per_step: [4, 8]\n'
      '  sac_trainer_config.critic_learning_rate: {loguniform: [1.0e-4, 1.0e-3]}\n'
      '  sac_trainer_config.num_envs: {choice: [8, 16]}\n')
  space = sweep_lib.load_space(str(path))
  points = sweep_lib.points(space, search_seed=1)
  assert len(points) == 6
  assert [p['sac_trainer_config.updates_per_step'] for p in points] == (
      [4] * 3 + [8] * 3)
  assert all(1e-4 <= p['sac_trainer_config.critic_learning_rate'] <= 1e-3
             for p in points)
  assert {p['sac_trainer_config.num_envs'] for p in points} <= {8, 16}
  assert points == sweep_lib.points(space, search_seed=1)  # Deterministic.
  assert points != sweep_lib.points(space, search_seed=2)
  merged = sweep_lib.merge(space, [sweep_lib.parse_grid_flag(
      'sac_trainer_config.gamma=0.98,0.99')], num_samples=1)
  assert len(sweep_lib.points(merged)) == 4
  assert sweep_lib.binding_lines({'a.b': 'x', 'a.c': 1e-3}) == [
      "a.b = 'x'", 'a.c = 0.001']


@pytest.mark.parametrize('text, message', [
    ('[1, 2]', 'expected a mapping'),
    ('{"bindings": {}}', 'non-empty mapping'),
    ('{"bindings": {"x": [1]}}', 'not a gin binding name'),
    ('{"bindings": {"a.b": {"normal": [0, 1]}}}', "unknown kind 'normal'"),
    ('{"bindings": {"a.b": {"uniform": [2, 1]}}}', 'low < high'),
    ('{"bindings": {"a.b": {"loguniform": [0, 1]}}}', 'low > 0'),
    ('{"bindings": {"a.b": [[1]]}}', 'not a gin literal'),
    ('{"bindings": {"a.b": [1]}, "seeds": [1]}', 'unknown keys .*seeds'),
    ('{"bindings": {"a.b": [1]}, "num_samples": 0}', 'num_samples'),
    ('{"bindings": ', 'not valid JSON'),
])
def test_bad_space_files_are_named(tmp_path, text, message):
  path = tmp_path / 'space.json'
  path.write_text(text)
  with pytest.raises(sweep_lib.SpaceError, match=message) as raised:
    sweep_lib.load_space(str(path))
  assert str(path) in str(raised.value)


def test_bad_space_file_names_and_yaml_objects_refused(tmp_path):
  with pytest.raises(sweep_lib.SpaceError, match='cannot read'):
    sweep_lib.load_space(str(tmp_path / 'missing.json'))
  path = tmp_path / 'space.yaml'
  path.write_text('bindings: !!python/object/apply:os.system ["echo hi"]\n')
  with pytest.raises(sweep_lib.SpaceError, match='not valid YAML'):
    sweep_lib.load_space(str(path))
  with pytest.raises(sweep_lib.SpaceError, match='NAME=V1,V2'):
    sweep_lib.parse_grid_flag('sac_trainer_config.gamma')


def test_sweep_size_is_bounded_before_expanding(tmp_path, capsys):
  """A 7-line space of 10^7 points was expanded until memory ran out."""
  path = tmp_path / 'space.yaml'
  path.write_text('bindings:\n' + ''.join(
      f'  a.b{i}: [0, 1, 2, 3, 4, 5, 6, 7, 8, 9]\n' for i in range(7)))
  began = time.monotonic()
  with pytest.raises(sweep_lib.SpaceError,
                     match=f'space file {path}: 10000000 trials \\(points\\) '
                     'exceed the limit of 10000'):
    sweep_lib.load_space(str(path))
  # Within the limit alone, over it with --grid, --num_samples or seeds.
  space = sweep_lib.parse_space(
      {'bindings': {'a.b': list(range(100)), 'a.c': {'uniform': [0, 1]}}},
      'space')
  assert sweep_lib.trial_count(space, num_seeds=5) == 500
  with pytest.raises(sweep_lib.SpaceError, match='20000 trials'):
    sweep_lib.merge(space, [('a.d', tuple(range(200)))], None)
  with pytest.raises(sweep_lib.SpaceError, match='1000000 trials'):
    sweep_lib.merge(space, [], 10_000)
  with pytest.raises(sweep_lib.SpaceError,
                     match=r'20000 trials \(points x 200 seeds\)'):
    sweep_lib.points(space, num_seeds=200)
  assert time.monotonic() - began < 5.0
  from ble_latex.cli import sweep as sweep_cli
  status = sweep_cli.main([f'--sweep_dir={tmp_path / "sweep"}',
                           f'--space={path}'])
  assert status == 2
  assert capsys.readouterr().err.strip().splitlines() == [
      f'ble-latex-sweep: space file {path}: 10000000 trials (points) exceed '
      'the limit of 10000; sweep fewer values']
  assert not (tmp_path / 'sweep').exists()


# -- Sweeps. --------------------------------------------------------------------
# Tiny trials: one balloon, a 1x16 network, 2 validation seeds.
_TINY_TRIALS = [
    '--validation_episodes=2', '--policy_snapshot_period=1',
    '--ray_num_cpus=2',
    '--gin_bindings=sac_trainer_config.num_envs = 1',
    '--gin_bindings=sac_trainer_config.num_layers = 1',
    '--gin_bindings=sac_trainer_config.hidden_units = 16',
    '--gin_bindings=sac_trainer_config.batch_size = 16',
    '--gin_bindings=sac_trainer_config.min_replay_history = 16',
    '--gin_bindings=sac_trainer_config.updates_per_step = 1',
]


def _sweep(sweep_dir, *extra, timeout=900, wait=True):
  command = [sys.executable, '-m', 'ble_latex.cli.sweep',
             f'--sweep_dir={sweep_dir}', *_TINY_TRIALS, *extra]
  if not wait:
    return subprocess.Popen(command, cwd=REPO, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)
  return subprocess.run(command, cwd=REPO, capture_output=True, text=True,
                        timeout=timeout)


def _rows(sweep_dir):
  with open(os.path.join(sweep_dir, sweep_lib.RESULTS_CSV),
            encoding='utf-8') as f:
    return list(csv.DictReader(f))


def _episode_seeds(run_dir):
  with open(os.path.join(run_dir, 'episodes.jsonl'), encoding='utf-8') as f:
    return [json.loads(line)['seed'] for line in f]


def test_sweep_directory_has_one_driver(tmp_path, capsys):
  """A sweep directory another driver holds: `run` and `ble-latex-sweep`
  refuse it (exit status 1, one line naming the holder), before Ray starts
  and before sweep.json is written."""
  sweep_dir = tmp_path / 'sweep'
  settings = sweep_lib.SweepSettings(
      sweep_dir=str(sweep_dir), points=({},), seeds=(0,), num_iterations=2,
      policy_snapshot_period=1, validation_episodes=2)
  message = (f'sweep directory {sweep_dir} is in use by pid {os.getpid()} '
             'on host ')
  with sweep_lib.lock(settings):
    with pytest.raises(safe_io.InUseError, match=message):
      sweep_lib.run(settings)
    capsys.readouterr()
    status = sweep_command.main([
        f'--sweep_dir={sweep_dir}', *_TINY_TRIALS,
        '--grid=sac_trainer_config.gamma=0.9', '--num_iterations=2'])
  err = capsys.readouterr().err
  assert status == 1, err[-3000:]
  (line,) = err.splitlines()
  assert line.startswith(f'ble-latex-sweep: {message}'), err[-3000:]
  assert line.endswith('; one writer per sweep directory')
  assert os.listdir(sweep_dir) == [safe_io.LOCK_FILE]


@pytest.mark.slow  # 6-7 min on 2 cores: CI runs it in `make test-ci`.
@pytest.mark.ci
def test_sweep_killed_resumes_and_writes_table_and_best_gin(tmp_path):
  """A 2-trial sweep, killed during its first trial, then re-run: both trials
  finish with no episode lost or repeated, and the outputs are written."""
  sweep_dir = tmp_path / 'sweep'
  args = ['--grid=sac_trainer_config.gamma=0.9,0.99', '--num_iterations=2',
          '--max_concurrent_trials=1']
  first = sweep_dir / 'runs' / 'p000_seed0'
  process = _sweep(sweep_dir, *args, wait=False)
  try:
    deadline = time.monotonic() + 600
    while not (first / 'checkpoints').is_dir() or not any(
        n.endswith('.msgpack') for n in os.listdir(first / 'checkpoints')):
      assert process.poll() is None, 'the sweep ended before it was killed'
      assert time.monotonic() < deadline
      time.sleep(0.5)
  finally:
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()
  time.sleep(3)  # Ray's own processes end with their driver.
  assert not (sweep_dir / sweep_lib.RESULTS_CSV).exists()
  other = _sweep(sweep_dir, '--grid=sac_trainer_config.gamma=0.9',
                 '--num_iterations=2')
  assert other.returncode == 2 and 'another sweep' in other.stderr
  result = _sweep(sweep_dir, *args)
  assert result.returncode == 0, result.stderr[-3000:]
  rows = _rows(sweep_dir)
  assert [(r['trial'], r['sac_trainer_config.gamma'], r['status'])
          for r in rows] == [('p000_seed0', '0.9', 'done'),
                             ('p001_seed0', '0.99', 'done')]
  for row in rows:
    assert 0.0 <= float(row['best_tw50_window']) <= 1.0
    run_dir = sweep_dir / row['run_dir']
    assert (run_dir / 'policies').is_dir()
    seeds = _episode_seeds(run_dir)
    assert seeds == sorted(set(seeds)) and len(seeds) == 2
  table = (sweep_dir / sweep_lib.RESULTS_MD).read_text()
  points = sorted(line.split(' | ')[:2] for line in table.splitlines()
                  if line.startswith('| ') and line[2].isdigit())
  assert points == [['| 0', '0.9'], ['| 1', '0.99']]  # Ranked by score.
  best = max(rows, key=lambda r: (float(r['best_tw50_window']),
                                  -int(r['point'])))
  gin_text = (sweep_dir / sweep_lib.BEST_GIN).read_text()
  assert f'sac_trainer_config.gamma = {best["sac_trainer_config.gamma"]}' in (
      gin_text)
  # ble-latex-train's gin binding accepts it: the trainer reads the values.
  check = subprocess.run(
      [sys.executable, '-c',
       'from ble_latex import configs\n'
       'from ble_latex.agents.sac import trainer as sac_trainer\n'
       'from ble_latex.run import gin_binding\n'
       f'gin_binding.bind_gin("sac", None, '
       f'[{str(sweep_dir / sweep_lib.BEST_GIN)!r}], [])\n'
       'c = sac_trainer.TrainerConfig()\n'
       'print(c.gamma, c.num_envs, c.hidden_units)\n'],
      cwd=REPO, capture_output=True, text=True, timeout=300)
  assert check.returncode == 0, check.stderr[-2000:]
  assert check.stdout.split() == [best['sac_trainer_config.gamma'], '1', '16']
