# coding=utf-8
"""Record writers in benchmarks/ check their output before the work (issue 67).

Item 2: `valbal_check.py --output` into a missing folder failed only after
every flight had run, and wrote with a plain open (a full disk left invalid
JSON). Every record writer now asks `safe_io.output_problem` first and
writes with `safe_io.atomic_write`; a test reads the scripts' source for
plain writes, so a new writer cannot slip back.
"""

import re
import subprocess
import sys

import pytest

from ble_latex import safe_io

from tests import helpers

ROOT = helpers.ROOT


def test_output_problem_names_what_is_wrong(tmp_path):
  assert safe_io.output_problem(str(tmp_path / 'r.json')) is None
  assert 'no folder' in safe_io.output_problem(str(tmp_path / 'x' / 'r.json'))
  assert 'is a folder' in safe_io.output_problem(str(tmp_path))


@pytest.mark.parametrize('script, flag', [
    ('valbal_check.py', '--output'),
    ('float_calibration.py', '--json'),
])
def test_a_missing_output_folder_is_refused_before_flying(script, flag,
                                                          tmp_path):
  out = subprocess.run(
      [sys.executable, str(ROOT / 'benchmarks' / script),
       f'{flag}={tmp_path}/missing/r.json'], capture_output=True, text=True,
      timeout=120, check=False)
  assert out.returncode == 2
  assert 'no folder' in out.stderr and 'Traceback' not in out.stderr


def test_no_record_writer_in_benchmarks_writes_with_a_plain_open():
  plain = re.compile(r"open\([^)]*['\"]w['\"]|\.write_text\(")
  offenders = [str(p.relative_to(ROOT)) for p in
               sorted((ROOT / 'benchmarks').rglob('*.py'))
               if plain.search(p.read_text(encoding='utf-8'))]
  assert not offenders, f'plain writes (use safe_io.atomic_write): {offenders}'
