"""Does the follow-up paper's tanh reward stop SAC skirting the circle's edge?

Saunders et al. 2024 (arXiv 2403.10784) report that SAC rewarded equally
everywhere inside the 50 km circle learns to fly near its edge, which
generalises badly to unseen winds, and that a tanh-shaped reward pulling
towards the centre flies more time in the region on unseen winds. This
study trains SAC with the jitted trainer (`ble-latex-train --trainer=jax`,
`ble_latex.run.seed_runs`, as `benchmarks/sac_seeds.py`) once per reward
and training seed, for --rounds rounds each:

  perciatelli  the paper's (2023) reward, the default (flat 1 inside);
  tanh         `latex_reward.reward_tanh_scale_km = --tanh_scale_km` (the
               inside falls from 1 at the station to the drop-off at the
               edge, `jax_features.tanh_inside`).

Each seed's policy is chosen on `latex_validation` only (the snapshot with
the best TW50 window among those with <= --max_oor_pct % out of resources,
`selection.choose_snapshot`), then flown once on the held-out
--held_out_suite (`latex_small`) with the gym env
(`seed_runs.fly_held_out`).
Per seed it reports the held-out TW50 window, the fraction of the window at
40-50 km from the station (edge-skirting) and at <= 40 km, and the share
of the in-circle time spent at the edge, into --output (JSON: per reward
and seed, mean +- std, the command, date, machine and load).

With --real_sources, each chosen policy also flies those real wind sources
(`benchmarks/real_winds.py`'s files and stations, `ble_latex.wind.sources`
and `run/wind_file.py`: a GFS grid at per-seed
stations, a sounding at its launch site), --real_seeds seeds each, with the
same TW50 window and edge fractions per source.

Resumable: training resumes from the run directories
(BASE_DIR/perciatelli/seed_S, BASE_DIR/tanh_<w>km/seed_S), and a cell
(reward, seed) already in --output with the same settings is skipped (it
flies only the real sources it lacks); other settings in the same file are
refused, naming what differs. --parallel=2 trains and flies two cells at
once (each in its own processes; this process alone writes the record, and
a second study on the same --output is refused). The full study (3 seeds x
2 rewards, 60 rounds each; 2 h 14 min on 2 cores at load 3-5.5 on
2026-11-28, real sources included):

  nice -n 5 python benchmarks/reward_shape.py \
      --base_dir=benchmarks/records/sac_jax/reward_shape --seeds=0,1,2 --rounds=60 \
      --parallel=2 --output=benchmarks/records/reward_shape.json \
      --real_sources=gfs_namerica,gfs_global,boise,hilo

A smoke run (tiny budget; its numbers mean nothing):

  python benchmarks/reward_shape.py --base_dir=/tmp/rs --seeds=0 --rounds=2 \
      --snapshot_period=1 --validation_episodes=4 --held_out_episodes=4 \
      --gin_bindings=sac_trainer_config.num_envs=4 --output=/tmp/rs/rs.json
"""

from concurrent import futures
import datetime as dt
import json
import multiprocessing
import os
import platform
import statistics
import sys
from typing import Any, Dict, List, Optional, Sequence

from absl import flags

from ble_latex import gin_values
from ble_latex import safe_io
from ble_latex.cli import common as cli
from ble_latex.run import episode_log
from ble_latex.run import gin_binding
from ble_latex.run import metrics
from ble_latex.run import real_cells
from ble_latex.run import run_dir
from ble_latex.run import seed_runs
from ble_latex.run import selection
from ble_latex.wind import sources

FLAGS = flags.FlagValues()
flags.DEFINE_string('base_dir', None, 'Training runs (perciatelli/seed_S, '
                    'tanh_<w>km/seed_S).',
                    flag_values=FLAGS)
flags.DEFINE_list('seeds', ['0', '1', '2'], 'Training seeds.',
                  flag_values=FLAGS)
flags.DEFINE_list('rewards', ['perciatelli', 'tanh'], 'Rewards to train.',
                  flag_values=FLAGS)
flags.DEFINE_integer('rounds', 60, 'Training rounds per seed '
                     '(sac_trainer_config.num_envs episodes each).',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_float('tanh_scale_km', 25.0, 'The tanh reward\'s scale w '
                   '(latex_reward.reward_tanh_scale_km).', flag_values=FLAGS)
flags.DEFINE_integer('snapshot_period', 5, 'Rounds between validated '
                     'snapshots (and checkpoints); at most --rounds.',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('validation_episodes', 100, 'latex_validation seeds '
                     'per snapshot.', lower_bound=1, flag_values=FLAGS)
flags.DEFINE_string('held_out_suite', 'latex_small', 'Held-out suite (never '
                    'used for choosing).', flag_values=FLAGS)
flags.DEFINE_integer('held_out_episodes', None, 'Fly only the first seeds '
                     'of the held-out suite (default: all).', lower_bound=1,
                     flag_values=FLAGS)
flags.DEFINE_float('max_oor_pct', 5.0, 'Most % of validation episodes out '
                   'of resources of a chosen snapshot.', flag_values=FLAGS)
cli.define_gin_flags(FLAGS, files_help=None, bindings_help='Bindings for '
                     'every reward\'s training (e.g. '
                     'sac_trainer_config.num_envs=8).')
flags.DEFINE_string('output', str(episode_log.RECORDS_DIR / 'reward_shape.json'), 'The record.',
                    flag_values=FLAGS)
flags.DEFINE_list('real_sources', [], 'Real wind sources each chosen policy '
                  f'also flies, of {list(sources.SOURCES)} '
                  '(ble_latex.wind.sources): a GFS grid at per-seed '
                  'stations, a sounding at its site, as README\'s real-winds '
                  'table. Done cells fly the sources they lack.',
                  flag_values=FLAGS)
flags.DEFINE_integer('real_seeds', 100, 'Seeds per real source (the held-'
                     'out suite\'s first).', lower_bound=1, flag_values=FLAGS)
flags.DEFINE_string('realdata_dir', sources.REALDATA_DIR, 'Folder of the '
                    'real files (PROVENANCE.md).', flag_values=FLAGS)
flags.DEFINE_string('edges_of', None, 'Only print an eval JSON\'s TW50 window '
                    'and edge fractions (e.g. the shipped policy\'s '
                    '`ble-latex-eval` file) and exit.', flag_values=FLAGS)
flags.DEFINE_integer('parallel', 1, 'Cells (reward, seed) trained and flown '
                     'at once, each in its own processes; the record is '
                     'written by this process alone, as cells finish.',
                     lower_bound=1, flag_values=FLAGS)

def reward_bindings(reward: str, tanh_scale_km: float) -> List[str]:
  """`seed_runs.reward_bindings`; an unknown reward is a usage error."""
  try:
    return seed_runs.reward_bindings(reward, tanh_scale_km)
  except ValueError as e:
    raise cli.CommandUsageError(f'--rewards: {e}') from e


def edges_of(path: str) -> Dict[str, Any]:
  """An eval file's flights: mean TW50 window and `metrics.edge_summary`."""
  from ble_latex.run import records  # pylint: disable=g-import-not-at-top
  try:
    held = records.load_eval(path)
    return {'file': path, 'episodes': len(held),
            'tw50_window': statistics.mean(r['tw50_window'] for r in held),
            **metrics.edge_summary(held)}
  except (ValueError, KeyError, TypeError, statistics.StatisticsError) as e:
    raise cli.CommandFailure(f'--edges_of: {path} is not a usable eval file '
                             f'({gin_binding.one_line(e)})') from e


def _held_out(suite_name: str, episodes: Optional[int], policy_path: str,
              output: str) -> Any:
  """Flies the chosen policy on the held-out seeds (a spawned process)."""
  from ble_latex.run import records  # pylint: disable=g-import-not-at-top
  summary = seed_runs.fly_held_out(suite_name, policy_path, output,
                                   num_seeds=episodes)
  return summary, records.load_eval(output)


def fly_real(args: Any, row: Dict[str, Any], policy: str) -> None:
  """Flies `policy` on the real sources `row` lacks, into row['real_winds']."""
  for name in real_cells.missing_sources(row, args.real_sources,
                                        args.real_seeds, args.held_out_suite):
    path = sources.path(name, args.realdata_dir)
    with futures.ProcessPoolExecutor(
        max_workers=1,
        mp_context=multiprocessing.get_context('spawn')) as pool:
      result = pool.submit(real_cells.fly_policy, policy,
                           real_cells.source_cell(name, args.held_out_suite,
                                                  path),
                           path, args.real_seeds).result()
    row.setdefault('real_winds', {})[name] = result


def settings(args: Any) -> Dict[str, Any]:
  """What a cell's result depends on (a resume must match it)."""
  return {'rounds': args.rounds, 'tanh_scale_km': args.tanh_scale_km,
          'snapshot_period': args.snapshot_period,
          'validation_episodes': args.validation_episodes,
          'held_out_suite': args.held_out_suite,
          'held_out_episodes': args.held_out_episodes,
          'max_oor_pct': args.max_oor_pct,
          'gin_bindings': list(args.gin_bindings)}


def run_folder(args: Any, reward: str) -> str:
  """A reward's runs under --base_dir (a tanh folder names its scale: another
  scale never resumes it)."""
  return reward if reward == 'perciatelli' else (
      f'{reward}_{args.tanh_scale_km:g}km')


def run_cell(args: Any, reward: str, seed: int) -> Dict[str, Any]:
  """Trains (or resumes), chooses and flies one (reward, seed)."""
  # pylint: disable=g-import-not-at-top
  from ble_latex.run import episode_log
  from ble_latex.run import records
  # pylint: enable=g-import-not-at-top
  base = os.path.join(args.base_dir, run_folder(args, reward))
  bindings = [*args.gin_bindings,
              *reward_bindings(reward, args.tanh_scale_km)]
  seed_runs.train_seeds(base, [seed], args.rounds, args.snapshot_period,
                        args.snapshot_period, bindings,
                        extra_flags=[f'--validation_episodes='
                                     f'{args.validation_episodes}'])
  run = os.path.join(base, f'seed_{seed}')
  validation = records.load_validation(
      os.path.join(run, episode_log.VALIDATION_LOG))
  row: Dict[str, Any] = {'seed': seed, 'gin_bindings': bindings,
                         'validated_rounds': len(validation)}
  chosen = selection.choose_snapshot(validation, args.max_oor_pct)
  if chosen is None:
    row['note'] = (f'no validated snapshot with <= {args.max_oor_pct:g} % '
                   'out of resources')
    return row
  policy = seed_runs.write_chosen_policy(run, seed, chosen, validation,
                                        args.max_oor_pct)
  output = os.path.join(run, f'held_out_{args.held_out_suite}.json')
  with futures.ProcessPoolExecutor(
      max_workers=1, mp_context=multiprocessing.get_context('spawn')) as pool:
    summary, held = pool.submit(_held_out, args.held_out_suite,
                                args.held_out_episodes, policy,
                                output).result()
  row.update({
      'chosen_round': chosen['iteration'],
      'validation_tw50_window': chosen['tw50_window_mean'],
      'validation_out_of_resources_pct': chosen['out_of_resources_pct'],
      'held_out_episodes': len(held),
      'held_out_tw50_window': summary['tw50_window_mean'],
      **metrics.edge_summary(held),
      'held_out_out_of_resources_pct': summary['out_of_resources_pct'],
      'held_out_file': output,
      'held_out_per_seed': metrics.per_seed_edges(held)})
  return row


def _load(path: str, current: Dict[str, Any]) -> Dict[str, Any]:
  if not os.path.exists(path):
    return {'settings': current, 'rewards': {}}
  try:
    with open(path, encoding='utf-8') as f:
      data = json.load(f)
  except (json.JSONDecodeError, UnicodeDecodeError) as e:
    raise cli.CommandFailure(f'{path}: truncated or not JSON ({e}); fix or '
                             'move it, or use another --output') from e
  if not isinstance(data, dict) or not isinstance(data.get('rewards'), dict):
    raise cli.CommandFailure(f'{path}: not a reward_shape record')
  for reward, cell in data['rewards'].items():
    if not (isinstance(cell, dict) and isinstance(cell.get('seeds', {}), dict)
            and all(isinstance(row, dict) for row in cell.get(
                'seeds', {}).values())):
      raise cli.CommandFailure(
          f'{path}: rewards.{reward} is not a {{"seeds": {{seed: row}}}} '
          'object (not a reward_shape record)')
  recorded = data.get('settings', {})
  differ = sorted(k for k in set(recorded) | set(current)
                  if recorded.get(k) != current.get(k))
  if differ:
    raise cli.CommandFailure(
        f'{path} was made with other settings ('
        + ', '.join(f'{k}: {recorded.get(k)!r} -> {current.get(k)!r}'
                    for k in differ) + '); use another --output')
  return data


def _main(argv: Sequence[str]) -> int:
  del argv
  args = FLAGS
  if args.edges_of:
    print(json.dumps(edges_of(args.edges_of)))
    return 0
  if not args.base_dir:
    raise cli.CommandUsageError('--base_dir is required')
  # Training seeds in [0, 2**32), checked before any child is started.
  seeds = run_dir.training_seeds(args.seeds)
  for reward in args.rewards:
    reward_bindings(reward, args.tanh_scale_km)
  if not gin_values.is_positive(args.tanh_scale_km):
    raise cli.CommandUsageError(
        f'--tanh_scale_km must be a finite number > 0 in float32 (>= 1.2e-38;'
        f' smaller is 0, the flat reward), got {args.tanh_scale_km!r}')
  if args.snapshot_period > args.rounds:
    raise cli.CommandUsageError(
        f'--snapshot_period={args.snapshot_period} > --rounds={args.rounds}: '
        'no snapshot would be validated')
  unknown = sources.unknown(args.real_sources)
  if unknown:
    raise cli.CommandUsageError(f'--real_sources: unknown {unknown} (known: '
                                f'{list(sources.SOURCES)})')
  for name in args.real_sources:
    path = sources.path(name, args.realdata_dir)
    if not os.path.isfile(path):
      raise cli.CommandUsageError(f'{path}: no such file (--realdata_dir)')
  current = settings(args)
  # One writer per record: a second study on the same --output is refused.
  with safe_io.locked_file(args.output, what='reward_shape record'):
    data = _load(args.output, current)
    # Seed by seed, each seed's rewards together: a study stopped part way
    # has both rewards of its first seeds.
    pending = []
    for seed in seeds:
      for reward in args.rewards:
        cell = data['rewards'].setdefault(reward, {'seeds': {}})
        row = cell['seeds'].get(str(seed), {})
        if ('held_out_tw50_window' in row and 'held_out_per_seed' in row
            and not real_cells.missing_sources(
                row, args.real_sources, args.real_seeds,
                args.held_out_suite)):
          print(f'{reward} seed {seed}: done, kept', flush=True)
        else:
          pending.append((reward, seed))

    def one_cell(reward: str, seed: int) -> Dict[str, Any]:
      row = dict(data['rewards'][reward]['seeds'].get(str(seed), {}))
      if 'held_out_tw50_window' not in row:
        load = os.getloadavg()
        row = run_cell(args, reward, seed)
        row.update({'date': dt.datetime.now(dt.timezone.utc).isoformat(
            timespec='seconds'), 'machine': f'{platform.node()} '
            f'({os.cpu_count()} CPUs)', 'load_at_start': list(load),
                    'load_at_end': list(os.getloadavg())})
      if ('held_out_tw50_window' in row and 'held_out_per_seed' not in row
          and os.path.exists(row['held_out_file'])):  # Flown before it was kept.
        from ble_latex.run import records  # pylint: disable=g-import-not-at-top
        row['held_out_per_seed'] = metrics.per_seed_edges(records.load_eval(
            row['held_out_file']))
      if 'held_out_tw50_window' in row and args.real_sources:
        fly_real(args, row, os.path.join(
            args.base_dir, run_folder(args, reward), f'seed_{seed}',
            'chosen_policy.msgpack'))
      return row

    # Threads only wait here: each cell trains in a `ble-latex-train` process
    # and flies in a spawned one. The record is read-modify-written by this
    # thread alone, one finished cell at a time.
    with futures.ThreadPoolExecutor(max_workers=args.parallel) as pool:
      running = {pool.submit(one_cell, reward, seed): (reward, seed)
                 for reward, seed in pending}
      for done in futures.as_completed(running):
        reward, seed = running[done]
        row = done.result()
        cell = data['rewards'][reward]
        cell['seeds'][str(seed)] = row
        cell['summary'] = seed_runs.reward_summary(cell['seeds'])
        data['command'] = ' '.join(['python', 'benchmarks/reward_shape.py',
                                    *sys.argv[1:]])
        safe_io.atomic_write(args.output, json.dumps(data, indent=1) + '\n')
        print(f'{reward} seed {seed}: {json.dumps(row)}', flush=True)
  for reward, cell in data['rewards'].items():
    print(reward, json.dumps(cell.get('summary', {})))
  return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/reward_shape.py', FLAGS, argv,
                      doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
