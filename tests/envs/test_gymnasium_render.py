"""The single Gymnasium env's rendering (`envs/gymnasium_render.py`)."""

import gymnasium
import numpy as np

from ble_latex.envs import gymnasium_render

from tests.envs import gymnasium_cases as cases


def test_render_keeps_the_station_visible_far_away():
  """A path 3 000 km wide: the 50 km circle gets a zoomed inset."""
  from matplotlib import patches  # pylint: disable=g-import-not-at-top
  near = [(0.0, 10.0, 0.0, 15.0), (1.0, 20.0, 5.0, 15.0)]
  far = near + [(2.0, 1500.0, -900.0, 16.0)]
  fig = gymnasium_render.draw_flight(None, near, 50.0)
  assert len(fig.axes) == 2  # No inset needed.
  fig = gymnasium_render.draw_flight(fig, far, 50.0)
  inset = [a for a in fig.axes[0].child_axes]
  assert len(inset) == 1
  assert inset[0].get_xlim() == (-150.0, 150.0)
  assert any(isinstance(p, patches.Circle) and p.get_radius() == 50.0
             for p in inset[0].patches)
  assert gymnasium_render.figure_rgb(fig).shape == (320, 640, 3)


# -- Rendering. ---------------------------------------------------------------
def test_render_rgb_array_draws_the_flight():
  env = gymnasium.make(cases.ID, render_mode='rgb_array',
                       normalize_actions=False)
  env.reset(seed=4)
  first = env.render()
  assert first.dtype == np.uint8 and first.shape == (320, 640, 3)
  for _ in range(3):
    env.step(np.array([20000.0, 1.0, -1.0]))
  later = env.render()
  assert later.shape == first.shape
  assert np.any(later != first)  # The path and altitude curve grew.
  assert len(env.unwrapped._path) == 4  # pylint: disable=protected-access
  env.close()
