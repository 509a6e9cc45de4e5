# coding=utf-8
"""The documentation: README's size and links, the site's coverage and build.

The site (mkdocs.yml, docs/) is built with `mkdocs build --strict` (every
warning is an error: broken links and anchors, docstrings griffe cannot
parse, pages missing from the nav). That test needs the `docs` extra
(`pip install -c constraints.txt -e '.[docs]'`, which `make venv` and CI
install) and is skipped, saying so, where mkdocs is not installed.
"""

import importlib.util
import json
import os
import re
import subprocess
import sys

import pytest

from tests import helpers

ROOT = helpers.ROOT
DOCS = ROOT / 'docs'
README = ROOT / 'README.md'
README_MAX_LINES = 300


@pytest.fixture(name='hooks')
def _hooks(monkeypatch):
  """Imports a module of docs/hooks by name, as MkDocs runs its hook: with
  docs/hooks on sys.path (the hooks import each other as siblings)."""
  monkeypatch.syspath_prepend(str(DOCS / 'hooks'))
  return importlib.import_module


def _docs_text() -> str:
  return '\n'.join(p.read_text(encoding='utf-8')
                   for p in sorted(DOCS.rglob('*.md')))


def test_readme_fits_its_budget():
  lines = README.read_text(encoding='utf-8').splitlines()
  assert len(lines) <= README_MAX_LINES, (
      f'README.md has {len(lines)} lines, more than {README_MAX_LINES}: move '
      'reference material to a page under docs/')


def test_readme_links_into_the_docs_exist():
  text = README.read_text(encoding='utf-8')
  targets = re.findall(r'\]\((docs/[^)#\s]+)(?:#[^)\s]*)?\)', text)
  assert targets, 'README.md links to no page under docs/'
  missing = sorted({t for t in targets if not (ROOT / t).exists()})
  assert not missing, f'README.md links to missing files: {missing}'


def test_every_command_and_gin_file_is_documented(hooks):
  docs = _docs_text()
  commands = hooks('generated').console_scripts()
  assert 'ble-latex-train' in commands  # the parser found the entry points
  gin_files = sorted(p.name for p in (ROOT / 'gin_configs').glob('*.gin'))
  assert gin_files
  undocumented = [name for name in list(commands) + gin_files
                  if not re.search(rf'(?<![\w-]){re.escape(name)}(?![\w-])',
                                   docs)]
  assert not undocumented, (
      f'not mentioned on any page under docs/: {undocumented}')


def test_observation_map_names_every_feature_once(hooks):
  """The table the site generates covers indices 0..NUM_FEATURES-1."""
  from ble_latex.envs import jax_features  # pylint: disable=g-import-not-at-top
  hook = hooks('generated')
  rows = hook.observation_rows()
  indices = [i for index, _, _ in rows for i in hook.row_indices(index)]
  assert indices == list(range(jax_features.NUM_FEATURES))
  # The scalings the table states are the module's constants.
  text = ' '.join(scaling for _, _, scaling in rows)
  for constant in (jax_features.SPEED_SQUASH_MPS,
                   jax_features.DISTANCE_SQUASH_KM,
                   jax_features.ASCENT_RATE_SCALE_MPS,
                   jax_features.DRAG_AREA_SCALE_M2,
                   jax_features.VOLUME_SCALE_M3):
    assert f'{constant:g}' in text, constant


def test_hook_refuses_unknown_generated_blocks(hooks):
  with pytest.raises(ValueError, match='unknown generated block'):
    hooks('generated').on_page_markdown('<!-- generated: no-such-table -->')


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
def test_site_builds_strictly(tmp_path):
  if importlib.util.find_spec('mkdocs') is None:
    pytest.skip("mkdocs is not installed: pip install -c constraints.txt "
                "-e '.[docs]' (make venv does) to build the site")
  site = tmp_path / 'site'
  env = dict(os.environ, NO_MKDOCS_2_WARNING='1')
  result = subprocess.run(
      [sys.executable, '-m', 'mkdocs', 'build', '--strict', '--quiet',
       '--config-file', str(ROOT / 'mkdocs.yml'), '--site-dir', str(site)],
      cwd=ROOT, env=env, capture_output=True, text=True, timeout=300,
      check=False)
  assert result.returncode == 0, result.stdout + result.stderr
  pages = sorted(p.parent.relative_to(site).as_posix()
                 for p in site.rglob('index.html'))
  assert len(pages) >= 6, pages
  environment = (site / 'environment' / 'index.html').read_text()
  assert 'generated:' not in environment
  assert 'squash(|x|, 250 km)' in environment  # the generated table
  reference = (site / 'api' / 'envs' / 'index.html').read_text()
  assert 'ble_latex.envs.jax_env.LatexBalloonJaxEnv' in reference
  changelog = (site / 'changelog' / 'index.html').read_text()
  assert 'Keep a Changelog' in changelog  # CHANGELOG.md is included


def test_result_tables_are_the_records(hooks):
  """README's and the docs' result tables equal what the records give."""
  tables = hooks('tables')
  pages = {str(p.relative_to(ROOT)) for p in tables.pages()}
  assert {'README.md', 'docs/results.md', 'docs/planners.md'} <= pages
  assert not tables.stale(), 'run python docs/hooks/tables.py'


def test_a_result_table_follows_its_record(tmp_path, monkeypatch, hooks):
  tables = hooks('tables')
  rows = json.loads(tables.RESULTS.read_text(encoding='utf-8'))
  for row in rows:
    if row['agent'] == 'latex_random':
      row['tw50_window'] = [0.5, 0.25]
  changed = tmp_path / 'results.json'
  changed.write_text(json.dumps(rows), encoding='utf-8')
  text = '<!-- table: agents-short -->\nold\n<!-- end table -->\n'
  monkeypatch.setattr(tables, 'RESULTS', changed)
  assert '| `latex_random` | 50.0 % ± 25.0 |' in tables.fill(text)
  with pytest.raises(ValueError, match='unknown table'):
    tables.fill('<!-- table: nosuch -->\n<!-- end table -->')
  # The site's hook regenerates the blocks too.
  assert 'old' not in hooks('generated').on_page_markdown(text)


def test_the_reward_study_tables_pair_the_same_flights(tmp_path, monkeypatch,
                                                        hooks):
  """Over training seeds: mean ± sample std, each seed; per seed: tanh − flat
  on the same flights with its standard error, ahead / behind."""
  tables = hooks('tables')

  def row(windows, real):
    return {'held_out_tw50_window': sum(windows) / len(windows),
            'edge_fraction': 0.1, 'core_fraction': 0.5,
            'edge_share_of_inside': 0.2,
            'held_out_out_of_resources_pct': 3.0,
            'held_out_per_seed': {'seeds': [1, 2, 3], 'tw50_window': windows},
            'real_winds': {'hilo': {'tw50_window': real, 'per_seed': {
                'seeds': [1, 2, 3], 'tw50_window': [real] * 3}}}}
  record = {'rewards': {
      'perciatelli': {'seeds': {'0': row([0.4, 0.5, 0.6], 0.3),
                                '1': row([0.6, 0.6, 0.6], 0.5)}},
      'tanh': {'seeds': {'0': row([0.5, 0.5, 0.8], 0.4),
                         '1': row([0.6, 0.6, 0.6], 0.5)}}}}
  path = tmp_path / 'reward_shape.json'
  path.write_text(json.dumps(record), encoding='utf-8')
  monkeypatch.setattr(tables, 'REWARD_SHAPE', path)
  study = tables.reward_shape()
  assert '| flat (the paper\'s, default) | 2 | 55.0 % ± 7.1 (50.0 / 60.0) |' \
      in study
  assert '40.0 % ± 14.1 (30.0 / 50.0)' in study  # Hilo, flat.
  paired = tables.reward_shape_paired().splitlines()
  # Seed 0: differences +0.1, 0, +0.2: mean +10 pts, SE 0.1/sqrt(3).
  assert paired[2].startswith('| 0 | +10.0 ± 5.8 (2 / 0) |'), paired[2]
  assert '| +10.0 ± 0.0 (3 / 0) |' in paired[2]  # Hilo.
  assert paired[3].startswith('| 1 | +0.0 ± 0.0 (0 / 0) |'), paired[3]
