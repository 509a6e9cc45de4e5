# coding=utf-8
"""`ble-latex-demo` (`make demo`): what the project can do, in a few minutes.

1. Flies the shipped trained SAC policy (`sac_pretrained`), the shipped
   learned controller (`sac_ensemble`, under its gin file) and a baseline
   (--baseline, default the geometric station seeker) on the held-out seeds
   of --suite (default `latex_tiny`, 10 seeds) of `LatexBalloon-v0`, writing
   `ble-latex-eval` files to OUTPUT_DIR/eval/;
2. draws the paper's figures into OUTPUT_DIR/figures/ with `ble-latex-plot`
   (flight paths of the trained policy, the same seed flown by both in 3D,
   forecast wind fields, training curves and terminal conditions of --run_dir)
   and `ble-latex-validate` (venting and ballasting);
3. prints the agents' summaries (TW50 over the window, TW50 over the flown
   steps, helium, sand, % out of resources).

--run_dir defaults to the training run of the shipped policy
(`benchmarks/records/sac_jax/n32/seed_2`, in a checkout of the repository,
when its episodes.jsonl is there: run logs stay out of git). With
--train_episodes=N the demo first trains SAC (paper settings, learning after
2 episodes) for N episodes into OUTPUT_DIR/sac_run and draws that run's curves
instead: the pipeline end to end (a few episodes are far too few to learn
station-keeping; the shipped policy trained on 2260).
"""

import json
import os
import sys
from typing import Dict, List, Optional, Sequence

from absl import flags

import ble_latex  # pylint: disable=unused-import  # Fixes first.
from ble_latex import agents
from ble_latex import errors
from ble_latex.cli import common as cli
from ble_latex.run import episode_log
from ble_latex.run import gin_binding

# Imported on first use, after the flags are parsed (`--help` stays fast).
plot = cli.lazy_module('ble_latex.cli.plot')
validate = cli.lazy_module('ble_latex.cli.validate')
eval_lib = cli.lazy_module('ble_latex.run.eval_lib')
metrics = cli.lazy_module('ble_latex.run.metrics')
suites = cli.lazy_module('ble_latex.run.suites')
train_lib = cli.lazy_module('ble_latex.run.train_lib')
configs = cli.lazy_module('ble_latex.configs')
ensemble = cli.lazy_module('ble_latex.agents.sac.ensemble')

_SAC = 'ble_latex.agents.sac.SACAgent'
TRAINED = 'sac_pretrained'
LEARNED = 'sac_ensemble'  # Issue 47's controller, under its gin file.
# The shipped policy's training run, in a checkout of the repository.
SHIPPED_RUN = episode_log.RECORDS_DIR / 'sac_jax' / 'n32' / 'seed_2'

# The command's own flags (`cli.run_absl`).
FLAGS = flags.FlagValues()
flags.DEFINE_string('output_dir', 'demo_output',
                    'Folder for eval/, figures/ (and sac_run/).',
                    flag_values=FLAGS)
flags.DEFINE_string('suite', 'latex_tiny', 'Held-out suite the agents fly.',
                    flag_values=FLAGS)
flags.DEFINE_string('baseline', 'latex_station_seeker',
                    'Box agent flown beside the trained policy.',
                    flag_values=FLAGS)
flags.DEFINE_string('run_dir', None,
                    'Training run whose curves are drawn (default: the '
                    f'shipped policy\'s, {SHIPPED_RUN}, when present).',
                    flag_values=FLAGS)
flags.DEFINE_integer('train_episodes', 0,
                     'Train SAC for this many episodes first and draw that '
                     'run (0: no training).', lower_bound=0,
                     flag_values=FLAGS)


def _train(run_dir: str, episodes: int) -> None:
  """A short SAC training run (paper settings, learning after 2 episodes)."""
  gin_bindings = [f'{_SAC}.min_replay_history = 432']
  gin_binding.bind_gin('sac', None, [], gin_bindings)
  train_lib.train(agent_name='sac', env_name='LatexBalloon-v0',
                  base_dir=run_dir, num_iterations=1,
                  episodes_per_iteration=episodes,
                  max_episode_length=suites.EPISODE_STEPS,
                  collectors=['progress', 'episodes', 'tensorboard'])


def _fly(agent: str, seeds: List[int], path: str,
         gin_files: Sequence[str] = ()) -> Dict[str, float]:
  """Flies `agent` on `seeds`, writes its eval file; returns its summary."""
  built, env = eval_lib.build(eval_lib.EvalSpec(agent=agent,
                                                gin_files=tuple(gin_files)))
  results = eval_lib.evaluate(built, env, seeds, suites.EPISODE_STEPS,
                              description=f'eval {agent}')
  eval_lib.write_results(path, results)
  return metrics.summarize(results)


def run(output_dir: str, suite: str, baseline: str, run_dir: Optional[str],
        train_episodes: int) -> Dict[str, Dict[str, float]]:
  """Runs the demo; returns the summaries by agent name.

  Raises:
    RuntimeError: If `ble-latex-plot` or `ble-latex-validate` fails.
  """
  steps = 3 if train_episodes else 2
  if train_episodes:
    run_dir = os.path.join(output_dir, 'sac_run')
    print(f'[1/{steps}] Training SAC for {train_episodes} episodes into '
          f'{run_dir}', flush=True)
    _train(run_dir, train_episodes)
  elif run_dir is None and (SHIPPED_RUN / episode_log.EPISODE_LOG).is_file():
    run_dir = str(SHIPPED_RUN)
  seeds = suites.get_eval_suite(suite).seeds
  eval_dir = os.path.join(output_dir, 'eval')
  figures = os.path.join(output_dir, 'figures')
  print(f'[{steps - 1}/{steps}] Flying {TRAINED}, {LEARNED} and {baseline} '
        f'on {suite} ({len(seeds)} held-out seeds)', flush=True)
  paths, summaries = {}, {}
  learned_gin = [configs.gin_file(ensemble.SHIPPED_GIN_FILE)]
  for name in (TRAINED, LEARNED, baseline):
    paths[name] = eval_lib.output_path(eval_dir, suite, name, 1, 0)
    summaries[name] = _fly(name, list(seeds), paths[name],
                           learned_gin if name == LEARNED else ())

  print(f'[{steps}/{steps}] Figures into {figures}', flush=True)
  argv = [f'--output_dir={figures}', f'--eval_json={paths[TRAINED]}',
          f'--baseline_eval_json={paths[baseline]}',
          f'--wind_seeds={seeds[0]},{seeds[1 % len(seeds)]}', '--wind_grid=15']
  if run_dir is not None:
    argv.append(f'--run_dir={run_dir}')
  else:
    print(f'(no training log at {SHIPPED_RUN}: training figures skipped; '
          'give --run_dir or --train_episodes)', flush=True)
  if plot.main(argv):
    raise RuntimeError('ble-latex-plot failed')
  if validate.main([f'--output_dir={figures}']):
    raise RuntimeError('ble-latex-validate failed')
  print(json.dumps(summaries, indent=1))
  return summaries


def _check() -> None:
  suites.check_suite(FLAGS.suite)
  agents.check_agent(FLAGS.baseline)
  if FLAGS.baseline not in agents.BOX_AGENTS:
    raise cli.CommandUsageError(errors.unknown(
        'Box agent', FLAGS.baseline,
        agents.BOX_AGENTS - {TRAINED, LEARNED, 'sac'}))
  if FLAGS.run_dir is not None and FLAGS.train_episodes:
    raise cli.CommandUsageError('--run_dir and --train_episodes exclude each '
                                'other (the demo draws the run it trains)')


def _main(argv: Sequence[str]) -> int:
  run(FLAGS.output_dir, FLAGS.suite, FLAGS.baseline, FLAGS.run_dir,
      FLAGS.train_episodes)
  return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
  """The command (`cli.run_absl`); returns the exit status."""
  return cli.run_absl(_main, 'ble-latex-demo', FLAGS, argv, doc=__doc__,
                      check=_check)


if __name__ == '__main__':
  sys.exit(main())
