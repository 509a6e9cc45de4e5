"""The core, its gin files and the planners run where TensorFlow is absent.

A lent GPU machine's image has JAX but no TensorFlow (docs/planners.md, "On
a GPU"). The functional env, the shipped env gin files and the planners need
none of it: `latex_env.gin` names only the core's configurables, gin's
finalize hook imports BLE's env modules only on BLE's own path (its
`run_helpers` imported, `ble_latex.compat`), and the planners' pure JAX
modules import no BLE agent. Each check runs in a fresh process whose
imports of TensorFlow, TFP and flax's TensorBoard writer raise ImportError
(a `sys.meta_path` finder), as they would there.
"""

import subprocess
import sys
import textwrap

import pytest

from tests import helpers

ROOT = helpers.ROOT

# Put first in each process: TensorFlow's imports fail as where it is absent
# (the finder goes ahead of ble_latex's compat hook, which `import ble_latex`
# installs first in `sys.meta_path`).
BLOCK_TENSORFLOW = textwrap.dedent('''
    import sys
    import ble_latex
    BLOCKED = ('tensorflow', 'tensorflow_probability',
               'flax.metrics.tensorboard')

    class NoTensorFlow:
      def find_spec(self, name, path=None, target=None):
        if name in BLOCKED or name.startswith(tuple(b + '.' for b in BLOCKED)):
          raise ImportError(f'{name}: TensorFlow is not installed here')
        return None

    sys.meta_path.insert(0, NoTensorFlow())
    ''')


def _run(code: str, *args: str, timeout: int = 600):
  return subprocess.run([sys.executable, '-c', BLOCK_TENSORFLOW + code,
                         *args], cwd=ROOT, capture_output=True, text=True,
                        check=False, timeout=timeout)


def test_the_blocker_can_fail():
  """TensorFlow itself (as BLE's arena imports it) is refused here."""
  out = _run('import tensorflow', timeout=300)
  assert out.returncode != 0
  assert 'tensorflow: TensorFlow is not installed here' in out.stderr


_ENV_AND_PLANNER = textwrap.dedent('''
    import ble_latex
    from ble_latex import configs
    from ble_latex.agents.planning import config as plan_config
    from ble_latex.agents.planning import planner as planning
    from ble_latex.envs import env_params
    from ble_latex.envs import jax_env
    from ble_latex.run import gin_binding
    from ble_latex.run import planner_batch
    from ble_latex.run import real_cells
    from ble_latex.run import wind_file
    from ble_latex.wind import sources

    # The commands' binder: the shipped env gin files, finalized (gin's
    # finalize hook runs), plus the realistic-physics mode file.
    gin_binding.bind_gin(None, None, [configs.gin_file('latex_realistic.gin')],
                         ['LatexMpcAgent.num_samples = 4'])
    params = env_params.params_from_gin()
    assert params.reward_dropoff == 0.4 and params.radius_km == 50.0
    env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
    assert env.action_space(params).shape == (3,)
    config = plan_config.from_gin('latex_mpc')
    assert config.num_samples == 4 and callable(planning.plan_batch)
    assert callable(planner_batch.fly_planner) and sources.SOURCES
    assert callable(real_cells.fly_cell)  # benchmarks/real_winds.py's core
    assert wind_file.cell_bindings
    # BLE's light package modules (its gym id, its noise constants) may load;
    # its env, arena and agents (TensorFlow behind them) may not.
    heavy = sorted(m for m in sys.modules if m.startswith((
        'tensorflow', 'dopamine', 'ble_latex.ble.gym_env',
        'ble_latex.ble.arena', 'balloon_learning_environment.env.balloon_env',
        'balloon_learning_environment.env.balloon_arena',
        'balloon_learning_environment.agents')))
    print('heavy', heavy)
    ''')


def test_env_gin_files_env_and_planner_without_tensorflow():
  out = _run(_ENV_AND_PLANNER)
  assert out.returncode == 0, out.stderr[-3000:]
  assert out.stdout.strip().splitlines()[-1] == 'heavy []'


@pytest.mark.slow
def test_planners_benchmark_without_tensorflow(tmp_path):
  """benchmarks/planners.py --short, the script the GPU sweep runs: the
  env and a planner compiled and flown (2 balloons, 12 strides)."""
  code = textwrap.dedent('''
      import runpy
      sys.argv = sys.argv[1:]
      sys.path.insert(0, '.')
      runpy.run_path('benchmarks/planners.py', run_name='__main__')
      ''')
  out = _run(code, 'benchmarks/planners.py', '--short',
             '--suite=latex_validation', f'--output_dir={tmp_path}',
             '--gin_bindings=LatexMpcAgent.num_samples=4')
  assert out.returncode == 0, out.stderr[-3000:]
  assert (tmp_path / 'latex_validation' / 'latex_mpc.json').is_file()
