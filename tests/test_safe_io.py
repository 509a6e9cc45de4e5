"""The run-directory lock (`ble_latex.safe_io.locked_dir` / `locked_file`):
one writer per directory, a killed holder blocks nobody."""

import os
import re
import signal
import socket
import subprocess
import sys
import time

import pytest

from ble_latex import errors
from ble_latex import safe_io

from tests import helpers

REPO = str(helpers.ROOT)

# Holds the lock of argv[1] for argv[2] seconds; with argv[3] == 'fork' it
# first forks a child that outlives it. Prints each pid, then 'locked'.
_HOLDER = '''
import os, sys, time
from ble_latex import safe_io
with safe_io.locked_dir(sys.argv[1]):
  if sys.argv[3] == 'fork':
    ready, done = os.pipe()
    child = os.fork()
    if child == 0:
      os.write(done, b'x')  # The child runs (its fork handlers ran).
      time.sleep(120)
      os._exit(0)
    os.read(ready, 1)
    print(child, flush=True)
  print(os.getpid(), flush=True)
  print('locked', flush=True)
  time.sleep(float(sys.argv[2]))
'''


def _holder(directory, hold_s=120.0, fork=False):
  """A process that holds `directory`'s lock; returns it and its pids."""
  process = subprocess.Popen(
      [sys.executable, '-c', _HOLDER, str(directory), str(hold_s),
       'fork' if fork else '-'],
      cwd=REPO, stdout=subprocess.PIPE, text=True)
  lines = []
  while not lines or lines[-1] != 'locked':
    line = process.stdout.readline().strip()
    assert line, 'the holder ended before it took the lock'
    lines.append(line)
  return process, [int(pid) for pid in lines[:-1]]


def _message(directory, pid, host, what='run directory'):
  return (rf'^{what} {re.escape(str(directory))} is in use by pid {pid} on '
          rf'host {re.escape(host)} \(since \d{{4}}-\d\d-\d\dT\d\d:\d\d:\d\dZ'
          rf'\)(.*); one writer per {what}$')


def test_second_holder_in_this_process_is_refused(tmp_path):
  with safe_io.locked_dir(tmp_path / 'run'):
    with pytest.raises(safe_io.InUseError,
                       match=_message(tmp_path / 'run', os.getpid(),
                                      socket.gethostname())) as error:
      with safe_io.locked_dir(tmp_path / 'run'):
        pass
    assert '(this process)' in str(error.value)
    assert '\n' not in str(error.value)
    with safe_io.locked_dir(tmp_path / 'other'):  # Other directories: free.
      pass


def test_lock_is_released_on_exit_exception_and_interrupt(tmp_path):
  for error in (None, RuntimeError, KeyboardInterrupt):
    try:
      with safe_io.locked_dir(tmp_path, what='sweep directory'):
        if error is not None:
          raise error('stop')
    except (RuntimeError, KeyboardInterrupt):
      pass
    assert (tmp_path / safe_io.LOCK_FILE).read_text() == ''  # Names nobody.
    with safe_io.locked_dir(tmp_path):
      pass


def test_other_process_is_refused_and_a_killed_holder_blocks_nobody(
    tmp_path):
  process, (pid,) = _holder(tmp_path)
  try:
    with pytest.raises(safe_io.InUseError,
                       match=_message(tmp_path, pid, socket.gethostname())):
      with safe_io.locked_dir(tmp_path):
        pass
  finally:
    process.send_signal(signal.SIGKILL)
    process.wait()
  assert str(pid) in (tmp_path / safe_io.LOCK_FILE).read_text()  # Left over.
  with safe_io.locked_dir(tmp_path):  # The kernel released it.
    pass


def test_forked_child_does_not_keep_the_lock(tmp_path):
  """A child forked while the lock is held, alive after its parent was
  killed, does not hold the parent's directory."""
  process, (child, pid) = _holder(tmp_path, fork=True)
  try:
    process.send_signal(signal.SIGKILL)
    process.wait()
    os.kill(child, 0)  # Still alive.
    with safe_io.locked_dir(tmp_path):
      pass
  finally:
    os.kill(child, signal.SIGKILL)
  assert pid != child


def test_waiting_for_a_holder_that_ends(tmp_path):
  process, _ = _holder(tmp_path, hold_s=1.0)
  try:
    with pytest.raises(safe_io.InUseError, match=r'\(waited 0.1 s\); one'):
      with safe_io.locked_dir(tmp_path, wait_s=0.1):
        pass
    with safe_io.locked_dir(tmp_path, wait_s=60):
      pass
  finally:
    process.wait()


def test_locked_file_locks_one_file_of_a_folder(tmp_path):
  a, b = tmp_path / 'suite' / 'a.json', tmp_path / 'suite' / 'b.json'
  with safe_io.locked_file(a, what='eval output'):
    with safe_io.locked_file(b, what='eval output'):  # Side by side.
      pass
    with pytest.raises(safe_io.InUseError,
                       match=_message(a, os.getpid(), socket.gethostname(),
                                      'eval output')):
      with safe_io.locked_file(a, what='eval output'):
        pass
  assert sorted(os.listdir(tmp_path / 'suite')) == ['.a.json.lock',
                                                     '.b.json.lock']


def test_a_fifo_is_not_read_as_a_policy(tmp_path):
  from ble_latex import safe_io  # pylint: disable=g-import-not-at-top
  path = tmp_path / 'fifo.msgpack'
  import os  # pylint: disable=g-import-not-at-top
  os.mkfifo(path)
  with pytest.raises(errors.BadFileError, match='not a regular file'):
    safe_io.read_tree(str(path), file_format='x', what='SAC policy')
