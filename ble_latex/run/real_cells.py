# coding=utf-8
"""Real-winds cells: where an agent flies a real wind source, and the flights.

A cell (the settings a record of `benchmarks/real_winds.py` or
`benchmarks/reward_shape.py` keeps) names a source of `wind.sources.SOURCES`,
the suite whose first seeds fly, and its station (`wind_file.station_settings`:
a grid's centre or per-seed stations, a sounding's site). This module is the
scripts' library (issue 66: scripts parse flags and call the package):

- `seeds_per_source`: the seeds each source flies ('N' or 'SOURCE:N');
- `source_cell`: where a source flies as the committed real-winds table flies
  it (`sources.table_station_mode`);
- `fly_cell`: flies a cell's agent, keeping each seed's compact record
  (`KEPT`); `fly_policy`: flies a pretrained SAC policy on a cell, summarised
  with the edge fractions (`metrics.edge_summary`);
- `missing_sources`: the sources a study's row has not flown with its
  settings.
"""

import time
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

from ble_latex.run import metrics
from ble_latex.run import planner_batch
from ble_latex.run import wind_file
from ble_latex.wind import sources

# Seeds a source flies unless --seeds names another number.
DEFAULT_SEEDS = 100
# Agents named here for what they fly: name -> (BLE agent id, env id).
BLE_AGENTS = {'ble_station_seeker_discrete': ('station_seeker',
                                              'LatexBalloonDiscrete-v0')}
# Flown by `planner_batch.fly_planner` (no TensorFlow).
PLANNERS = ('latex_mpc', 'latex_mpc_oracle')
# What a seed's compact record keeps of `eval_lib.fly`'s.
KEPT = ('seed', 'tw50', 'tw50_window', 'window_steps', 'reward', 'steps',
        'helium_vented_mols', 'sand_dropped_kg', 'terminal_reason',
        'final_distance_km')
# Kept too where the records have them (a per-seed station's place).
KEPT_IF_THERE = ('station_lat', 'station_lon')


def seeds_per_source(entries: Sequence[str], names: Sequence[str]
                     ) -> Dict[str, int]:
  """Seeds per source of `names`: 'N' for all, or 'SOURCE:N' entries
  (sources not named: `DEFAULT_SEEDS`).

  Raises:
    ValueError: one line naming the entry that is not N or SOURCE:N (N an
      integer >= 1, SOURCE among `names`).
  """
  counts = {s: DEFAULT_SEEDS for s in names}
  for entry in entries:
    name, _, number = entry.rpartition(':')
    try:
      n = int(number)
    except ValueError:
      raise ValueError(f'{entry!r} is not N or SOURCE:N') from None
    if n < 1:
      raise ValueError(f'{entry!r}: N must be >= 1')
    if not name:
      counts = {s: n for s in names}
    elif name not in counts:
      raise ValueError(f'{name!r} is not among --sources {list(names)}')
    else:
      counts[name] = n
  return counts


def source_cell(name: str, suite: str, path: str) -> Dict[str, Any]:
  """Where source `name` (file `path`) flies `suite`'s seeds: the committed
  real-winds table's station mode (`sources.table_station_mode`)."""
  return {'source': name, 'suite': suite,
          **wind_file.station_settings(
              name, path, sources.table_station_mode(name))}


def fly_cell(cell: Mapping[str, Any], path: str, seeds: Sequence[int]
             ) -> Tuple[List[Dict[str, Any]], str, Union[bool, str], float]:
  """Flies `seeds` of `cell['agent']` on `path` (`wind_file.cell_bindings`).

  Returns:
    (compact records (`KEPT`, `KEPT_IF_THERE`), the wind source, batched,
    seconds flying): `batched` whether `eval_lib.evaluate` flew them batched,
    or 'planners.py' for a planner (`planner_batch.fly_planner`, batched
    too). `cell['max_steps']` None flies the suite's length.
  """
  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import env_params
  from ble_latex.run import suites
  # pylint: enable=g-import-not-at-top
  bindings = wind_file.cell_bindings(cell, path)
  max_steps = cell['max_steps'] or suites.get_eval_suite(
      cell['suite']).max_episode_length
  if cell['agent'] in PLANNERS:
    records, source, wall = planner_batch.fly_planner(
        cell['agent'], bindings, seeds, max_steps)
    batched = 'planners.py'
  else:
    # pylint: disable=g-import-not-at-top
    from ble_latex.run import batch_eval
    from ble_latex.run import eval_lib
    # pylint: enable=g-import-not-at-top
    name, env_name = BLE_AGENTS.get(cell['agent'],
                                    (cell['agent'], 'LatexBalloon-v0'))
    agent, env = eval_lib.build(eval_lib.EvalSpec(
        agent=name, env_name=env_name, gin_bindings=tuple(bindings)))
    source = env_params.wind_source()
    batched = batch_eval.flies_batched(agent, env)
    began = time.perf_counter()
    records = eval_lib.evaluate(
        agent, env, seeds, max_steps,
        description=f"{cell['source']} {cell['agent']}")
    wall = time.perf_counter() - began
  kept = [{**{k: r[k] for k in KEPT},
           **{k: r[k] for k in KEPT_IF_THERE if k in r}} for r in records]
  return kept, source, batched, wall


def fly_policy(policy_path: str, cell: Mapping[str, Any], path: str,
               num_seeds: int, max_steps: Optional[int] = None
               ) -> Dict[str, Any]:
  """Flies a pretrained SAC policy on a cell's first `num_seeds` seeds.

  `max_steps`: strides per flight (default the suite's). Returns the cell
  with the wind source, episodes, mean TW50 window, out-of-resources %
  [%], `metrics.edge_summary` and per-seed edges (`metrics.per_seed_edges`).
  """
  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import env_params
  from ble_latex.run import eval_lib
  from ble_latex.run import suites
  # pylint: enable=g-import-not-at-top
  bindings = [*wind_file.cell_bindings(cell, path),
              f'SACPretrainedAgent.policy_path = {policy_path!r}']
  agent, env = eval_lib.build(eval_lib.EvalSpec(
      agent='sac_pretrained', gin_bindings=tuple(bindings)))
  suite = suites.get_eval_suite(cell['suite'])
  held = eval_lib.evaluate(agent, env, list(suite.seeds)[:num_seeds],
                           max_steps or suite.max_episode_length,
                           description=f"{cell['source']} {policy_path}")
  summary = metrics.summarize(held)
  return {**cell, 'wind_source': env_params.wind_source(),
          'episodes': len(held),
          'tw50_window': summary['tw50_window_mean'],
          'out_of_resources_pct': summary['out_of_resources_pct'],
          **metrics.edge_summary(held),
          'per_seed': metrics.per_seed_edges(held)}


def missing_sources(row: Mapping[str, Any], names: Sequence[str],
                    num_seeds: int, suite: str) -> List[str]:
  """The sources of `names` that `row['real_winds']` has not flown with
  `num_seeds` seeds of `suite`."""
  flown = row.get('real_winds', {})
  return [name for name in names
          if flown.get(name, {}).get('episodes') != num_seeds
          or flown[name].get('suite') != suite]
