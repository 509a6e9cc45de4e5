# coding=utf-8
"""Files that cannot run code: atomic writes, msgpack state files, locks.

Checkpoints and policies are trees of dicts, lists, strings, numbers and NumPy
arrays, written with flax's msgpack serialisation
(`flax.serialization.msgpack_serialize`). Reading such a file decodes data
only: a crafted file can at worst fail to load, never execute code. Every
file carries a format tag that `read_tree` checks, and every error names the
file.

Older ble_latex versions wrote pickles (`*.pkl`). Unpickling can run arbitrary
code, so `read_legacy_pickle` reads one only when the caller passes
`trust=True` (an explicit user opt-in, see README "Trusted files"), and even
then only through an unpickler that accepts NumPy arrays and optax's
optimiser-state tuples and refuses any other class.

A run directory (or sweep directory, or eval output) has one writer at a
time: `locked_dir` / `locked_file` hold an exclusive `fcntl.flock` on a lock
file for as long as the writer works. The kernel drops the lock when its
process ends, however it ends, so the lock file a killed process leaves
behind blocks nobody; while the lock is held the file names the holder
(pid, host, start time) for the message a second writer gets.
"""

import contextlib
import datetime
import fcntl
import json
import os
import pickle
import secrets
import socket
import time
from typing import Any, Dict, Iterator, Optional, Sequence, Tuple, Union

import numpy as np

from ble_latex import errors

FORMAT_KEY = 'format'
TMP_PREFIX = '.tmp-'
LOCK_FILE = '.lock'  # In a locked directory.
_LOCK_POLL_S = 0.5  # [s] Between tries while waiting for a lock.
# Lock file descriptors this process holds -> the pid that took them.
_HELD_LOCKS: Dict[int, int] = {}


# A policy is ~1 MB (an ensemble member too); a policy file above this is
# refused before it is read. Checkpoints (replay buffers) are bounded by the
# memory available instead. # [B]
MAX_POLICY_BYTES = 256 * 2**20


def available_memory_bytes() -> int:
  """Memory available to a new allocation now (MemAvailable). # [B]

  Linux's /proc/meminfo MemAvailable; elsewhere the free pages, else the
  physical memory.
  """
  try:
    with open('/proc/meminfo', encoding='ascii') as f:
      for line in f:
        if line.startswith('MemAvailable:'):
          return int(line.split()[1]) * 1024
  except (OSError, ValueError, IndexError):
    pass
  page = os.sysconf('SC_PAGE_SIZE')
  try:
    return page * os.sysconf('SC_AVPHYS_PAGES')
  except (ValueError, OSError):
    return page * os.sysconf('SC_PHYS_PAGES')


def check_file_size(path: str, what: str,
                    max_bytes: Optional[int] = None) -> int:
  """A regular file's size, refused above `max_bytes` before it is read.

  Args:
    path: The file.
    what: What it is, for the message (e.g. 'SAC policy').
    max_bytes: The most bytes; None: the memory available now
      (`available_memory_bytes`). # [B]

  Returns:
    The size. # [B]

  Raises:
    errors.BadFileError: Not a regular file (a FIFO, a device), or too big;
      one line naming `path`.
  """
  import stat  # pylint: disable=g-import-not-at-top
  info = os.stat(path)
  if not stat.S_ISREG(info.st_mode):
    raise errors.BadFileError(f'{what} {path} is not a regular file')
  limit = available_memory_bytes() if max_bytes is None else int(max_bytes)
  if info.st_size > limit:
    where = ('the memory available now' if max_bytes is None else
             f'the most a {what} may be')
    raise errors.BadFileError(
        f'{what} {path} is {info.st_size / 2**20:,.1f} MiB, more than '
        f'{where} ({limit / 2**20:,.1f} MiB); not read')
  return info.st_size


class UntrustedFileError(errors.BadFileError):
  """A pickle file was given without the explicit opt-in to trust it."""


class InUseError(RuntimeError):
  """Another writer (another process, or this one) holds a lock."""


def atomic_write(path: str, data: Union[bytes, str]) -> None:
  """Writes `data` to `path` so that `path` is either the old or the new file.

  Writes a uniquely named temporary file in the same folder (its name starts
  with `TMP_PREFIX`, which no checkpoint or policy pattern matches), fsyncs
  it, renames it over `path` and fsyncs the folder. On any error the
  temporary file is removed and `path` is left as it was.

  Args:
    path: Destination file; its folder is created if missing.
    data: Bytes, or text (written as UTF-8).
  """
  folder = os.path.dirname(os.path.abspath(path))
  os.makedirs(folder, exist_ok=True)
  if isinstance(data, str):
    data = data.encode('utf-8')
  tmp_path = os.path.join(folder, f'{TMP_PREFIX}{os.path.basename(path)}-'
                          f'{os.getpid()}-{secrets.token_hex(4)}')
  # Mode 0o666 minus the umask, like a plain open() (mkstemp would use 0o600).
  fd = os.open(tmp_path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
  try:
    with os.fdopen(fd, 'wb') as f:
      f.write(data)
      f.flush()
      os.fsync(f.fileno())
    os.replace(tmp_path, path)
  except BaseException:
    if os.path.exists(tmp_path):
      os.remove(tmp_path)
    raise
  try:  # Make the rename itself durable.
    dir_fd = os.open(folder, os.O_RDONLY)
    try:
      os.fsync(dir_fd)
    finally:
      os.close(dir_fd)
  except OSError:
    pass


def output_problem(path: str) -> Optional[str]:
  """Why a record cannot be written at `path`, or None (check before work).

  The folder must exist and be writable, and `path` must not be a folder:
  record writers check this before they fly or train, so a mistyped
  `--json`/`--output` fails at once rather than after the work.
  """
  folder = os.path.dirname(os.path.abspath(path))
  if not os.path.isdir(folder):
    return f'no folder {folder!r} for {path!r}'
  if os.path.isdir(path):
    return f'{path!r} is a folder, not a file'
  if not os.access(folder, os.W_OK):
    return f'the folder {folder!r} is not writable'
  return None


def remove_stale_temporaries(folder: str, prefix: str) -> None:
  """Removes `atomic_write` leftovers of a killed write (`TMP_PREFIX` + prefix)."""
  if not os.path.isdir(folder):
    return
  for name in os.listdir(folder):
    if name.startswith(TMP_PREFIX + prefix):
      os.remove(os.path.join(folder, name))


def _forget_locks_in_child() -> None:
  """After a fork: the child closes its copies of the parent's lock files.

  A flock belongs to the open file, which a fork shares: without this, a
  child that outlives a killed parent would keep the parent's directory
  locked. Closing the child's copy leaves the parent's lock as it is.
  """
  for fd in list(_HELD_LOCKS):
    try:
      os.close(fd)
    except OSError:
      pass
  _HELD_LOCKS.clear()


os.register_at_fork(after_in_child=_forget_locks_in_child)


def _holder(fd: int) -> str:
  """'pid P on host H (since T)' from a lock file, or a vaguer phrase."""
  try:
    info = json.loads(os.pread(fd, 4096, 0).decode('utf-8'))
    pid, host, since = int(info['pid']), str(info['host']), str(info['since'])
  except (OSError, ValueError, KeyError, TypeError):
    return 'another process'  # It has not written its name yet.
  mine = ' (this process)' if (pid == os.getpid() and
                               host == socket.gethostname()) else ''
  return f'pid {pid} on host {host} (since {since}){mine}'


@contextlib.contextmanager
def _hold(lock_path: str, target: str, what: str,
          wait_s: float) -> Iterator[None]:
  """Holds an exclusive flock on `lock_path` (see `locked_dir`)."""
  fd = os.open(lock_path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o666)
  deadline = time.monotonic() + wait_s
  try:
    while True:
      try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        break
      except BlockingIOError:
        if time.monotonic() >= deadline:
          waited = f' (waited {wait_s:g} s)' if wait_s > 0 else ''
          raise InUseError(
              f'{what} {target} is in use by {_holder(fd)}{waited}; one '
              f'writer per {what}') from None
        time.sleep(_LOCK_POLL_S)
  except BaseException:
    os.close(fd)
    raise
  owner = os.getpid()
  _HELD_LOCKS[fd] = owner
  try:
    since = datetime.datetime.now(datetime.timezone.utc).strftime(
        '%Y-%m-%dT%H:%M:%SZ')
    os.ftruncate(fd, 0)
    os.pwrite(fd, (json.dumps({'pid': owner, 'host': socket.gethostname(),
                               'since': since}) + '\n').encode('utf-8'), 0)
    yield
  finally:
    # A forked child that runs this has already closed its copy (and must
    # not unlock the parent's lock, which the open file shares).
    if _HELD_LOCKS.get(fd) == owner == os.getpid():
      del _HELD_LOCKS[fd]
      try:
        os.ftruncate(fd, 0)  # Names nobody once released.
      finally:
        fcntl.flock(fd, fcntl.LOCK_UN)
        os.close(fd)


def locked_dir(directory: str, *, what: str = 'run directory',
               wait_s: float = 0.0) -> contextlib.AbstractContextManager:
  """Context manager: this process is the one writer of `directory`.

  Takes an exclusive `fcntl.flock` on `directory/LOCK_FILE` (the directory
  is created if missing) and writes this process's pid, host and start time
  into it. The lock is released when the block ends, normally or by an
  exception (KeyboardInterrupt included), and by the kernel when the
  process dies: a lock file left by a killed process blocks nobody. It is
  not inherited: the file is closed on exec, and a forked child closes its
  copy. A second lock on the same directory conflicts, also within one
  process.

  Args:
    directory: The directory to lock.
    what: What it is, for the message (e.g. 'sweep directory').
    wait_s: How long to wait for another holder to finish (e.g. a killed
      sweep's worker that is still exiting); 0: refuse at once. # [s]

  Returns:
    The context manager.

  Raises:
    InUseError: On entering, if another writer holds the lock:
      '<what> <directory> is in use by pid P on host H (since T); one writer
      per <what>'.
  """
  directory = os.path.abspath(directory)
  os.makedirs(directory, exist_ok=True)
  return _hold(os.path.join(directory, LOCK_FILE), directory, what, wait_s)


def locked_file(path: str, *, what: str = 'output file',
                wait_s: float = 0.0) -> contextlib.AbstractContextManager:
  """`locked_dir` for one file: locks `.<name>.lock` beside `path`.

  For outputs that several writers put into one folder under different
  names (e.g. eval shards), so that only writers of the same file conflict.
  """
  path = os.path.abspath(path)
  folder, name = os.path.split(path)
  os.makedirs(folder, exist_ok=True)
  return _hold(os.path.join(folder, f'.{name}.lock'), path, what, wait_s)


def _check_tree(tree: Any, where: str) -> None:
  """Raises TypeError for anything msgpack would not store as plain data."""
  if isinstance(tree, dict):
    for key, value in tree.items():
      if not isinstance(key, str):
        raise TypeError(f'{where}: key {key!r} is not a string')
      _check_tree(value, f'{where}/{key}')
  elif isinstance(tree, list):
    for i, value in enumerate(tree):
      _check_tree(value, f'{where}[{i}]')
  elif isinstance(tree, np.ndarray):
    if tree.dtype.hasobject:
      raise TypeError(f'{where}: object arrays cannot be stored')
  elif not (tree is None or isinstance(tree, (bool, int, float, str,
                                              np.generic))):
    raise TypeError(f'{where}: cannot store a {type(tree).__name__} (use '
                    'dicts with string keys, lists, numbers, strings, arrays)')


def write_tree(path: str, tree: dict, *, file_format: str) -> None:
  """Writes a data tree atomically as msgpack, tagged with `file_format`.

  Args:
    path: Destination file.
    tree: Dict of dicts / lists / numbers / strings / NumPy arrays (no tuples,
      no objects); the key `FORMAT_KEY` is set to `file_format`.
    file_format: Format tag that `read_tree` checks.

  Raises:
    TypeError: If the tree holds anything but plain data.
  """
  from flax import serialization  # pylint: disable=g-import-not-at-top  # Light import of this module.
  tree = {**tree, FORMAT_KEY: file_format}
  _check_tree(tree, os.path.basename(path))
  atomic_write(path, serialization.msgpack_serialize(tree))


def read_tree(path: str, *, file_format: str, what: str = 'file',
              max_bytes: Optional[int] = None) -> dict:
  """Reads a `write_tree` file; decodes data only (no code can run).

  Args:
    path: File to read.
    file_format: The format tag the file must carry.
    what: What the file is, for error messages (e.g. 'SAC checkpoint').
    max_bytes: The largest file read (`check_file_size`; None: the memory
      available now). # [B]

  Returns:
    The tree (dict), including `FORMAT_KEY`. Arrays are read-only views of
    the file's bytes; copy them before writing into them.

  Raises:
    FileNotFoundError: If `path` does not exist.
    errors.BadFileError (a ValueError): If `path` is a directory, not a
      msgpack file, truncated or corrupt, carries another format tag, or is
      not a regular file or bigger than `max_bytes`; the message names
      `path`.
  """
  if os.path.isdir(path):
    raise errors.BadFileError(f'{what} {path} is a directory, not a file')
  if not os.path.exists(path):
    raise FileNotFoundError(f'no {what} at {path}')
  check_file_size(path, what, max_bytes)  # Before a byte is read.
  with open(path, 'rb') as f:
    data = f.read()
  if data[:1] == b'\x80' and data[1:2] in (b'\x02', b'\x03', b'\x04',
                                           b'\x05'):
    raise UntrustedFileError(
        f'{path} is a pickle ({what} of an older ble_latex?). Pickles can run '
        'code and are not read by default; see docs/trusted-files.md to '
        'convert one you made yourself.')
  from flax import serialization  # pylint: disable=g-import-not-at-top
  try:
    tree = serialization.msgpack_restore(data)
  except Exception as e:  # msgpack raises several types for bad bytes.
    raise errors.BadFileError(
        f'{what} {path} is truncated or corrupt (not a '
        f'readable msgpack file: {type(e).__name__}: {e})') from e
  if not isinstance(tree, dict) or tree.get(FORMAT_KEY) != file_format:
    found = tree.get(FORMAT_KEY) if isinstance(tree, dict) else None
    raise errors.BadFileError(f'{path} is not a {what} (format {file_format!r} '
                              f'expected, found {found!r})')
  # Only what `write_tree` stores: a msgpack ext type (which would load and
  # then fail when the tree is used or written again) or a non-string key
  # is refused here, naming the file.
  try:
    _check_tree(tree, 'top level')
  except TypeError as e:
    raise errors.BadFileError(f'{what} {path}: {e} (not written by '
                              'ble_latex)') from e
  return tree


# --- Checking what a file holds ---------------------------------------------
# A data file cannot run code, but its numbers can still be wrong: NaN weights,
# a complex or integer array where weights belong, a negative counter. These
# checks run on the host copy of what was read, before anything is built from
# it, and name the file and the entry.


@contextlib.contextmanager
def checking(what: str = '') -> Iterator[None]:
  """Checks of what a read file holds: their refusals are the file's.

  A ValueError, TypeError or KeyError raised in the block (a missing entry,
  a wrong shape, a NaN, an out-of-range counter, from whichever check) is
  re-raised as `errors.BadFileError` with the same message, prefixed by
  `what` (e.g. 'SAC checkpoint P: '), so commands report it as a bad file
  (one line, exit 1).
  """
  try:
    yield
  except (ValueError, TypeError, KeyError) as e:
    raise errors.BadFileError(f'{what}{e}') from e


def leaf_name(path: Sequence[Any]) -> str:
  """'params/actor/Dense_0/kernel' for a `jax.tree_util` key path."""
  parts = []
  for key in path:
    for attr in ('key', 'name', 'idx'):
      if hasattr(key, attr):
        parts.append(str(getattr(key, attr)))
        break
    else:
      parts.append(str(key))
  return '/'.join(parts) or '.'


def checked_array(value: Any, what: str, *, kind: str = 'float',
                  shape: Optional[Tuple[int, ...]] = None) -> np.ndarray:
  """A stored array of real floats (all finite) or of integers.

  Args:
    value: The stored value (array, number or nested list).
    what: The file and entry, for the message.
    kind: 'float' (real floating point, every value finite) or 'int'
      (integers, no booleans).
    shape: The shape it must have, if given.

  Returns:
    `value` as a NumPy array.

  Raises:
    ValueError: On another dtype (complex, object, integers for 'float'),
      another shape or a NaN / inf; the message names `what`.
  """
  try:
    array = np.asarray(value)
  except (TypeError, ValueError) as e:
    raise ValueError(f'{what} is not an array ({e})') from e
  expected = {'float': 'f', 'int': 'iu'}[kind]
  if array.dtype.kind not in expected:
    wanted = 'real floating point' if kind == 'float' else 'integer'
    raise ValueError(f'{what} has dtype {array.dtype}; expected {wanted} '
                     'values')
  if shape is not None and array.shape != tuple(shape):
    raise ValueError(f'{what} has shape {array.shape}, expected '
                     f'{tuple(shape)}')
  if kind == 'float':
    bad = array.size - int(np.count_nonzero(np.isfinite(array)))
    if bad:
      raise ValueError(f'{what} has {bad} non-finite value'
                       f'{"s" if bad > 1 else ""} (NaN/inf)')
  return array


def checked_count(value: Any, what: str, *, low: int = 0,
                  high: Optional[int] = None) -> int:
  """A stored counter: an integer (not a float or bool) in [low, high]."""
  if isinstance(value, np.ndarray) and value.ndim == 0:
    value = value[()]
  if isinstance(value, (bool, np.bool_)) or not isinstance(
      value, (int, np.integer)):
    raise ValueError(f'{what} must be an integer, got {value!r}')
  if value < low or (high is not None and value > high):
    bounds = f'>= {low}' + (f' and <= {high}' if high is not None else '')
    raise ValueError(f'{what} must be {bounds}, got {int(value)}')
  return int(value)


# Classes a legacy ble_latex pickle may contain: NumPy arrays and scalars, and
# optax's optimiser-state named tuples (checkpoints only). Nothing callable
# beyond these constructors is ever looked up.
_NUMPY_GLOBALS = frozenset([
    ('numpy', 'ndarray'), ('numpy', 'dtype'),
    ('numpy.core.multiarray', '_reconstruct'),
    ('numpy._core.multiarray', '_reconstruct'),
    ('numpy.core.multiarray', 'scalar'),
    ('numpy._core.multiarray', 'scalar'),
    ('numpy.core.numeric', '_frombuffer'),
    ('numpy._core.numeric', '_frombuffer'),
    ('builtins', 'set'), ('builtins', 'frozenset'),
])


class _DataOnlyUnpickler(pickle.Unpickler):
  """Unpickler that resolves only `_NUMPY_GLOBALS` and optax NamedTuples."""

  def find_class(self, module: str, name: str) -> Any:
    if (module, name) in _NUMPY_GLOBALS:
      return super().find_class(module, name)
    if module.startswith('optax.') or module.startswith('numpy.dtypes'):
      cls = super().find_class(module, name)
      if isinstance(cls, type) and (issubclass(cls, tuple) or issubclass(
          cls, np.dtype)):
        return cls
    raise pickle.UnpicklingError(f'refusing to load {module}.{name}')


def read_legacy_pickle(path: str, *, trust: bool, what: str = 'file') -> Any:
  """Reads a pickle written by an older ble_latex, only if `trust` is True.

  Args:
    path: The `.pkl` file.
    trust: The user's explicit statement that they made this file (or trust
      whoever did). False raises `UntrustedFileError`.
    what: What the file is, for error messages.

  Returns:
    The unpickled object (dicts, lists, numbers, strings, arrays, optax
    state tuples).

  Raises:
    UntrustedFileError: If `trust` is False.
    FileNotFoundError: If `path` does not exist.
    errors.BadFileError (a ValueError): If the file is corrupt, truncated or
      refers to any class outside the allowed data classes; names `path`.
  """
  if not trust:
    raise UntrustedFileError(
        f'{path} is a legacy pickle {what}; pickles can run code, so it is '
        'read only with the explicit opt-in (docs/trusted-files.md).')
  if os.path.isdir(path):
    raise errors.BadFileError(f'{what} {path} is a directory, not a file')
  if not os.path.exists(path):
    raise FileNotFoundError(f'no {what} at {path}')
  check_file_size(path, what)
  try:
    with open(path, 'rb') as f:
      return _DataOnlyUnpickler(f).load()
  except (pickle.UnpicklingError, EOFError, AttributeError, ImportError,
          IndexError, TypeError, ValueError, KeyError) as e:
    raise errors.BadFileError(f'unreadable legacy {what} {path}: '
                              f'{type(e).__name__}: {e}') from e
