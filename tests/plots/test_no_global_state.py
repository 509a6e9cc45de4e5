"""The package's figures leave matplotlib's process-wide state alone.

A user's notebook or GUI keeps its own backend after drawing one of our
figures: every module of `ble_latex/` draws on its own `Figure` with an Agg
canvas (`plots.figures.save_png`), never through pyplot, and never calls
`matplotlib.use` (the developers' guide: no process-wide setting the user did
not ask for). Read statically, as tests/test_layers.py reads imports; the
figures themselves are drawn by their commands' tests (e.g. ble-latex-validate's
in tests/ble/test_balloon.py).
"""

import ast
import pathlib

from ble_latex.plots import validation

PACKAGE = pathlib.Path(validation.__file__).resolve().parents[1]


def _offences(path: pathlib.Path) -> list:
  """`matplotlib.use(...)` calls and pyplot imports in one source file."""
  found = []
  for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
    if isinstance(node, ast.Import):
      found += [a.name for a in node.names if a.name == 'matplotlib.pyplot']
    elif isinstance(node, ast.ImportFrom):
      if node.module == 'matplotlib.pyplot' or (
          node.module == 'matplotlib' and
          any(a.name == 'pyplot' for a in node.names)):
        found.append('pyplot')
    elif (isinstance(node, ast.Call) and
          isinstance(node.func, ast.Attribute) and node.func.attr == 'use' and
          isinstance(node.func.value, ast.Name) and
          node.func.value.id in ('matplotlib', 'mpl')):
      found.append(f'matplotlib.use at line {node.lineno}')
  return found


def test_no_module_sets_a_backend_or_uses_pyplot():
  offences = {str(p.relative_to(PACKAGE.parent)): _offences(p)
              for p in sorted(PACKAGE.rglob('*.py'))}
  assert not {p: o for p, o in offences.items() if o}


def test_the_check_finds_a_backend_switch(tmp_path):
  probe = tmp_path / 'probe.py'
  probe.write_text('import matplotlib\nmatplotlib.use("Agg")\n'
                   'from matplotlib import pyplot\n')
  assert sorted(_offences(probe)) == ['matplotlib.use at line 2', 'pyplot']

