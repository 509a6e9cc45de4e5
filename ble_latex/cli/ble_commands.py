# coding=utf-8
r"""Runs BLE's own train/eval commands with the compatibility fixes applied.

BLE's own flags; BLE's modules run as they are (`python -m
balloon_learning_environment.train ...` works too, docs/ble-commands.md):

  ble-latex-ble train --env_name=LatexBalloon-v0 --agent=sac \
      --base_dir=/tmp/ble/train --num_iterations=1 --episodes_per_iteration=1
  ble-latex-ble eval --agent=station_seeker --suite=micro_eval \
      --output_dir=/tmp/ble/eval

BLE's eval builds only BLE's env; with --env_name (or a latex suite) it runs
as BLE's eval on that env, the latex suites among --suite's choices
(`ble_latex.run.ble_eval`, records in BLE's format):

  ble-latex-ble eval --env_name=LatexBalloon-v0 --agent=sac_pretrained \
      --suite=latex_micro --output_dir=/tmp/ble/eval
"""

import importlib
import runpy
import sys
from typing import Optional, Sequence

import ble_latex  # pylint: disable=unused-import  # Installs the fixes first.
from ble_latex.cli import common as cli
from ble_latex import errors
from ble_latex import quiet
from ble_latex.run import gin_binding

COMMANDS = {
    'train': 'balloon_learning_environment.train',
    'eval': 'balloon_learning_environment.eval.eval',
}
# What each command imports, loaded first inside `quiet.third_party_noise`
# (the commands themselves define absl flags, so runpy must run them once).
_DEPENDENCIES = {
    'train': ('balloon_learning_environment.train_lib',
              'balloon_learning_environment.utils.run_helpers'),
    'eval': ('balloon_learning_environment.eval.eval_lib',
             'balloon_learning_environment.utils.run_helpers'),
}
_HELP = ('-h', '--help', '-help', '--helpshort', '--helpfull')


def _latex_eval(args: Sequence[str]) -> bool:
  """Whether eval's flags ask for a latex env (--env_name) or suite."""
  return any(a.startswith(('--env_name', '-env_name', '--suite=latex_'))
             for a in args) or any(
                 a in ('--suite', '-suite') and b.startswith('latex_')
                 for a, b in zip(args, args[1:]))


def _latex_ble_eval(args: Sequence[str]) -> int:
  """BLE's eval on a latex env (`run.ble_eval`); refused input is one line."""
  from ble_latex.run import ble_eval  # pylint: disable=g-import-not-at-top
  prog = 'ble-latex-ble eval'
  cli.quiet_init_callbacks()
  try:
    return ble_eval.main([prog, *args], prog)
  except (OSError, errors.BadFileError) as e:
    print(f'{prog}: {gin_binding.one_line(e)}', file=sys.stderr)
    return cli.EXIT_FAILURE
  except ValueError as e:  # A refused configuration (gin, agent, env).
    message = gin_binding.refused_config_message(e)
    if message is None:
      raise
    return cli.usage(prog, message)


def main(argv: Optional[Sequence[str]] = None) -> int:
  argv = list(sys.argv[1:] if argv is None else argv)
  if argv and argv[0] in ('-h', '--help', 'help'):
    print(f'usage: ble-latex-ble {{{"|".join(COMMANDS)}}} [BLE flags...]\n'
          f'{__doc__}\nBLE\'s flags of a command: ble-latex-ble train --help')
    return 0
  if not argv or argv[0] not in COMMANDS:
    print(f'usage: ble-latex-ble {{{"|".join(COMMANDS)}}} [BLE flags...]\n'
          f'{__doc__}', file=sys.stderr)
    return 2
  if argv[0] == 'eval' and _latex_eval(argv[1:]):
    return _latex_ble_eval(argv[1:])
  module = COMMANDS[argv[0]]
  with quiet.third_party_noise():
    for name in _DEPENDENCIES[argv[0]]:
      importlib.import_module(name)
  sys.argv = [module] + argv[1:]
  cli.quiet_init_callbacks()
  try:
    runpy.run_module(module, run_name='__main__', alter_sys=True)
  except SystemExit as e:  # absl's app.run exits; pass its code on.
    code = int(e.code or 0) if not isinstance(e.code, str) else 1
    if code == 1 and set(argv[1:]) & set(_HELP):
      return 0  # absl exits 1 after printing --help.
    return code
  return 0


if __name__ == '__main__':
  sys.exit(main())
