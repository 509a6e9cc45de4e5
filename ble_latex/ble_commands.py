# coding=utf-8
r"""Runs BLE's own train/eval commands with the compatibility fixes applied.

BLE 1.0.1's `python -m balloon_learning_environment.eval.eval` does not import on
today's stack by itself; run it through ble_latex instead, with BLE's own flags:

  ble-latex-ble eval --agent=station_seeker --suite=micro_eval \
      --output_dir=/tmp/ble/eval
  ble-latex-ble train --agent=random --base_dir=/tmp/ble/train \
      --num_iterations=1 --episodes_per_iteration=1
"""

import runpy
import sys
from typing import Optional, Sequence

import ble_latex  # pylint: disable=unused-import  # Installs the fixes first.

COMMANDS = {
    'train': 'balloon_learning_environment.train',
    'eval': 'balloon_learning_environment.eval.eval',
}


def main(argv: Optional[Sequence[str]] = None) -> int:
  argv = list(sys.argv[1:] if argv is None else argv)
  if not argv or argv[0] not in COMMANDS:
    print(f'usage: ble-latex-ble {{{"|".join(COMMANDS)}}} [BLE flags...]\n'
          f'{__doc__}', file=sys.stderr)
    return 2
  module = COMMANDS[argv[0]]
  sys.argv = [module] + argv[1:]
  try:
    runpy.run_module(module, run_name='__main__', alter_sys=True)
  except SystemExit as e:  # absl's app.run exits; pass its code on.
    return int(e.code or 0) if not isinstance(e.code, str) else 1
  return 0


if __name__ == '__main__':
  sys.exit(main())
