"""Each BLE-compat fix: the broken behaviour without it, the right one with it.

"Without it" runs in a subprocess with the fix switched off through
BLE_LATEX_COMPAT_DISABLE, so the stock failure is reproduced on this stack.
"""

import json
import os
import subprocess
import sys

import ble_latex
from ble_latex import compat
import numpy as np
import pytest

from tests import helpers

_DATA = helpers.DATA


def _run(code: str, disable: str = '') -> subprocess.CompletedProcess:
  env = dict(os.environ, BLE_LATEX_COMPAT_DISABLE=disable,
             TF_CPP_MIN_LOG_LEVEL='3', JAX_PLATFORMS='cpu')
  return subprocess.run([sys.executable, '-c', code], env=env,
                        capture_output=True, text=True, timeout=240)


# fix name -> (code that needs the fix, text of the stock failure).
_NEEDED = {
    'interp2d': (
        'import ble_latex\n'
        'from balloon_learning_environment.env.balloon import acs',
        'interp2d'),
    'hashable_units': (
        'import ble_latex\n'
        'from balloon_learning_environment.env.balloon import balloon',
        'mutable default'),
    'hashable_field_shape': (
        'import ble_latex\n'
        'from balloon_learning_environment.generative import vae',
        'mutable default'),
    'jax_xla_aval_alias': (
        'import ble_latex\n'
        'from balloon_learning_environment.utils import sampling\n'
        'import jax\n'
        'sampling.sample_upwelling_infrared(jax.random.PRNGKey(0))',
        'pytype_aval_mappings'),
    'flax_optim': (
        'import ble_latex\n'
        'from balloon_learning_environment.agents import agent_registry',
        'optim'),
    'gym_rng_copy': (
        'import ble_latex, copy, gym\n'
        'from gym.utils import seeding\n'
        'rng = seeding.np_random(3)[0]\n'
        'assert copy.deepcopy(rng).random() == rng.random()',
        'BitGenerator'),
    'jax_tree_map': (
        'import ble_latex\n'
        'from dopamine.jax.agents.sac import sac_agent\n'
        'import jax\n'
        'sac_agent.jax.tree_map(lambda x: x, [1])',
        'tree_map'),
}


# Runs every case's code with all fixes on, in one process (each in its own
# namespace), and prints {name: ['ok' or the error, what it printed]} as JSON.
_ALL_FIXED = """
import contextlib, io, json, traceback
codes = {codes!r}
results = {{}}
for name, code in codes.items():
  out = io.StringIO()
  try:
    with contextlib.redirect_stdout(out):
      exec(code, {{}})
    results[name] = ['ok', out.getvalue()]
  except BaseException:  # pylint: disable=broad-except
    results[name] = [traceback.format_exc(), out.getvalue()]
print(json.dumps(results))
"""


@pytest.fixture(scope='module')
def fixed_runs():
  """{name: ('ok' or the traceback, its stdout)} of each case's code and of
  the threefry check (_SPLIT), fixes on: one process for all of them."""
  codes = {name: code for name, (code, _) in _NEEDED.items()}
  codes['jax_threefry'] = _SPLIT
  fixed = _run(_ALL_FIXED.format(codes=codes))
  assert fixed.returncode == 0, fixed.stderr[-2000:]
  return json.loads(fixed.stdout.strip().splitlines()[-1])


@pytest.fixture(scope='module')
def fixed_results(fixed_runs):
  """{fix name: 'ok' or the traceback} of each case's code, fixes on."""
  return {name: fixed_runs[name][0] for name in _NEEDED}


@pytest.mark.parametrize('name', sorted(_NEEDED))
def test_fix_is_needed_and_works(name, fixed_results):
  code, failure = _NEEDED[name]
  stock = _run(code, disable=name)
  assert stock.returncode != 0, f'{name}: stock code unexpectedly worked'
  assert failure in stock.stderr, stock.stderr[-2000:]
  assert fixed_results[name] == 'ok', fixed_results[name][-2000:]


# Fixes whose cases import BLE's agents, env modules and TensorFlow in each
# process (14-18 s a case on 2 busy cores, 2026-12-05): CI runs them.
_NEEDED_SLOW = {
    # BLE's train/eval parse --agent's gin file and --gin_bindings before
    # gym.make imports the latex env (issue 69).
    'ble_commands': (
        'import ble_latex, gin\n'
        'from balloon_learning_environment.utils import run_helpers\n'
        'with gin.unlock_config():\n'
        "  run_helpers.bind_gin_variables('sac', None, [\n"
        "      'latex_episode.episode_steps = 30'])\n"
        'from ble_latex.envs import env_params\n'
        "assert env_params.episode()['episode_steps'] == 30\n"
        'gin.clear_config()',
        'Agent sac not recognized'),
    # BLE's console collector (BLE's train's default) on a Box action.
    'ble_console_collector': (
        'import ble_latex, numpy as np\n'
        'from balloon_learning_environment.metrics import '
        'collector_dispatcher, statistics_instance\n'
        "c = collector_dispatcher.AVAILABLE_COLLECTORS['console'](None, 3, 0)\n"
        'c.pre_training(); c.begin_episode()\n'
        's = statistics_instance.StatisticsInstance(\n'
        '    step=0, action=np.array([18e3, 1.0, -1.0]), reward=1.0,\n'
        '    terminal=False)\n'
        'c.step(s); c.end_episode(s)',
        'ambiguous'),
}


@pytest.mark.slow
@pytest.mark.ci
@pytest.mark.parametrize('name', sorted(_NEEDED_SLOW))
def test_slow_fix_is_needed_and_works(name):
  code, failure = _NEEDED_SLOW[name]
  stock = _run(code, disable=name)
  assert stock.returncode != 0, f'{name}: stock code unexpectedly worked'
  assert failure in stock.stderr, stock.stderr[-2000:]
  fixed = _run(code)
  assert fixed.returncode == 0, fixed.stderr[-2000:]


def test_interp2d_equals_old_scipy_interp2d_on_ble_table():
  from balloon_learning_environment.env.balloon import acs
  from balloon_learning_environment.utils import units
  reference = json.loads((_DATA / 'interp2d_reference.json').read_text())
  assert reference['scipy_version'] == '1.13.1'
  for pressure_ratio, power, expected in reference['points']:
    got = acs.get_fan_efficiency(pressure_ratio, units.Power(watts=power))
    assert got == pytest.approx(expected, abs=1e-12), (pressure_ratio, power)


def test_interp2d_fix_is_local_to_ble():
  from balloon_learning_environment.env.balloon import acs  # noqa: F401
  from scipy import interpolate
  assert interpolate.interp2d is not compat.GridInterp2d
  with pytest.raises(NotImplementedError):
    interpolate.interp2d([0, 1], [0, 1], [0, 1, 2, 3])


def test_units_hash_consistent_with_eq():
  from balloon_learning_environment.utils import units
  assert compat.applied.get('hashable_units')
  assert hash(units.Power(watts=3.0)) == hash(units.Power(watts=3.0))
  assert hash(units.Energy(watt_hours=2.0)) == hash(units.Energy(watt_hours=2.0))
  # Distance/Velocity compare with a tolerance: equal objects, equal hashes.
  a, b = units.Distance(m=1.0), units.Distance(m=1.0 + 1e-12)
  assert a == b and hash(a) == hash(b)
  u, v = units.Velocity(mps=2.0), units.Velocity(mps=2.0 + 1e-12)
  assert u == v and hash(u) == hash(v)


def test_field_shape_hashable_and_unchanged():
  from balloon_learning_environment.generative import vae
  assert hash(vae.FieldShape()) == hash(vae.FieldShape())
  assert vae.FieldShape().grid_shape() == (21, 21, 10, 9, 2)
  assert vae.Decoder().field_shape == vae.FieldShape()


def test_wind_gp_returns_one_deviation_per_query():
  import datetime as dt
  from balloon_learning_environment.env import wind_field
  from balloon_learning_environment.env import wind_gp
  from balloon_learning_environment.utils import units
  gp = wind_gp.WindGP(wind_field.SimpleStaticWindField())
  gp.observe(units.Distance(m=0), units.Distance(m=0), 9000.0,
             dt.timedelta(hours=1),
             wind_field.WindVector(units.Velocity(mps=3.0),
                                   units.Velocity(mps=-1.0)))
  locations = np.array([[0.0, 0.0, p, 3600.0] for p in (6000., 9000., 12000.)])
  raw_means, raw_std = wind_gp.WindGP.query_batch.__wrapped__(gp, locations)
  assert raw_std.shape == (3, 2)  # What new scikit-learn returns.
  means, deviations = gp.query_batch(locations)
  assert deviations.shape == (3,)
  np.testing.assert_allclose(deviations, raw_std.mean(axis=1))
  np.testing.assert_allclose(means, raw_means)


def test_gym_checker_sees_bool8_but_numpy_is_untouched():
  from gym.utils import passive_env_checker
  assert not hasattr(np, 'bool8')  # NumPy 2 removed it: the fix is needed.
  assert passive_env_checker.np.bool8 is np.bool_
  assert passive_env_checker.np.float32 is np.float32


def test_flax_optim_shim_is_sgd():
  from flax import optim
  import jax.numpy as jnp
  params = {'w': jnp.array([1.0, -2.0])}
  opt = optim.GradientDescent(learning_rate=0.5).create(params)
  opt = opt.apply_gradient({'w': jnp.array([2.0, 4.0])})
  np.testing.assert_allclose(opt.target['w'], [0.0, -4.0])


def test_jax_tree_map_alias():
  import jax
  from dopamine.jax.agents.sac import sac_agent  # noqa: F401
  assert jax.tree_map(lambda x: x * 2, {'a': 1}) == {'a': 2}


_SPLIT = ('import ble_latex\n'
          'from balloon_learning_environment.env import balloon_env\n'
          'import jax\n'
          'print(jax.random.split(jax.random.PRNGKey(0)).tolist())')
# jax.random.split(PRNGKey(0)) on the jax versions BLE 1.0.1 was built with.
_OLD_SPLIT = [[4146024105, 967050713], [2718843009, 1272950319]]


def test_threefry_restores_old_streams(fixed_runs):
  status, printed = fixed_runs['jax_threefry']
  assert status == 'ok', status[-2000:]
  assert json.loads(printed.strip().splitlines()[-1]) == _OLD_SPLIT
  stock = _run(_SPLIT, disable='jax_threefry')
  assert stock.returncode == 0, stock.stderr[-2000:]
  assert json.loads(stock.stdout.strip().splitlines()[-1]) != _OLD_SPLIT


def test_import_ble_latex_is_light():
  code = ('import sys, ble_latex, gym\n'
          'heavy = [m for m in ("jax", "tensorflow", "balloon_learning_environment.env.balloon_env") if m in sys.modules]\n'
          'print(heavy)')
  out = _run(code)
  assert out.returncode == 0, out.stderr[-2000:]
  assert out.stdout.strip().splitlines()[-1] == '[]'


def test_global_changes_are_listed_in_the_docs():
  page = (helpers.ROOT / 'docs' /
          'ble-compat.md')
  text = page.read_text()
  for change in ('jax_threefry_partitionable', 'jax.tree_map',
                 'pytype_aval_mappings', 'flax.optim'):
    assert change in text, change
