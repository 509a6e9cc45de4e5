"""The committed records: one folder, benchmarks/records/ (issue 66).

Scripts stay in benchmarks/; every record a table or figure reads is tracked
under `episode_log.RECORDS_DIR`, <= 8 MB in all (run logs stay out of git:
a run's committed summary is `episode_log.summarize`'s).
"""

import json
import subprocess
import sys

import pytest

from ble_latex.run import episode_log

ROOT = episode_log.RECORDS_DIR.parents[1]
RECORDS = episode_log.RECORDS_DIR.relative_to(ROOT).as_posix()
MAX_TRACKED_BYTES = 8_000_000
RECORD_SUFFIXES = ('.json', '.jsonl', '.md', '.png', '.gin')
# Records a run still writes beside its checkpoints outside RECORDS_DIR
# (benchmarks/sac_seeds.py --base_dir); they move under it when the run is
# done. None today (the realistic task's run moved there when it stopped).
STILL_WRITTEN = ()


def _tracked_sizes(where: str) -> dict:
  """path -> bytes of each file git tracks (the index) under `where`."""
  try:
    staged = subprocess.run(['git', 'ls-files', '-s', '-z', '--', where],
                            cwd=ROOT, capture_output=True, check=True).stdout
  except (OSError, subprocess.CalledProcessError):
    pytest.skip('not a git checkout')
  entries = [e.split('\t', 1) for e in staged.decode().split('\0') if e]
  if not entries:
    return {}
  objects = '\n'.join(meta.split()[1] for meta, _ in entries) + '\n'
  sizes = subprocess.run(['git', 'cat-file', '--batch-check=%(objectsize)'],
                         cwd=ROOT, input=objects.encode(), capture_output=True,
                         check=True).stdout.decode().split()
  return {path: int(size) for (_, path), size in zip(entries, sizes)}


def test_records_folder_stays_within_8_mb_tracked():
  sizes = _tracked_sizes(RECORDS)
  assert sizes, f'nothing tracked under {RECORDS}'
  total = sum(sizes.values())
  largest = sorted(sizes.items(), key=lambda kv: -kv[1])[:5]
  assert total <= MAX_TRACKED_BYTES, (
      f'{RECORDS} tracks {total} bytes (> {MAX_TRACKED_BYTES}); largest: '
      f'{largest} (commit summaries, not run logs)')


def test_no_record_tracked_in_benchmarks_outside_the_records_folder():
  outside = [p for p in _tracked_sizes('benchmarks')
             if not p.startswith(RECORDS + '/')
             and not p.startswith(STILL_WRITTEN)
             and p.endswith(RECORD_SUFFIXES)]
  assert not outside, f'records outside {RECORDS}: {outside}'


# The one run log kept: the paper-settings run's, the data of its figures
# (docs/results.md: training_curves.png, Figs. 2 and 5).
KEPT_LOGS = (f'{RECORDS}/sac_paper_run/{episode_log.EPISODE_LOG}',)


def test_no_training_run_log_tracked_but_the_kept_one():
  logs = [p for p in _tracked_sizes('benchmarks')
          if p.endswith('/' + episode_log.EPISODE_LOG) and p not in KEPT_LOGS]
  assert not logs, f'training run logs tracked (commit a summary): {logs}'


def test_summarize_means_blocks_and_counts_reasons():
  records = [{'episode': i, 'seed': i, 'reward': float(i), 'tw50': 0.5,
              'terminal_reason': 'time_limit' if i % 2 else 'out_of_sand'}
             for i in range(5)]
  blocks = episode_log.summarize(records, every=2)
  assert [(b['first_episode'], b['last_episode'], b['episodes'])
          for b in blocks] == [(0, 1, 2), (2, 3, 2), (4, 4, 1)]
  assert [b['reward'] for b in blocks] == [0.5, 2.5, 4.0]
  assert blocks[0]['terminal_reasons'] == {'out_of_sand': 1, 'time_limit': 1}
  assert 'seed' not in blocks[0]
  with pytest.raises(ValueError, match='every must be >= 1'):
    episode_log.summarize(records, every=0)


def test_summarize_run_script_writes_the_summary(tmp_path):
  run = tmp_path / 'run'
  run.mkdir()
  (run / episode_log.EPISODE_LOG).write_text(''.join(
      json.dumps({'episode': i, 'reward': 1.0, 'terminal_reason': 'time_limit'})
      + '\n' for i in range(3)))
  out = subprocess.run(
      [sys.executable, str(ROOT / 'benchmarks' / 'summarize_run.py'),
       str(run), '--every=2'], capture_output=True, text=True, check=False)
  assert out.returncode == 0, out.stderr
  record = json.loads((run / episode_log.EPISODE_SUMMARY).read_text())
  assert record['episodes'] == 3 and len(record['blocks']) == 2
  missing = subprocess.run(
      [sys.executable, str(ROOT / 'benchmarks' / 'summarize_run.py'),
       str(tmp_path)], capture_output=True, text=True, check=False)
  assert missing.returncode == 1
  assert missing.stderr.strip().endswith('no episode log there'), missing.stderr


def test_committed_summary_matches_the_shipped_run():
  summary = (episode_log.RECORDS_DIR / 'sac_jax' / 'n32' / 'seed_2' /
             episode_log.EPISODE_SUMMARY)
  record = json.loads(summary.read_text())
  assert record['episodes'] == sum(b['episodes'] for b in record['blocks'])
