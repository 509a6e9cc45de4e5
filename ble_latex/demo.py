# coding=utf-8
"""`make demo`: the project's main job, short.

Until the latex environment and SAC agent land, the demo proves the stack
works: BLE's StationSeeker flies BLE's own micro_eval suite through ble_latex's
compatibility layer, and the result (reward, time within 50 km) is printed and
written as JSON under --output_dir.
"""

import json
import os
import sys
from typing import Optional, Sequence

from absl import app
from absl import flags

from ble_latex import ble_commands

flags.DEFINE_string('output_dir', 'demo_output', 'Where the demo writes.')
FLAGS = flags.FLAGS


def run(output_dir: str) -> dict:
  """Runs BLE's StationSeeker on micro_eval and returns its first result."""
  eval_dir = os.path.join(output_dir, 'ble_station_seeker_eval')
  code = ble_commands.main(['eval', '--agent=station_seeker',
                            '--suite=micro_eval', f'--output_dir={eval_dir}'])
  if code:
    raise RuntimeError(f'BLE eval exited with status {code}')
  path = os.path.join(eval_dir, 'micro_eval', 'station_seeker.json')
  with open(path) as f:
    result = json.load(f)[0]
  summary = {k: v for k, v in result.items() if k != 'flight_path'}
  print(f'StationSeeker on BLE micro_eval: {json.dumps(summary)}')
  print(f'Full result (with flight path): {path}')
  return summary


def main(argv: Sequence[str]) -> None:
  del argv
  run(FLAGS.output_dir)


if __name__ == '__main__':
  app.run(main)
