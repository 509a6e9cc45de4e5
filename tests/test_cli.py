"""Command-line contract: --help lists flags and exits 0; usage errors are one
line naming the valid choices, with exit status 2 (README "Commands")."""

import os
import subprocess
import sys

import pytest

from ble_latex.cli import common as cli

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _python(code: str, timeout: float = 300) -> subprocess.CompletedProcess:
  return subprocess.run([sys.executable, '-c', code], cwd=REPO,
                        capture_output=True, text=True, timeout=timeout)


def test_unknown_names_one_line_with_guess():
  message = cli.unknown('suite', 'latex_tinyy', ['latex_tiny', 'micro_eval'])
  assert message == ("unknown suite 'latex_tinyy' (did you mean 'latex_tiny'?)"
                     '; valid: latex_tiny, micro_eval')
  assert '\n' not in message


def test_gin_usage_message():
  assert cli.gin_usage_message(ValueError(
      "No configurable matching 'nope'.\n  In bindings string line 1")
                              ).startswith("unknown gin configurable 'nope'")
  assert cli.gin_usage_message(ValueError('other')) is None


# One process per command (a clean start, as from the shell); each case is
# run with main(argv) and reported as "CASE <i> EXIT <code>" on stdout, its
# stderr between "CASE <i>" markers.
_ABSL_CASES = '''
import sys
from ble_latex.cli import {module} as command
for i, argv in enumerate({cases!r}):
  print(f'CASE {{i}}', file=sys.stderr, flush=True)
  code = command.main(argv)
  print(f'CASE {{i}} EXIT {{code}}', flush=True)
'''


def _absl_cases(module: str, cases):
  result = _python(_ABSL_CASES.format(module=module, cases=cases))
  assert result.returncode == 0, result.stderr[-3000:]
  codes = [int(line.rsplit(' ', 1)[1]) for line in result.stdout.splitlines()
           if line.startswith('CASE ')]
  errors = [part.split('\n', 1)[1] if '\n' in part else ''
            for part in result.stderr.split('CASE ')[1:]]
  return codes, errors, result.stdout


def test_eval_help_and_usage_errors():
  cases = [['--help'], ['--agent=nope'],
           ['--agent=latex_random', '--suite=latex_tinyy'],
           ['--agent=latex_random', '--gin_file=nope.gin'],
           ['--agent=latex_random', '--gin_bindings=nope.x = 1'],
           ['--agent=latex_random', '--env_name=Nope-v0'],
           ['--nope'],
           ['--agent=latex_random', '--checkpoint_idx=3']]
  codes, errors, stdout = _absl_cases('eval', cases)
  assert codes == [0, 2, 2, 2, 2, 2, 2, 2]
  for flag in ('--agent', '--suite', '--output_dir', '--checkpoint_dir',
               '--gin_bindings', '--max_episode_length'):
    assert flag in stdout
  for error in errors[1:]:
    assert error.startswith('ble-latex-eval: ') and error.count('\n') == 1, (
        error)
  assert 'latex_station_seeker' in errors[1] and 'sac' in errors[1]
  assert "did you mean 'latex_tiny'" in errors[2]
  assert 'sac.gin' in errors[3]
  assert 'LatexBalloonEnv' in errors[4]
  assert 'LatexBalloonDiscrete-v0' in errors[5]
  assert "'nope'" in errors[6]
  assert '--checkpoint_dir and --checkpoint_idx' in errors[7]


def test_sweep_and_ray_eval_usage_errors(tmp_path):
  space = tmp_path / 'space.json'
  space.write_text('{"bindings": {"sac_trainer_config.gamma": {"normal": 1}}}')
  d = f'--sweep_dir={tmp_path}/sweep'
  cases = [['--help'], [d], [d, f'--space={space}'],
           [d, '--grid=sac_trainer_config.gamma'],
           [d, '--grid=sac_trainer_config.nope=1,2'],
           [d, '--grid=sac_trainer_config.gamma=0.9', '--ray_address=nowhere'],
           [d, '--grid=sac_trainer_config.gamma=0.9', '--seeds=0,0'],
           [d, '--grid=sac_trainer_config.gamma=0.9',
            '--ray_address=127.0.0.1:9']]
  codes, errors, stdout = _absl_cases('sweep', cases)
  assert codes == [0] + [2] * 7
  for flag in ('--sweep_dir', '--space', '--grid', '--seeds', '--asha',
               '--ray_address'):
    assert flag in stdout
  for error in errors[1:]:
    assert error.startswith('ble-latex-sweep: ') and error.count('\n') == 1, (
        error)
  assert 'nothing to sweep' in errors[1]
  assert str(space) in errors[2] and 'normal' in errors[2]
  assert 'NAME=V1,V2' in errors[3]
  assert 'nope' in errors[4]  # gin's own message, before Ray starts.
  assert 'HOST:PORT' in errors[5] and 'distinct' in errors[6]
  assert 'cannot reach the Ray cluster' in errors[7]
  codes, errors, _ = _absl_cases('eval', [
      ['--agent=latex_random', '--ray_address=nowhere'],
      ['--agent=latex_random', '--ray_num_cpus=2'],
      ['--agent=latex_random', '--ray_address=127.0.0.1:9']])
  assert codes == [2, 2, 2]
  assert 'HOST:PORT' in errors[0] and '--ray_address=local' in errors[1]
  assert 'cannot reach the Ray cluster' in errors[2]


@pytest.mark.slow
def test_train_and_export_policy_help_and_usage_errors():
  codes, errors, stdout = _absl_cases(
      'train', [['--help'], ['--agent=sac'],
                ['--base_dir=/tmp/x', '--agent=nope'],
                ['--base_dir=/tmp/x', '--collectors=nope']])
  assert codes == [0, 2, 2, 2]
  assert '--base_dir' in stdout and '--episodes_per_iteration' in stdout
  assert 'base_dir' in errors[1] and 'dqn' in errors[2]
  assert 'episodes' in errors[3]
  assert all(e.count('\n') == 1 for e in errors[1:])
  codes, errors, stdout = _absl_cases(
      'train', [['--base_dir=/tmp/x', '--trainer=jax',
                 '--episodes_per_iteration=3'],
                ['--base_dir=/tmp/x', '--trainer=jax', '--agent=latex_random'],
                ['--base_dir=/tmp/x', '--seeds=0,x'],
                ['--base_dir=/tmp/x', '--seeds=1,1'],
                ['--base_dir=/tmp/x', '--trainer=jax',
                 '--validation_episodes=101'],
                ['--base_dir=/tmp/x', '--trainer=nope'],
                ['--base_dir=/tmp/x', '--trainer=jax', '--vmap_seeds'],
                ['--base_dir=/tmp/x', '--seeds=0,1', '--vmap_seeds']])
  assert codes == [2] * 8
  assert 'episodes_per_iteration is not used by --trainer=jax' in errors[0]
  assert '--agent=sac' in errors[1]
  assert 'integers' in errors[2] and 'distinct' in errors[3]
  assert 'validation_episodes' in errors[4] and 'trainer' in errors[5]
  assert all('--vmap_seeds needs --trainer=jax and --seeds' in e
             for e in errors[6:])
  codes, errors, stdout = _absl_cases('export_policy', [['--help'], []])
  assert codes == [0, 2]
  assert '--checkpoint' in stdout and '--output' in stdout
  assert errors[1].startswith('ble-latex-export-policy: ')


@pytest.mark.parametrize('module, flag', [
    ('validate', '--max_error_percent'),
    ('download_era5', '--dry_run'),
    ('plot', '--eval_json'),
    ('demo', '--train_episodes'),
])
def test_in_process_commands_share_the_convention(module, flag, capsys):
  # Every command's own flags: these import side by side in one process,
  # though their flags share names (--output_dir, --gin_file, --seed).
  command = __import__(f'ble_latex.cli.{module}', fromlist=['main'])
  prog = 'ble-latex-' + module.replace('_', '-')
  assert command.main(['--help']) == 0
  out = capsys.readouterr().out
  assert out.startswith(f'usage: {prog} [flags]') and flag in out
  assert command.main(['--no_such_flag']) == 2
  err = capsys.readouterr().err
  assert err.startswith(f'{prog}: ') and err.count('\n') == 1, err
  assert "'no_such_flag'" in err
  required = ['--output_dir=unused'] if module == 'plot' else []
  assert command.main(['stray', *required]) == 2
  err = capsys.readouterr().err
  assert err == f"{prog}: unexpected arguments: ['stray']\n", err


def test_ble_commands_help(capsys):
  from ble_latex.cli import ble_commands  # pylint: disable=g-import-not-at-top
  assert ble_commands.main(['--help']) == 0
  assert 'train' in capsys.readouterr().out


def test_gin_usage_errors_of_validate_and_plot(capsys, tmp_path):
  from ble_latex.cli import plot  # pylint: disable=g-import-not-at-top
  from ble_latex.cli import validate  # pylint: disable=g-import-not-at-top
  assert validate.main(['--gin_file', 'nope.gin']) == 2
  err = capsys.readouterr().err
  assert err.count('\n') == 1 and 'latex_physics.gin' in err
  assert plot.main([f'--output_dir={tmp_path}', '--wind_seed=1',
                    '--gin_files=nope.gin']) == 2
  err = capsys.readouterr().err
  assert err.count('\n') == 1 and 'paper_era5.gin' in err


@pytest.mark.slow
def test_demo_unknown_suite(capsys):
  from ble_latex.cli import demo  # pylint: disable=g-import-not-at-top
  assert demo.main(['--suite=nope']) == 2
  err = capsys.readouterr().err
  assert err.count('\n') == 1 and 'latex_tiny' in err
  assert demo.main(['--baseline=station_seeker']) == 2
  err = capsys.readouterr().err
  assert err.count('\n') == 1 and 'latex_station_seeker' in err


def test_plot_wind_stats_usage_errors(capsys, tmp_path):
  from ble_latex.cli import plot  # pylint: disable=g-import-not-at-top
  out = f'--output_dir={tmp_path / "plots"}'
  for argv, message in (
      (['--wind_stats'], '--wind_stats needs --era5_path'),
      (['--wind_seed=1', '--era5_path=x.nc'],
       '--era5_path and --wind_stats_* need --wind_stats'),
      (['--wind_seed=1', '--wind_stats_samples=5'],
       '--era5_path and --wind_stats_* need --wind_stats'),
      (['--wind_stats', '--era5_path=x.nc', '--wind_stats_samples=0'],
       '--wind_stats_samples'),
      (['--wind_stats', '--era5_path=x.nc', '--wind_stats_pressures_pa=5000'],
       '--wind_stats_pressures_pa needs 2 or more levels')):
    assert plot.main([out, *argv]) == 2, argv
    err = capsys.readouterr().err
    assert err.startswith('ble-latex-plot: ') and err.count('\n') == 1, err
    assert message in err, err
  assert not (tmp_path / 'plots').exists()
