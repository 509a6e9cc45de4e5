"""benchmarks/launch_search.py: its flags, record and output folder checked
up front (issue 67)."""

import pytest

from tests import helpers


# -- Items 13, 14: benchmarks/launch_search.py. -----------------------------
@pytest.mark.parametrize('argv, needle', [
    (['--seeds=abc'], '--seeds'),
    (['--seeds=-1'], '--seeds'),
    (['--budgets=0'], '--budgets'),
    (['--budgets=x'], '--budgets'),
    (['--grid=100000,100000,100'], 'balloons, more than'),
    (['--grid=3,3'], '--grid'),
    (['--draws=0'], '--draws'),
])
def test_launch_search_flags_are_checked_up_front(argv, needle, tmp_path,
                                                  capsys, benchmark_script):
  script = benchmark_script('launch_search.py')
  out = tmp_path / 'ls.json'
  assert script.main([f'--output={out}', *argv]) == 2
  assert needle in helpers.one_line(capsys, 'launch_search')
  assert not out.exists()


@pytest.mark.parametrize('text', ['{"settings": {"gri', '[1, 2]',
                                  '{"settings": {}, "cases": []}'])
def test_launch_search_bad_record_is_one_line(text, tmp_path, capsys,
                                              benchmark_script):
  script = benchmark_script('launch_search.py')
  out = tmp_path / 'ls.json'
  out.write_text(text)
  assert script.main([f'--output={out}', '--seeds=0']) == 1
  assert str(out) in helpers.one_line(capsys, 'launch_search')
  assert out.read_text() == text


def test_launch_search_output_folder_checked_first(tmp_path, capsys,
                                                   benchmark_script):
  script = benchmark_script('launch_search.py')
  blocker = tmp_path / 'file'
  blocker.write_text('x')
  assert script.main([f'--output={blocker / "ls.json"}', '--seeds=0']) == 1
  assert '--output' in helpers.one_line(capsys, 'launch_search')
