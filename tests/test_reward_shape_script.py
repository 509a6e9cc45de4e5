"""benchmarks/reward_shape.py's own pieces (the study itself is not run here)."""

import importlib.util
import json
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


@pytest.fixture
def script():
  spec = importlib.util.spec_from_file_location(
      'bench_reward_shape', ROOT / 'benchmarks' / 'reward_shape.py')
  module = importlib.util.module_from_spec(spec)
  spec.loader.exec_module(module)
  return module


def _record(distances_km, window):
  path = [{'x_km': 0.0, 'y_km': 0.0}]  # The start point does not count.
  path += [{'x_km': d * 0.6, 'y_km': d * 0.8} for d in distances_km]
  return {'flight_path': path, 'window_steps': window}


def test_edge_fractions_count_strides_of_the_window(script):
  record = _record([10.0, 39.9, 40.0, 40.1, 45.0, 50.0, 50.1, 80.0], 10)
  fractions = script.edge_fractions(record)
  assert fractions['core'] == pytest.approx(3 / 10)  # 10, 39.9, 40.
  assert fractions['edge'] == pytest.approx(3 / 10)  # 40.1, 45, 50.
  assert fractions['edge_share'] == pytest.approx(0.5)
  never = script.edge_fractions(_record([60.0, 70.0], 216))
  assert never['edge'] == never['core'] == 0.0


def test_rewards_and_their_bindings(script):
  assert script.reward_bindings('perciatelli', 25.0) == []
  assert script.reward_bindings('tanh', 25.0) == [
      'latex_reward.reward_tanh_scale_km = 25.0']


@pytest.mark.parametrize('args, message', [
    (['--rewards=flat'], "--rewards: 'flat' is not one of perciatelli, tanh"),
    (['--rounds=2'], '--snapshot_period=5 > --rounds=2'),
    (['--tanh_scale_km=-1'], '--tanh_scale_km must be a finite number > 0'),
])
def test_bad_flags_are_one_line(script, tmp_path, capsys, args, message):
  rc = script.main([f'--base_dir={tmp_path}',
                    f'--output={tmp_path / "r.json"}', *args])
  err = capsys.readouterr().err.strip().splitlines()
  assert rc == 2 and len(err) == 1 and message in err[0], err
  assert not (tmp_path / 'r.json').exists()


def test_a_resume_with_other_settings_is_refused(script, tmp_path, capsys):
  output = tmp_path / 'r.json'
  output.write_text(json.dumps({'settings': {'rounds': 60}, 'rewards': {}}))
  rc = script.main([f'--base_dir={tmp_path}', f'--output={output}',
                    '--rounds=61'])
  err = capsys.readouterr().err.strip().splitlines()
  assert rc == 1 and len(err) == 1, err
  assert 'made with other settings (' in err[0] and 'rounds: 60 -> 61' in err[0]
