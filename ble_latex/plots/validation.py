# coding=utf-8
"""The figures of `ble-latex-validate` (`cli/validate.py`), Fig. 1 of the paper.

- `plot_validation`: altitude, desired vs simulated ascent rate, helium and
  sand under the scripted vent/ballast/float strides
  (`flight.reference.run_validation`);
- `plot_modes`: the paper's and the realistic physics side by side
  (`flight.reference.compare_modes`).

Both draw on their own `Figure` with matplotlib's Agg canvas
(`figures.save_png`): no pyplot state, no process-wide backend.
"""

from typing import Any, Dict

from matplotlib import figure as mpl_figure
import numpy as np

from ble_latex.flight import physics
from ble_latex.flight import reference
from ble_latex.plots import figures


def plot_validation(result: Dict[str, Any], path: str) -> None:
  """Writes the four-panel figure (altitude, ascent rate, helium, sand)."""
  stride_h = result['stride_s'] / 3600.0
  t = result['times_h']
  fig = mpl_figure.Figure(figsize=(10, 11))
  axes = fig.subplots(4, 1, sharex=True)
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
  figures.save_png(fig, path)


def plot_modes(results: Dict[str, Dict[str, Any]], path: str) -> None:
  """Writes the side-by-side figure of `reference.compare_modes`."""
  fig = mpl_figure.Figure(figsize=(12, 9))
  axes = fig.subplots(2, 2)
  (ax_up, ax_man), (ax_day, ax_cost) = axes
  colors = {'paper': 'C0', 'realistic': 'C3'}
  for name, r in results.items():
    c = colors.get(name, 'C2')
    ax_up.plot(r['ascent_mps'], r['altitudes_m'] / 1000.0, color=c,
               label=name)
    m = r['manoeuvre']
    ax_man.plot(m['times_h'], m['altitude'] / 1000.0, color=c, label=name)
    d = r['day']
    ax_day.plot(d['times_h'], d['altitude'] / 1000.0, color=c, label=name)
  astra = [(reference.PUBLISHED[f'ascent_{h:.0f}m'], h / 1000.0)
           for h in reference.ASCENT_ALTITUDES_M]
  ax_up.plot(*zip(*astra), 'kx', label='ASTRA')
  ax_up.set_xlabel('steady ascent rate [m/s]')
  ax_up.set_ylabel('altitude [km]')
  ax_up.set_title('Ascent of the reference system (1.2 kg latex, 1 kg '
                  'payload, 1 kg free lift)', fontsize=9)
  ax_man.set_xlabel('time [h]')
  ax_man.set_ylabel('altitude [km]')
  ax_man.set_title('Scripted vent/ballast manoeuvre (20-min strides)',
                   fontsize=9)
  ax_day.set_xlabel('time [h] (from 2022-11-01 0h UTC at 1 N, 113 W)')
  ax_day.set_ylabel('altitude [km]')
  ax_day.set_title('A day at float at 17 km (float every 20 min)',
                   fontsize=9)
  names = list(results)
  width = 0.8 / max(1, len(names))
  groups = ('manoeuvre\nhelium', 'manoeuvre\nsand', 'day\nhelium',
            'day\nsand')
  for i, name in enumerate(names):
    r = results[name]
    values = [physics.LIFT_PER_MOL * r['manoeuvre']['helium_vented_mols'],
              r['manoeuvre']['sand_dropped_kg'],
              physics.LIFT_PER_MOL * r['day']['helium_vented_mols'],
              r['day']['sand_dropped_kg']]
    ax_cost.bar(np.arange(len(groups)) + i * width, values, width,
                color=colors.get(name, 'C2'), label=name)
  ax_cost.set_xticks(np.arange(len(groups)) + 0.5 * width * (len(names) - 1))
  ax_cost.set_xticklabels(groups, fontsize=8)
  ax_cost.set_ylabel('lift spent [kg] (helium as its lift)')
  ax_cost.set_title('Resources spent', fontsize=9)
  for ax in axes.flat:
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
  fig.tight_layout()
  figures.save_png(fig, path)
