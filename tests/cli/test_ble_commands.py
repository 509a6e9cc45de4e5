# coding=utf-8
"""BLE's own train and eval commands on the latex envs (docs/ble-commands.md).

The slow test runs every command of docs/ble-commands.md as written (its
/tmp/ble_cmds paths in a temporary folder): BLE's train with SAC on
LatexBalloon-v0 and a latex gin binding, BLE's train with DQN on
LatexBalloonDiscrete-v0, BLE's eval (`ble-latex-ble eval --env_name`) of both
checkpoints on latex_micro, the same checkpoints through `ble-latex-eval`
(records equal per seed), and a mistake that is one line.
"""

import json
import os
import pathlib
import re
import shlex
import subprocess
import sys

import pytest

from ble_latex.cli import ble_commands

from tests import helpers

ROOT = helpers.ROOT
PAGE = ROOT / 'docs' / 'ble-commands.md'
PLACEHOLDER = '/tmp/ble_cmds'
# How each documented program runs here (the console scripts' modules).
PROGRAMS = {
    'python': [sys.executable],
    'ble-latex-ble': [sys.executable, '-m', 'ble_latex.cli.ble_commands'],
    'ble-latex-eval': [sys.executable, '-m', 'ble_latex.cli.eval'],
}


MISTAKES = '## Mistakes are one line'


def documented_commands(section: str = ''):
  """The page's `sh` blocks (of one `## ` section), one per (continued) line."""
  text = PAGE.read_text(encoding='utf-8')
  if section:
    text = text.split(section, 1)[1].split('\n## ', 1)[0]
  commands = []
  for block in re.findall(r'```sh\n(.*?)```', text, re.S):
    commands += [c.strip() for c in block.replace('\\\n', ' ').splitlines()
                 if c.strip()]
  return commands


def test_the_page_documents_the_issue_commands():
  commands = documented_commands()
  assert any('balloon_learning_environment.train' in c and '--agent=sac' in c
             and 'latex_episode.' in c for c in commands)
  assert any('--agent=dqn' in c and 'LatexBalloonDiscrete-v0' in c and
             'balloon_learning_environment.train' in c for c in commands)
  assert sum(c.startswith('ble-latex-ble eval --env_name') for c in commands
             ) >= 2
  assert all(shlex.split(c)[0] in PROGRAMS for c in commands)


@pytest.mark.parametrize('args,latex', [
    (['--env_name=LatexBalloon-v0', '--agent=sac'], True),
    (['--agent=station_seeker', '--suite=latex_micro'], True),
    (['--agent=station_seeker', '--suite', 'latex_tiny'], True),
    (['--agent=station_seeker', '--suite=micro_eval'], False),
    ([], False),
])
def test_eval_runs_on_a_latex_env_when_asked(args, latex):
  assert ble_commands._latex_eval(args) == latex  # pylint: disable=protected-access


def test_agent_fit_errors_name_the_way_out():
  from ble_latex import errors  # pylint: disable=g-import-not-at-top
  from ble_latex.run import ble_support  # pylint: disable=g-import-not-at-top
  train, evaluate = ble_support.BLE_TRAIN, ble_support.BLE_EVAL
  ble_support.check_agent_fits('sac', 'LatexBalloon-v0', train)
  ble_support.check_agent_fits('dqn', 'LatexBalloonDiscrete-v0', train)
  cases = [
      ('sac', 'LatexBalloonDiscrete-v0', train, '--env_name=LatexBalloon-v0'),
      ('sac', 'BalloonLearningEnvironment-v0', evaluate,
       'ble-latex-ble eval --env_name=LatexBalloon-v0'),
      ('dqn', 'LatexBalloon-v0', train, 'LatexBalloonDiscrete-v0'),
      ('latex_mpc', 'LatexBalloon-v0', train, 'ble-latex-ble eval'),
      ('sac_ensemble', 'LatexBalloon-v0', train, 'ble-latex-eval'),
  ]
  for agent, env, command, hint in cases:
    with pytest.raises(errors.ConfigError, match=re.escape(hint)):
      ble_support.check_agent_fits(agent, env, command)


def _run(command: str, tmp_path: pathlib.Path) -> subprocess.CompletedProcess:
  args = shlex.split(command.replace(PLACEHOLDER, str(tmp_path)))
  env = dict(os.environ, TF_CPP_MIN_LOG_LEVEL='3', JAX_PLATFORMS='cpu')
  return subprocess.run(PROGRAMS[args[0]] + args[1:], env=env, cwd=ROOT,
                        capture_output=True, text=True, timeout=900)


def _records(path: pathlib.Path):
  return {r['seed']: r for r in json.loads(path.read_text())}


@pytest.mark.slow
@pytest.mark.ci  # 7-13 min on 2 busy cores (load 4-8, 2026-12-05): make test-ci.
@pytest.mark.timeout(1800)  # Ten processes in a row, each importing BLE and TF.
def test_documented_commands_run_and_ble_eval_equals_latex_eval(tmp_path):
  """Every command of the page, in order; BLE's records = ble-latex-eval's."""
  mistakes = documented_commands(MISTAKES)
  assert len(mistakes) == 2
  for command in documented_commands():
    result = _run(command, tmp_path)
    if command in mistakes:
      assert result.returncode == 2, (command, result.stderr[-3000:])
      agent = re.search(r'--agent=(\w+)', command).group(1)
      lines = [l for l in result.stderr.splitlines() if repr(agent) in l]
      assert len(lines) == 1, (command, result.stderr[-3000:])
      assert 'Traceback' not in result.stderr
    else:
      assert result.returncode == 0, (command, result.stderr[-3000:])
      assert 'not fully represented' not in result.stderr
  for agent in ('sac', 'dqn'):
    assert (tmp_path / 'train' / agent / '1' / 'checkpoints').is_dir()
    ble = _records(tmp_path / 'ble_eval' / 'latex_micro' / f'{agent}_0.json')
    ours = _records(
        tmp_path / 'latex_eval' / 'latex_micro' / f'{agent}_0.json')
    assert sorted(ble) == sorted(ours) == [1_000_000]
    for seed, record in ble.items():
      assert record['final_timestep'] == ours[seed]['steps'], agent
      assert record['cumulative_reward'] == pytest.approx(
          ours[seed]['reward'], rel=1e-5), agent
      assert record['time_within_radius'] == pytest.approx(
          ours[seed]['tw50'], abs=1.5 / record['final_timestep']), agent
  for agent in ('sac_pretrained', 'sac_ensemble'):
    assert (tmp_path / 'ble_eval' / 'latex_micro' / f'{agent}.json').is_file()
