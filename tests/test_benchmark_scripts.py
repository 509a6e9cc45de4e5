"""The planner benchmark scripts' own checks (benchmarks/planners.py --seeds,
benchmarks/gpu/boot_no_tensorflow.py's stand-in modules)."""

import importlib.util
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _load(name, path):
  spec = importlib.util.spec_from_file_location(name, path)
  module = importlib.util.module_from_spec(spec)
  spec.loader.exec_module(module)
  return module


@pytest.mark.parametrize('seeds, message', [
    ('5', '--seeds: [5] not among the 100 seeds of latex_small'),
    ('1000000,x', "--seeds: integers, got ['1000000', 'x']"),
])
def test_planners_seeds_outside_the_suite_are_one_line(tmp_path, capsys,
                                                       seeds, message):
  planners = _load('bench_planners', ROOT / 'benchmarks' / 'planners.py')
  rc = planners.main(['--suite=latex_small', f'--seeds={seeds}',
                      f'--output_dir={tmp_path}'])
  err = capsys.readouterr().err.strip().splitlines()
  assert rc == 2
  assert err == [f'benchmarks/planners.py: {message}']
  assert not list(tmp_path.rglob('*.json'))  # Nothing written.


def test_no_tensorflow_stand_ins_fail_loudly():
  """The stand-ins import, but any use of them raises (no silent stub)."""
  code = (
      'import sys; sys.path.insert(0, "benchmarks/gpu");'
      'import boot_no_tensorflow as b; b.install_stubs();'
      'import tensorflow as tf;'
      'from flax.metrics import tensorboard;'
      'from tensorflow_probability.substrates import jax as tfp\n'
      'for use in (lambda: tf.io, lambda: tfp.distributions,'
      '            lambda: tensorboard.SummaryWriter("/tmp/x")):\n'
      '  try:\n'
      '    use()\n'
      '  except RuntimeError as e:\n'
      '    print("refused:", e)\n')
  out = subprocess.run([sys.executable, '-c', code], cwd=ROOT, check=True,
                       capture_output=True, text=True).stdout.splitlines()
  assert len(out) == 3
  assert out[0].startswith('refused: tensorflow.io: TensorFlow is not')
  assert out[1].startswith('refused: tensorflow_probability.substrates.jax.'
                           'distributions')
  assert out[2].startswith('refused: flax.metrics.tensorboard.SummaryWriter')
