# coding=utf-8
"""MkDocs hook: pages' generated parts, read from the code (nothing imported).

A page writes a marker comment on a line of its own and the hook puts the
generated Markdown there:

  * `<!-- generated: observation-table -->`: the observation index map, parsed
    from the module docstring of `ble_latex/envs/jax_features.py` (the one
    home of the feature list; `NamedLatexFeatures` decodes the same indices).
  * `<!-- generated: observation-options-table -->`: the optional features'
    index map, parsed from the docstring of `jax_features.option_features`.
  * `<!-- generated: console-scripts -->`: the commands of setup.py's
    `console_scripts`, each with the module it runs and that module's first
    docstring line.

Result tables (`<!-- table: NAME -->` ... `<!-- end table -->`) are made
from the committed records by `tables.py` beside this file (imported as a
sibling: MkDocs runs a hook with its folder on sys.path); the hook
regenerates them in every page it builds.

The parsers read source text with `ast` only (no JAX, TensorFlow or BLE).
tests/docs/test_docs.py uses them too.
"""

import ast
import pathlib
import re
from typing import Dict, List, Tuple

import tables  # docs/hooks/tables.py (MkDocs puts docs/hooks on sys.path)

ROOT = pathlib.Path(__file__).resolve().parents[2]
FEATURES_MODULE = ROOT / 'ble_latex' / 'envs' / 'jax_features.py'
SETUP_PY = ROOT / 'setup.py'
_MARKER = re.compile(r'^<!-- generated: ([a-z-]+) -->$', re.MULTILINE)


def _module_docstring(path: pathlib.Path) -> str:
  doc = ast.get_docstring(ast.parse(path.read_text(encoding='utf-8')))
  if not doc:
    raise ValueError(f'{path}: no module docstring')
  return doc


def _function_docstring(path: pathlib.Path, name: str) -> str:
  for node in ast.parse(path.read_text(encoding='utf-8')).body:
    if isinstance(node, ast.FunctionDef) and node.name == name:
      doc = ast.get_docstring(node)
      if doc:
        return doc
  raise ValueError(f'{path}: no function {name} with a docstring')


def observation_rows(path: pathlib.Path = FEATURES_MODULE,
                     function: str = '') -> List[Tuple[str, str, str]]:
  """The rows (indices, feature, scaling) of the features' index map.

  Args:
    path: The features module (its docstring holds the table).
    function: '' (the module's docstring), or the function of `path` whose
      docstring holds the table (`option_features`: the options').

  Returns:
    The table's rows in order, each cell stripped.

  Raises:
    ValueError: If the docstring has no index-map table.
  """
  # Cells hold pipes (|v|), so cells are split only at pipes with white space
  # on both sides, as the table's column borders are written.
  rows = []
  doc = (_function_docstring(path, function) if function else
         _module_docstring(path))
  for line in doc.splitlines():
    line = line.strip()
    if not line.startswith('|') or set(line) <= set('|- '):
      continue
    cells = [c.strip() for c in re.split(r'\s\|\s', line[1:-1].strip())]
    if cells[0] == 'index':
      continue
    if len(cells) != 3:
      raise ValueError(f'{path}: index-map row {line!r} has {len(cells)} '
                       'cells, expected 3 (index, feature, scaling)')
    rows.append((cells[0], cells[1], cells[2]))
  if not rows:
    raise ValueError(f'{path}: its docstring has no index-map table')
  return rows


def row_indices(index: str) -> List[int]:
  """The feature indices a row names: '0-24' -> 0..24, '58, 59' -> [58, 59]."""
  out = []
  for part in index.split(','):
    part = part.strip()
    if '-' in part:
      low, high = part.split('-')
      out.extend(range(int(low), int(high) + 1))
    else:
      out.append(int(part))
  return out


def _escape(cell: str) -> str:
  # Pipes inside a cell (|v|) would split a Markdown table cell.
  return cell.replace('|', r'\|')


def observation_table(function: str = '') -> str:
  """The index map (`observation_rows(function=...)`) as a Markdown table."""
  lines = ['| index | feature | scaling |', '|---|---|---|']
  for index, feature, scaling in observation_rows(function=function):
    index = index.replace('-', '–')
    lines.append(f'| {index} | {_escape(feature)} | {_escape(scaling)} |')
  return '\n'.join(lines)


def console_scripts(path: pathlib.Path = SETUP_PY) -> Dict[str, str]:
  """setup.py's console_scripts: command name -> 'module:function'."""
  tree = ast.parse(path.read_text(encoding='utf-8'))
  for node in ast.walk(tree):
    if (isinstance(node, ast.Dict) and any(
        isinstance(k, ast.Constant) and k.value == 'console_scripts'
        for k in node.keys)):
      for key, value in zip(node.keys, node.values):
        if isinstance(key, ast.Constant) and key.value == 'console_scripts':
          entries = ast.literal_eval(value)
          return dict((part.strip() for part in e.split('=', 1))
                      for e in entries)
  raise ValueError(f'{path}: no console_scripts entry points')


def commands_table() -> str:
  """The console scripts as a Markdown table (command, module, summary)."""
  lines = ['| command | module | what it does (module docstring) |',
           '|---|---|---|']
  for name, target in console_scripts().items():
    module = target.split(':')[0]
    source = ROOT.joinpath(*module.split('.')).with_suffix('.py')
    summary = _module_docstring(source).splitlines()[0]
    lines.append(f'| `{name}` | `python -m {module}` | {_escape(summary)} |')
  return '\n'.join(lines)


_GENERATORS = {
    'observation-table': observation_table,
    'observation-options-table': lambda: observation_table('option_features'),
    'console-scripts': commands_table,
}


def on_page_markdown(markdown: str, **kwargs) -> str:  # pylint: disable=unused-argument
  """MkDocs event: replaces each marker with its generated Markdown."""

  def generate(match: 're.Match[str]') -> str:
    name = match.group(1)
    if name not in _GENERATORS:
      raise ValueError(f'unknown generated block {name!r}; known: '
                       f'{sorted(_GENERATORS)}')
    return _GENERATORS[name]()

  return tables.fill(_MARKER.sub(generate, markdown),
                     kwargs.get('page', 'page'))
