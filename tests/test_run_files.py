"""A run directory's file names, one home (ble_latex/run_files.py)."""

import os

from ble_latex import run_files


def test_the_names_of_a_run_directory(tmp_path):
  run = str(tmp_path)
  assert run_files.checkpoint_path(run, 7) == os.path.join(
      run, 'checkpoints', 'checkpoint_00007.msgpack')
  assert run_files.legacy_checkpoint_file(
      run_files.checkpoint_dir(run), 7) == os.path.join(
          run, 'checkpoints', 'checkpoint_00007.pkl')
  assert run_files.policy_snapshot_path(run, 123456) == os.path.join(
      run, 'policies', 'policy_123456.msgpack')
  assert run_files.chosen_policy_path(run) == os.path.join(
      run, 'chosen_policy.msgpack')
  assert run_files.dagger_checkpoint_path(run, 2) == os.path.join(
      run, 'checkpoints', 'dagger_00002.msgpack')


def test_listings_read_back_what_the_paths_name(tmp_path):
  run = str(tmp_path)
  assert run_files.iterations(run_files.checkpoint_dir(run)) == []
  assert run_files.newest_dagger_checkpoint(run) is None
  assert run_files.policy_snapshots(run) == []
  written = [run_files.checkpoint_path(run, 3),
             run_files.checkpoint_path(run, 10),
             run_files.dagger_checkpoint_path(run, 1),
             run_files.dagger_checkpoint_path(run, 12),
             run_files.policy_snapshot_path(run, 2),
             run_files.policy_snapshot_path(run, 100000)]
  for path in written:
    os.makedirs(os.path.dirname(path), exist_ok=True)
    open(path, 'wb').close()
  # Strays and temporaries are no checkpoint or snapshot.
  for stray in ('checkpoint_backup.msgpack', 'dagger_1.msgpack',
                '.tmp-checkpoint_00011.msgpack-1-ab'):
    open(os.path.join(run_files.checkpoint_dir(run), stray), 'wb').close()
  open(os.path.join(run_files.policy_dir(run), 'policy_7.msgpack'),
       'wb').close()
  assert run_files.iterations(run_files.checkpoint_dir(run)) == [3, 10]
  assert run_files.newest_dagger_checkpoint(run) == (
      12, run_files.dagger_checkpoint_path(run, 12))
  assert run_files.policy_snapshots(run) == [
      (2, run_files.policy_snapshot_path(run, 2)),
      (100000, run_files.policy_snapshot_path(run, 100000))]
