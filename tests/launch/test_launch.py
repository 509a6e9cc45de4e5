"""Launch planning (issue 46, `ble_latex.launch`): candidates flown batched
score by TW50 over K noise draws, are ranked by it, a launch at the world's
own start flies the env's own flight, the searches count their budget and
regret, and the command writes its table and map; bad input is one line."""

import json

import jax
import numpy as np
import pytest

from ble_latex import errors
from ble_latex.agents import baselines
from ble_latex.envs import env_params
from ble_latex.envs import jax_env
from ble_latex.launch import controllers
from ble_latex.launch import scoring
from ble_latex.launch import search

# Launch grids fly the batched core (~90 s loaded): make test-slow.
pytestmark = pytest.mark.slow

SEED = 3
STEPS = 8  # Strides per flight: short flights, one compile per shape.
DRAWS = 2
CHUNK = 9  # Every score call here flies 9 candidates x 2 draws.


def _seeker():
  return baselines.GeometricStationSeeker(
      3, (71,), action_low=jax_env.ACTION_LOW,
      action_high=jax_env.ACTION_HIGH)


@pytest.fixture(scope='module')
def setup():
  agent = _seeker()
  world = scoring.generative_world(SEED, steps=STEPS)
  space = scoring.SearchSpace(east_km=(-60.0, 60.0), north_km=(-60.0, 60.0),
                              hours=(0.0, 6.0)).checked(world.params)
  return agent, controllers.controller_for(agent), world, space


def test_grid_is_dense_and_indexed(setup):
  _, _, _, space = setup
  launches = scoring.grid(space, 3, 3, 2)
  assert len(launches) == 18
  # Index ((a * n_hours + t) * n_north + j) * n_east + k.
  assert launches.east_km[:3].tolist() == [-60.0, 0.0, 60.0]
  assert launches.north_km[3] == 0.0 and launches.hours[9] == 6.0
  assert set(launches.altitude_m) == {17_500.0}  # The start band's middle.


def test_tiny_grid_flies_and_ranks_by_score(setup):
  _, controller, world, space = setup
  launches = scoring.grid(space, 3, 3, 1)
  done = []
  scores = scoring.score(world, controller, launches, draws=DRAWS,
                         chunk=CHUNK, progress=done.append)
  assert done == [9]
  assert scores.tw50.shape == (DRAWS, 9)
  # TW50 is a count of strides over the window.
  counts = scores.tw50 * STEPS
  np.testing.assert_allclose(counts, np.round(counts), atol=1e-6)
  np.testing.assert_allclose(scores.std, scores.tw50.std(axis=0, ddof=1))
  np.testing.assert_allclose(scores.stderr, scores.std / np.sqrt(DRAWS))
  table = scoring.ranked(scores, world)
  means = [r['tw50_mean'] for r in table]
  assert means == sorted(means, reverse=True)
  assert table[0]['tw50_mean'] == scores.mean.max()
  assert sorted(r['index'] for r in table) == list(range(9))
  centre = next(r for r in table if r['distance_km'] == 0.0)
  assert centre['inside_radius']
  # The station's own launch is within 50 km at once: its first strides count.
  assert centre['tw50_mean'] > 0
  # K draws differ: the noise of draw 1 is not draw 0's.
  u0 = jax.tree.leaves(scoring.noise_draws(world, 2)[0])
  assert any(np.any(np.asarray(a)[0] != np.asarray(a)[1]) for a in u0)


def test_own_start_flies_the_env_flight(setup):
  """Draw 0 of a launch at the world's own start is `reset(key)`'s flight
  flown by the agent itself, one balloon, on the host."""
  agent, controller, world, space = setup
  params = world.params
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  obs, state = jax.jit(env.reset)(jax.random.PRNGKey(SEED), params)
  f = state.flight
  own = [float(f.x_m) / 1000.0, float(f.y_m) / 1000.0, 0.0,
         float(f.altitude_m)]
  others = scoring.grid(space, 2, 2, 2).array()
  launches = scoring.Launches.from_array(np.vstack([own, others]))
  scores = scoring.score(world, controller, launches, draws=DRAWS,
                         chunk=CHUNK)
  step = jax.jit(env.step_env)
  within, path = 0, []
  action = agent.begin_episode(np.asarray(obs))
  for _ in range(STEPS):
    obs, state, _, _, info = step(None, state, action, params)
    within += float(info['distance_km']) <= params.radius_km
    path.append([float(state.flight.x_m) / 1e3, float(state.flight.y_m) / 1e3])
    action = agent.step(0.0, np.asarray(obs))
  assert scores.tw50[0, 0] == within / STEPS
  paths = scoring.flight_paths(world, controller, launches.take([0]))
  assert paths.shape == (1, 1, STEPS + 1, 2)
  np.testing.assert_allclose(paths[0, 0, 0], own[:2])
  np.testing.assert_allclose(paths[0, 0, 1:], path, atol=0.005)


def test_seeker_controller_acts_as_the_agent(setup):
  agent, controller, world, _ = setup
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  keys = jax.random.split(jax.random.PRNGKey(7), 6)
  obs, states = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(
      keys, world.params)
  for o, altitude in zip(np.asarray(obs), np.asarray(states.flight.altitude_m)):
    expected = agent.begin_episode(o)
    action, target = jax.jit(controller.act)(controller.init(o, None), o,
                                             None, 0)
    np.testing.assert_allclose(action, expected, rtol=1e-5, atol=1e-3)
    # Held target: the next stride keeps the chosen level.
    again, _ = jax.jit(controller.act)(target, o, None, 1)
    np.testing.assert_allclose(again, agent.step(0.0, o), rtol=1e-5,
                               atol=1e-3)
    del altitude


@pytest.mark.parametrize('space, match', [
    (scoring.SearchSpace(east_km=(10.0, -10.0)), 'east_km: low 10 > high -10'),
    (scoring.SearchSpace(hours=(-1.0, 5.0)), 'hours must be >= 0'),
    (scoring.SearchSpace(north_km=(0.0, float('nan'))), 'north_km high'),
    (scoring.SearchSpace(altitude_m=(15_000.0, 90_000.0)), 'altitude_m'),
])
def test_bad_search_space_is_one_line(setup, space, match):
  _, _, world, _ = setup
  with pytest.raises(errors.ConfigError, match=match) as info:
    space.checked(world.params)
  assert '\n' not in str(info.value)


def test_bad_arguments_are_one_line(setup):
  _, controller, world, space = setup
  launches = scoring.grid(space, 3, 3, 1)
  for call, match in (
      (lambda: scoring.score(world, controller, launches, draws=0),
       'noise draws'),
      (lambda: scoring.score(world, controller, launches.take([])),
       'at least one candidate'),
      (lambda: scoring.grid(space, 0, 3, 1), 'grid points'),
      (lambda: scoring.generative_world(-1), 'world seed'),
      (lambda: controllers.controller_for(baselines.LatexRandomAgent(
          3, (71,), action_low=jax_env.ACTION_LOW,
          action_high=jax_env.ACTION_HIGH)), 'no JAX controller')):
    with pytest.raises(errors.ConfigError, match=match) as info:
      call()
    assert '\n' not in str(info.value)


# --- The search methods, on a synthetic scored grid (nothing flies). ------


def _table(shape=(7, 5, 3)):
  space = scoring.SearchSpace(east_km=(-30.0, 30.0), north_km=(-20.0, 20.0),
                              hours=(0.0, 4.0)).checked(
                                  env_params.params_from_gin())
  launches = scoring.grid(space, *shape)
  # A smooth bump off the station, peaked at (10 km, -10 km, 2 h).
  value = np.exp(-((launches.east_km - 10.0)**2 + (launches.north_km + 10.0)
                   **2) / 400.0 - (launches.hours - 2.0)**2 / 4.0)
  scores = scoring.Scores(launches, np.stack([value, value]), STEPS)
  return search.GridTable.from_scores(space, shape, scores), launches


def test_grid_table_indexes_as_the_grid():
  table, launches = _table()
  assert table.active == [0, 1, 2]
  for i in (0, 5, 34, len(launches) - 1):
    assert table.index(table.unit(i)) == i
  best = int(np.argmax(table.score))
  assert (launches.east_km[best], launches.north_km[best],
          launches.hours[best]) == (10.0, -10.0, 2.0)
  with pytest.raises(errors.ConfigError, match='not the grid'):
    search.GridTable.from_scores(
        scoring.SearchSpace().checked(env_params.params_from_gin()), (7, 5, 3),
        scoring.Scores(launches, np.zeros((1, len(launches))), STEPS))


def test_regret_falls_to_zero_and_methods_keep_budget():
  table, _ = _table()
  budgets = [1, 5, 20]
  regret = search.compare(table, budgets, seeds=[0, 1])
  assert set(regret) == {'grid', 'random', 'bayes'}
  for curves in regret.values():
    for curve in curves:
      assert all(r >= 0 for r in curve)
      assert curve == sorted(curve, reverse=True)
  # The grid in any order, and BO (which never proposes a node twice while
  # one is left), find the optimum once they have seen every node.
  small, _ = _table((5, 3, 2))
  n = len(small.score)
  for method in ('grid', 'bayes'):
    everything = search.PROPOSERS[method](small, n, 0)
    assert sorted(everything) == list(range(n)), method
    assert search.regret_curve(small, everything, [n]) == [0.0]
  proposals = search.bayes_proposals(table, 8, seed=3)
  assert len(proposals) == 8
  assert ((0 <= proposals) & (proposals < len(table.score))).all()
  np.testing.assert_array_equal(proposals,
                                search.bayes_proposals(table, 8, seed=3))


def test_search_bad_arguments_are_one_line():
  table, _ = _table()
  for call, match in (
      (lambda: search.random_proposals(table, 0, 0), 'budget'),
      (lambda: search.compare(table, [3], [0], methods=['pso']),
       "unknown search method 'pso'")):
    with pytest.raises(errors.ConfigError, match=match) as info:
      call()
    assert '\n' not in str(info.value)


# --- The command. ---------------------------------------------------------


def test_command_writes_table_and_map(tmp_path, setup):
  from ble_latex.cli import launch as launch_command
  out = tmp_path / 'out'
  status = launch_command.main([
      f'--output_dir={out}', f'--seed={SEED}', '--east_km=-60,60',
      '--north_km=-60,60', '--hours=0,6', '--grid=3,3,1', f'--draws={DRAWS}',
      f'--max_steps={STEPS}', '--top=5', '--paths=1'])
  assert status == 0
  record = json.loads((out / 'launches.json').read_text())
  assert record['grid'] == [3, 3, 1] and record['draws'] == DRAWS
  assert len(record['ranked']) == 5 and len(record['grid_tw50_mean']) == 9
  means = [r['tw50_mean'] for r in record['ranked']]
  assert means == sorted(means, reverse=True)
  assert record['timing']['balloon_strides'] == 9 * DRAWS * STEPS
  # The library's scores of the same grid (the same world and agent).
  _, controller, world, space = setup
  scores = scoring.score(world, controller, scoring.grid(space, 3, 3, 1),
                         draws=DRAWS, chunk=CHUNK)
  np.testing.assert_allclose(record['grid_tw50_mean'], scores.mean, atol=1e-5)
  png = (out / 'launch_map.png').read_bytes()
  assert png[:8] == b'\x89PNG\r\n\x1a\n' and len(png) > 10_000


@pytest.mark.parametrize('args, match', [
    (['--grid=3,3'], '--grid must be 3 or 4 positive integers'),
    (['--east_km=5'], '--east_km must be two numbers'),
    (['--hours=0,x'], '--hours must be two numbers'),
    (['--station_lat=1'], 'need --wind_file'),
    (['--wind_file=x.nc', '--station_lat=1'], 'go together'),
    (['--draws=0'], '--draws must be >= 1'),
    (['--agent=nope'], "unknown agent 'nope'"),
    (['--east_km=5,-5'], 'east_km: low 5 > high -5'),
])
def test_command_usage_errors_are_one_line(tmp_path, capsys, args, match):
  from ble_latex.cli import launch as launch_command
  status = launch_command.main([f'--output_dir={tmp_path}', '--grid=2,2,1',
                                '--max_steps=2', *args])
  err = capsys.readouterr().err.strip().splitlines()
  assert status == 2, err
  assert len(err) == 1 and err[0].startswith('ble-latex-launch: ')
  assert match in err[0]


def test_command_output_dir_a_file_exits_1(tmp_path, capsys):
  from ble_latex.cli import launch as launch_command
  path = tmp_path / 'file'
  path.write_text('x')
  assert launch_command.main([f'--output_dir={path}']) == 1
  assert 'is a file' in capsys.readouterr().err


def test_era5_world_places_the_station_and_launch_date(tmp_path, setup):
  from tests.wind import test_gridded  # pylint: disable=g-import-not-at-top
  _, controller, _, _ = setup
  times = test_gridded.T0 + np.arange(9) * np.timedelta64(6, 'h')  # 2 days.
  path = test_gridded.write_era5(
      tmp_path / 'era5.nc', times=times, lat=np.arange(6.0, -4.01, -1.0),
      lon=np.arange(-118.0, -107.99, 1.0))
  world = scoring.era5_world(path, center_lat=1.0, center_lon=-113.0,
                             date='2022-11-01T06:00', max_hours=6.0,
                             steps=STEPS)
  assert world.describe['source'] == 'era5'
  # The world starts at the date: 6 h after the file's first time.
  first_s = (np.datetime64('2022-11-01T06:00') -
             np.datetime64('2011-01-01T00:00')) / np.timedelta64(1, 's')
  assert int(world.state.start_time_offset_s) == int(first_s)
  space = scoring.SearchSpace(east_km=(-60.0, 60.0), north_km=(-60.0, 60.0),
                              hours=(0.0, 6.0)).checked(world.params)
  scores = scoring.score(world, controller, scoring.grid(space, 3, 3, 1),
                         draws=DRAWS, chunk=CHUNK)
  table = scoring.ranked(scores, world)
  centre = next(r for r in table if r['distance_km'] == 0.0)
  assert centre['lat'] == pytest.approx(1.0, abs=1e-4)
  assert centre['lon'] == pytest.approx(-113.0, abs=1e-4)
  east = next(r for r in table if r['east_km'] == 60.0 and r['north_km'] == 0)
  assert east['lon'] > -113.0 and east['lat'] == pytest.approx(1.0, abs=0.01)
  # The file must hold the episode after the latest delay.
  with pytest.raises(errors.ConfigError) as info:
    scoring.era5_world(path, center_lat=1.0, center_lon=-113.0,
                       date='2022-11-02T12:00', max_hours=24.0, steps=STEPS)
  assert '\n' not in str(info.value)
  with pytest.raises(errors.ConfigError, match='not an ISO date'):
    scoring.era5_world(path, center_lat=1.0, center_lon=-113.0,
                       date='Tuesday', max_hours=1.0, steps=STEPS)
