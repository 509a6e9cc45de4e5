# coding=utf-8
r"""Exports a SAC checkpoint's policy, or converts a policy file.

  ble-latex-export-policy --checkpoint=RUN/checkpoints/checkpoint_00049.msgpack \
      --output=my_policy.msgpack [--note='...']

The policy (config, network parameters, temperature; ~1 MB) is what
`SACPretrainedAgent.policy_path` loads. `--checkpoint` may also name a policy
file, which is then rewritten (e.g. a legacy `.pkl` policy converted to
msgpack). Legacy pickles are read only with `--trust_legacy_pickle`: unpickling
can run code, so pass it only for files you made (README "Trusted files").
"""

import os
import sys
from typing import Optional, Sequence

from absl import flags

from ble_latex.cli import common as cli

# Imported on first use, after the flags are parsed (`--help` stays fast).
pretrained = cli.lazy_module('ble_latex.agents.sac.pretrained')

# The command's own flags (`cli.run_absl`).
FLAGS = flags.FlagValues()
flags.DEFINE_string('checkpoint', None, 'SAC checkpoint to export '
                    '(checkpoint_NNNNN.msgpack), or a policy file to convert.',
                    flag_values=FLAGS)
flags.DEFINE_string('output', None, 'Policy file to write (.msgpack).',
                    flag_values=FLAGS)
flags.DEFINE_string('note', '', 'Free text recorded in the policy.',
                    flag_values=FLAGS)
flags.DEFINE_bool('trust_legacy_pickle', False,
                  'Read a legacy pickle checkpoint or policy (.pkl). Pickles '
                  'can run code: only for files you made.', flag_values=FLAGS)
flags.mark_flags_as_required(['checkpoint', 'output'], flag_values=FLAGS)


def _main(argv: Sequence[str]) -> None:
  source = FLAGS.checkpoint
  # Refused input (a bad file, an unwritable output) is one line, exit 1
  # (`cli.run_absl`).
  if os.path.basename(source).startswith('checkpoint_'):
    policy = pretrained.export_policy(source, FLAGS.output, FLAGS.note,
                                      FLAGS.trust_legacy_pickle)
  else:
    policy = pretrained.load_policy(source, FLAGS.trust_legacy_pickle)
    if FLAGS.note:
      policy['note'] = FLAGS.note
    pretrained.write_policy(policy, FLAGS.output)
  print(f'wrote {FLAGS.output} ({os.path.getsize(FLAGS.output) / 1e6:.1f} MB) '
        f'from {policy["source"]}, iteration {policy["iteration"]}')


def main(argv: Optional[Sequence[str]] = None) -> int:
  """The command (`cli.run_absl`); returns the exit status."""
  return cli.run_absl(_main, 'ble-latex-export-policy', FLAGS, argv,
                      doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
