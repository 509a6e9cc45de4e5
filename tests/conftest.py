"""Shared pytest setup: ble_latex is imported first so its BLE fixes apply.

The test session shares one JAX persistent compilation cache (a fresh
temporary directory, through $JAX_COMPILATION_CACHE_DIR, which JAX reads at
import and the commands the tests start inherit): the flight core takes
tens of seconds to compile on 2 cores, and the train/eval commands run as
subprocesses would otherwise compile it again each time. Only this test
session uses the directory; the package itself never turns the cache on.

Unless $XLA_FLAGS is set (even empty), the suite compiles with XLA's CPU
loop emitters (`--xla_cpu_use_fusion_emitters=false`, what the single
Gymnasium env's programs use, `jax_cache.CPU_FAST_COMPILE`): the default
suite is compile-bound, and this takes a quarter of its CPU time off
(860 s -> 650 s of user CPU, 7 min 52 s -> 5 min 55 s, run back to back on
2026-11-26);
values agree with the default compile to float32 rounding, within every
tolerance here. `make test-ci` sets XLA_FLAGS empty, so CI also runs the
real clients compiled as users compile them.
"""

import atexit
import os
import shutil
import tempfile

import pytest

os.environ.setdefault('TF_CPP_MIN_LOG_LEVEL', '3')
os.environ.setdefault('JAX_PLATFORMS', 'cpu')
os.environ.setdefault('XLA_FLAGS', '--xla_cpu_use_fusion_emitters=false')
if 'JAX_COMPILATION_CACHE_DIR' not in os.environ:
  _CACHE = tempfile.mkdtemp(prefix='ble_latex_test_jax_cache_')
  os.environ['JAX_COMPILATION_CACHE_DIR'] = _CACHE
  atexit.register(shutil.rmtree, _CACHE, ignore_errors=True)

pytest_plugins = ('pytester',)  # tests/test_conftest.py runs a session in one.

import ble_latex  # noqa: E402,F401  pylint: disable=g-import-not-at-top,unused-import

# $BLE_LATEX_TEST_COMPILES=DIR: each test process appends one JSON line per
# test to DIR/<worker>.jsonl: {"test", "compiles", "compile_s", "wall_s"}
# (JAX's backend compiles, persistent-cache reads included, and their
# seconds; subprocesses are not counted). Measurement only: finds tests that
# recompile (e.g. per hypothesis example); off by default.
_COMPILE_LOG = os.environ.get('BLE_LATEX_TEST_COMPILES')
_COMPILES = {'count': 0, 'seconds': 0.0}


def _count_compile(event: str, duration_s: float, **kwargs) -> None:
  del kwargs
  if event == '/jax/core/compile/backend_compile_duration':
    _COMPILES['count'] += 1
    _COMPILES['seconds'] += duration_s


if _COMPILE_LOG:
  import jax.monitoring  # pylint: disable=g-import-not-at-top
  jax.monitoring.register_event_duration_secs_listener(_count_compile)

  @pytest.hookimpl(hookwrapper=True)
  def pytest_runtest_protocol(item, nextitem):
    """Logs the test's compiles (setup and teardown included)."""
    del nextitem
    import json  # pylint: disable=g-import-not-at-top
    import time  # pylint: disable=g-import-not-at-top
    before = dict(_COMPILES)
    began = time.monotonic()
    yield
    record = {'test': item.nodeid,
              'compiles': _COMPILES['count'] - before['count'],
              'compile_s': round(_COMPILES['seconds'] - before['seconds'], 3),
              'wall_s': round(time.monotonic() - began, 3)}
    os.makedirs(_COMPILE_LOG, exist_ok=True)
    worker = os.environ.get('PYTEST_XDIST_WORKER', 'main')
    with open(os.path.join(_COMPILE_LOG, f'{worker}.jsonl'), 'a',
              encoding='utf-8') as f:
      f.write(json.dumps(record) + '\n')


@pytest.fixture(autouse=True, scope='module')
def _free_compiled_code():
  """Drops JAX's in-memory compiled programs after each test module.

  Every XLA:CPU executable keeps its machine code in memory mappings of its
  own; the whole suite in one process compiles enough of them to exhaust
  the process's mappings ('LLVM ERROR: Unable to allocate section memory',
  seen at ~520 tests). Recompiling in a later module mostly reads the
  session's persistent cache (above).
  """
  yield
  import sys  # pylint: disable=g-import-not-at-top
  if 'jax' in sys.modules:
    sys.modules['jax'].clear_caches()


@pytest.fixture(autouse=True, scope='module')
def _fresh_gin():
  """Each test module starts and ends with gin's bindings cleared.

  Gin's bindings are process-wide; under pytest-xdist one worker runs many
  modules (`--dist loadfile`), so a binding left by one module (a wind
  file, an env setting) would reach the next and make its result depend on
  the file order (a 3-day Gymnasium comparison failed so, passing alone).
  No test module binds gin at import, so clearing at its first test's
  setup loses nothing of its own.
  """
  import gin  # pylint: disable=g-import-not-at-top
  gin.clear_config()
  yield
  gin.clear_config()


@pytest.fixture(scope='session')
def atmosphere():
  """BLE's standard atmosphere (PRNG key 0), shared by the physics tests."""
  # pylint: disable=g-import-not-at-top
  from balloon_learning_environment.env.balloon import standard_atmosphere
  import jax
  # pylint: enable=g-import-not-at-top
  return standard_atmosphere.Atmosphere(jax.random.PRNGKey(0))


@pytest.fixture
def benchmark_script():
  """Loads a script of benchmarks/ as a module: `benchmark_script('x.py')`."""
  import importlib.util  # pylint: disable=g-import-not-at-top

  def load(name):
    path = os.path.join(os.path.dirname(__file__), '..', 'benchmarks', name)
    spec = importlib.util.spec_from_file_location(name[:-3], path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module

  return load
