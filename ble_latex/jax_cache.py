# coding=utf-8
"""JAX's persistent compilation cache for the latex envs, on request.

The env's jitted functions (one balloon's draw/measure/observation/step and
the batched vector env's) take 20-60 s to compile on a small CPU, every
process. `enable()` points JAX's own persistent compilation cache
(`jax_compilation_cache_dir`, keyed by the compiled program, JAX version,
backend and flags) at a per-user directory, so a new process loads them from
disk instead (it still traces them, ~2-5 s).

Opt-in, because it is process-wide (every jit compilation of the process
longer than `jax_persistent_cache_min_compile_time_secs`, 1 s, is cached
there) and JAX runs what it loads from that directory: the envs call
`enable()` only when $BLE_LATEX_JAX_CACHE=1; a program may call it itself.
It is left alone when the process already chose a cache directory
(`jax.config.update('jax_compilation_cache_dir', ...)` or
$JAX_COMPILATION_CACHE_DIR). $BLE_LATEX_JAX_CACHE_DIR sets the directory
(default $XDG_CACHE_HOME/ble_latex/jax or ~/.cache/ble_latex/jax, mode
0700).
"""

import importlib.util
import os
from typing import Optional

ENV_SWITCH = 'BLE_LATEX_JAX_CACHE'
ENV_DIR = 'BLE_LATEX_JAX_CACHE_DIR'
# Size bound of the directory we create (JAX evicts least recently used
# entries, and locks the directory while reading and writing, so concurrent
# processes never read a half-written entry).
MAX_SIZE_BYTES = 2 * 1024**3


def default_dir() -> str:
  """`$XDG_CACHE_HOME/ble_latex/jax` (default `~/.cache/ble_latex/jax`)."""
  base = os.environ.get('XDG_CACHE_HOME') or os.path.join(
      os.path.expanduser('~'), '.cache')
  return os.path.join(base, 'ble_latex', 'jax')


def enabled_by_env() -> bool:
  """Whether the user asked for the cache ($BLE_LATEX_JAX_CACHE=1)."""
  return os.environ.get(ENV_SWITCH, '0').strip().lower() in (
      '1', 'true', 'yes', 'on')


def enable_if_requested() -> Optional[str]:
  """`enable()` when $BLE_LATEX_JAX_CACHE=1, else nothing (the envs' call).

  Returns:
    As `enable()`; None when not requested.
  """
  return enable() if enabled_by_env() else None


def enable() -> Optional[str]:
  """Turns on JAX's persistent compilation cache unless chosen already.

  Returns:
    The cache directory in use (the process's own if it set one), or None
    when the directory cannot be created.
  """
  import jax  # pylint: disable=g-import-not-at-top
  current = jax.config.jax_compilation_cache_dir
  if current:
    return current
  path = os.environ.get(ENV_DIR) or default_dir()
  try:
    os.makedirs(path, mode=0o700, exist_ok=True)
  except OSError:
    return None
  jax.config.update('jax_compilation_cache_dir', path)
  if (jax.config.jax_compilation_cache_max_size == -1 and
      importlib.util.find_spec('filelock') is not None):
    jax.config.update('jax_compilation_cache_max_size', MAX_SIZE_BYTES)
  return path


# XLA's CPU compiler options for the single Gymnasium env's programs (draw,
# start, step; the vector env's batched step runs ~10 % faster with XLA's
# defaults and keeps them): with the loop emitters instead of the fusion
# emitters the single env's three compile in 3.6 s instead of 4.8 s (5.1 s
# instead of 7.7 s of CPU) and its step runs as fast
# (`benchmarks/compile_options.py`, docs/benchmarks.md); values agree with
# the default compile to float32 rounding (not bit for bit). Per program
# (`jax.jit`'s `compiler_options`), not process-wide.
CPU_FAST_COMPILE = {'xla_cpu_use_fusion_emitters': False}


def fast_compile_options() -> Optional[dict]:
  """`compiler_options` for `jax.jit` of the envs' small programs.

  Returns:
    `CPU_FAST_COMPILE` on the CPU backend, None (XLA's defaults) elsewhere.
  """
  import jax  # pylint: disable=g-import-not-at-top
  return dict(CPU_FAST_COMPILE) if jax.default_backend() == 'cpu' else None
