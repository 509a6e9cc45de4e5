"""Several SAC training seeds with the jitted trainer, chosen and reported.

Two steps, both resumable (re-run the same command after a kill):

  # 1. Train each seed (`ble-latex-train --trainer=jax`, gin sac_jax.gin),
  #    in BASE_DIR/seed_<s>, one after another; every --snapshot_period rounds
  #    the policy is exported and flown on the 100 latex_validation seeds
  #    (batched, into seed_<s>/validation.jsonl with the training time so far).
  python benchmarks/sac_seeds.py train --base_dir=benchmarks/records/sac_jax/n32 \
      --seeds=0,1,2,3,4 --num_iterations=230 [--parallel=2]

  #    --parallel=2 runs two ble-latex-train processes at once (seeds dealt
  #    round-robin): on a 2-core CPU two processes fly ~1.6x the rounds per
  #    hour of one (README, "Jitted SAC trainer"). --vmap_seeds trains each
  #    process's seeds together (`ble-latex-train --vmap_seeds`).

  # 2. For each seed, choose the snapshot with the best validation TW50 over
  #    the window among those with at most --max_oor_pct % out of resources
  #    (validation seeds only: nothing held out is looked at), copy it to
  #    seed_<s>/chosen_policy.msgpack, fly it on the held-out latex_small
  #    seeds with the gym env (`ble-latex-eval`'s code) and write
  #    BASE_DIR/report.{md,json}: per seed and mean +- std. --ship also
  #    writes the seed with the best *validation* score as the shipped
  #    policy. --max_minutes / --max_iteration cap the snapshots looked at
  #    (a time budget, or the same number of rounds for every seed);
  #    --parallel=2 flies two seeds' held-out evals at once.
  python benchmarks/sac_seeds.py report --base_dir=benchmarks/records/sac_jax/n32 \
      --seeds=0,1,2,3,4 [--max_iteration=229] [--parallel=2] \
      [--ship=ble_latex/agents/policies/sac_latex.msgpack]

  # 3. Compare runs of different settings on validation only (no flights):
  #    per run directory, the chosen snapshot as in `report` and the mean of
  #    the last five validations, within the same caps.
  python benchmarks/sac_seeds.py compare --max_iteration=99 \
      --run_dirs=benchmarks/records/sac_jax/n32/seed_0,benchmarks/records/sac_jax/critic_crossq/seed_0
"""

from concurrent import futures
import json
import multiprocessing
import os
import shutil
import statistics
import sys
from typing import Any, Dict, List, Optional, Sequence

from absl import flags

from ble_latex import safe_io
from ble_latex.cli import common as cli
from ble_latex.run import seed_runs
from ble_latex.run import selection

FLAGS = flags.FlagValues()
flags.DEFINE_string('base_dir', None, 'Folder of the seeds\' runs.',
                    flag_values=FLAGS)
flags.DEFINE_list('seeds', ['0', '1', '2', '3', '4'], 'Training seeds.',
                  flag_values=FLAGS)
flags.DEFINE_integer('num_iterations', 230, 'train: rounds per seed '
                     '(sac_trainer_config.num_envs episodes each).', lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('snapshot_period', 5, 'train: rounds between policy '
                     'snapshots.', lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('checkpoint_period', 10, 'train: rounds between '
                     'checkpoints.', lower_bound=1, flag_values=FLAGS)
cli.define_gin_flags(
    FLAGS, bindings_help='train: gin bindings.',
    files_help='train and report: extra gin files (e.g. '
    'gin_configs/latex_realistic.gin: trained, validated and flown held out '
    'under them).')
flags.DEFINE_float('max_oor_pct', 5.0, 'report: most % of validation '
                   'episodes out of resources of a chosen snapshot.',
                   flag_values=FLAGS)
flags.DEFINE_float('max_minutes', None, 'report: choose only among snapshots '
                   'taken within this much training time (e.g. 45).',
                   flag_values=FLAGS)
flags.DEFINE_integer('max_iteration', None, 'report: choose only among '
                     'snapshots of rounds up to this one (0-based), e.g. '
                     'the same training budget for every seed.',
                     lower_bound=0, flag_values=FLAGS)
flags.DEFINE_integer('parallel', 1, 'train: ble-latex-train processes at '
                     'once (seeds dealt round-robin); report: held-out evals '
                     'at once.', lower_bound=1, flag_values=FLAGS)
flags.DEFINE_list('run_dirs', [], 'compare: run directories.',
                  flag_values=FLAGS)
flags.DEFINE_string('json', None, 'compare: also write the rows here.',
                    flag_values=FLAGS)
flags.DEFINE_bool('vmap_seeds', False, 'train: each process trains its '
                  'seeds in one vmapped call per round (ble-latex-train '
                  '--vmap_seeds).', flag_values=FLAGS)
flags.DEFINE_string('results_dir', 'benchmarks/results/sac_seeds', 'report: where the '
                    'held-out eval files go.', flag_values=FLAGS)
flags.DEFINE_string('held_out_suite', 'latex_small', 'report: the held-out '
                    'suite (never used for choosing).', flag_values=FLAGS)
flags.DEFINE_string('ship', None, 'report: also write the best-validated '
                    'seed\'s policy here.', flag_values=FLAGS)



def report(base_dir: str, seeds: List[int], max_oor_pct: float,
           max_minutes: Optional[float], max_iteration: Optional[int],
           results_dir: str, ship: Optional[str], parallel: int = 1,
           held_out_suite: str = 'latex_small',
           gin_files: Sequence[str] = ()) -> int:
  """Chooses, evaluates and tabulates each seed; returns the exit status."""
  # pylint: disable=g-import-not-at-top
  from ble_latex.run import episode_log
  from ble_latex.run import records
  # pylint: enable=g-import-not-at-top
  chosen_rows = []
  for seed in seeds:
    run = os.path.join(base_dir, f'seed_{seed}')
    validation = records.load_validation(
        os.path.join(run, episode_log.VALIDATION_LOG))
    chosen = selection.choose_snapshot(validation, max_oor_pct, max_minutes,
                                       max_iteration)
    if chosen is None:
      print(f'seed {seed}: no validated snapshot with <= {max_oor_pct} % out '
            f'of resources within {max_minutes} training minutes and round '
            f'{max_iteration}', file=sys.stderr)
      return 1
    policy_path = seed_runs.write_chosen_policy(run, seed, chosen, validation,
                                                max_oor_pct)
    output = os.path.join(results_dir, held_out_suite,
                          f'sac_jax_{os.path.basename(base_dir)}_seed_{seed}'
                          '.json')
    chosen_rows.append((seed, chosen, policy_path, output))
  # Each held-out eval is independent: `parallel` processes (spawned, so no
  # JAX state is forked) fly them at once.
  with futures.ProcessPoolExecutor(
      max_workers=parallel,
      mp_context=multiprocessing.get_context('spawn')) as pool:
    held_outs = list(pool.map(seed_runs.fly_held_out,
                              [held_out_suite] * len(chosen_rows),
                              [c[2] for c in chosen_rows],
                              [c[3] for c in chosen_rows],
                              [tuple(gin_files)] * len(chosen_rows)))
  rows = []
  for (seed, chosen, policy_path, output), held_out in zip(chosen_rows,
                                                           held_outs):
    rows.append({
        'seed': seed, 'iteration': chosen['iteration'],
        'training_episodes': chosen['training_episodes'],
        'updates': chosen['updates'],
        'training_minutes': chosen['elapsed_s'] / 60.0,
        'validation_tw50_window': chosen['tw50_window_mean'],
        'validation_out_of_resources_pct': chosen['out_of_resources_pct'],
        'held_out_tw50_window': held_out['tw50_window_mean'],
        'held_out_tw50': held_out['tw50_mean'],
        'held_out_out_of_resources_pct': held_out['out_of_resources_pct'],
        'held_out_episodes': held_out['episodes'],
        'held_out_file': output, 'policy': policy_path})
  window = [r['held_out_tw50_window'] for r in rows]
  oor = [r['held_out_out_of_resources_pct'] for r in rows]
  summary = {
      'seeds': seeds, 'max_oor_pct': max_oor_pct, 'max_minutes': max_minutes,
      'max_iteration': max_iteration,
      'held_out_tw50_window_mean': statistics.mean(window),
      'held_out_tw50_window_std': (statistics.stdev(window) if len(window) > 1
                                   else 0.0),
      'held_out_out_of_resources_pct_mean': statistics.mean(oor),
      'held_out_out_of_resources_pct_max': max(oor),
      'held_out_suite': held_out_suite, 'rows': rows}
  lines = [
      f'Held-out `{held_out_suite}` ({rows[0]["held_out_episodes"]} seeds), '
      'each seed\'s policy chosen on `latex_validation` only'
      + (f', among snapshots within {max_minutes:g} training minutes'
         if max_minutes else '')
      + (f', among snapshots of rounds 0..{max_iteration}'
         if max_iteration is not None else '') + '.', '',
      '| seed | chosen round | episodes | updates | training time [min] | '
      'validation TW50 window | held-out TW50 window | held-out TW50 flown | '
      'held-out out of resources |', '|---|---|---|---|---|---|---|---|---|']
  for r in rows:
    lines.append(
        f'| {r["seed"]} | {r["iteration"]} | {r["training_episodes"]} | '
        f'{r["updates"]} | {r["training_minutes"]:.1f} | '
        f'{100 * r["validation_tw50_window"]:.1f} % | '
        f'{100 * r["held_out_tw50_window"]:.1f} % | '
        f'{100 * r["held_out_tw50"]:.1f} % | '
        f'{r["held_out_out_of_resources_pct"]:.0f} % |')
  lines += ['', f'Mean ± std over {len(rows)} seeds: held-out TW50 window '
            f'{100 * summary["held_out_tw50_window_mean"]:.1f} % ± '
            f'{100 * summary["held_out_tw50_window_std"]:.1f}; out of '
            f'resources {summary["held_out_out_of_resources_pct_mean"]:.1f} % '
            f'(worst seed {summary["held_out_out_of_resources_pct_max"]:.0f} '
            '%).']
  if ship:
    best = max(rows, key=lambda r: r['validation_tw50_window'])
    shutil.copyfile(best['policy'], ship)
    summary['shipped_seed'] = best['seed']
    lines.append(f'Shipped: seed {best["seed"]} (best validation TW50 '
                 f'window, {100 * best["validation_tw50_window"]:.1f} %) to '
                 f'`{ship}`.')
  text = '\n'.join(lines) + '\n'
  print(text)
  safe_io.atomic_write(os.path.join(base_dir, 'report.md'), text)
  safe_io.atomic_write(os.path.join(base_dir, 'report.json'),
                       json.dumps(summary, indent=1))
  return 0


def _main(argv: Sequence[str]) -> int:
  if len(argv) != 2 or argv[1] not in ('train', 'report', 'compare'):
    raise cli.CommandUsageError('give one command: train, report or compare')
  args = FLAGS
  try:
    seeds = [int(s) for s in args.seeds]
  except ValueError as e:
    raise cli.CommandUsageError(
        f'--seeds takes integers, got {",".join(args.seeds)!r}') from e
  if argv[1] == 'compare':
    if not args.run_dirs:
      raise cli.CommandUsageError('compare needs --run_dirs')
    rows = seed_runs.validation_rows(args.run_dirs, args.max_oor_pct,
                                     args.max_iteration, args.max_minutes)
    print(seed_runs.comparison_table(rows))
    if args.json:
      safe_io.atomic_write(args.json, json.dumps(rows, indent=1) + '\n')
    return 0
  if not args.base_dir:
    raise cli.CommandUsageError(f'{argv[1]} needs --base_dir')
  if argv[1] == 'train':
    seed_runs.train_seeds(args.base_dir, seeds, args.num_iterations,
                          args.snapshot_period, args.checkpoint_period,
                          args.gin_bindings, args.parallel, args.vmap_seeds,
                          args.gin_file)
    return 0
  return report(args.base_dir, seeds, args.max_oor_pct, args.max_minutes,
                args.max_iteration, args.results_dir, args.ship,
                args.parallel, args.held_out_suite, args.gin_file)


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/sac_seeds.py', FLAGS, argv,
                      doc=__doc__, positional=True)


if __name__ == '__main__':
  sys.exit(main())
