# coding=utf-8
r"""ERA5 end to end: a (synthetic) file -> train -> select -> held-out eval.

  python examples/era5_end_to_end.py --work_dir=runs/era5_example
  python examples/era5_end_to_end.py --era5_path=era5_paper.nc --work_dir=...
  python examples/era5_end_to_end.py --short   # CI's run (a few tiny steps)

docs/era5.md's pipeline through the real commands, each a subprocess:

1. the ERA5 file: `--era5_path` (a real download, `ble-latex-download-era5`),
   or else a small synthetic NetCDF of the paper's period written here
   (1 Nov 2022 - 31 Jan 2023, 6-hourly, 7 levels 20-175 hPa, +-4 deg around
   the station at 1 deg, random winds; CDS's current layout, which
   `ble_latex.wind.gridded.load` reads and checks);
2. `ble-latex-train --trainer=jax --era5_path=FILE` on the training dates,
   a policy snapshot every `--snapshot_period` rounds, each flown on
   `--validation_episodes` latex_validation seeds on the validation dates
   (`validation.jsonl`);
3. select: the snapshot with the best validation TW50 (`tw50_mean`) from
   `validation.jsonl`;
4. `ble-latex-eval --agent=sac_pretrained --era5_path=FILE --suite=SUITE`
   with that policy, on the suite's held-out seeds and the eval dates.

Prints each command, then the eval's summary as one JSON line (with the
chosen snapshot and the output file). The commands run as
`python -m ble_latex.cli.train` / `.eval`, which is what the
`ble-latex-train` / `ble-latex-eval` scripts run.
"""

import argparse
import json
import os
import shlex
import subprocess
import sys
import tempfile
import time
from typing import Any, Dict, List, Optional, Sequence

import numpy as np
import xarray as xr

from ble_latex import run_files

# The paper's period, 6-hourly: 1 Nov 2022 00:00 - 31 Jan 2023 18:00.
_TIMES = (np.datetime64('2022-11-01T00:00', 'ns') +
          np.arange(368) * np.timedelta64(6, 'h'))
_LEVELS_HPA = np.array([20.0, 50.0, 70.0, 100.0, 125.0, 150.0, 175.0])  # [hPa]
_LATS = np.arange(5.0, -3.01, -1.0)  # Descending, as ERA5. # [deg N]
_LONS = np.arange(-117.0, -108.99, 1.0)  # [deg E]


def write_synthetic_era5(path: str, *, seed: int = 0) -> str:
  """Writes a small synthetic ERA5 pressure-level file; returns `path`.

  CDS's current layout (`valid_time`, `pressure_level` in hPa, descending
  `latitude`, `longitude`; `u`, `v` in m s**-1), random winds of 8 m/s
  standard deviation, float32. Not real weather: for trying the pipeline.

  Args:
    path: The NetCDF file to write.
    seed: Seed of the random winds.
  """
  rng = np.random.default_rng(seed)
  dims = ('valid_time', 'pressure_level', 'latitude', 'longitude')
  shape = (len(_TIMES), len(_LEVELS_HPA), len(_LATS), len(_LONS))
  wind = lambda: rng.normal(0.0, 8.0, shape).astype(np.float32)  # [m/s]
  dataset = xr.Dataset(
      {'u': (dims, wind(), {'units': 'm s**-1'}),
       'v': (dims, wind(), {'units': 'm s**-1'})},
      coords={
          'valid_time': _TIMES,
          'pressure_level': ('pressure_level', _LEVELS_HPA,
                             {'units': 'hPa', 'long_name': 'pressure'}),
          'latitude': ('latitude', _LATS, {'units': 'degrees_north'}),
          'longitude': ('longitude', _LONS, {'units': 'degrees_east'}),
      })
  dataset.to_netcdf(path)
  return path


def _run(command: List[str], cwd: str) -> str:
  """Runs a command (echoed to stderr); its stdout, or exits with its status."""
  print('$ ' + shlex.join(command), file=sys.stderr, flush=True)
  result = subprocess.run(command, cwd=cwd, stdout=subprocess.PIPE, text=True,
                          check=False)
  if result.returncode != 0:
    sys.exit(f'era5_end_to_end: {command[2]} exited with status '
             f'{result.returncode}')
  return result.stdout


def parse_args(argv: Optional[Sequence[str]]) -> argparse.Namespace:
  parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
  parser.add_argument('--era5_path', default=None,
                      help='ERA5 file (default: write a synthetic one).')
  parser.add_argument('--work_dir', default=None,
                      help='Run, eval and synthetic file go here '
                      '(default: a temporary folder).')
  parser.add_argument('--num_iterations', type=int, default=20)
  parser.add_argument('--snapshot_period', type=int, default=5)
  parser.add_argument('--validation_episodes', type=int, default=10)
  parser.add_argument('--suite', default='latex_tiny')
  parser.add_argument('--max_episode_length', type=int, default=None,
                      help="Eval steps per episode (default: the suite's).")
  parser.add_argument('--short', action='store_true',
                      help='A tiny run (CI): 1 round of 2 envs x 3-step '
                      'episodes, a 1-layer 16-unit net, 2 validation '
                      'episodes; eval latex_micro for 3 steps.')
  args = parser.parse_args(argv)
  if args.short:
    args.num_iterations, args.snapshot_period = 1, 1
    args.validation_episodes, args.suite = 2, 'latex_micro'
    args.max_episode_length = 3
  return args


def main(argv: Optional[Sequence[str]] = None) -> Dict[str, Any]:
  args = parse_args(argv)
  start = time.time()
  work_dir = args.work_dir or tempfile.mkdtemp(prefix='era5_end_to_end_')
  os.makedirs(work_dir, exist_ok=True)
  work_dir = os.path.abspath(work_dir)
  era5_path = os.path.abspath(args.era5_path or write_synthetic_era5(
      os.path.join(work_dir, 'era5_synthetic.nc')))
  run_dir = os.path.join(work_dir, 'run')
  python = [sys.executable, '-m']

  # 2. Train (jitted SAC) on the training dates.
  train = python + [
      'ble_latex.cli.train', '--trainer=jax', f'--base_dir={run_dir}',
      f'--era5_path={era5_path}', f'--num_iterations={args.num_iterations}',
      f'--policy_snapshot_period={args.snapshot_period}',
      f'--validation_episodes={args.validation_episodes}',
      '--collectors=episodes']
  if args.short:
    train += [f'--gin_bindings={b}' for b in (
        'latex_episode.episode_steps = 3',
        'sac_trainer_config.num_envs = 2',
        'sac_trainer_config.num_layers = 1',
        'sac_trainer_config.hidden_units = 16',
        'sac_trainer_config.batch_size = 4',
        'sac_trainer_config.min_replay_history = 4',
        'sac_trainer_config.updates_per_step = 1')]
  _run(train, work_dir)

  # 3. Select: the best snapshot by validation TW50 (validation dates).
  with open(os.path.join(run_dir, 'validation.jsonl'), encoding='utf-8') as f:
    validation = [json.loads(line) for line in f if line.strip()]
  best = max(validation, key=lambda r: r['tw50_mean'])
  policy = run_files.policy_snapshot_path(run_dir, best['iteration'])
  if not os.path.exists(policy):
    sys.exit(f'era5_end_to_end: no snapshot {policy} for the chosen round')

  # 4. Evaluate on the suite's held-out seeds and the eval dates.
  evaluate = python + [
      'ble_latex.cli.eval', '--agent=sac_pretrained', f'--suite={args.suite}',
      f'--era5_path={era5_path}', f'--output_dir={work_dir}/eval',
      f'--gin_bindings=SACPretrainedAgent.policy_path = {policy!r}']
  if args.max_episode_length:
    evaluate.append(f'--max_episode_length={args.max_episode_length}')
  summary = json.loads(_run(evaluate, work_dir).strip().splitlines()[-1])
  summary = {'era5_path': era5_path, 'policy': policy,
             'chosen_iteration': best['iteration'],
             'validation_tw50': best['tw50_mean'], **summary,
             'elapsed_s': round(time.time() - start, 1)}
  print(json.dumps(summary))
  return summary


if __name__ == '__main__':
  main()
