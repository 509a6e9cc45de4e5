"""Issue 67 (hardening, fourth round): each refusal is one line before any
work; each test fails without its fix."""

import json

import gin
import pytest

from ble_latex import errors
from ble_latex import gin_values


def _one_line(capsys, prog):
  err = capsys.readouterr().err.strip().splitlines()
  assert len(err) == 1, err
  assert err[0].startswith(f'{prog}: '), err
  return err[0]


# -- Item 6: "> 0" holds in float32 (XLA flushes subnormals to 0). ---------
@pytest.mark.parametrize('value', [1e-40, 1e-46, 1e-39])
def test_a_positive_number_that_is_0_in_float32_is_refused(value):
  assert not gin_values.is_positive(value)
  with pytest.raises(errors.ConfigError, match='float32'):
    gin_values.check_number('gin binding x.y', value, above=0.0)
  with pytest.raises(errors.ConfigError, match='float32'):
    gin_values.check_number('gin binding x.y', -value, below=0.0)
  assert gin_values.check_number('x', 1.2e-38, above=0.0) == 1.2e-38


@pytest.mark.parametrize('binding', [
    'latex_reward.reward_tanh_scale_km = 1e-40',
    'latex_reward.reward_halflife_km = 1e-45',
    'LatexBalloonEnv.station_keeping_radius_km = 1e-40',
])
def test_reward_bindings_that_are_0_in_float32_are_refused(binding):
  from ble_latex.envs import env_params  # pylint: disable=g-import-not-at-top
  gin.clear_config()
  try:
    gin.parse_config(binding)
    with pytest.raises(ValueError, match=binding.split(' ')[0]):
      env_params.params_from_gin()
  finally:
    gin.clear_config()


def test_tanh_scale_0_still_switches_the_reward_off():
  gin_values.check_reward_values({'reward_tanh_scale_km': 0.0})


# -- Items 6, 11, 12: benchmarks/reward_shape.py. ---------------------------
@pytest.mark.parametrize('argv, needle', [
    (['--tanh_scale_km=1e-40'], '--tanh_scale_km'),
    (['--seeds=99999999999999999999'], '[0, 4294967295]'),
    (['--seeds=0,-1'], '[0, 4294967295]'),
])
def test_reward_shape_refuses_flags_up_front(argv, needle, tmp_path, capsys,
                                             benchmark_script):
  script = benchmark_script('reward_shape.py')
  out = tmp_path / 'r.json'
  assert script.main([f'--base_dir={tmp_path / "b"}', f'--output={out}',
                      *argv]) == 2
  assert needle in _one_line(capsys, 'benchmarks/reward_shape.py')
  assert not (tmp_path / 'b').exists() and not out.exists()


@pytest.mark.parametrize('text, needle', [
    ('{"settings": {}, "rew', 'truncated'),
    ('{"settings": {}, "rewards": {"perciatelli": []}}', 'rewards.perciatelli'),
    ('{"settings": {}, "rewards": {"tanh": {"seeds": [1]}}}', 'rewards.tanh'),
])
def test_reward_shape_bad_record_is_one_line(text, needle, tmp_path, capsys,
                                             benchmark_script):
  script = benchmark_script('reward_shape.py')
  out = tmp_path / 'r.json'
  out.write_text(text)
  assert script.main([f'--base_dir={tmp_path / "b"}', f'--output={out}',
                      '--seeds=0']) == 1
  assert needle in _one_line(capsys, 'benchmarks/reward_shape.py')
  assert out.read_text() == text


def test_reward_shape_edges_of_a_bad_eval_file_is_one_line(
    tmp_path, capsys, benchmark_script):
  script = benchmark_script('reward_shape.py')
  for i, content in enumerate(([{'seed': 0}], {'a': 1}, '[{"seed"')):
    path = tmp_path / f'e{i}.json'
    path.write_text(content if isinstance(content, str) else
                    json.dumps(content))
    assert script.main([f'--edges_of={path}']) == 1
    assert str(path) in _one_line(capsys, 'benchmarks/reward_shape.py')
