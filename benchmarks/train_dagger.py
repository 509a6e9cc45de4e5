"""DAgger: distil the forecast planner into a policy (issue 47), one seed.

  python benchmarks/train_dagger.py --base_dir=benchmarks/records/dagger/seed_0 \
      --seed=0 --rounds=4 [--gin_bindings='dagger_config.num_balloons = 8']

`ble_latex.run.dagger.train` in a run directory: resumable (run it again
with more --rounds), seeded, refusing a resume with other settings
(`run.json`). Settings are gin's `dagger_config.*` (`DaggerConfig`), the
teacher's its planner's (`LatexMpcAgent.*`), the env's as for every
command. The run directory keeps `summary.json` (per-round validation TW50,
wall times, load), `best_policy.msgpack` (the best student as a SAC policy)
and `checkpoints/` (the newest round only).

Fly the best student:

  ble-latex-eval --agent=sac_pretrained --suite=latex_small \
      --gin_bindings="SACPretrainedAgent.policy_path='RUN/best_policy.msgpack'"
"""

import sys
from typing import Optional, Sequence

from absl import flags

import ble_latex  # pylint: disable=unused-import  # Fixes first.
from ble_latex.cli import common as cli

FLAGS = flags.FlagValues()
flags.DEFINE_string('base_dir', None, 'The run directory.', flag_values=FLAGS)
flags.DEFINE_integer('rounds', 4, 'DAgger rounds in all.', lower_bound=1,
                     flag_values=FLAGS)
flags.DEFINE_integer('seed', 0, 'Training seed (dagger_config.seed).',
                     flag_values=FLAGS)
cli.define_gin_flags(FLAGS, files_help='Gin files.',
                     bindings_help='Gin bindings (dagger_config, the '
                     'teacher, the env).')
flags.mark_flag_as_required('base_dir', flag_values=FLAGS)


def _main(argv: Sequence[str]) -> int:
  del argv
  from ble_latex import quiet  # pylint: disable=g-import-not-at-top
  from ble_latex.run import gin_binding  # pylint: disable=g-import-not-at-top
  with quiet.third_party_noise():
    from ble_latex.run import dagger  # pylint: disable=g-import-not-at-top
  gin_binding.bind_gin(None, None, FLAGS.gin_file, FLAGS.gin_bindings)
  config = dagger.DaggerConfig(seed=FLAGS.seed)
  summary = dagger.train(base_dir=FLAGS.base_dir, num_rounds=FLAGS.rounds,
                         config=config,
                         log=lambda line: print(line, file=sys.stderr))
  curve = [r['validation']['tw50_window_mean'] for r in summary['rounds']]
  print('validation TW50 window per round:',
        ' '.join(f'{100 * x:.1f}' for x in curve))
  return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/train_dagger.py', FLAGS, argv,
                      doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
