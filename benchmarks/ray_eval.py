"""Serial vs Ray `ble-latex-eval`, side by side in one run.

Runs the same `ble-latex-eval` command twice as subprocesses: in one process
(the default) and with `--ray_address=local --ray_num_cpus=N` (seeds as Ray
tasks on an embedded Ray with N worker CPUs). Reports each command's wall
time (start-up, Ray's and the workers' included), the speed-up, and whether
the two JSON files are byte-identical. The machine's load average is noted
before and after each command.

  python benchmarks/ray_eval.py --agent=station_seeker \\
      --env_name=LatexBalloonDiscrete-v0 --suite=latex_small --num_cpus=2 \\
      --json=benchmarks/records/ray_eval.json
"""

import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from typing import Optional, Sequence

from absl import flags

from ble_latex import safe_io
from ble_latex.cli import common as cli

FLAGS = flags.FlagValues()
flags.DEFINE_string('agent', 'station_seeker', 'Agent evaluated.',
                    flag_values=FLAGS)
flags.DEFINE_string('env_name', 'LatexBalloonDiscrete-v0', 'Env evaluated.',
                    flag_values=FLAGS)
flags.DEFINE_string('suite', 'latex_small', 'Suite evaluated.',
                    flag_values=FLAGS)
flags.DEFINE_integer('num_cpus', 2, 'CPUs of the local Ray.', lower_bound=1,
                     flag_values=FLAGS)
flags.DEFINE_string('json', None, 'Write the results here.',
                    flag_values=FLAGS)


def run(command, label):
  load_before = os.getloadavg()
  began = time.monotonic()
  subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
  wall = time.monotonic() - began
  result = {'command': ' '.join(command), 'wall_s': round(wall, 1),
            'loadavg_before': [round(x, 2) for x in load_before],
            'loadavg_after': [round(x, 2) for x in os.getloadavg()]}
  print(f'{label}: {result["wall_s"]} s', flush=True)
  return result


def _main(argv: Sequence[str]) -> None:
  args = FLAGS
  with tempfile.TemporaryDirectory() as tmp:
    base = [sys.executable, '-m', 'ble_latex.cli.eval', f'--agent={args.agent}',
            f'--env_name={args.env_name}', f'--suite={args.suite}',
            '--name_override=out']
    serial = run([*base, f'--output_dir={tmp}/serial'], 'serial')
    ray = run([*base, f'--output_dir={tmp}/ray', '--ray_address=local',
               f'--ray_num_cpus={args.num_cpus}'],
              f'ray ({args.num_cpus} CPUs)')
    paths = [os.path.join(tmp, k, args.suite, 'out.json')
             for k in ('serial', 'ray')]
    with open(paths[0], 'rb') as a, open(paths[1], 'rb') as b:
      identical = a.read() == b.read()
    with open(paths[0], encoding='utf-8') as f:
      episodes = len(json.load(f))
  result = {
      'agent': args.agent, 'env_name': args.env_name, 'suite': args.suite,
      'episodes': episodes, 'ray_num_cpus': args.num_cpus,
      'serial': serial, 'ray': ray,
      'speedup': round(serial['wall_s'] / ray['wall_s'], 2),
      'identical_json': identical,
      'machine': {'cpus': os.cpu_count(), 'platform': platform.platform(),
                  'python': platform.python_version()},
  }
  print(json.dumps({k: result[k] for k in ('speedup', 'identical_json')}))
  if args.json:
    safe_io.atomic_write(args.json, json.dumps(result, indent=1) + '\n')


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/ray_eval.py', FLAGS, argv,
                      doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
