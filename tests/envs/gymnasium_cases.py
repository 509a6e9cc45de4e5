"""What the Gymnasium env tests share that is not a fixture: the two ids and
a fresh Python process (tests/envs/conftest.py holds the envs as fixtures)."""

import os
import subprocess
import sys

from tests import helpers

ID = 'ble_latex/LatexBalloon-v0'
DISCRETE_ID = 'ble_latex/LatexBalloonDiscrete-v0'
REPO = str(helpers.ROOT)


def python(code: str, timeout: float = 300, **env_changes):
  env = dict(os.environ)
  for key, value in env_changes.items():
    if value is None:
      env.pop(key, None)
    else:
      env[key] = value
  return subprocess.run([sys.executable, '-c', code], env=env, cwd=REPO,
                        capture_output=True, text=True, timeout=timeout)
