"""The import layers of the package, read statically (docs/layout.md).

Every `import` in every module of `ble_latex/` is read with `ast`, those
inside functions too (a lazy import is still a dependency), and held against
the layer rules:

- a module imports only modules on its own floor or below (`FLOORS`);
- `flight/` and `wind/` never import `envs/`;
- `envs/`, `flight/` and `wind/` never import `ble_latex.ble`, TensorFlow,
  Dopamine or BLE's env/agent modules (`HEAVY`);
- `agents/` never imports `run/`; nothing imports `cli/`;
- no module is over 800 lines;
- the modules import each other in no circle;
- the scripts of benchmarks/ import only the package: no `sys.path` edit,
  no import of another script (issue 66);
- `cli/common.py` defines only the command convention (`CLI_CONVENTION`)
  and the scripts take only that from it, and no other `cli/` module.

Nothing is imported or run: the test reads source text only.
"""

import ast
import pathlib
from typing import Dict, List, Set, Tuple

import pytest

from tests import helpers

PACKAGE = helpers.ROOT / 'ble_latex'
BENCHMARKS = PACKAGE.parent / 'benchmarks'

# Floors, ground first: a module may import its own floor or lower ones.
# A top-level module (`ble_latex/x.py`) or a folder (`ble_latex/x/`) is named
# by its first component.
FLOORS = (
    ('errors', 'quiet', 'jax_cache', 'dtypes'),
    ('gin_values', 'gin_aliases', 'safe_io', 'configs', 'run_files'),
    ('wind', 'flight'),
    ('envs',),
    ('ble', 'compat'),
    ('agents',),
    ('run', 'launch'),
    ('plots',),
    ('cli',),
)
# What the light layers (the functional env, the Gymnasium envs, physics and
# winds) never import, even lazily.
LIGHT = ('envs', 'flight', 'wind')
HEAVY = ('ble_latex.ble', 'tensorflow', 'dopamine',
         'balloon_learning_environment.agents',
         'balloon_learning_environment.env.balloon',
         'balloon_learning_environment.env.balloon_env',
         'balloon_learning_environment.env.balloon_arena',
         'balloon_learning_environment.env.features',
         'balloon_learning_environment.env.wind_field',
         'balloon_learning_environment.env.gym',
         'balloon_learning_environment.train_lib',
         'balloon_learning_environment.eval')
MAX_LINES = 800


def _module_name(path: pathlib.Path) -> str:
  parts = path.relative_to(PACKAGE.parent).with_suffix('').parts
  if parts[-1] == '__init__':
    parts = parts[:-1]
  return '.'.join(parts)


def _imports(path: pathlib.Path, package: str = '') -> Set[str]:
  """Absolute names of every module `path` imports (anywhere in it).

  Args:
    path: A Python source file.
    package: The package its relative imports start from (default: its own).
  """
  tree = ast.parse(path.read_text(encoding='utf-8'), str(path))
  if not package:
    package = _module_name(path)
    if path.name != '__init__.py':
      package = package.rpartition('.')[0]
  names = set()
  for node in ast.walk(tree):
    if isinstance(node, ast.Import):
      names.update(alias.name for alias in node.names)
    elif isinstance(node, ast.ImportFrom):
      if node.level:
        base = package.split('.')
        base = base[:len(base) - node.level + 1]
        module = '.'.join(base + ([node.module] if node.module else []))
      else:
        module = node.module or ''
      # `from ble_latex.envs import jax_env` imports ble_latex.envs.jax_env
      # (the package's face only hands it on); `from x import name` imports x.
      submodules = {f'{module}.{alias.name}' for alias in node.names}
      if module.split('.')[0] == 'ble_latex':
        known = {s for s in submodules if _is_source(s)}
        names.update(known or {module})
      else:  # A third-party name may be a module or an attribute: both.
        names.update({module} | submodules)
  return names


def _is_source(module: str) -> bool:
  path = PACKAGE.parent.joinpath(*module.split('.'))
  return path.with_suffix('.py').is_file() or (path / '__init__.py').is_file()


def _sources() -> Dict[str, pathlib.Path]:
  return {_module_name(p): p for p in sorted(PACKAGE.rglob('*.py'))}


def _internal_edges() -> Dict[str, Set[str]]:
  """Module -> the package's modules it imports (packages' faces dropped)."""
  sources = _sources()
  edges = {}
  for name, path in sources.items():
    targets = set()
    for imported in _imports(path):
      if imported in sources and imported != name and imported != 'ble_latex':
        targets.add(imported)
    edges[name] = targets
  return edges


def _floor(module: str) -> Tuple[int, str]:
  parts = module.split('.')
  if len(parts) < 2:
    return -1, ''
  top = parts[1]
  for i, floor in enumerate(FLOORS):
    if top in floor:
      return i, top
  raise AssertionError(
      f'{module}: {top!r} is on no floor of tests/test_layers.py FLOORS')


def test_every_module_is_on_a_floor_and_imports_none_above():
  upward = []
  for module, targets in _internal_edges().items():
    floor, _ = _floor(module)
    if floor < 0:
      continue
    for target in targets:
      target_floor, _ = _floor(target)
      if target_floor > floor:
        upward.append(f'{module} -> {target}')
  assert not upward, upward


def test_light_layers_import_nothing_heavy():
  found = []
  for module, path in _sources().items():
    if _floor(module)[1] not in LIGHT:
      continue
    for imported in _imports(path):
      if any(imported == h or imported.startswith(h + '.') for h in HEAVY):
        found.append(f'{module} imports {imported}')
  assert not found, found


def test_physics_and_winds_never_import_envs_and_agents_never_run():
  found = []
  for module, targets in _internal_edges().items():
    top = _floor(module)[1]
    for target in targets:
      target_top = _floor(target)[1]
      if top in ('flight', 'wind') and target_top == 'envs':
        found.append(f'{module} -> {target}')
      if top == 'agents' and target_top == 'run':
        found.append(f'{module} -> {target}')
      if target_top == 'cli' and top != 'cli':
        found.append(f'{module} -> {target}')
  assert not found, found


def _cycles(edges: Dict[str, Set[str]]) -> List[List[str]]:
  """Strongly connected components of more than one module (Tarjan)."""
  index, low, on_stack, stack, found = {}, {}, set(), [], []
  counter = [0]

  def visit(v: str) -> None:
    index[v] = low[v] = counter[0]
    counter[0] += 1
    stack.append(v)
    on_stack.add(v)
    for w in sorted(edges.get(v, ())):
      if w not in index:
        visit(w)
        low[v] = min(low[v], low[w])
      elif w in on_stack:
        low[v] = min(low[v], index[w])
    if low[v] == index[v]:
      component = []
      while True:
        w = stack.pop()
        on_stack.discard(w)
        component.append(w)
        if w == v:
          break
      if len(component) > 1:
        found.append(sorted(component))

  for v in sorted(edges):
    if v not in index:
      visit(v)
  return found


def test_no_import_circles():
  assert not _cycles(_internal_edges())


def test_the_cycle_finder_finds_a_circle():
  # The check above cannot pass vacuously.
  assert _cycles({'a': {'b'}, 'b': {'c'}, 'c': {'a'}, 'd': {'a'}}) == [
      ['a', 'b', 'c']]
  assert not _cycles({'a': {'b'}, 'b': set()})


def test_the_import_reader_sees_lazy_and_relative_imports(tmp_path):
  source = tmp_path / 'probe.py'
  source.write_text('import os\n'
                    'def f():\n  from ble_latex.ble import wind\n'
                    'def g():\n  from . import physics\n'
                    '  from ..wind import simplex\n', encoding='utf-8')
  imports = _imports(source, package='ble_latex.flight')
  assert {'os', 'ble_latex.ble.wind', 'ble_latex.flight.physics',
          'ble_latex.wind.simplex'} <= imports


@pytest.mark.parametrize('path', sorted(PACKAGE.rglob('*.py')),
                         ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_module_is_over_800_lines(path):
  lines = len(path.read_text(encoding='utf-8').splitlines())
  assert lines <= MAX_LINES, f'{path.name}: {lines} lines'


# -- benchmarks/ holds scripts: they import the package, not each other. ------

def _scripts() -> Dict[str, pathlib.Path]:
  """benchmarks/ scripts by path under it (committed runs' folders left)."""
  return {str(p.relative_to(BENCHMARKS)): p
          for p in sorted(BENCHMARKS.rglob('*.py'))
          if p.relative_to(BENCHMARKS).parts[0] not in ('sac_jax', 'records')}


def _edits_sys_path(path: pathlib.Path) -> List[int]:
  """Lines that change `sys.path` (a call on it, or an assignment to it)."""
  tree = ast.parse(path.read_text(encoding='utf-8'), str(path))

  def is_sys_path(node: ast.AST) -> bool:
    while isinstance(node, ast.Subscript):
      node = node.value
    return (isinstance(node, ast.Attribute) and node.attr == 'path' and
            isinstance(node.value, ast.Name) and node.value.id == 'sys')

  lines = []
  for node in ast.walk(tree):
    if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
        and is_sys_path(node.func.value)):
      lines.append(node.lineno)
    elif isinstance(node, (ast.Assign, ast.AugAssign, ast.AnnAssign)):
      targets = node.targets if isinstance(node, ast.Assign) else [
          node.target]
      if any(is_sys_path(t) for t in targets):
        lines.append(node.lineno)
  return lines


def _script_imports() -> Dict[str, Set[str]]:
  """Script -> the other scripts it imports (by module name)."""
  scripts = _scripts()
  stems = {pathlib.Path(name).stem for name in scripts}
  found = {}
  for name, path in scripts.items():
    imported = {i.split('.')[0] for i in _imports(path, package='benchmarks')}
    others = (imported & stems) - {pathlib.Path(name).stem}
    if others:
      found[name] = others
  return found


def test_benchmark_scripts_import_only_the_package():
  assert not _script_imports(), (
      'benchmarks/ scripts import each other: move the shared logic into '
      'ble_latex/')


def test_benchmark_scripts_leave_sys_path_alone():
  edits = {name: _edits_sys_path(path) for name, path in _scripts().items()}
  edits = {name: lines for name, lines in edits.items() if lines}
  assert not edits, edits


def test_the_script_checks_see_sys_path_edits_and_script_imports(tmp_path):
  # The checks above cannot pass vacuously.
  probe = tmp_path / 'probe.py'
  probe.write_text('import sys\n'
                   'sys.path.insert(0, "x")\n'
                   'def f():\n  sys.path[:] = []\n  import real_winds\n'
                   'text = "sys.path.insert(0, tree)"\n', encoding='utf-8')
  assert _edits_sys_path(probe) == [2, 4]
  assert 'real_winds' in _imports(probe, package='benchmarks')
  assert {'batch_speed.py', 'gpu/decode_grib.py'} <= set(_scripts())


# -- cli/ holds the commands: library logic lives in the package. -----------
# `ble_latex/cli/common.py` is the command convention (absl plumbing, usage
# errors, flag definitions and help texts) and holds nothing else: every name
# it defines is one of these. A script of benchmarks/ uses from it only these
# and imports no other cli/ module (a command's library is in the package).
CLI_COMMON = PACKAGE / 'cli' / 'common.py'
CLI_CONVENTION = frozenset({
    'HELP_FLAGS', 'EXIT_USAGE', 'EXIT_FAILURE', 'LazyModule', 'lazy_module',
    'CommandUsageError', 'CommandFailure', 'usage', 'usage_error',
    'help_text', '_exit_status', 'run_absl', 'number_flags_message',
    'quiet_init_callbacks', 'output_name', 'prepare_output_dir',
    'WIND_FILE_HELP', 'ERA5_DATES_HELP', 'GIN_FILE_HELP',
    'GIN_BINDINGS_HELP', 'define_gin_flags', 'STATION_HELP',
    'define_station_flags'})


def _defined_names(path: pathlib.Path) -> Set[str]:
  """Names a module defines at its top level (functions, classes, values)."""
  tree = ast.parse(path.read_text(encoding='utf-8'), str(path))
  names = set()
  for node in tree.body:
    if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef,
                         ast.ClassDef)):
      names.add(node.name)
    elif isinstance(node, (ast.Assign, ast.AnnAssign)):
      targets = node.targets if isinstance(node, ast.Assign) else [
          node.target]
      names |= {t.id for t in targets if isinstance(t, ast.Name)}
  return names


def _cli_uses(path: pathlib.Path) -> Tuple[Set[str], Set[str]]:
  """A script's (names it takes from `ble_latex.cli.common`, other cli/
  modules it imports)."""
  tree = ast.parse(path.read_text(encoding='utf-8'), str(path))
  aliases, used, others = set(), set(), set()
  for node in ast.walk(tree):
    if isinstance(node, ast.ImportFrom) and node.module == 'ble_latex.cli':
      for alias in node.names:
        if alias.name == 'common':
          aliases.add(alias.asname or alias.name)
        else:
          others.add(alias.name)
    elif (isinstance(node, ast.ImportFrom) and node.module
          == 'ble_latex.cli.common'):
      used |= {alias.name for alias in node.names}
    elif isinstance(node, ast.ImportFrom) and (node.module or '').startswith(
        'ble_latex.cli.'):
      others.add(node.module)
    elif isinstance(node, ast.Import):
      for alias in node.names:
        if alias.name == 'ble_latex.cli.common' and alias.asname:
          aliases.add(alias.asname)
        elif alias.name.startswith('ble_latex.cli.'):
          others.add(alias.name)
  for node in ast.walk(tree):
    if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
        and node.value.id in aliases):
      used.add(node.attr)
  return used, others


def test_cli_common_holds_only_the_command_convention():
  extra = sorted(_defined_names(CLI_COMMON) - CLI_CONVENTION)
  assert not extra, (
      f'{extra}: ble_latex/cli/common.py is the command convention; move '
      'library logic into the package (or add a convention name to '
      'CLI_CONVENTION)')


def test_benchmark_scripts_take_only_the_convention_from_cli():
  found = {}
  for name, path in _scripts().items():
    used, others = _cli_uses(path)
    bad = sorted(used - CLI_CONVENTION) + sorted(others)
    if bad:
      found[name] = bad
  assert not found, (
      f'{found}: scripts take only the command convention from '
      'ble_latex.cli.common (CLI_CONVENTION); call library logic in its home '
      'in the package')


def test_the_cli_checks_see_a_library_call_through_cli(tmp_path):
  # The checks above cannot pass vacuously.
  probe = tmp_path / 'probe.py'
  probe.write_text('from ble_latex.cli import common as cli\n'
                   'from ble_latex.cli import plot\n'
                   'import ble_latex.cli.common as c2\n'
                   'from ble_latex.cli.common import run_absl, one_line\n'
                   'cli.run_absl(None)\n'
                   'def f():\n  return cli.era5_bindings(None, None, "x")\n'
                   'c2.station_bindings(1, 2)\n', encoding='utf-8')
  used, others = _cli_uses(probe)
  assert used - CLI_CONVENTION == {'era5_bindings', 'station_bindings',
                                   'one_line'}
  assert others == {'plot'}
  assert {'run_absl', 'define_gin_flags', 'CommandUsageError'} <= (
      _defined_names(CLI_COMMON))


# -- tests load a script of benchmarks/ only to run its command line. --------
# A script is loaded by conftest's `benchmark_script` fixture alone, and a
# test uses only its `main` (monkeypatching what main calls is fine): logic a
# test needs on its own belongs in the package (issue 66).
TESTS = PACKAGE.parent / 'tests'
SCRIPT_LOADER = 'benchmark_script'
SCRIPT_COMMAND_LINE = frozenset({'main'})
_LOADER_CALLS = frozenset({'spec_from_file_location', 'spec_from_loader',
                           'run_path', 'run_module', 'import_module',
                           'SourceFileLoader'})
# (test file, script, name) still reached in a script for library logic:
# each moves into the package and leaves this list (a stale entry fails).
SCRIPT_LOGIC_PENDING = frozenset()


def _script_name(call: ast.AST) -> str:
  """'x.py' of `benchmark_script('x.py')` (os.path.join of constants read
  as 'a/b.py'), '' if `call` is no such call, '?' if not constant."""
  if not (isinstance(call, ast.Call) and isinstance(call.func, ast.Name)
          and call.func.id == SCRIPT_LOADER and call.args):
    return ''
  arg = call.args[0]
  if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
    return arg.value
  if isinstance(arg, ast.Call) and all(
      isinstance(a, ast.Constant) for a in arg.args):
    return '/'.join(a.value for a in arg.args)
  return '?'


def _called_name(call: ast.Call) -> str:
  func = call.func
  return func.attr if isinstance(func, ast.Attribute) else getattr(
      func, 'id', '')


def _script_uses(path: pathlib.Path) -> Tuple[Set[Tuple[str, str]],
                                               List[int]]:
  """A test file's ({(script, name used)} beyond `main`, lines loading a
  benchmarks/ script other than through the fixture)."""
  tree = ast.parse(path.read_text(encoding='utf-8'), str(path))

  def is_benchmarks(node: ast.AST) -> bool:  # 'benchmarks', 'benchmarks/x'
    return (isinstance(node, ast.Constant) and isinstance(node.value, str)
            and node.value.split('/')[0] == 'benchmarks')

  # Names bound to a path under benchmarks/ (`script = ROOT / 'benchmarks'
  # / 'x.py'`), then calls that load from one.
  paths = {t.id for n in ast.walk(tree) if isinstance(n, ast.Assign)
           and any(is_benchmarks(c) for c in ast.walk(n.value))
           for t in n.targets if isinstance(t, ast.Name)}
  # The loaders: importlib's and runpy's, and the file's helpers around them.
  loaders = _LOADER_CALLS | {
      f.name for f in ast.walk(tree) if isinstance(f, ast.FunctionDef)
      and any(isinstance(c, ast.Call) and _called_name(c) in _LOADER_CALLS
              for c in ast.walk(f))}
  loads = sorted(
      n.lineno for n in ast.walk(tree)
      if isinstance(n, ast.Call) and _called_name(n) in loaders
      and any(is_benchmarks(c) or (isinstance(c, ast.Name) and c.id in paths)
              for a in [*n.args, *(k.value for k in n.keywords)]
              for c in ast.walk(a)))
  fixtures = {}  # A fixture returning a loaded script: its name -> script.
  for node in ast.walk(tree):
    if isinstance(node, ast.FunctionDef):
      for ret in ast.walk(node):
        if isinstance(ret, ast.Return) and _script_name(ret.value):
          fixtures[node.name] = _script_name(ret.value)
  used = set()
  for func in ast.walk(tree):
    if not isinstance(func, ast.FunctionDef):
      continue
    bound = {a.arg: fixtures[a.arg] for a in func.args.args
             if a.arg in fixtures}
    for node in ast.walk(func):
      if (isinstance(node, ast.Assign) and len(node.targets) == 1 and
          isinstance(node.targets[0], ast.Name) and _script_name(node.value)):
        bound[node.targets[0].id] = _script_name(node.value)
    for node in ast.walk(func):
      if not isinstance(node, ast.Attribute):
        continue
      script = _script_name(node.value) or (
          bound.get(node.value.id, '') if isinstance(node.value, ast.Name)
          else '')
      if script and node.attr not in SCRIPT_COMMAND_LINE:
        used.add((script, node.attr))
  return used, loads


def _tests_script_uses() -> Tuple[Set[Tuple[str, str, str]],
                                  Dict[str, List[int]]]:
  uses, loads = set(), {}
  for path in sorted(TESTS.rglob('test_*.py')):
    used, lines = _script_uses(path)
    uses |= {(str(path.relative_to(TESTS)), *u) for u in used}
    if lines:
      loads[str(path.relative_to(TESTS))] = lines
  return uses, loads


def test_tests_load_benchmark_scripts_only_through_the_fixture():
  _, loads = _tests_script_uses()
  assert not loads, (
      f'{loads}: load a benchmarks/ script with the `{SCRIPT_LOADER}` '
      'fixture (tests/conftest.py), to run its main')


def test_tests_use_benchmark_scripts_only_for_their_command_line():
  uses, _ = _tests_script_uses()
  new = sorted(uses - SCRIPT_LOGIC_PENDING)
  assert not new, (
      f'{new}: tests use these benchmarks/ scripts\' names beyond main: '
      'move the logic into ble_latex/ and test it there')
  moved = sorted(SCRIPT_LOGIC_PENDING - uses)
  assert not moved, f'{moved}: no longer used; drop from SCRIPT_LOGIC_PENDING'


def test_the_script_use_check_sees_library_use_and_direct_loads(tmp_path):
  # The checks above cannot pass vacuously.
  probe = tmp_path / 'test_probe.py'
  probe.write_text(
      'import importlib.util, pytest\n'
      '@pytest.fixture\n'
      'def paths(benchmark_script):\n'
      '  return benchmark_script("real_winds_paths.py")\n'
      'def test_a(paths, benchmark_script):\n'
      '  paths.main([])\n'
      '  paths.track_latlon({})\n'
      '  benchmark_script("sac_seeds.py").compare([])\n'
      '  grib = benchmark_script(os.path.join("gpu", "decode_grib.py"))\n'
      '  grib.digest(1)\n'
      'def test_b(tmp_path):\n'
      '  importlib.util.spec_from_file_location("x", ROOT / "benchmarks" /'
      ' "x.py")\n'
      '  script = ROOT / "benchmarks" / "y.py"\n'
      '  runpy.run_path(str(script))\n'
      '  importlib.import_module("ble_latex.cli.eval")\n'
      '  text = "benchmarks/planners.py"\n'
      'def _load(name, path):\n'
      '  return importlib.util.spec_from_file_location(name, path)\n'
      'def test_c():\n'
      '  _load("y", ROOT / "benchmarks" / "y.py")\n'
      '  _load("t", ROOT / "docs" / "hooks" / "tables.py")\n',
      encoding='utf-8')
  used, loads = _script_uses(probe)
  assert used == {('real_winds_paths.py', 'track_latlon'),
                  ('sac_seeds.py', 'compare'),
                  ('gpu/decode_grib.py', 'digest')}
  assert loads == [12, 14, 20]
