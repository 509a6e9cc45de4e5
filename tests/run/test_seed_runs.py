"""run.seed_runs: training seeds in parallel processes, comparing and choosing
among their validated snapshots."""

import json
import os

import pytest

from ble_latex import run_files
from ble_latex.run import episode_log
from ble_latex.run import seed_runs


def test_train_seeds_trains_seeds_in_parallel_processes(monkeypatch):
  module = seed_runs
  started = []

  class FakeProcess:

    def __init__(self, args):
      self.args = args
      started.append(args)

    def wait(self):
      return 1 if '--seeds=1,4' in self.args else 0

  monkeypatch.setattr(module.subprocess, 'Popen', FakeProcess)
  module.train_seeds('runs/x', [0, 1, 2, 3, 4], 7, 5, 10, ['a = 1'],
                     parallel=1)
  assert [a for a in started[0] if a.startswith('--seeds')] == [
      '--seeds=0,1,2,3,4']
  started.clear()
  with pytest.raises(RuntimeError, match='seeds=1,4'):
    module.train_seeds('runs/x', [0, 1, 2, 3, 4], 7, 5, 10, ['a = 1'],
                       parallel=3)
  assert [[a for a in c if a.startswith('--seeds')] for c in started] == [
      ['--seeds=0,3'], ['--seeds=1,4'], ['--seeds=2']]
  assert all('--gin_bindings=a = 1' in c and '--num_iterations=7' in c
             for c in started)
  started.clear()
  module.train_seeds('runs/x', [0], 7, 5, 10, [], parallel=2)  # No empty.
  assert len(started) == 1
  assert '--vmap_seeds' not in started[0]
  started.clear()
  module.train_seeds('runs/x', [0, 1, 2], 7, 5, 10, [], parallel=2,
                     vmap_seeds=True)  # Only where a process has several seeds.
  assert ['--vmap_seeds' in c for c in started] == [True, False]


def _two_validated_runs(tmp_path):
  """Two runs' folders (run.json, validation.jsonl) of different critics."""
  runs = []
  for name, critic, scores in (('old', None, [0.3, 0.5, 0.4, 0.6]),
                               ('ln', 'layernorm', [0.2, 0.45, 0.1, 0.7])):
    run = tmp_path / name
    run.mkdir()
    config = {'num_envs': 32}
    if critic:
      config['critic'] = critic
    (run / 'run.json').write_text(json.dumps({'config': config}))
    with open(run / episode_log.VALIDATION_LOG, 'w', encoding='utf-8') as f:
      for i, score in enumerate(scores):
        f.write(json.dumps({
            'iteration': i, 'training_episodes': 32 * (i + 1), 'updates': i,
            'elapsed_s': 1.0 + i, 'seeds': [0, 99], 'episodes': 100,
            'tw50_window_mean': score, 'tw50_mean': score,
            'out_of_resources_pct': 10.0 if i == 1 else 0.0}) + '\n')
    runs.append(str(run))
  return runs


def test_validation_rows_compare_runs_within_the_caps(tmp_path):
  """`seed_runs.validation_rows` + `comparison_table` (the comparison
  `benchmarks/sac_seeds.py compare` prints)."""
  runs = _two_validated_runs(tmp_path)
  rows = seed_runs.validation_rows(runs, max_oor_pct=5.0, max_iteration=2,
                                   max_minutes=None)
  # Round 1 is out (10 % OOR), round 3 beyond the cap.
  assert [r['chosen']['iteration'] for r in rows] == [2, 0]
  assert rows[0]['config']['critic'] == 'mlp'  # Run from before critics.
  assert rows[1]['last5_tw50_window_mean'] == pytest.approx(0.25)
  assert rows[1]['last5_oor_pct'] == pytest.approx(10 / 3)
  table = seed_runs.comparison_table(rows).splitlines()
  # Only the settings that differ are columns (critic, not num_envs).
  assert table[0].startswith('| run | critic | last round |')
  assert table[1] == '|---' * 8 + '|'
  assert table[2] == (f'| {runs[0]} | mlp | 2 | 2 | 40.0 % | 0.0 | '
                      '40.0 % | 3.3 |')
  assert table[3] == (f'| {runs[1]} | layernorm | 2 | 0 | 20.0 % | 0.0 | '
                      '25.0 % | 3.3 |')
  # A run with nothing within the caps: dashes, no error.
  none = seed_runs.validation_rows(runs[:1], 5.0, 0, 0.001)
  assert none[0]['chosen'] is None
  assert seed_runs.comparison_table(none).splitlines()[2].endswith(
      '| 0 | — | — | — | 30.0 % | 0.0 |')


def test_sac_seeds_compare_command_prints_and_writes_the_rows(
    benchmark_script, tmp_path, capsys):
  """The script's command line: `compare --run_dirs --json`."""
  runs = _two_validated_runs(tmp_path)
  out = tmp_path / 'rows.json'
  assert benchmark_script('sac_seeds.py').main(
      ['compare', f'--run_dirs={",".join(runs)}', '--max_iteration=2',
       f'--json={out}']) == 0
  rows = seed_runs.validation_rows(runs, 5.0, 2, None)
  assert json.loads(out.read_text()) == json.loads(json.dumps(rows))
  assert seed_runs.comparison_table(rows) in capsys.readouterr().out


def test_write_chosen_policy_copies_the_snapshot_with_why(tmp_path):
  """seed_runs.write_chosen_policy (was sac_seeds._chosen_policy)."""
  from ble_latex.agents.sac import pretrained  # pylint: disable=g-import-not-at-top
  run = str(tmp_path / 'seed_0')
  chosen = {'iteration': 3, 'seeds': [0, 99], 'tw50_window_mean': 0.5}
  with pytest.raises(FileNotFoundError, match='chosen snapshot .* missing'):
    seed_runs.write_chosen_policy(run, 0, chosen, [chosen], 5.0)
  policy = pretrained.load_policy(pretrained.shipped_policy(False))
  policy['iteration'] = 3
  source = run_files.policy_snapshot_path(run, 3)
  os.makedirs(os.path.dirname(source))
  pretrained.write_policy(policy, source)
  path = seed_runs.write_chosen_policy(run, 0, chosen, [chosen, chosen], 5.0)
  assert path == os.path.join(run, 'chosen_policy.msgpack')
  assert pretrained.load_policy(path)['note'] == policy['note'] + (
      '; chosen among 2 snapshots by TW50 (window) on latex_validation seeds'
      ' 0..99 (50.0 %, <= 5 % out of resources)')
  os.remove(source)  # A fresh checkout: the chosen policy of that round kept.
  assert seed_runs.write_chosen_policy(run, 0, chosen, [chosen], 5.0) == path


def test_best_snapshots_ranks_a_runs_validation_within_the_cap(tmp_path):
  """seed_runs.best_snapshots (was policy_select._best_snapshots)."""
  run = tmp_path / 'seed_0'
  run.mkdir()
  scores = [(0.3, 0.0), (0.6, 8.0), (0.5, 0.0), (0.5, 2.0), (0.4, 0.0)]
  with open(run / episode_log.VALIDATION_LOG, 'w', encoding='utf-8') as f:
    for i, (score, oor) in enumerate(scores):
      f.write(json.dumps({
          'iteration': i, 'training_episodes': 32 * (i + 1), 'updates': i,
          'elapsed_s': 1.0 + i, 'seeds': [0, 99], 'episodes': 100,
          'tw50_window_mean': score, 'tw50_mean': score,
          'out_of_resources_pct': oor}) + '\n')
  got = seed_runs.best_snapshots(str(run), 3, 5.0)
  # Round 1 is out (8 %); rounds 2 and 3 tie, the earlier first.
  assert got == [run_files.policy_snapshot_path(str(run), i) for i in (2, 3, 4)]
  assert got[0] == str(run / 'policies' / 'policy_00002.msgpack')
