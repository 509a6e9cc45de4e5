"""ble_latex.plots.wind_samples (the wind `--wind_seed` draws) and
ble_latex.run.metrics.format_summary (what ble-latex-plot prints)."""

import types

import numpy as np


def test_wind_samples_grid_queries_each_point_and_summary_is_one_line_each():
  """`plots.wind_samples` (the wind `--wind_seed` draws) and
  `metrics.format_summary` (what ble-latex-plot prints), out of cli/."""
  # pylint: disable=g-import-not-at-top
  import datetime as dt
  from ble_latex.plots import wind_samples
  from ble_latex.run import metrics
  # pylint: enable=g-import-not-at-top
  queries = []

  class Field:

    def get_forecast_column(self, x, y, pressures, elapsed):
      queries.append((x.kilometers, y.kilometers, tuple(pressures), elapsed))
      speed = types.SimpleNamespace
      return [speed(u=speed(meters_per_second=x.kilometers + p),
                    v=speed(meters_per_second=y.kilometers))
              for p in pressures]

  grid = wind_samples.sample_wind_grid(
      Field(), [5000.0, 7000.0], extent_km=10.0, num_points=3,
      elapsed=dt.timedelta(hours=1))
  assert len(queries) == 9 and grid['u_mps'].shape == (2, 3, 3)
  np.testing.assert_allclose(grid['x_km'], [-10.0, 0.0, 10.0])
  assert grid['u_mps'][1, 0, 2] == 10.0 + 7000.0  # [level, y, x]
  assert grid['v_mps'][0, 2, 0] == 10.0
  keys = ('tw50_window', 'tw50', 'reward', 'helium_vented_mols',
          'sand_dropped_kg')
  summary = {'a.json': {'episodes': 2, 'out_of_resources_pct': 50.0,
                        **{f'{k}_{s}': 0.5 for k in keys
                           for s in ('mean', 'std')}}}
  text = metrics.format_summary(summary)
  assert text.startswith('a.json: 2 seeds, TW50 (window) 50.0 +- 50.0%')
  assert text.endswith('out of resources 50%') and '\n' not in text
