# coding=utf-8
r"""`ble-latex-validate`: the paper's Fig. "impact of venting and ballasting".

Flies the latex balloon through a fixed sequence of float / vent / ballast
commands at 20-minute intervals (no wind), plots altitude, desired vs
simulated ascent rate, helium and sand over time to
`<output_dir>/latex_validation.png`, and prints the max ascent-rate error
(at the end of the strides that vented or ballasted) and the integrator's
error against a fine-step RK4 reference (dt = 0.05 s) of Eq. fullN2L
(`ble_latex.flight.reference`).

Usage:
  ble-latex-validate --output_dir /tmp/val
  python -m ble_latex.cli.validate --output_dir /tmp/val \
      --gin_bindings 'LatexBalloon.valve_flow_mols_per_s = 0.1'

Exit status 0 when the max ascent-rate error is below --max_error_percent.
"""

import os
import sys
from typing import Any, Dict, Optional, Sequence

from absl import flags

from ble_latex import configs
from ble_latex import quiet
from ble_latex.cli import common as cli

with quiet.third_party_noise():
  # pylint: disable=g-import-not-at-top
  import numpy as np

  from ble_latex.flight import reference
  # pylint: enable=g-import-not-at-top

OUTPUT_FILENAME = 'latex_validation.png'


def plot(result: Dict[str, Any], path: str) -> None:
  """Writes the four-panel figure (altitude, ascent rate, helium, sand)."""
  import matplotlib  # pylint: disable=g-import-not-at-top
  matplotlib.use('Agg')
  import matplotlib.pyplot as plt  # pylint: disable=g-import-not-at-top

  stride_h = result['stride_s'] / 3600.0
  t = result['times_h']
  fig, axes = plt.subplots(4, 1, figsize=(10, 11), sharex=True)
  ax_h, ax_v, ax_n, ax_s = axes
  ax_h.plot(t, result['altitude'] / 1000.0, color='C0', label='altitude')
  ax_v.plot(t, result['ascent_rate'], color='C0', label='simulated')
  desired_t, desired_v = [], []
  colors = {'vent': 'C3', 'ballast': 'C2', 'float': 'C7', 'nothing': 'w'}
  for i, r in enumerate(result['strides']):
    start, end = i * stride_h, (i + 1) * stride_h
    for ax in axes:
      ax.axvspan(start, end, color=colors[r['decision']], alpha=0.12, lw=0)
    ax_h.text(start + 0.5 * stride_h, 1.0, r['decision'], rotation=90,
              ha='center', va='top', fontsize=7,
              transform=ax_h.get_xaxis_transform())
    if r['decision'] in ('vent', 'ballast'):
      # a0 is due a1 strides after the command.
      ax_h.plot([start + r['command'][1] * stride_h],
                [r['command'][0] / 1000.0], 'x', color='C1')
    desired_t += [start, end]
    desired_v += [r['desired_rate'], r['desired_rate']]
  ax_h.plot([], [], 'x', color='C1', label='a0 at a1 strides after the command')
  ax_v.plot(desired_t, desired_v, '--', color='C1', label='desired')
  ax_n.plot(t, result['helium'], color='C4')
  ax_s.plot(t, result['sand'], color='C5')
  ax_h.set_ylabel('altitude [km]')
  ax_v.set_ylabel('ascent rate [m/s]')
  ax_n.set_ylabel('helium [mol]')
  ax_s.set_ylabel('sand [kg]')
  ax_s.set_xlabel('time [h]')
  ax_h.legend(loc='lower right', fontsize=8)
  ax_v.legend(loc='lower right', fontsize=8)
  ax_h.set_title('Latex balloon: venting and ballasting at 20-min intervals '
                 f'(max ascent-rate error {100 * result["max_rate_error"]:.2f}'
                 '%)')
  for ax in axes:
    ax.grid(alpha=0.3)
  fig.tight_layout()
  fig.savefig(path, dpi=120)
  plt.close(fig)


# The command's own flags (`cli.run_absl`).
FLAGS = flags.FlagValues()
flags.DEFINE_string('output_dir', 'validation_output',
                    f'Folder for {OUTPUT_FILENAME}.', flag_values=FLAGS)
flags.DEFINE_integer('seed', 0, "Seed of BLE's atmosphere.", flag_values=FLAGS)
flags.DEFINE_float('max_error_percent', 5.0,
                   'Exit status 1 above this ascent-rate error.',
                   flag_values=FLAGS)
flags.DEFINE_multi_string('gin_file', [],
                          'Gin files (e.g. gin_configs/latex_physics.gin).',
                          flag_values=FLAGS)
flags.DEFINE_alias('gin_files', 'gin_file', flag_values=FLAGS)  # ble_latex 0.1.
flags.DEFINE_multi_string('gin_bindings', [],
                          "Gin bindings, e.g. 'create_state.sand_kg = 3.0'.",
                          flag_values=FLAGS)
flags.DEFINE_boolean('no_reference', False,
                     'Skip the RK4 reference comparison.', flag_values=FLAGS)


def _check() -> None:
  cli.check_gin_files(FLAGS.gin_file)


def _main(argv: Sequence[str]) -> int:
  """Flies the command sequence, writes the figure; 1 above the error bound."""
  args = FLAGS
  if args.gin_file or args.gin_bindings:
    configs.bind_gin(None, None, args.gin_file, args.gin_bindings,
                     env_defaults=False)
  cli.prepare_output_dir(args.output_dir, '--output_dir')
  result = reference.run_validation(seed=args.seed,
                                    reference=not args.no_reference)
  path = os.path.join(args.output_dir, OUTPUT_FILENAME)
  plot(result, path)

  print(f'{"stride":>6} {"command (a0, a1, a2)":>24} {"decision":>9} '
        f'{"h0 [m]":>9} {"h1 [m]":>9} {"desired":>8} {"simulated":>9} '
        f'{"error":>7}')
  for i, r in enumerate(result['strides']):
    a0, a1, a2 = r['command']
    error = (f'{100 * r["rate_error"]:6.2f}%' if 'rate_error' in r else
             f'{"-":>7}')
    print(f'{i:>6} {f"({a0:.0f}, {a1:g}, {a2:g})":>24} {r["decision"]:>9} '
          f'{r["start_altitude_m"]:9.1f} {r["end_altitude_m"]:9.1f} '
          f'{r["desired_rate"]:8.3f} {r["end_rate"]:9.3f} {error}')
  if not args.no_reference:
    if np.isnan(result['max_rk4_altitude_error_m']):
      print('integrator vs RK4 reference: skipped (finite actuation rates or '
            'in-stride guard)')
    else:
      print('integrator vs RK4 reference (dt=0.05 s), per 20-min stride: max '
            f'altitude error {result["max_rk4_altitude_error_m"]:.3f} m, max '
            f'ascent-rate error {100 * result["max_rk4_rate_error"]:.3f}%')
  print(f'wrote {path}')
  print(f'max ascent-rate error: {100 * result["max_rate_error"]:.2f}%')
  return 0 if 100 * result['max_rate_error'] < args.max_error_percent else 1


def main(argv: Optional[Sequence[str]] = None) -> int:
  """The command (`cli.run_absl`); returns the exit status."""
  return cli.run_absl(_main, 'ble-latex-validate', FLAGS, argv, doc=__doc__,
                      check=_check)


if __name__ == '__main__':
  sys.exit(main())
