"""benchmarks/policy_select.py: its sizes and output folder checked before
compiling (issue 67)."""

import pytest

from tests import helpers


# -- Items 18, 23: benchmarks/policy_select.py sizes before compiling. ------
@pytest.mark.parametrize('argv, needle', [
    (['--samples=1000000000'], '--samples must be in [0, '),
    (['--samples=-1'], '--samples must be in [0, '),
    (['--batch=0'], '--batch must be in [1, 65536]'),
    (['--batch=100000'], '--batch must be in [1, 65536]'),
    (['--num_seeds=0'], '--num_seeds'),
])
def test_policy_select_sizes_are_checked_before_compiling(
    argv, needle, tmp_path, capsys, benchmark_script):
  script = benchmark_script('policy_select.py')
  out = tmp_path / 'r.json'
  assert script.main(['policy_select.py', '--policy=shipped',
                      '--mode=critic', *argv, f'--output={out}']) == 2
  assert needle in helpers.one_line(capsys, 'policy_select')
  assert not out.exists()


def test_policy_select_output_folder_checked_first(tmp_path, capsys,
                                                   benchmark_script):
  script = benchmark_script('policy_select.py')
  out = tmp_path / 'missing' / 'r.json'
  assert script.main(['policy_select.py', '--policy=shipped',
                      f'--output={out}']) == 1
  assert '--output' in helpers.one_line(capsys, 'policy_select')
