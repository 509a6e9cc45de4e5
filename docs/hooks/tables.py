# coding=utf-8
"""Result tables made from the committed records (nothing typed by hand).

README and the docs hold each table between two marker lines:

  <!-- table: NAME -->
  ...generated Markdown...
  <!-- end table -->

`python docs/hooks/tables.py` rewrites every such block in README.md and
docs/*.md from the records; `python docs/hooks/tables.py --check` exits 1
naming the first stale block (tests/docs/test_docs.py runs the same check, and
the MkDocs hook `generated.py` regenerates the blocks of the site's pages at
build time). This file says which records, which rows and where each table
goes; what a cell holds (means, spreads, per-seed pairs, percentage cells) is
`ble_latex.run.tables`'s; issue 47's tables are `learned.py`'s beside it.

Records read (all committed):
  * `benchmarks/records/results_table.json`: the eval rows `benchmarks/results_table.py`
    writes (`make results`), one per agent, mean and std over the suite.
  * `benchmarks/records/physics_results.json`: paper vs realistic physics
    (`benchmarks/physics_results.py`, issue 44), summaries per agent.
  * `benchmarks/records/valbal_check.json`: the ValBal preset's flights
    (`benchmarks/valbal_check.py`, issue 44).
  * `benchmarks/records/float_calibration.json`, `float_calibration_before.json`:
    the realistic float's calibration table on the plant of issue 68 and
    before it (`benchmarks/float_calibration.py`).
  * `benchmarks/records/planners/**/SUITE/NAME.json`: the per-seed records of
    `benchmarks/planners.py`, and `.../timing/NAME.json` its timing summary.
  * `benchmarks/records/real_winds.json`: agents on the real wind sources
    (`benchmarks/real_winds.py`), one cell per (source, agent, station mode).
  * `benchmarks/records/wind_compare.json`: BLE's VAE winds against each real source
    (`benchmarks/wind_compare.py`).
  * `benchmarks/records/reward_shape.json`: SAC trained with the flat and the tanh
    reward (`benchmarks/reward_shape.py`, issue 46), per training seed.
  * `benchmarks/records/planners/realistic_task/validation_sweep.json`: the
    reserves planner's settings on 16 validation seeds
    (`benchmarks/planner_sweep_summary.py`, issue 63).
  * `benchmarks/records/dagger/results.json`: DAgger runs and their best students'
    held-out flights (`benchmarks/dagger_results.py`, issue 47).

Means and standard deviations are over episodes (population std, as
`ble_latex.run.metrics.summarize`).
"""

import math
import pathlib
import re
import sys
from typing import Callable, Dict, List, Sequence, Tuple

from ble_latex.run import episode_log
from ble_latex.run import records as records_lib
from ble_latex.run import tables as tables_lib
import learned  # docs/hooks/learned.py (MkDocs and this script: on sys.path)

ROOT = pathlib.Path(__file__).resolve().parents[2]
RECORDS = episode_log.RECORDS_DIR
RESULTS = RECORDS / 'results_table.json'
REAL_WINDS = RECORDS / 'real_winds.json'
PHYSICS = RECORDS / 'physics_results.json'
VALBAL = RECORDS / 'valbal_check.json'
FLOAT_CALIBRATION = RECORDS / 'float_calibration.json'
FLOAT_CALIBRATION_BEFORE = RECORDS / 'float_calibration_before.json'
FLOAT_CALIBRATION_SWEEP = RECORDS / 'float_calibration_sweep.json'
WIND_COMPARE = RECORDS / 'wind_compare.json'
REWARD_SHAPE = RECORDS / 'reward_shape.json'
RESERVES_SWEEP = RECORDS / 'planners' / 'realistic_task' / 'validation_sweep.json'
BLOCK = re.compile(r'(<!-- table: ([a-z0-9-]+) -->\n)(.*?)(<!-- end table -->)',
                   re.DOTALL)

# (record name in benchmarks/records/results_table.json, label).
AGENTS = (
    ('sac_ensemble', '`sac_ensemble` (12 SAC policies, each proposal flown 3 '
     'strides ahead; issue 47)'),
    ('sac_pretrained', '`sac_pretrained` (jitted trainer, seed 2, 6880 training '
     'episodes)'),
    ('ble_station_seeker_discrete',
     'BLE `station_seeker` on `LatexBalloonDiscrete-v0`'),
    ('latex_station_seeker', '`latex_station_seeker` (Du et al., geometric)'),
    ('sac_untrained', '`sac` untrained'),
    ('latex_random', '`latex_random`'),
)
# (record path under benchmarks/records/planners/, label, what s / decision means).
PLANNER_ROWS = (
    ('latex_small/latex_mpc', '`latex_mpc` (beam search on the forecast, '
     'corrected by a Gaussian process of its last 16 measured winds)', ''),
    ('latex_small/latex_mpc_exp_correction', '`latex_mpc` with the exp-decay '
     'correction of the current measurement only (`wind_memory=0`, its '
     'previous default)', ''),
    ('latex_small/latex_mpc_oracle', '`latex_mpc_oracle` (one beam search over '
     'the whole 3-day episode on the true winds: an upper bound, not a '
     'controller)', ' (one per episode)'),
    ('latex_small/latex_mpc_oracle_receding', '`latex_mpc_oracle`, receding '
     'horizon (12 h plans remade every 40 min; its previous default)', ''),
    ('gpu_h100/latex_small/o_h72_b128_d1_small', '`latex_mpc_oracle`, receding, '
     'wide search (beam 128, 24 h horizon; `make planners-wide`; flown on an '
     'H100)', ' (H100)'),
    ('latex_small/latex_mpc_grad', '`latex_mpc_grad` (first-order MPC, '
     '`jax.grad` through the core)', ''),
)


def _agent_rows() -> Dict[str, dict]:
  rows = {r['agent']: r for r in tables_lib.load(RESULTS)}
  missing = [name for name, _ in AGENTS if name not in rows]
  if missing:
    raise ValueError(f'{RESULTS}: no rows for {missing}')
  return rows


def agents_short() -> str:
  """README's table: both TW50s, reward, out of resources."""
  rows = _agent_rows()
  lines = ['| agent | TW50 window | TW50 flown (BLE\'s) | reward | '
           'out of resources |', '|---|---|---|---|---|']
  for name, label in AGENTS:
    r = rows[name]
    lines.append(f'| {label} | {tables_lib.pct(*r["tw50_window"])} '
                 f'| {tables_lib.pct(*r["tw50"])} '
                 f'| {r["reward"][0]:.1f} ± {r["reward"][1]:.1f} '
                 f'| {r["out_of_resources_pct"]:.0f} % |')
  return '\n'.join(lines)


def agents_full() -> str:
  """docs/results.md's table: also resources spent and episodes."""
  rows = _agent_rows()
  lines = ['| agent | TW50 window (mean ± std) | TW50 flown (BLE\'s) | reward '
           '(mean ± std) | helium vented [mol] | sand dropped [kg] | out of '
           'resources | episodes |', '|---|---|---|---|---|---|---|---|']
  for name, label in AGENTS:
    r = rows[name]
    lines.append(f'| {label} | {tables_lib.pct(*r["tw50_window"])} '
                 f'| {tables_lib.pct(*r["tw50"])} '
                 f'| {r["reward"][0]:.1f} ± {r["reward"][1]:.1f} '
                 f'| {r["helium"]:.1f} | {r["sand"]:.2f} '
                 f'| {r["out_of_resources_pct"]:.0f} % | {r["episodes"]} |')
  return '\n'.join(lines)


def _seconds(value: float) -> str:
  return f'{value:.3g}'


def planners_short() -> str:
  """README's planners table."""
  lines = ['| planner | seeds | TW50 window | out of resources | s / decision |',
           '|---|---|---|---|---|']
  for path, label, note in PLANNER_ROWS:
    s = tables_lib.planner_summary(path)
    lines.append(f'| {label} | {s["seeds"]} '
                 f'| {tables_lib.pct(*s["tw50_window"])} '
                 f'| {s["out_of_resources_pct"]:.0f} % '
                 f'| {_seconds(s["s_per_decision"])}{note} |')
  return '\n'.join(lines)


def planners_full() -> str:
  """docs/planners.md's table: also resources and seconds per episode."""
  lines = ['| agent | seeds | TW50 window (mean ± std) | out of resources | '
           'sand dropped [kg] | helium vented [mol] | s / decision | '
           's / episode |', '|---|---|---|---|---|---|---|---|']
  for path, label, note in PLANNER_ROWS:
    s = tables_lib.planner_summary(path)
    lines.append(f'| {label} | {s["seeds"]} '
                 f'| {tables_lib.pct(*s["tw50_window"])} '
                 f'| {s["out_of_resources_pct"]:.0f} % | {s["sand"]:.2f} '
                 f'| {s["helium"]:.1f} | {_seconds(s["s_per_decision"])}{note} '
                 f'| {_seconds(s["s_per_episode"])} |')
  return '\n'.join(lines)


# Agents of the real-winds table, in its order: (name, label).
REAL_WINDS_AGENTS = (
    ('sac_pretrained', '`sac_pretrained`'),
    ('latex_mpc', '`latex_mpc`'),
    ('latex_mpc_oracle', '`latex_mpc_oracle` (upper bound)'),
    ('ble_station_seeker_discrete', 'BLE `station_seeker` (discrete)'),
    ('latex_station_seeker', '`latex_station_seeker` (geometric)'),
    ('latex_random', '`latex_random`'),
)
# Sources of the real-winds tables, in their order: (name, short label).
REAL_WINDS_SOURCES = (
    ('gfs_namerica', 'GFS N. America 1°'),
    ('gfs_global', 'GFS global 2.5° (GRIB2)'),
    ('boise', 'sounding Boise'),
    ('hilo', 'sounding Hilo'),
)


def _real_cells() -> List[dict]:
  """The cells of benchmarks/records/real_winds.json in table order."""
  cells = list(tables_lib.load(REAL_WINDS)['cells'].values())
  agents = [a for a, _ in REAL_WINDS_AGENTS]
  sources = [s for s, _ in REAL_WINDS_SOURCES]
  known = [c for c in cells if c['settings']['agent'] in agents and
           c['settings']['source'] in sources]
  if not known:
    raise ValueError(f'{REAL_WINDS}: no cells')
  return sorted(known, key=lambda c: (
      agents.index(c['settings']['agent']),
      sources.index(c['settings']['source']), c['settings']['station_mode']))


def _station(cell: dict) -> str:
  settings = cell['settings']
  if settings['station_mode'] == 'per_seed':
    return 'per-seed stations'
  if settings['station_mode'] != 'center':
    return settings['station_mode']
  lat, lon = settings['station_lat_lon']
  where = 'site' if settings['source'] in ('boise', 'hilo') else 'centre'
  return f'{where} {lat:g}°, {lon:g}°'


def _seeds(cell: dict, cells: List[dict]) -> str:
  """'100 seeds', or 'first 10 seeds only' for a cell that flew fewer seeds
  than its source's other cells (a planner's subset on a CPU)."""
  n = cell['summary']['episodes']
  most = max(c['summary']['episodes'] for c in cells
             if c['settings']['source'] == cell['settings']['source'])
  seeds = f'first {n} seeds only' if n < most else f'{n} seeds'
  if 'noise_scale' not in cell['settings']:  # Flown before it was recorded.
    seeds += ' †'  # Not re-flown: 1.05 m/s noise, before the seam closed.
  return seeds


def real_winds_short() -> str:
  """README's real-winds table: agents x sources, TW50 window (seeds)."""
  cells = _real_cells()
  columns = [(s, label) for s, label in REAL_WINDS_SOURCES
             if any(c['settings']['source'] == s for c in cells)]
  lines = ['| agent | ' + ' | '.join(label for _, label in columns) + ' |',
           '|---' * (len(columns) + 1) + '|']
  for agent, label in REAL_WINDS_AGENTS:
    mine = [c for c in cells if c['settings']['agent'] == agent]
    if not mine:
      continue
    row = []
    for source, _ in columns:
      here = [c for c in mine if c['settings']['source'] == source]
      row.append('; '.join(
          f"{100 * c['summary']['tw50_window_mean']:.1f} % "
          f"({_seeds(c, cells)}"
          f"{', ' + _station(c) if c['settings']['station_mode'] != 'center' else ''})"
          for c in here) or '—')
    lines.append(f'| {label} | ' + ' | '.join(row) + ' |')
  return '\n'.join(lines)


def real_winds_full() -> str:
  """The docs' real-winds table: one row per cell."""
  labels = dict(REAL_WINDS_AGENTS)
  sources = dict(REAL_WINDS_SOURCES)
  lines = ['| agent | source (time-invariant) | station | seeds | TW50 window '
           '(mean ± std) | TW50 flown | out of resources | left the wind '
           'domain | final distance [km] (mean) |',
           '|---|---|---|---|---|---|---|---|---|']
  cells = _real_cells()
  for c in cells:
    s = c['summary']
    distance = tables_lib.mean_std(
        [f['final_distance_km'] for f in c['flights']])[0]
    left = 100.0 * sum(f['terminal_reason'] == 'left_wind_domain'
                       for f in c['flights']) / len(c['flights'])
    lines.append(
        f"| {labels[c['settings']['agent']]} "
        f"| {sources[c['settings']['source']]} | {_station(c)} "
        f"| {_seeds(c, cells).replace(' seeds', '')} "
        f"| {tables_lib.pct(s['tw50_window_mean'], s['tw50_window_std'])} "
        f"| {tables_lib.pct(s['tw50_mean'], s['tw50_std'])} "
        f"| {s['out_of_resources_pct']:.0f} % | {left:.0f} % "
        f"| {distance:.0f} |")
  return '\n'.join(lines)


def _apart(profile: dict) -> str:
  apart = profile['apart']
  return f"{100 * apart['ge90']:.0f} % / {100 * apart['ge135']:.0f} %"


def wind_compare() -> str:
  """docs/winds.md's table: the VAE and each real source, 15-25 km."""
  record = tables_lib.load(WIND_COMPARE)
  common = record['settings']['common_pressures_pa']
  at = ', '.join(f'{p / 100:g}' for p in common)
  top = common[0]
  lines = [f'| source | columns | levels in 15–25 km | ≥ 90° / ≥ 135° apart '
           f'(own levels) | ≥ 90° / ≥ 135° apart ({at} hPa) | speed at '
           f'{top / 100:g} hPa: median (5–95 %) [m/s] | shear {at} hPa: '
           'median [m/s/km] | spread over own levels: median [m/s] | '
           'Wasserstein to the VAE, u / v [m/s] |',
           '|---|---|---|---|---|---|---|---|---|']
  for row in record['sources']:
    own, common_profile = row['own'], row['common']
    speed = common_profile['speed_mps'][0]
    single = own['single_column']
    spread = (f"{speed['p50']:.1f} (one column)" if single else
              f"{speed['p50']:.1f} ({speed['p5']:.1f}–{speed['p95']:.1f})")
    heights = own['heights_m']
    vs = row.get('vs_vae')
    distance = ('—' if vs is None else
                f"{vs['wasserstein_u_mps']:.1f} / {vs['wasserstein_v_mps']:.1f}")
    columns = '1 (a single sample)' if single else f"{own['columns']}"
    lines.append(
        f"| {row['label']} | {columns} "
        f"| {len(own['pressures_pa'])} ({heights[-1] / 1000:.1f}–"
        f"{heights[0] / 1000:.1f} km) | {_apart(own)} "
        f"| {_apart(common_profile)} | {spread} "
        f"| {common_profile['shear']['shear_mps_per_km']['p50']:.2f} "
        f"| {own['shear']['spread_mps']['p50']:.1f} | {distance} |")
  return '\n'.join(lines)


# Realistic physics (issue 44; `benchmarks/physics_results.py`'s record):
# (label, record name in the paper sections, in the realistic sections).
PHYSICS_ROWS = (
    ('`sac_pretrained`, the paper-trained policy', 'sac_pretrained',
     'sac_pretrained_paper_policy'),
    ('`sac_pretrained`, the realistic policy (retrained on the calibrated '
     'physics, best-validated of 3 seeds)', None, 'sac_pretrained'),
    ('SAC retrained on the calibrated physics, 3 seeds (mean ± std over '
     'seeds)', None, 'sac_jax_realistic_calibrated (3 seeds)'),
    ('BLE `station_seeker` (discrete)', 'ble_station_seeker_discrete',
     'ble_station_seeker_discrete'),
    ('`latex_station_seeker`', 'latex_station_seeker', 'latex_station_seeker'),
    ('`latex_mpc` (forecast; before issue 63 item 4: the launch day\'s sun '
     'clock, no sunset reserve; H200 GPU)', None, 'latex_mpc'),
    ('`latex_mpc_oracle` (true wind, one whole-episode plan; before issue 63 '
     'item 4: blind to the disturbance, not a bound; H200 GPU)', None,
     'latex_mpc_oracle'),
    ('`latex_random`', 'latex_random', 'latex_random'),
)
# Rows flown before the calibration (lift walk 1.4 g/sqrt(s), +5/-2 K,
# 150 Pa), kept for the record: (label, record name).
UNCALIBRATED_ROWS = (
    ('SAC retrained on that physics, 3 seeds (mean ± std over seeds)',
     'sac_jax_realistic (3 seeds)'),
    ('`latex_mpc` (previous defaults)', 'latex_mpc'),
    ('`latex_mpc_grad`', 'latex_mpc_grad'),
    ('`latex_mpc_oracle`, first 25 seeds', 'latex_mpc_oracle'),
)


def _physics() -> dict:
  record = tables_lib.load(PHYSICS)
  for section in ('paper', 'realistic', 'paper_long', 'realistic_long'):
    if not record.get(section):
      raise ValueError(f'{PHYSICS}: no {section!r} rows')
  return record


def _tw(row, oor: bool = True, std: bool = False) -> str:
  if row is None:
    return '—'
  text = f'{100 * row["tw50_window_mean"]:.1f} %'
  if std:
    seeds = ' (seeds)' if 'num_seeds' in row else ''
    text += f' ± {100 * row["tw50_window_std"]:.1f}{seeds}'
  if oor:
    text += f' ({row["out_of_resources_pct"]:.0f} % out of resources)'
  return text


def _days(row) -> str:
  return '—' if row is None else f'{row["days_aloft_mean"]:.2f}'


def _cost(row) -> str:
  if row is None:
    return '—'
  return (f'{row["out_of_resources_pct"]:.0f} % / '
          f'{row["helium_vented_mols_mean"]:.1f} mol / '
          f'{row["sand_dropped_kg_mean"]:.2f} kg')


def realistic_full() -> str:
  """docs/physics.md's 3-day table: spreads and resources, stress too."""
  r = _physics()
  stress = r.get('realistic_stress', {})
  lines = ['| agent | TW50 window, paper | TW50 window, realistic | '
           'realistic, stress 1.4 g/√s | out of resources / helium / sand, '
           'paper | same, realistic | same, stress |',
           '|---|---|---|---|---|---|---|']
  for label, paper, realistic in PHYSICS_ROWS:
    row = r['realistic'].get(realistic)
    if row is None:
      continue
    p = r['paper'].get(paper) if paper else None
    s = stress.get(realistic)
    lines.append(f'| {label} | {_tw(p, False, True)} | '
                 f'{_tw(row, False, True)} | {_tw(s, False, True)} | '
                 f'{_cost(p)} | {_cost(row)} | {_cost(s)} |')
  return '\n'.join(lines)


def realistic_long() -> str:
  """docs/physics.md's 7-day table (504 strides) in both physics."""
  r = _physics()
  lines = ['| agent | physics | days aloft (mean ± std) | aloft all 7 days | '
           'TW50 over 7 days | out of resources | episodes |',
           '|---|---|---|---|---|---|---|']
  for section, physics, column in (('paper_long', 'paper', 1),
                                   ('realistic_long', 'realistic', 2)):
    for row_def in PHYSICS_ROWS:
      row = r[section].get(row_def[column])
      if row is None:
        continue
      lines.append(
          f'| {row_def[0]} | {physics} | {row["days_aloft_mean"]:.2f} ± '
          f'{row["days_aloft_std"]:.2f} | {row["full_window_pct"]:.0f} % | '
          f'{_tw(row, False, True)} | {row["out_of_resources_pct"]:.0f} % | '
          f'{row["episodes"]} |')
  return '\n'.join(lines)


# The realistic task (issue 63; the record's `realistic_task` sections):
# (label, record name). The paired column is each row minus `latex_mpc` on
# the same held-out seeds.
TASK_ROWS = (
    ('SAC trained on the task (sun and gas observation), 3 seeds (mean ± '
     'std over seeds)', 'sac_jax_realistic_task (3 seeds)'),
    ('the best-validated of those seeds', 'sac_realistic_task_best'),
    ('`sac_ensemble` of those 3 seeds, 3 strides ahead (chosen on '
     'validation)', 'sac_ensemble_realistic_task'),
    ('`latex_mpc` (forecast, estimated disturbance, sunset-aware)',
     'latex_mpc'),
    ('`latex_mpc` with resource reserves (sunsets\' lift kept in helium, '
     '0.6 kg buffer; chosen on validation)', 'latex_mpc_reserves'),
    ('the same with its resources priced 20 times higher (sand and helium '
     'cost 2.0; chosen on 16 validation seeds)', 'latex_mpc_priced'),
    ('`latex_mpc_oracle`', 'latex_mpc_oracle'),
    ('`sac_pretrained`, the realistic policy trained before issue 68',
     'sac_pretrained_realistic_before_68'),
    ('`sac_pretrained`, the paper-trained policy',
     'sac_pretrained_paper_policy'),
    ('BLE `station_seeker` (discrete)', 'ble_station_seeker_discrete'),
    ('`latex_station_seeker`', 'latex_station_seeker'),
)
TASK_REFERENCE = 'latex_mpc'


def realistic_task() -> str:
  """README's realistic-task table: 3-day TW50, resources, 7-day days
  aloft, and each row minus `latex_mpc` per seed (mean ± standard error,
  seeds ahead / behind)."""
  r = _physics()
  task, long = r.get('realistic_task', {}), r.get('realistic_task_long', {})
  reference = task.get(TASK_REFERENCE)
  lines = ['| controller | TW50 window (mean ± std) | out of resources | '
           'sand dropped [kg] | days aloft in 7-day flights | − `latex_mpc` '
           'per seed [points] |', '|---|---|---|---|---|---|']
  for label, name in TASK_ROWS:
    row = task.get(name)
    if row is None:
      continue
    tw = _tw(row, oor=False, std=True)
    if 'num_seeds' in row:
      se = row['tw50_window_mean_over_seeds_std'] / math.sqrt(
          row['num_seeds'])
      tw += f', standard error {100 * se:.1f}'
    paired = '—'
    if (reference is not None and name != TASK_REFERENCE and
        'per_seed' in row and 'per_seed' in reference):
      flown = set(row['per_seed']['seeds'])  # Both flew: the shorter's.
      seeds = [s for s in reference['per_seed']['seeds'] if s in flown]
      paired = tables_lib.paired_cell(
          tables_lib.per_seed_on(reference, seeds),
          tables_lib.per_seed_on(row, seeds), PHYSICS)
      if len(seeds) < len(reference['per_seed']['seeds']):
        paired += ' on its seeds'
      elif len(seeds) < len(row['per_seed']['seeds']):
        paired += f' on its {len(seeds)} seeds'
    if 'per_seed' in row and len(row['per_seed']['seeds']) < 100:
      label += f' (first {len(row["per_seed"]["seeds"])} seeds)'
    lines.append(
        f'| {label} | {tw} | {row["out_of_resources_pct"]:.0f} % | '
        f'{row["sand_dropped_kg_mean"]:.2f} | {_days(long.get(name))} | '
        f'{paired} |')
  return '\n'.join(lines)


def realistic_uncalibrated() -> str:
  """docs/physics.md: the rows flown only before the calibration."""
  r = _physics()
  old = r.get('realistic_uncalibrated', {})
  lines = ['| agent (physics before the calibration) | TW50 window | out of '
           'resources / helium / sand | episodes |', '|---|---|---|---|']
  for label, name in UNCALIBRATED_ROWS:
    row = old.get(name)
    if row is not None:
      lines.append(f'| {label} | {_tw(row, False, True)} | {_cost(row)} | '
                   f'{row["episodes"]} |')
  return '\n'.join(lines)


# The ValBal check's flights (`benchmarks/valbal_check.py`, issue 44):
# (record key, case, what ValBal reports for it).
VALBAL_ROWS = (
    ('default', '1 kg payload, the preset', 'datasheet 3 days (not a '
     'demonstrated flight)'),
    ('sigma_0.67', '1 kg payload, the preset', ''),
    ('stress', '1 kg payload, the preset', ''),
    ('no_payload_default', 'no payload, the planner\'s 4.5 kg',
     '5 days demonstrated (121 h 34 min); ValBal\'s simulator at 1.4: '
     '5 days on 4.949 kg (0.99 kg a day)'),
    ('no_payload_sigma_0.67', 'no payload, the planner\'s 4.5 kg', ''),
    ('no_payload_stress', 'no payload, the planner\'s 4.5 kg', ''),
    ('payload_takes_ballast_default', 'what-if: 1 kg payload in place of '
     '1 kg of ballast', ''),
    ('payload_takes_ballast_sigma_0.67', 'what-if: 1 kg payload in place of '
     '1 kg of ballast', ''),
    ('payload_takes_ballast_stress', 'what-if: 1 kg payload in place of '
     '1 kg of ballast', ''),
)


def valbal_check() -> str:
  """docs/physics.md's ValBal table: days aloft and ballast per case."""
  record = tables_lib.load(VALBAL)
  lines = ['| case | system + payload / ballast [kg] | disturbance [g/√s] | '
           'days aloft (of 7; flights) | ballast a day [kg] | within ±750 m '
           '| ValBal |', '|---|---|---|---|---|---|---|']
  for key, case, valbal in VALBAL_ROWS:
    row = record.get(key)
    if row is None:
      continue
    up = sum(d >= row['max_days'] for d in row['days_aloft'])
    lines.append(
        f'| {case} | {row["payload_kg"]:.1f} / {row["initial_sand_kg"]:.1f} '
        f'| {1e3 * row["lift_walk_kg_per_sqrt_s"]:.2f} '
        f'| {row["days_aloft_mean"]:.2f} ({up} of {row["flights"]} up at the '
        f'end) | {row["ballast_kg_per_day_mean"]:.2f} '
        f'| {row["time_in_band_pct"]:.0f} % | {valbal} |')
  return '\n'.join(lines)


REWARDS = (('perciatelli', 'flat (the paper\'s, default)'),
           ('tanh', 'tanh'))


def _float_calibration(path: pathlib.Path) -> str:
  """The rows of a `benchmarks/float_calibration.py` record (issue 68)."""
  record = tables_lib.load(path)
  lines = ['| row | measured | range | inside |', '|---|---|---|---|']
  for row in record['rows']:
    value = row['value']
    text = (f'{value:.3g}' if isinstance(value, float) else
            ' - '.join(f'{v:g}' for v in value))
    span = ('—' if row['range'] is None else
            f'{row["range"][0]:g}–{row["range"][1]:g}')
    inside = {None: '—', True: 'yes', False: '**no**'}[row['inside']]
    name = row['row'].replace('|', '\\|')
    if name.startswith('days aloft') and value >= record['details'][
        'band']['max_days']:
      text += ' (all up at the limit)'
    lines.append(f'| {name} | {text} | {span} | {inside} |')
  lines.append(f'\n({record["date"][:10]}, {record["machine"]}, '
               f'{record["seconds"]:.0f} s: `{record["command"]}`)')
  return '\n'.join(lines)


def float_calibration_sweep() -> str:
  """The heating-disturbance sweep of `float_calibration.py --sweep`."""
  record = tables_lib.load(FLOAT_CALIBRATION_SWEEP)
  lines = ['| heating rms [K] | correlation time [s] | calm probability | '
           'band cost [kg/day] | days aloft (of 7) | within ±750 m |',
           '|---|---|---|---|---|---|']
  for r in record['sweep']:
    lines.append(f'| {r["rms_k"]:g} | {r["time_s"]:g} | {r["calm"]:.3f} | '
                 f'{r["cost"]:.2f} | {r["days"]:.2f} | {r["inband"]:.0f} % |')
  return '\n'.join(lines)


def _reward_cells() -> List[Tuple[str, dict]]:
  rewards = tables_lib.load(REWARD_SHAPE)['rewards']
  out = [(label, rewards[name]) for name, label in REWARDS if name in rewards]
  if not out:
    raise ValueError(f'{REWARD_SHAPE}: no rewards')
  return out


def _seeds_done(cell: dict) -> List[dict]:
  return [cell['seeds'][k] for k in sorted(cell['seeds'], key=int)
          if 'held_out_tw50_window' in cell['seeds'][k]]


def reward_shape() -> str:
  """docs/launch.md's reward study: each reward over its training seeds."""
  lines = ['| reward | training seeds | held-out TW50 window | time at 40–50 km '
           '| time ≤ 40 km | edge share of the time inside | out of resources '
           '| ' + ' | '.join(f'{label}: TW50 window'
                              for _, label in REAL_WINDS_SOURCES) + ' |',
           '|---' * (7 + len(REAL_WINDS_SOURCES)) + '|']
  over = tables_lib.over_seeds_cell
  for label, cell in _reward_cells():
    rows = _seeds_done(cell)
    if not rows:
      continue
    real = []
    for source, _ in REAL_WINDS_SOURCES:
      flown = [r['real_winds'][source]['tw50_window'] for r in rows
               if source in r.get('real_winds', {})]
      real.append(over(flown) + (
          f' [{len(flown)} seeds]' if len(flown) != len(rows) else '')
                  if flown else '—')
    oor = ' / '.join(f"{r['held_out_out_of_resources_pct']:.0f}"
                     for r in rows)
    lines.append(
        f'| {label} | {len(rows)} '
        f'| {over([r["held_out_tw50_window"] for r in rows])} '
        f'| {over([r["edge_fraction"] for r in rows])} '
        f'| {over([r["core_fraction"] for r in rows])} '
        f'| {over([r["edge_share_of_inside"] for r in rows], 0)} '
        f'| {oor} % | ' + ' | '.join(real) + ' |')
  return '\n'.join(lines)


def reward_shape_paired() -> str:
  """Per training seed, tanh − flat on the same flights, TW50 window pts."""
  cells = dict(_reward_cells())
  flat, tanh = (cells.get(label) for _, label in REWARDS)
  lines = ['| training seed | held-out `latex_small` | ' + ' | '.join(
      label for _, label in REAL_WINDS_SOURCES) + ' |',
           '|---' * (2 + len(REAL_WINDS_SOURCES)) + '|']
  if flat is None or tanh is None:
    return '\n'.join(lines)
  for key in sorted(set(flat['seeds']) & set(tanh['seeds']), key=int):
    a, b = flat['seeds'][key], tanh['seeds'][key]
    if 'held_out_per_seed' not in a or 'held_out_per_seed' not in b:
      continue
    real = []
    for source, _ in REAL_WINDS_SOURCES:
      ra = a.get('real_winds', {}).get(source, {}).get('per_seed')
      rb = b.get('real_winds', {}).get(source, {}).get('per_seed')
      real.append(tables_lib.paired_cell(ra, rb, REWARD_SHAPE) if ra and rb
                  else '—')
    held = tables_lib.paired_cell(a['held_out_per_seed'],
                                  b['held_out_per_seed'], REWARD_SHAPE)
    lines.append(f'| {key} | {held} | '
                 + ' | '.join(real) + ' |')
  return '\n'.join(lines)


def reserves_sweep() -> str:
  """docs/physics.md: the reserves planner's settings on validation seeds
  (issue 63): TW50, failures by resource, sand, the opening's spending."""
  record = tables_lib.load(RESERVES_SWEEP)
  hours = record['early_hours']
  lines = ['| `LatexMpcAgent` bindings | validation TW50 window (mean ± std) | '
           'out of resources (helium, sand) | sand dropped [kg] | '
           f'spent in the first {hours:g} h: sand [kg], helium |',
           '|---|---|---|---|---|']
  for entry in record['settings']:
    seeds = entry['per_seed']
    n = len(seeds['seeds'])
    reasons = seeds['terminal_reason']
    label = ', '.join(f'`{b.split(".", 1)[-1]}`'
                      for b in entry['gin_bindings']) or 'defaults'
    mean, std = entry['summary']['tw50_window']
    failed = sum(r in records_lib.OUT_OF_RESOURCES_REASONS for r in reasons)
    early_sand = sum(seeds['early_sand_kg']) / n
    early_helium = sum(seeds['early_helium_fraction']) / n
    lines.append(
        f'| {label} | {100 * mean:.1f} % ± {100 * std:.1f} | '
        f'{failed} / {n} '
        f'({reasons.count("out_of_helium")}, {reasons.count("out_of_sand")}) | '
        f'{entry["summary"]["sand"]:.2f} | {early_sand:.2f}, '
        f'{100 * early_helium:.0f} % |')
  return '\n'.join(lines)


# (reference name in benchmarks/records/dagger/results.json, column label).
TABLES: Dict[str, Callable[[], str]] = {
    'valbal-check': valbal_check,
    'float-calibration': lambda: _float_calibration(FLOAT_CALIBRATION),
    'float-calibration-before': lambda: _float_calibration(
        FLOAT_CALIBRATION_BEFORE),
    'float-calibration-sweep': float_calibration_sweep,
    'realistic-full': realistic_full,
    'realistic-long': realistic_long,
    'realistic-uncalibrated': realistic_uncalibrated,
    'realistic-task': realistic_task,
    'reserves-sweep': reserves_sweep,
    'agents-short': agents_short,
    'agents-full': agents_full,
    'planners-short': planners_short,
    'planners-full': planners_full,
    'real-winds': real_winds_short,
    'real-winds-full': real_winds_full,
    'wind-compare': wind_compare,
    'reward-shape': reward_shape,
    'reward-shape-paired': reward_shape_paired,
    **learned.TABLES,  # Issue 47's learned controllers.
}


def fill(text: str, where: str = 'text') -> str:
  """`text` with every table block regenerated.

  Raises:
    ValueError: A block names no known table.
  """
  def replace(match: re.Match) -> str:
    name = match.group(2)
    if name not in TABLES:
      raise ValueError(f'{where}: unknown table {name!r} (known: '
                       f'{sorted(TABLES)})')
    return f'{match.group(1)}{TABLES[name]()}\n{match.group(4)}'
  return BLOCK.sub(replace, text)


def pages() -> List[pathlib.Path]:
  """README and the docs pages that hold a table block."""
  candidates = [ROOT / 'README.md', *sorted((ROOT / 'docs').glob('*.md'))]
  return [p for p in candidates
          if BLOCK.search(p.read_text(encoding='utf-8'))]


def stale() -> List[str]:
  """Pages whose table blocks differ from the records."""
  return [str(p.relative_to(ROOT)) for p in pages()
          if fill(p.read_text(encoding='utf-8'), str(p)) !=
          p.read_text(encoding='utf-8')]


def main(argv: Sequence[str]) -> int:
  if argv[1:] == ['--check']:
    out_of_date = stale()
    if out_of_date:
      print(f'tables out of date in {out_of_date}: run python '
            'docs/hooks/tables.py', file=sys.stderr)
      return 1
    return 0
  if argv[1:]:
    print('usage: python docs/hooks/tables.py [--check]', file=sys.stderr)
    return 2
  for page in pages():
    text = page.read_text(encoding='utf-8')
    new = fill(text, str(page))
    if new != text:
      page.write_text(new, encoding='utf-8')
      print(f'rewrote {page.relative_to(ROOT)}')
  return 0


if __name__ == '__main__':
  sys.exit(main(sys.argv))
