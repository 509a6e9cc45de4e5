"""benchmarks/gpu/dagger.sh's command line (no GPU, no training).

The driver's Python is a stub that prints its arguments, so what the script
would run is read back from its logs; refused settings end it before it
writes anything.
"""

import os
import subprocess

from tests import helpers

SCRIPT = helpers.ROOT / 'benchmarks' / 'gpu' / 'dagger.sh'


def _run(tmp_path, *args, **env):
  stub = tmp_path / 'python'
  stub.write_text('#!/bin/sh\necho "ARGS $*"\n')
  stub.chmod(0o755)
  return subprocess.run(
      ['bash', str(SCRIPT), str(tmp_path / 'out'), *args],
      cwd=helpers.ROOT, capture_output=True, text=True, timeout=60,
      env={**os.environ, 'PYTHON': str(stub), 'RUNS': str(tmp_path / 'runs'),
           **env})


def test_gin_files_come_first_and_in_order(tmp_path):
  files = ('gin_configs/latex_realistic.gin,'
           'gin_configs/latex_realistic_task.gin')
  done = _run(tmp_path, '100', '0', '2', DAGGER_GIN_FILES=files,
              DAGGER_BINDINGS='LatexMpcAgent.resource_buffer_kg = 0.6')
  assert done.returncode == 0, done.stderr
  line = next(l for l in (tmp_path / 'out' / 'seed_0.log').read_text()
              .splitlines() if 'train_dagger.py' in l)
  first = line.index('--gin_file=gin_configs/latex_realistic.gin')
  second = line.index('--gin_file=gin_configs/latex_realistic_task.gin')
  binding = line.index('--gin_bindings=dagger_config.num_balloons = 2')
  extra = line.index('--gin_bindings=LatexMpcAgent.resource_buffer_kg = 0.6')
  assert first < second < binding < extra


def test_a_missing_gin_file_is_refused_before_anything_runs(tmp_path):
  done = _run(tmp_path, '100', DAGGER_GIN_FILES='gin_configs/nope.gin')
  assert done.returncode == 2
  assert done.stderr.strip() == (
      'dagger.sh: DAGGER_GIN_FILES: no file gin_configs/nope.gin')
  assert not (tmp_path / 'out').exists()


def test_more_than_three_seeds_are_refused(tmp_path):
  done = _run(tmp_path, '100', '0,1,2,3')
  assert done.returncode == 2
  assert 'at most 3 seeds' in done.stderr
  assert not (tmp_path / 'out').exists()
