# coding=utf-8
"""Which code a recorded run flew: the commit and whether it was changed.

The benchmarks' records (`benchmarks/real_winds.py`, `real_winds_paths.py`,
`wind_compare.py`) keep it beside their command, date, machine and load.
"""

import os
import subprocess
from typing import Any, Dict, Optional

# The checkout this package lives in (a source checkout).
CHECKOUT = os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))))


def code_version(checkout: Optional[str] = None) -> Dict[str, Any]:
  """{'git_head': the commit (None outside git), 'package_changed_since_head':
  whether ble_latex/ or gin_configs/ differ from it}.

  Args:
    checkout: The git checkout (default: this package's).
  """
  def git(*args):
    return subprocess.run(['git', *args], cwd=checkout or CHECKOUT,
                          capture_output=True, text=True,
                          check=False).stdout.strip()
  return {'git_head': git('rev-parse', 'HEAD') or None,
          'package_changed_since_head': bool(git(
              'status', '--porcelain', '--', 'ble_latex', 'gin_configs'))}
