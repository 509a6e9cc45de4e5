"""The distribution's metadata, licence and citation files."""

import importlib.metadata

import yaml

from tests import helpers

ROOT = helpers.ROOT


def test_wheel_metadata_names_licence_and_links():
  metadata = importlib.metadata.metadata('ble_latex')
  licence = metadata.get('License-Expression') or metadata.get('License')
  assert licence == 'Apache-2.0'
  urls = metadata.get_all('Project-URL') or []
  assert any('2303.01173' in url for url in urls)
  assert any('balloon-learning-environment' in url for url in urls)
  assert metadata['Requires-Python'] == '>=3.11'
  files = [str(f) for f in importlib.metadata.files('ble_latex') or []]
  assert any(f.endswith('LICENSE') for f in files), files


def test_licence_is_apache_2():
  text = (ROOT / 'LICENSE').read_text(encoding='utf-8')
  assert 'Apache License' in text and 'Version 2.0, January 2004' in text


def test_citation_cites_the_project_the_paper_and_ble():
  citation = yaml.safe_load((ROOT / 'CITATION.cff').read_text('utf-8'))
  assert citation['cff-version'] == '1.2.0'
  assert citation['license'] == 'Apache-2.0'
  setup = (ROOT / 'setup.py').read_text(encoding='utf-8')
  assert f"version='{citation['version']}'" in setup
  titles = [ref['title'] for ref in citation['references']]
  assert any('Resource-Constrained Station-Keeping' in t for t in titles)
  assert 'Balloon Learning Environment' in titles
