# coding=utf-8
"""Days aloft and TW50 against the lift disturbance and the diurnal swing.

Issue 44, item 6: how the realistic physics' two calibrated values move
station keeping. Each cell of a grid (lift disturbance sigma [g/sqrt(s)] x
the helium's day-night swing S [K]) flies the same seeds for a long flight
(default 504 strides = 7 days) under gin_configs/latex_realistic.gin with
that sigma and swing, everything else as calibrated:

  python benchmarks/realistic_sensitivity.py \
      --json=benchmarks/records/realistic_sensitivity.json \
      --png=docs/assets/realistic_sensitivity.png

Agents: `latex_station_seeker` (the geometric seeker) and, with
`--agents=latex_station_seeker,sac_pretrained`, the shipped paper-trained
SAC policy (`ble_latex/agents/policies/sac_latex.msgpack`, trained on the
paper's physics, not on these). The cells, flights and summaries are
`ble_latex.run.sensitivity`'s. Both fly as pure JAX controllers
(`launch.controllers`, the same actions as the agents), all seeds of a cell
in one jitted, vmapped scan; each seed's world is the gym env's
(`jax_env.LatexBalloonJaxEnv.reset(PRNGKey(seed))`), so a cell's flights
are `ble-latex-eval`'s flights of those seeds.

The swing S splits into superheat by day and cooling at night in the
calibrated proportion (`flight.params.REALISTIC`: 8.1 K : 3.3 K), so only
its size changes. Per cell and agent: days aloft (the strides flown until
the flight ended, x 20 min; a flight that reaches the limit counts all of
it), the share aloft at the end, TW50 over the whole flight (strides within
the station radius / all strides), sand dropped.

The record is rewritten after every cell; a rerun with the same settings
skips the cells already in it (resume after a kill).
"""

import argparse
import datetime as dt
import json
import os
import platform
import sys
import time
from typing import Any, Dict, List, Sequence

import gin
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import safe_io
from ble_latex.flight import params as params_lib
from ble_latex.run import sensitivity
from ble_latex.run import suites

PAPER_POLICY = 'ble_latex/agents/policies/sac_latex.msgpack'
# The suites whose seeds a cell flies (their first --seeds).
SEED_SUITES = {'latex_small': suites.EVAL_SEED_OFFSET,
               'latex_validation': suites.VALIDATION_SEED_OFFSET}


def _floats(text: str, name: str) -> List[float]:
  try:
    values = [float(v) for v in text.split(',') if v.strip()]
  except ValueError:
    values = []
  if not values or not all(np.isfinite(v) and v >= 0.0 for v in values):
    raise argparse.ArgumentTypeError(
        f'{name} must be comma-separated numbers >= 0, got {text!r}')
  return values


def controller_of(agent: str):
  """The JAX controller of `agent` (sac_pretrained: the paper's policy).

  `launch.controllers` imports BLE's agents (TensorFlow): imported here.
  """
  from ble_latex.launch import controllers  # pylint: disable=g-import-not-at-top
  gin.clear_config()
  try:
    if agent == 'sac_pretrained':
      gin.parse_config(
          f'SACPretrainedAgent.policy_path = "{PAPER_POLICY}"')
    controller = controllers.controller_named(agent)
  finally:
    gin.clear_config()
  if controller.period != 1:
    raise SystemExit(f'{agent}: only controllers acting every stride fly '
                     'here')
  return controller


def plot(record: Dict[str, Any], path: str) -> None:
  """Days aloft and TW50 against sigma, a line per swing and agent."""
  import matplotlib  # pylint: disable=g-import-not-at-top
  matplotlib.use('Agg')
  import matplotlib.pyplot as plt  # pylint: disable=g-import-not-at-top
  grid = record['grid']
  fig, axes = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
  colors = plt.rcParams['axes.prop_cycle'].by_key()['color']
  styles = {'latex_station_seeker': '-o', 'sac_pretrained': '--s'}
  labels = {'latex_station_seeker': 'seeker',
            'sac_pretrained': 'SAC (paper-trained)'}
  for agent in grid['agents']:
    for j, swing in enumerate(grid['swing_k']):
      cells = [record['cells'].get(_cell_name(agent, s, swing))
               for s in grid['sigma_g']]
      xs = [s for s, c in zip(grid['sigma_g'], cells) if c]
      cells = [c for c in cells if c]
      if not cells:
        continue
      label = f'{labels.get(agent, agent)}, swing {swing:g} K'
      for ax, key in zip(axes, ('days_aloft_mean', 'tw50_mean')):
        scale = 100.0 if key == 'tw50_mean' else 1.0
        ax.plot(xs, [scale * c[key] for c in cells], styles.get(agent, '-'),
                color=colors[j % len(colors)], label=label)
  # The walk that was the default before issue 68.
  calibrated = params_lib.LIFT_WALK_RANDOM['lift_walk_kg_per_sqrt_s'] * 1e3
  stress = params_lib.LIFT_WALK_STRESS['lift_walk_kg_per_sqrt_s'] * 1e3
  for ax in axes:
    ax.set_xscale('log')
    ax.set_xlabel('lift disturbance sigma [g/sqrt(s)]')
    ax.axvline(calibrated, color='0.6', lw=0.8, ls=':')
    ax.axvline(stress, color='0.6', lw=0.8, ls=':')
    ax.set_xticks(grid['sigma_g'])
    ax.set_xticklabels([f'{s:g}' for s in grid['sigma_g']])
    ax.grid(alpha=0.3)
  axes[0].set_ylabel(f'days aloft (of {grid["days"]:g})')
  axes[1].set_ylabel(f'TW50 over {grid["days"]:g} days [%]')
  axes[0].legend(fontsize=7)
  fig.suptitle(f'Realistic physics, {grid["seeds"]} seeds of '
               f'{grid["suite"]} per cell (dotted: 0.35 calibrated, '
               '1.4 stress)', fontsize=9)
  fig.savefig(path, dpi=110)
  plt.close(fig)


def _cell_name(agent: str, sigma: float, swing: float) -> str:
  return f'{agent} sigma={sigma:g} swing={swing:g}'


def main(argv: Sequence[str]) -> int:
  parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
  parser.add_argument('--sigma_g', default='0.1,0.2,0.35,0.67,1.4',
                      type=lambda t: _floats(t, '--sigma_g'),
                      help='lift disturbance sigmas [g/sqrt(s)]')
  parser.add_argument('--swing_k', default='0,7,11.4,17',
                      type=lambda t: _floats(t, '--swing_k'),
                      help='day-night helium swings [K]')
  parser.add_argument('--agents', default='latex_station_seeker')
  parser.add_argument('--seeds', type=int, default=64)
  parser.add_argument('--suite', default='latex_small',
                      choices=sorted(SEED_SUITES))
  parser.add_argument('--days', type=float, default=7.0)
  parser.add_argument('--json', default='')
  parser.add_argument('--png', default='')
  args = parser.parse_args(argv)
  agents = [a for a in args.agents.split(',') if a]
  unknown = set(agents) - {'latex_station_seeker', 'sac_pretrained'}
  if unknown or not agents:
    parser.error(f'--agents: latex_station_seeker and/or sac_pretrained, '
                 f'got {args.agents!r}')
  if not 1 <= args.seeds <= 1000:
    parser.error(f'--seeds must be in [1, 1000], got {args.seeds}')
  if not 0.0 < args.days <= 30.0:
    parser.error(f'--days must be in (0, 30], got {args.days}')
  params = sensitivity.env_params(1)
  steps = int(round(args.days * sensitivity.SECONDS_PER_DAY /
                    params.stride_s))
  params = sensitivity.env_params(steps)
  grid = {'agents': agents, 'sigma_g': args.sigma_g,
          'swing_k': args.swing_k, 'seeds': args.seeds, 'suite': args.suite,
          'days': args.days, 'steps': steps}
  record = {'grid': grid, 'cells': {}}
  if args.json and os.path.exists(args.json):
    with open(args.json, encoding='utf-8') as f:
      old = json.load(f)
    if old.get('grid') == grid:
      record = old
      print(f'resuming: {len(old["cells"])} cells done', flush=True)
  record.update({
      'command': 'python benchmarks/realistic_sensitivity.py ' + ' '.join(
          argv),
      'date': dt.datetime.now(dt.timezone.utc).isoformat(timespec='seconds'),
      'machine': f'{platform.machine()}, {os.cpu_count()} CPUs, load '
                 f'{os.getloadavg()[0]:.1f} at start',
      'calibrated': {'sigma_g': params_lib.LIFT_WALK_RANDOM[
          'lift_walk_kg_per_sqrt_s'] * 1e3, 'swing_k': params_lib.REALISTIC[
              'superheat_day_k'] + params_lib.REALISTIC['cooling_night_k']},
  })
  start = time.time()
  first = SEED_SUITES[args.suite]
  keys = jnp.stack([jax.random.PRNGKey(s)
                    for s in range(first, first + args.seeds)])
  for agent in agents:
    fly = sensitivity.flier(controller_of(agent), steps)
    for swing in args.swing_k:
      for sigma in args.sigma_g:
        name = _cell_name(agent, sigma, swing)
        if name in record['cells']:
          continue
        t0 = time.time()
        out = jax.device_get(fly(sensitivity.cell_params(params, sigma, swing),
                                 keys))
        cell = sensitivity.summarize(*out, steps=steps,
                                     stride_s=params.stride_s)
        cell['seconds'] = round(time.time() - t0, 1)
        record['cells'][name] = cell
        print(f'{name}: {cell["days_aloft_mean"]:.2f} days, TW50 '
              f'{100 * cell["tw50_mean"]:.1f} %, {cell["seconds"]} s',
              flush=True)
        record['seconds'] = round(record.get('seconds', 0.0) + time.time() -
                                  t0, 1)
        record['load_at_end'] = round(os.getloadavg()[0], 1)
        if args.json:
          safe_io.atomic_write(args.json, json.dumps(record, indent=1) + '\n')
  print(f'{time.time() - start:.0f} s', flush=True)
  # Wall time of this run, compilation included (`seconds`: the cells').
  record['wall_seconds'] = round(time.time() - start, 1)
  record['load_at_end'] = round(os.getloadavg()[0], 1)
  if args.json:
    safe_io.atomic_write(args.json, json.dumps(record, indent=1) + '\n')
  if args.png:
    plot(record, args.png)
  return 0


if __name__ == '__main__':
  sys.exit(main(sys.argv[1:]))
