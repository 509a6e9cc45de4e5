"""Runs a benchmarks/ script on a machine whose Python has JAX but no TensorFlow.

Used for the planner figures measured on a lent NVIDIA H100 (2026-11-26,
`docs/planners.md`, "On a GPU"): that machine's image has JAX 0.11.2 with CUDA,
flax, NumPy and SciPy, but no TensorFlow, and packages cannot be installed
there. The planners and the JAX env never call TensorFlow, but three BLE
1.0.1 modules import it at import time:

- `agents/agent.py` imports `flax.metrics.tensorboard` (a `SummaryWriter`
  the planners never create), which imports TensorFlow;
- `models/models.py` imports `tensorflow` (`tf.io.gfile`, used only for an
  explicit decoder path; ble_latex reads the decoder through
  `importlib.resources`);
- `utils/sampling.py` imports TFP's JAX substrate (the env draws with
  `jax.random`).

Stand-in modules take their place: any attribute read from them raises, so
a code path that does need TensorFlow fails loudly instead of running on a
stub. BLE and the other pure-Python packages it needs (gym, gin-config,
opensimplex, s2sphere, future, transitions, gymnasium) travel as source on
PYTHONPATH (`benchmarks/gpu/planners_sweep.py`'s docstring).

  python benchmarks/gpu/boot_no_tensorflow.py SCRIPT [FLAGS...]
"""
import runpy
import sys
import types


class _Absent(types.ModuleType):
  """A module that is imported but must never be used."""

  def __getattr__(self, name):
    if name.startswith('__'):
      raise AttributeError(name)
    raise RuntimeError(f'{self.__name__}.{name}: TensorFlow is not installed '
                       'here (benchmarks/gpu/boot_no_tensorflow.py)')


class _SummaryWriter:
  """BLE's agent.py names it in a type annotation; never created here."""

  def __init__(self, *args, **kwargs):
    raise RuntimeError('flax.metrics.tensorboard.SummaryWriter: TensorFlow is '
                       'not installed here')


def install_stubs() -> None:
  """Puts the stand-ins in `sys.modules` (this process only)."""
  import flax.metrics  # pylint: disable=g-import-not-at-top
  names = ('flax.metrics.tensorboard', 'tensorflow', 'tensorflow_probability',
           'tensorflow_probability.substrates',
           'tensorflow_probability.substrates.jax')
  for name in names:
    sys.modules[name] = _Absent(name)
  board = sys.modules['flax.metrics.tensorboard']
  board.__dict__['SummaryWriter'] = _SummaryWriter
  flax.metrics.tensorboard = board
  tfp = sys.modules['tensorflow_probability']
  tfp.__dict__['substrates'] = sys.modules['tensorflow_probability.substrates']
  tfp.substrates.__dict__['jax'] = sys.modules[
      'tensorflow_probability.substrates.jax']


if __name__ == '__main__':
  install_stubs()
  script = sys.argv[1]
  sys.argv = sys.argv[1:]
  sys.path.insert(0, '.')
  runpy.run_path(script, run_name='__main__')
