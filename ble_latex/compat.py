# coding=utf-8
"""Fixes that make BLE 1.0.1, dopamine-rl 4.0.9 and gym 0.25.2 run on today's stack.

BLE 1.0.1 (Feb 2022) does not import on Python 3.11 with SciPy >= 1.14,
NumPy 2, flax >= 0.6, new jax and new scikit-learn. Every fix lives here, each
in one small function with a test in `tests/test_compat.py` that fails without
it.

The fixes are applied lazily by an import hook (`install()`, called by
`import ble_latex`): each one runs right before (or after) the module it fixes
executes, so `import ble_latex` itself stays cheap (no TF/JAX/BLE import) and the
gym entry point can install the hook at `import gym` time. Where possible a fix
is local to the broken third-party module; the few global changes are listed
in docs/ble-compat.md.

| # | breakage (see shared ble-compat-notes)             | fix                         |
|---|----------------------------------------------------|-----------------------------|
| 1 | scipy.interpolate.interp2d removed (BLE acs.py)    | `_acs_interp2d` (local)     |
| 2 | units.Power etc. unhashable dataclass defaults     | `_hashable_units` (BLE)     |
| 3 | vae.FieldShape unhashable dataclass default        | `_hashable_field_shape`     |
| 4 | TFP's jax substrate needs xla.pytype_aval_mappings | `_jax_xla_aval_alias` (add) |
| 5 | sklearn GP per-output std (N, 2) in WindGP         | `_wind_gp_std` (BLE class)  |
| 6 | gym's passive checker uses np.bool8                | `_gym_checker_bool8` (local)|
| 7 | `from flax import optim` (BLE mlp_agent)           | `_flax_optim_shim` (module) |
| 8 | jax.tree_map removed (dopamine agents, BLE)        | `_jax_tree_map` (add)       |
| 9 | jax_threefry_partitionable default flipped         | `_jax_threefry` (global)    |
|10 | gym's RandomNumberGenerator uncopyable on NumPy 2  | `_gym_rng_copy` (gym class) |
|11 | BLE's commands parse gin before the latex names exist | `_ble_commands` (wraps) |
|12 | BLE's console collector counts only discrete actions  | `_ble_console_collector`  |

The same hook also runs three integration steps that are not fixes:
`gymnasium_register` (the `ble_latex/...` ids, after `import gymnasium`),
`gin_latex_configurables` (a gin finalize hook that imports
`GIN_CONFIGURABLE_MODULES` before BLE's `bind_gin_variables` locks the config,
where BLE's `run_helpers` is imported)
and `quiet_import` (ble_latex.ble.gym_env imports inside `quiet.third_party_noise`).
"""

import contextlib
import dataclasses
import functools
import importlib.abc
import importlib.machinery
import os
import sys
import types
from typing import Any, Callable, Dict, Iterator, Optional, Sequence, Tuple

_BLE = 'balloon_learning_environment'

# Fixes already applied, by name (each is applied at most once per process).
applied: Dict[str, bool] = {}


def disabled() -> Tuple[str, ...]:
  """Fix names listed in $BLE_LATEX_COMPAT_DISABLE (comma-separated).

  For debugging and for the tests that show each fix is needed; with a fix
  disabled the corresponding BLE/dopamine/gym code fails as it does stock.
  """
  names = os.environ.get('BLE_LATEX_COMPAT_DISABLE', '')
  return tuple(n.strip() for n in names.split(',') if n.strip())


def _once(name: str, fn: Callable[[], None]) -> None:
  if not applied.get(name) and name not in disabled():
    fn()
    applied[name] = True


# ---------------------------------------------------------------------------
# 1. interp2d (removed in SciPy 1.14) for BLE's ACS efficiency table.
# ---------------------------------------------------------------------------
class GridInterp2d:
  """Drop-in for the removed `scipy.interpolate.interp2d`, gridded data only.

  Reproduces the old behaviour for what BLE uses: `interp2d(x, y, z)` with `z`
  a flat table of len(x) * len(y) values that old interp2d read x-major
  (z[i * len(y) + j] = f(x[i], y[j]); reading it the other way is off by up to
  0.3 on BLE's table), linear kind, and `fill_value=None`, which old interp2d
  (FITPACK `bispev`) evaluated by clamping the query to the grid edge.
  Interpolation itself is SciPy's `RegularGridInterpolator`. Checked against
  values recorded with SciPy 1.13.1's interp2d in tests/data.
  """

  def __init__(self, x: Sequence[float], y: Sequence[float],
               z: Sequence[float], kind: str = 'linear',
               fill_value: Optional[float] = None, **unused_kwargs: Any):
    import numpy as np  # pylint: disable=g-import-not-at-top
    from scipy import interpolate  # pylint: disable=g-import-not-at-top
    if kind != 'linear' or fill_value is not None:
      raise NotImplementedError(
          'ble_latex.compat.GridInterp2d only supports the linear, '
          f'fill_value=None case BLE uses (got kind={kind!r}, '
          f'fill_value={fill_value!r}).')
    self._x = np.asarray(x, dtype=float)
    self._y = np.asarray(y, dtype=float)
    table = np.asarray(z, dtype=float).reshape(len(self._x), len(self._y))
    self._interp = interpolate.RegularGridInterpolator(
        (self._x, self._y), table, method='linear')

  def __call__(self, x: Any, y: Any) -> Any:
    """Evaluates on the grid x × y like interp2d: shape (len(y), len(x))."""
    import numpy as np  # pylint: disable=g-import-not-at-top
    xs = np.clip(np.sort(np.atleast_1d(np.asarray(x, dtype=float))),
                 self._x[0], self._x[-1])
    ys = np.clip(np.sort(np.atleast_1d(np.asarray(y, dtype=float))),
                 self._y[0], self._y[-1])
    yy, xx = np.meshgrid(ys, xs, indexing='ij')
    out = self._interp(np.stack([xx.ravel(), yy.ravel()], axis=-1))
    out = out.reshape(len(ys), len(xs))
    if np.ndim(x) == 0 and np.ndim(y) == 0:
      # Old interp2d returned shape (1,) here, which BLE passes to float();
      # NumPy 2.4 only converts 0-d arrays, so return one.
      return np.asarray(out[0, 0])
    # Old interp2d returned a 1-D array when one argument was a scalar.
    return out[0] if out.shape[0] == 1 else out


@contextlib.contextmanager
def _acs_interp2d() -> Iterator[None]:
  """Provides interp2d only while BLE's acs.py executes (local fix)."""
  from scipy import interpolate  # pylint: disable=g-import-not-at-top
  original = interpolate.interp2d
  interpolate.interp2d = GridInterp2d
  try:
    yield
  finally:
    interpolate.interp2d = original


# ---------------------------------------------------------------------------
# 2. BLE units classes define __eq__ without __hash__.
# ---------------------------------------------------------------------------
def _hashable_units(units: types.ModuleType) -> None:
  """Makes BLE's unit classes hashable, consistently with their __eq__.

  Python 3.11 dataclasses reject defaults whose class has `__hash__ is None`
  (`BalloonState` has `units.Power(...)` defaults). Power and Energy compare
  exactly, so they hash their value; Distance and Velocity compare with a
  1e-9 tolerance, which no value hash can respect, so they get a per-class
  constant hash (correct, merely slow as dict keys).
  """
  exact = {'Power': 'watts', 'Energy': 'watt_hours'}
  tolerant = ('Distance', 'Velocity')
  for name, attr in exact.items():
    cls = getattr(units, name)
    if cls.__hash__ is None:
      cls.__hash__ = (lambda a: lambda self: hash(getattr(self, a)))(attr)
  for name in tolerant:
    cls = getattr(units, name)
    if cls.__hash__ is None:
      cls.__hash__ = (lambda n: lambda self: hash(n))(name)


# ---------------------------------------------------------------------------
# 3. generative/vae.py: `field_shape: FieldShape = FieldShape()`.
# ---------------------------------------------------------------------------
@contextlib.contextmanager
def _hashable_field_shape() -> Iterator[None]:
  """While vae.py executes, builds its `FieldShape` dataclass with a hash.

  `FieldShape` and the modules using `FieldShape()` as a default live in the
  same file, so the class must be hashable when it is created: the dataclass
  decorator is wrapped (for that one class only) to pass `unsafe_hash=True`,
  a hash of the fields, consistent with the generated __eq__.
  """
  original = dataclasses.dataclass

  def dataclass(cls=None, /, **kwargs):
    def wrap(c):
      if c.__name__ == 'FieldShape' and c.__module__.startswith(_BLE):
        kwargs.setdefault('unsafe_hash', True)
      return original(c, **kwargs)
    return wrap if cls is None else wrap(cls)

  dataclasses.dataclass = dataclass
  try:
    yield
  finally:
    dataclasses.dataclass = original


# ---------------------------------------------------------------------------
# 4, 8, 9. jax: removed aliases and the threefry default.
# ---------------------------------------------------------------------------
def _jax_xla_aval_alias() -> None:
  """TFP 0.25's jax substrate reads jax.interpreters.xla.pytype_aval_mappings."""
  import jax  # pylint: disable=g-import-not-at-top
  from jax._src import core  # pylint: disable=g-import-not-at-top
  xla = jax.interpreters.xla
  if not hasattr(xla, 'pytype_aval_mappings'):
    xla.pytype_aval_mappings = core.pytype_aval_mappings


def _jax_tree_map() -> None:
  """dopamine 4.0.9 and BLE's quantile agent call jax.tree_map."""
  import jax  # pylint: disable=g-import-not-at-top
  if not hasattr(jax, 'tree_map'):
    jax.tree_map = jax.tree.map


def _jax_threefry() -> None:
  """Restores jax's old PRNG stream so BLE's seeded worlds match published ones.

  JAX >= 0.5 defaults `jax_threefry_partitionable=True`, which changes every
  random stream BLE derives from a seed (wind fields, atmospheres, start
  positions). Set BLE_LATEX_COMPAT_DISABLE=jax_threefry to keep jax's new
  default.
  """
  import jax  # pylint: disable=g-import-not-at-top
  jax.config.update('jax_threefry_partitionable', False)


def _jax_fixes() -> None:
  _once('jax_xla_aval_alias', _jax_xla_aval_alias)
  _once('jax_tree_map', _jax_tree_map)
  _once('jax_threefry', _jax_threefry)


# ---------------------------------------------------------------------------
# 5. WindGP with new scikit-learn.
# ---------------------------------------------------------------------------
def _wind_gp_std(wind_gp: types.ModuleType) -> None:
  """Averages sklearn's per-output std (N, 2) to BLE's expected (N,).

  scikit-learn >= 1.1 returns one std per target for multi-output GPs; BLE's
  features expect one deviation per query. BLE fixed this upstream after 1.0.1
  the same way (mean over outputs).
  """
  cls = wind_gp.WindGP
  if getattr(cls.query_batch, '_ble_latex_fixed', False):
    return
  original = cls.query_batch

  def query_batch(self, locations):
    means, deviations = original(self, locations)
    if getattr(deviations, 'ndim', 1) == 2:
      deviations = deviations.mean(axis=1)
    return means, deviations

  functools.update_wrapper(query_batch, original)
  query_batch._ble_latex_fixed = True
  cls.query_batch = query_batch


# ---------------------------------------------------------------------------
# 6. gym 0.25.2 passive env checker and NumPy 2.
# ---------------------------------------------------------------------------
class _NumpyWithBool8(types.ModuleType):
  """numpy, plus the `bool8` alias NumPy 2 removed; seen only by gym's checker."""

  def __init__(self, numpy_module: types.ModuleType):
    super().__init__(numpy_module.__name__)
    self._numpy = numpy_module
    self.bool8 = numpy_module.bool_

  def __getattr__(self, name: str) -> Any:
    return getattr(self._numpy, name)


def _gym_checker_bool8(checker: types.ModuleType) -> None:
  if not isinstance(checker.np, _NumpyWithBool8):
    checker.np = _NumpyWithBool8(checker.np)


def _gym_rng_copy(seeding: types.ModuleType) -> None:
  """Lets gym's `RandomNumberGenerator` be copied/pickled on NumPy 2.

  NumPy 2 `Generator.__reduce__` passes the bit generator itself, where gym
  0.25.2's `_generator_ctor` expects its name and raises "is not a known
  BitGenerator module" — so `copy.deepcopy(env.np_random)` fails, and with it
  gym's own env checker. Accept the bit generator object as NumPy does.
  """
  cls = seeding.RandomNumberGenerator
  original = cls._generator_ctor
  if getattr(original, '_ble_latex_fixed', False):
    return

  def _generator_ctor(bit_generator_name='MT19937'):
    import numpy as np  # pylint: disable=g-import-not-at-top
    if isinstance(bit_generator_name, np.random.BitGenerator):
      return cls(bit_generator_name)
    return original(bit_generator_name)

  _generator_ctor._ble_latex_fixed = True
  cls._generator_ctor = staticmethod(_generator_ctor)


# ---------------------------------------------------------------------------
# 7. `from flax import optim` (removed in flax 0.6), BLE's MLP agent.
# ---------------------------------------------------------------------------
@dataclasses.dataclass
class _Optimizer:
  """The slice of the old `flax.optim.Optimizer` BLE's MLPAgent uses."""
  target: Any
  transform: Any
  state: Any

  def apply_gradient(self, grads: Any) -> '_Optimizer':
    import optax  # pylint: disable=g-import-not-at-top
    updates, state = self.transform.update(grads, self.state, self.target)
    return _Optimizer(optax.apply_updates(self.target, updates),
                      self.transform, state)


@dataclasses.dataclass(frozen=True)
class GradientDescent:
  """`flax.optim.GradientDescent` (plain SGD), implemented with optax.sgd."""
  learning_rate: float = 0.001

  def create(self, target: Any) -> _Optimizer:
    import optax  # pylint: disable=g-import-not-at-top
    transform = optax.sgd(self.learning_rate)
    return _Optimizer(target, transform, transform.init(target))


def _flax_optim_shim() -> types.ModuleType:
  module = types.ModuleType('flax.optim')
  module.__doc__ = 'ble_latex shim: the GradientDescent optimizer BLE uses.'
  module.GradientDescent = GradientDescent
  return module


# ---------------------------------------------------------------------------
# Integration hooks (not fixes): gymnasium ids, gin configurables, quiet start.
# ---------------------------------------------------------------------------
# Modules whose import declares every gin configurable a latex env needs.
GIN_CONFIGURABLE_MODULES = ('ble_latex.ble.gym_env',)
# BLE's gin binder: where it is imported, gin's finalize hook imports them.
_BLE_RUN_HELPERS = f'{_BLE}.utils.run_helpers'


def _register_gymnasium_envs(unused_gymnasium: types.ModuleType) -> None:
  """Registers the `ble_latex/...` ids once gymnasium is imported.

  Gymnasium 1.x has no plugin entry points; this keeps `import ble_latex`
  from importing gymnasium itself (~0.2 s).
  """
  from ble_latex.envs import gymnasium_registration  # pylint: disable=g-import-not-at-top
  gymnasium_registration.register_envs()


def _import_latex_configurables(unused_config: Any) -> None:
  """gin finalize hook: declare the gym env's configurables before BLE's lock.

  BLE's order (`run_helpers.bind_gin_variables`, which finalizes and locks
  gin's config, then `gym.make('LatexBalloonDiscrete-v0')`) would otherwise
  import ble_latex.ble.gym_env after the lock, and its `@gin.configurable`s raise
  "Attempted to add a new configurable after the config was locked". Only
  on BLE's path (its `run_helpers` imported): elsewhere a finalize imports
  nothing, so the core's gin files finalize without BLE's env modules and
  TensorFlow (the GPU scripts run where TensorFlow is not installed).
  """
  if _BLE_RUN_HELPERS not in sys.modules:
    return
  import importlib  # pylint: disable=g-import-not-at-top
  for name in GIN_CONFIGURABLE_MODULES:
    importlib.import_module(name)


# What BLE's own train/eval commands need (wrapped `bind_gin_variables`, the
# Box-aware console collector); imported only where BLE's run_helpers /
# collector_dispatcher are.
BLE_COMMANDS_SUPPORT = 'ble_latex.run.ble_support'


def _ble_commands(run_helpers: types.ModuleType) -> None:
  """BLE's train/eval: latex agents and gin names declared before parsing.

  BLE's commands parse `--agent`'s gin file and `--gin_bindings` in
  `run_helpers.bind_gin_variables` before `gym.make` imports the latex env,
  so a latex binding is "No configurable matching 'latex_episode'" and
  `--agent=sac` is "Agent sac not recognized". The wrapper registers
  ble_latex's agents and declares the latex configurables first
  (`ble_latex.run.ble_support.install`).
  """
  import importlib  # pylint: disable=g-import-not-at-top
  importlib.import_module(BLE_COMMANDS_SUPPORT).install(run_helpers)


def _ble_console_collector(collector_dispatcher: types.ModuleType) -> None:
  """BLE's `console` collector counts only discrete actions: Box-aware one."""
  import importlib  # pylint: disable=g-import-not-at-top
  importlib.import_module(BLE_COMMANDS_SUPPORT).install_collectors(
      collector_dispatcher)


def _gin_finalize_hook(gin_config: types.ModuleType) -> None:
  if _import_latex_configurables not in gin_config._FINALIZE_HOOKS:  # pylint: disable=protected-access
    gin_config.register_finalize_hook(_import_latex_configurables)


def _quiet_import() -> contextlib.AbstractContextManager:
  """Known gym/BLE/TensorFlow start-up notices are dropped (ble_latex.quiet)."""
  from ble_latex import quiet  # pylint: disable=g-import-not-at-top
  return quiet.third_party_noise()


# ---------------------------------------------------------------------------
# The import hook.
# ---------------------------------------------------------------------------
# module name -> (fix name, context manager around its execution, fix after).
_Around = Optional[Callable[[], contextlib.AbstractContextManager]]
_After = Optional[Callable[[types.ModuleType], None]]
_HOOKS: Dict[str, Tuple[str, _Around, _After]] = {
    f'{_BLE}.utils.units': ('hashable_units', None, _hashable_units),
    f'{_BLE}.env.balloon.acs': ('interp2d', _acs_interp2d, None),
    f'{_BLE}.generative.vae': (
        'hashable_field_shape', _hashable_field_shape, None),
    f'{_BLE}.env.wind_gp': ('wind_gp_std', None, _wind_gp_std),
    'gym.utils.passive_env_checker': ('gym_bool8', None, _gym_checker_bool8),
    'gym.utils.seeding': ('gym_rng_copy', None, _gym_rng_copy),
    # Integration hooks.
    'gymnasium': ('gymnasium_register', None, _register_gymnasium_envs),
    'gin.config': ('gin_latex_configurables', None, _gin_finalize_hook),
    f'{_BLE}.utils.run_helpers': ('ble_commands', None, _ble_commands),
    f'{_BLE}.metrics.collector_dispatcher': (
        'ble_console_collector', None, _ble_console_collector),
    'ble_latex.ble.gym_env': ('quiet_import', _quiet_import, None),
    # gym's own import prints its "unmaintained" notice and loads the gym.envs
    # plugins, BLE's among them (BLE's env modules, TensorFlow's start-up
    # lines): quiet wherever gym is imported from (e.g. SB3 imports it).
    'gym': ('quiet_gym_import', _quiet_import, None),
    # TensorFlow's native start-up lines (oneDNN, CUDA probe), wherever it is
    # imported from (e.g. tensorboard, which torch's SummaryWriter imports).
    'tensorflow': ('quiet_tensorflow_import', _quiet_import, None),
    # BLE's package import registers its gym env, reading gym's deprecated
    # `registry.env_specs` (a gym warning), also without `import gym` first.
    _BLE: ('quiet_ble_import', _quiet_import, None),
}
# Hooks that only keep an import quiet (nothing to fix if imported earlier).
_QUIET_ONLY = ('quiet_import', 'quiet_gym_import', 'quiet_tensorflow_import',
               'quiet_ble_import')
# Top-level packages whose (non-trivial) import first applies the jax fixes.
_JAX_USERS = (f'{_BLE}.', 'dopamine.', 'tensorflow_probability.substrates')
# BLE modules that are light and import before the fixes are needed.
_LIGHT = (_BLE, f'{_BLE}.env', f'{_BLE}.env.gym')


class _Loader(importlib.abc.Loader):
  """Wraps a module's real loader to run a fix around its execution."""

  def __init__(self, name: str, loader: importlib.abc.Loader,
               around: _Around, after: _After):
    self._name = name
    self._loader = loader
    self._around = around
    self._after = after

  def create_module(self, spec):
    return self._loader.create_module(spec)

  def exec_module(self, module: types.ModuleType) -> None:
    with (self._around() if self._around else contextlib.nullcontext()):
      self._loader.exec_module(module)
    if self._after:
      self._after(module)
    applied[self._name] = True


class _ShimLoader(importlib.abc.Loader):

  def create_module(self, spec):
    return _flax_optim_shim()

  def exec_module(self, module: types.ModuleType) -> None:
    applied['flax_optim'] = True


class _Finder(importlib.abc.MetaPathFinder):
  """Applies the fixes as BLE, dopamine and gym modules get imported."""

  def find_spec(self, fullname, path, target=None):
    if fullname.startswith(_JAX_USERS) and fullname not in _LIGHT:
      _jax_fixes()
    if fullname == 'flax.optim' and 'flax_optim' not in disabled():
      if importlib.machinery.PathFinder.find_spec(fullname, path) is None:
        return importlib.machinery.ModuleSpec(fullname, _ShimLoader())
      return None
    if fullname not in _HOOKS or _HOOKS[fullname][0] in disabled():
      return None
    spec = importlib.machinery.PathFinder.find_spec(fullname, path)
    if spec is None or spec.loader is None:
      return None
    name, around, after = _HOOKS[fullname]
    spec.loader = _Loader(name, spec.loader, around, after)
    return spec


_FINDER = _Finder()


def install() -> None:
  """Installs the import hook (idempotent); fixes modules already imported."""
  if _FINDER not in sys.meta_path:
    sys.meta_path.insert(0, _FINDER)
  for module_name, (name, around, after) in _HOOKS.items():
    module = sys.modules.get(module_name)
    if module is None or name in disabled() or applied.get(name):
      continue
    if around is not None:
      if name in _QUIET_ONLY:
        continue  # Integration hooks only; nothing to fix.
      raise ImportError(
          f'{module_name} was imported before ble_latex and is broken on this '
          'stack; import ble_latex (or gym) before any '
          'balloon_learning_environment module.')
    _once(name, functools.partial(after, module))
  if any(m.startswith(_JAX_USERS) for m in list(sys.modules)
         if m not in _LIGHT):
    _jax_fixes()
