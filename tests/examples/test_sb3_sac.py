"""examples/sb3_sac.py: SB3 SAC on ble_latex/LatexBalloon-v0, then its eval."""

import json
import os

import pytest

from tests.envs import gymnasium_cases as cases


# -- SB3 SAC (examples/sb3_sac.py). ------------------------------------------
def test_sb3_sac_trains_and_evaluates_with_eval_json(tmp_path, capsys):
  """SB3 SAC, a few hundred steps on ble_latex/LatexBalloon-v0, then eval."""
  import importlib.util  # pylint: disable=g-import-not-at-top
  from ble_latex.run import records as records_lib  # pylint: disable=g-import-not-at-top
  spec = importlib.util.spec_from_file_location(
      'sb3_sac', os.path.join(cases.REPO, 'examples', 'sb3_sac.py'))
  example = importlib.util.module_from_spec(spec)
  spec.loader.exec_module(example)
  threads = example.torch.get_num_threads()
  try:
    code = example.main([
        '--total_timesteps=300', '--learning_starts=100', '--batch_size=64',
        '--max_episode_length=20', '--num_eval_seeds=2', '--suite=latex_tiny',
        f'--output_dir={tmp_path}', f'--model_out={tmp_path / "sac.zip"}'])
  finally:
    example.torch.set_num_threads(threads)  # The example sets 1.
  assert code == 0
  path = tmp_path / 'latex_tiny' / 'sb3_sac.json'
  summary = json.loads(capsys.readouterr().out.splitlines()[-1])
  assert summary['output'] == str(path) and summary['episodes'] == 2
  records = records_lib.load_eval(str(path))  # ble-latex-eval's schema, checked.
  assert [r['seed'] for r in records] == [1_000_000, 1_000_001]
  assert all(r['steps'] == 20 and len(r['flight_path']) == 21
             for r in records)
  assert (tmp_path / 'sac.zip').is_file()
  with pytest.raises(SystemExit) as exit_info:
    example.main(['--suite=nope'])
  assert exit_info.value.code == 2
  assert 'latex_tiny' in capsys.readouterr().err
