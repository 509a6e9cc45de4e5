# coding=utf-8
"""Silences known third-party start-up noise that ble_latex triggers.

Building a latex env imports gym 0.25, BLE and (through BLE's VAE wind model)
TensorFlow, which print a screenful of notices nobody can act on: gym's
"unmaintained" notice, deprecation warnings from BLE's module code, and
TensorFlow's C++ start-up lines (oneDNN, "Could not find cuda drivers"; TF
2.21 prints them before its logging is set up, so TF_CPP_MIN_LOG_LEVEL does
not hide them). `third_party_noise()` drops exactly those, and only while
ble_latex imports and builds an env (it is not a process-wide filter):

- Python warnings matching `KNOWN_WARNINGS` (message and category);
- the exact texts of `known_stderr()` written to `sys.stderr` (gym's notice);
- lines written to file descriptor 2 matching `KNOWN_NATIVE_LINES`;
- log records (absl's and the root logger) starting with `KNOWN_LOG_MESSAGES`.

Everything else written to stderr meanwhile (our own warnings, errors and
tracebacks included) is passed on unchanged when the block ends.
"""

import contextlib
import io
import logging
import os
import re
import sys
import tempfile
import warnings
from typing import Any, Iterator, Optional, Tuple, Type

# (message regex, category) of warnings BLE 1.0.1 / gym 0.25.2 raise at import
# or construction on today's stack; none is actionable by a user.
KNOWN_WARNINGS: Tuple[Tuple[str, Type[Warning]], ...] = (
    # scipy, from BLE's env/balloon/acs.py module code.
    (r'Please import `interp[12]d` from the `scipy.interpolate` namespace',
     DeprecationWarning),
    # importlib.resources, from BLE's models/models.py (loads the VAE).
    (r'open_binary is deprecated', DeprecationWarning),
    # tensorflow_probability 0.25 at import, and its jax substrate.
    (r'distutils Version classes are deprecated', DeprecationWarning),
    (r'jax\.core\.pytype_aval_mappings is deprecated', DeprecationWarning),
    # gym 0.25.2: gym.make's wrappers and its passive checker on BLE's
    # (old step API) envs, which BLE's agents need.
    (r'.*Initializing (wrapper|environment) in old step API', DeprecationWarning),
    (r'.*Core environment is written in old step API', DeprecationWarning),
    # gym 0.25.2, from BLE's own gym plugin (env/gym.py) at `import gym`.
    (r'.*The `registry.env_specs` property along with `EnvSpecTree` is '
     r'deprecated', UserWarning),
)
# Whole lines TensorFlow's native code writes to fd 2 while it loads (INFO
# level, plus absl's note that precedes them).
KNOWN_NATIVE_LINES: Tuple[str, ...] = (
    r'WARNING: All log messages before absl::InitializeLog\(\) is called are '
    r'written to STDERR',
    r'I\d{4} [\d:.]+ +\d+ port\.cc:\d+\] oneDNN custom operations are on\. .*',
    r'I\d{4} [\d:.]+ +\d+ cudart_stub\.cc:\d+\] Could not find cuda drivers '
    r'on your machine, GPU will not be used\.',
    r'I\d{4} [\d:.]+ +\d+ cpu_feature_guard\.cc:\d+\] This TensorFlow binary '
    r'is optimized to use available CPU instructions in performance-critical '
    r'operations\.',
    r'To enable the following instructions: .*, in other operations, rebuild '
    r'TensorFlow with the appropriate compiler flags\.',
    # TF probing for a GPU on a machine without CUDA driver or device (when
    # dopamine's SAC module hides GPUs from TF at import).
    r'E\d{4} [\d:.]+ +\d+ cuda_platform\.cc:\d+\] failed call to cuInit: '
    r'INTERNAL: CUDA error: Failed call to cuInit: UNKNOWN ERROR \(303\)',
)
# Python log records (absl logger) third-party modules emit at import.
KNOWN_LOG_MESSAGES: Tuple[str, ...] = (
    # dopamine 4.0.9, jax/agents/sac/sac_agent.py module code.
    'Setting tf to CPU only, to avoid OOM.',
    # jax (INFO) when it first starts its backends on a machine without TPU.
    "Unable to initialize backend 'tpu'",
)
_NATIVE = re.compile('|'.join(f'(?:{p})' for p in KNOWN_NATIVE_LINES))


def known_stderr() -> Tuple[str, ...]:
  """Exact texts printed to sys.stderr that are dropped: gym's notices.

  gym 0.25.2 prints `gym_notices.notices.notices[gym version]` ("Gym has been
  unmaintained since 2022 ...") at import.
  """
  try:
    from gym_notices import notices  # pylint: disable=g-import-not-at-top
  except ImportError:
    return ()
  return tuple(f'{text}\n' for text in notices.notices.values() if text)


def filter_python_stderr(text: str) -> str:
  """The text with every known third-party notice (`known_stderr`) removed."""
  for notice in known_stderr():
    text = text.replace(notice, '')
  return text


def filter_native_stderr(text: str) -> str:
  """The text without the known native-library notice lines (`_NATIVE`)."""
  return ''.join(line for line in text.splitlines(keepends=True)
                 if not _NATIVE.fullmatch(line.rstrip('\r\n')))


@contextlib.contextmanager
def _capture_fd2() -> Iterator[None]:
  """Sends fd 2 to a temp file; on exit writes back what is not known noise."""
  try:
    saved = os.dup(2)
  except OSError:  # No fd 2: nothing to capture.
    yield
    return
  with tempfile.TemporaryFile() as tmp:
    _flush(sys.__stderr__)
    os.dup2(tmp.fileno(), 2)
    try:
      yield
    finally:
      _flush(sys.__stderr__)
      os.dup2(saved, 2)
      os.close(saved)
      tmp.seek(0)
      text = filter_native_stderr(tmp.read().decode('utf-8', 'replace'))
      if text:
        os.write(2, text.encode('utf-8'))


def _flush(stream: Optional[io.IOBase]) -> None:
  try:
    if stream is not None:
      stream.flush()
  except (OSError, ValueError):
    pass


class _DropKnownRecords(logging.Filter):

  def filter(self, record: logging.LogRecord) -> bool:
    try:
      message = record.getMessage()
    except Exception:  # pylint: disable=broad-except
      return True
    return not message.startswith(KNOWN_LOG_MESSAGES)


@contextlib.contextmanager
def _known_log_records_dropped() -> Iterator[None]:
  """Drops known records at the handlers that would print them.

  Records of child loggers (e.g. jax's) propagate to the root logger's
  handlers without passing the root logger's own filters, so the filter goes
  on the handlers (absl's is on the root logger) and on logging.lastResort.
  """
  targets = [logging.getLogger('absl'), logging.lastResort,
             *logging.getLogger().handlers,
             *logging.getLogger('absl').handlers]
  with log_filter(_DropKnownRecords(), *[t for t in targets if t is not None]):
    yield


@contextlib.contextmanager
def log_filter(record_filter: Any, *targets: Any) -> Iterator[None]:
  """`record_filter` on each target (loggers, handlers) during the block."""
  for target in targets:
    target.addFilter(record_filter)
  try:
    yield
  finally:
    for target in targets:
      target.removeFilter(record_filter)


# Logger of JAX's backend start-up (its "Unable to initialize backend 'tpu'"
# INFO record), filtered while a command runs (`command_logs`).
JAX_BACKEND_LOGGER = 'jax._src.xla_bridge'
# Dopamine's modules whose INFO records list an agent's or replay buffer's
# constructor arguments (~30 lines per agent built).
DOPAMINE_PARAMETER_DUMPS: Tuple[str, ...] = (
    os.path.join('dopamine', 'jax', 'agents'),
    os.path.join('dopamine', 'replay_memory'),
)


@contextlib.contextmanager
def command_logs() -> Iterator[None]:
  """While a command runs: drops JAX's known backend start-up record.

  JAX starts its backends at its first computation, wherever that happens, so
  the record is filtered at its own logger (not the root's handlers) for the
  command's duration only.
  """
  with log_filter(_DropKnownRecords(), logging.getLogger(JAX_BACKEND_LOGGER)):
    yield


class _DopamineInfoAtDebug(logging.Filter):
  """Dopamine's INFO parameter dumps become DEBUG records."""

  def filter(self, record: logging.LogRecord) -> bool:
    if (record.levelno != logging.INFO or
        not any(part in record.pathname for part in DOPAMINE_PARAMETER_DUMPS)):
      return True
    record.levelno, record.levelname = logging.DEBUG, 'DEBUG'
    return logging.getLogger('absl').isEnabledFor(logging.DEBUG)


@contextlib.contextmanager
def dopamine_parameters_at_debug() -> Iterator[None]:
  """Dopamine's constructor-argument dump is logged at DEBUG in the block.

  Dopamine's agents and replay buffers log every constructor argument at INFO
  (through absl's logger) when built; inside the block those records are
  DEBUG records, shown only with `--verbosity=1` (absl) or a DEBUG logger.
  """
  with log_filter(_DopamineInfoAtDebug(), logging.getLogger('absl')):
    yield


def is_known_warning(message: Warning, category: Type[Warning]) -> bool:
  """Whether a warning is one of `KNOWN_WARNINGS` (dropped at start-up)."""
  return any(issubclass(category, known) and re.match(pattern, str(message))
             for pattern, known in KNOWN_WARNINGS)


def _drop_known(show):
  def showwarning(message, category, *args, **kwargs):
    if not is_known_warning(message, category):
      show(message, category, *args, **kwargs)
  return showwarning


_depth = 0  # Nesting level: only the outermost block captures.


@contextlib.contextmanager
def third_party_noise() -> Iterator[None]:
  """Drops the known third-party notices raised inside the block."""
  global _depth
  _depth += 1
  try:
    with warnings.catch_warnings():
      for message, category in KNOWN_WARNINGS:
        warnings.filterwarnings('ignore', message=message, category=category)
      # Libraries imported meanwhile may put filters in front of ours (gym's
      # logger adds simplefilter('once', DeprecationWarning) at import), so
      # known warnings are also dropped where they would be shown.
      warnings.showwarning = _drop_known(warnings.showwarning)
      if _depth > 1:
        yield
        return
      captured = io.StringIO()
      original = sys.stderr
      try:
        with _capture_fd2(), contextlib.redirect_stderr(captured), \
            _known_log_records_dropped():
          yield
      finally:
        text = filter_python_stderr(captured.getvalue())
        if text:
          original.write(text)
          _flush(original)
  finally:
    _depth -= 1
