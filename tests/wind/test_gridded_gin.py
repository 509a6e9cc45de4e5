# coding=utf-8
"""ERA5 from one gin binding / flag in every env and command; the date split.

Issue 27 items 2 and 5: `latex_episode.wind_field_factory = @GriddedWindField`
(gin_configs/paper_era5.gin, or `--era5_path`) makes `env_params.params_from_gin`
hold the file's grid (`EnvParams.wind_grid`, read once by `gridded.load`), and
every env flies it in JAX; `env_params.check_params` refuses bad grids; flights
start inside disjoint date ranges (`gridded.DATE_SPLITS`) for training,
validation and evaluation. No network: a synthetic file spanning the paper's
period (`test_gridded.write_era5`, random winds).
"""

import datetime as dt
import importlib
import json
import os
import pathlib
import subprocess
import sys
import textwrap
import warnings

import ble_latex  # noqa: F401  pylint: disable=unused-import
import gin
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex import configs
from ble_latex import errors
from ble_latex import gin_aliases
from ble_latex.ble import gridded_field
from ble_latex.envs import env_params
from ble_latex.envs import jax_env
from ble_latex.envs import winds
from ble_latex.run import gin_binding
from ble_latex.run import suites
from ble_latex.run import wind_file
from ble_latex.wind import gridded
from ble_latex.wind import gridded_jax
from tests.wind import test_gridded
from tests import helpers

REPO = str(helpers.ROOT)
_ENV = dict(os.environ, TF_CPP_MIN_LOG_LEVEL='3', JAX_PLATFORMS='cpu')
# 1 Nov 2022 00:00 - 31 Jan 2023 18:00, 6-hourly: the paper's period.
_TIMES = test_gridded.T0 + np.arange(368) * np.timedelta64(6, 'h')


@pytest.fixture(name='era5_path', scope='module')
def fixture_era5_path(tmp_path_factory):
  """The paper's period on a small area (+-4 deg), random winds."""
  folder = tmp_path_factory.mktemp('era5_gin')
  path = test_gridded.write_era5(
      folder / 'linear.nc', times=_TIMES, lat=np.arange(5.0, -3.01, -1.0),
      lon=np.arange(-117.0, -108.99, 1.0),
      levels_hpa=np.array([20.0, 50.0, 70.0, 100.0, 125.0, 150.0, 175.0]))
  rng = np.random.default_rng(11)

  def random_winds(dataset):
    for name in ('u', 'v'):
      dataset[name].values = rng.normal(0.0, 8.0, dataset[name].shape)

  return test_gridded.rewrite(path, folder / 'era5.nc', random_winds)


@pytest.fixture(name='gin_era5')
def fixture_gin_era5(era5_path):
  """gin_configs/paper_era5.gin with the synthetic file (cleared after)."""
  gin.clear_config()
  gin_binding.bind_gin(None, None, [configs.gin_file('paper_era5.gin')],
                       [f"GriddedWindField.path = '{era5_path}'"])
  yield era5_path
  gin.clear_config()


# -- The date split. ----------------------------------------------------------
def _range(name):
  return gridded.start_dates_range(name)


def test_date_splits_are_disjoint_a_flight_apart():
  names = ['train', 'validation', 'eval']
  assert sorted(gridded.DATE_SPLITS) == sorted(names)
  ranges = [_range(n) for n in names]
  paper = (dt.datetime(2022, 11, 1, tzinfo=dt.timezone.utc),
           dt.datetime(2023, 2, 1, tzinfo=dt.timezone.utc))
  for (first, end), (next_first, _) in zip(ranges, ranges[1:]):
    # The last start's 3-day flight ends before the next split's first start.
    assert end - dt.timedelta(minutes=1) + dt.timedelta(hours=72) <= next_first
  for first, end in ranges:
    assert paper[0] <= first < end <= paper[1]
  assert suites.TRAIN_DATES == 'train'
  assert suites.era5_dates('latex_validation') == 'validation'
  for suite in (*suites.SUITE_SIZES, 'big_eval'):
    assert suites.era5_dates(suite) == 'eval'


def test_drawn_starts_fall_inside_their_dates(era5_path):
  data = gridded.load(era5_path)
  grid = gridded_jax.grid_from_data(data)
  draw = jax.jit(jax.vmap(gridded_jax.draw_start_minute, in_axes=(None, 0)))
  keys = jax.random.split(jax.random.PRNGKey(0), 500)
  starts = {}
  for name in gridded.DATE_SPLITS:
    split = gridded_jax.with_start_dates(
        grid, data, start_dates=name, center_lat=1.0, center_lon=-113.0,
        episode_hours=72.0)
    assert split.uv is grid.uv  # The winds are shared, not copied.
    minutes = np.asarray(draw(split, keys))
    first, end = _range(name)
    when = [data.start + dt.timedelta(minutes=int(m)) for m in minutes]
    assert all(first <= w < end for w in when), name
    assert all(w + dt.timedelta(hours=72) <= data.end for w in when)
    # Spread over the range, not stuck at one edge.
    assert max(when) - min(when) > 0.8 * (min(end, data.end) - first -
                                          dt.timedelta(hours=72 if
                                                       name == 'eval' else 0))
    starts[name] = set(when)
    # GriddedWindField (BLE's path) draws the same starts.
    field = gridded_field.GriddedWindField(path=era5_path, start_dates=name)
    for key, minute in list(zip(keys, minutes))[:5]:
      field.reset_forecast(key, dt.datetime(2012, 1, 1))
      assert field.start_date_time == data.start + dt.timedelta(
          minutes=int(minute))
  assert not starts['train'] & starts['eval']
  assert not starts['train'] & starts['validation']
  assert not starts['validation'] & starts['eval']


@pytest.mark.parametrize('dates, message', [
    ('test', "not a split"),
    (('2022-12-01', '2022-11-01'), 'must come before'),
    (('2022-11-01', 'soon'), 'not an ISO date'),
    (('2022-11-01',), 'pair of dates'),
    (('2021-01-01', '2021-02-01'), 'no flight of 72 h can start'),
])
def test_bad_start_dates_are_one_line(era5_path, dates, message):
  with pytest.raises(errors.ConfigError, match=message) as raised:
    gridded_field.GriddedWindField(path=era5_path, start_dates=dates)
  # One line (gin appends its call note; commands print `gin_binding.one_line`).
  assert message.split('|')[0] in gin_binding.one_line(raised.value)
  assert gin_binding.one_line(raised.value).startswith('GriddedWindField.start_dates = ')


# -- check_params: the grid. -------------------------------------------------
@pytest.fixture(name='params', scope='module')
def fixture_params(era5_path):
  params = env_params.params_from_gin()
  grid = gridded_jax.grid_from_data(gridded.load(era5_path))
  return params.replace(wind_grid=grid)


def test_check_params_takes_a_good_grid(params):
  assert env_params.check_params(params).wind_grid is params.wind_grid


@pytest.mark.parametrize('edit, message', [
    (lambda g: g.replace(uv=g.uv[:, :, :-1]), r'uv has shape .*expected'),
    (lambda g: g.replace(uv=g.uv.at[3, 2, 1, 1, 0].set(jnp.nan)),
     'uv holds non-finite'),
    (lambda g: g.replace(uv=g.uv.at[0, 0, 0, 0, 1].set(500.0)),
     'above 200 m/s'),
    (lambda g: g.replace(time_s=g.time_s + 60.0), 'time_s must start at 0'),
    (lambda g: g.replace(time_s=g.time_s[::-1]), 'time_s must start at 0|'
     'strictly ascending'),
    (lambda g: g.replace(pressure_pa=g.pressure_pa.at[2].set(jnp.inf)),
     'pressure_pa holds non-finite'),
    (lambda g: g.replace(latitude=g.latitude[:1]), 'latitude must be 1-D'),
    (lambda g: g.replace(first_start_minute=g.last_start_minute + 1),
     'start minutes'),
    (lambda g: g.replace(last_start_minute=jnp.int32(10**7)),
     'start minutes'),
    (lambda g: g.replace(center_lon=jnp.float32(jnp.nan)),
     'center_lon must be a finite scalar'),
    (lambda g: 'era5.nc', 'must be a gridded_jax.Era5Grid'),
])
def test_check_params_refuses_a_bad_grid_in_one_line(params, edit, message):
  with pytest.raises(errors.ConfigError, match=message) as raised:
    env_params.check_params(params.replace(wind_grid=edit(params.wind_grid)))
  assert '\n' not in str(raised.value)
  assert 'EnvParams.wind_grid' in str(raised.value)


# -- One gin binding. ---------------------------------------------------------
def test_paper_gin_puts_the_grid_in_the_params(gin_era5):
  params = env_params.params_from_gin()
  grid = params.wind_grid
  assert grid is not None
  assert env_params.params_from_gin().wind_grid is grid  # Read once, shared.
  data = gridded.load(gin_era5)
  np.testing.assert_array_equal(np.asarray(grid.uv),
                                np.float32(data.uv))
  assert (int(grid.first_start_minute), int(grid.last_start_minute)) == (
      gridded.start_window(data, center_lat=1.0, center_lon=-113.0,
                           episode_hours=72.0))
  with gin.unlock_config():
    gin.bind_parameter('GriddedWindField.start_dates', 'train')
  train = env_params.params_from_gin().wind_grid
  assert train.uv is grid.uv  # Another start range, the same winds.
  assert int(train.first_start_minute) == 0
  last = data.start + dt.timedelta(minutes=int(train.last_start_minute))
  assert last < _range('train')[1]


def test_the_grid_reaches_the_functional_env_as_plain_settings(era5_path):
  """paper_era5.gin flies the functional env with nothing of BLE's objects.

  gin's `GriddedWindField` is the reader's plain settings (`gridded.settings`):
  `env_params.params_from_gin` reads the file into the grid without importing
  BLE's `WindField`s (`ble_latex.ble.gridded_field`, `ble_latex.ble.wind`,
  BLE's `wind_field`), BLE's gym env or TensorFlow (a fresh process; gin's
  finalize hook, which declares the gym env's configurables, is BLE's
  path and is not run).
  """
  code = textwrap.dedent(f"""
      import sys
      import gin
      from ble_latex import configs
      from ble_latex.envs import env_params
      from ble_latex.wind import gridded
      from ble_latex.wind import gridded_jax
      gin.parse_config_files_and_bindings(
          [configs.gin_file('paper_era5.gin')],
          ["GriddedWindField.path = {era5_path!r}"], finalize_config=False)
      assert env_params.episode()['wind_field_factory'] is gridded.settings
      grid = env_params.params_from_gin().wind_grid
      assert grid is gridded_jax.grid_from_settings(gridded.Era5Settings(
          path={era5_path!r}))
      print(sorted(m for m in sys.modules if m.startswith((
          'ble_latex.ble.gridded_field', 'ble_latex.ble.wind',
          'ble_latex.ble.arena', 'ble_latex.ble.gym_env',
          'balloon_learning_environment.env.wind_field', 'tensorflow'))))
      """)
  out = subprocess.run([sys.executable, '-c', code], capture_output=True,
                       text=True, check=False, timeout=300)
  assert out.returncode == 0, out.stderr[-3000:]
  assert out.stdout.strip().splitlines()[-1] == '[]'


def test_era5_factory_without_a_path_is_one_line():
  gin.clear_config()
  try:
    gin_binding.bind_gin(None, None, [], [
        'import ble_latex.wind.gridded',
        'latex_episode.wind_field_factory = @GriddedWindField'])
    with pytest.raises(errors.ConfigError, match='GriddedWindField.path'):
      env_params.params_from_gin()
  finally:
    gin.clear_config()


def test_flags_bind_the_path_and_the_commands_dates(era5_path):
  gin.clear_config()
  try:
    gin_binding.bind_gin(None, None, [], [])
    assert wind_file.era5_bindings(None, None, 'train') == []  # No ERA5: none.
    with pytest.raises(errors.UsageError, match='--era5_dates needs'):
      wind_file.era5_bindings(None, 'eval', 'train')
    bindings = wind_file.era5_bindings(era5_path, None, 'train')
    assert bindings == [
        'latex_episode.wind_field_factory = @GriddedWindField',
        f'GriddedWindField.path = {era5_path!r}',
        "GriddedWindField.start_dates = 'train'"]
    assert wind_file.era5_bindings(era5_path, '2022-11-03,2022-11-09', 'x')[-1] == (
        "GriddedWindField.start_dates = ('2022-11-03', '2022-11-09')")
    assert wind_file.era5_bindings(era5_path, 'all', 'x')[-1] == (
        'GriddedWindField.start_dates = None')
    with pytest.raises(errors.UsageError, match='--era5_dates'):
      wind_file.era5_bindings(era5_path, 'later', 'train')
    # A range the user's gin chose stays.
    gin_binding.bind_gin(None, None, [configs.gin_file('paper_era5.gin')],
                         ["GriddedWindField.start_dates = 'validation'"])
    assert wind_file.era5_bindings(None, None, 'eval') == []
  finally:
    gin.clear_config()


# -- Every env flies ERA5 from the binding. ----------------------------------
_SEEDS = (3, 4)
_ACTIONS = np.array([[18_000.0, 1.0, -1.0], [15_500.0, 1.0, 1.0],
                     [19_000.0, 2.0, -1.0]], np.float32)


@pytest.mark.slow
def test_every_env_flies_era5_from_the_gin_binding(gin_era5):
  import gym  # pylint: disable=g-import-not-at-top
  import gymnasium  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import gymnasium_vector  # pylint: disable=g-import-not-at-top
  params = env_params.params_from_gin()
  assert params.wind_grid is not None
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  keys = jnp.stack([jax.random.PRNGKey(s) for s in _SEEDS])
  # The functional env, from gin: positions after each stride.
  obs0, state = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(keys, params)
  step = jax.jit(jax.vmap(env.step_env, in_axes=(0, 0, 0, None)))
  where, observations = [], [np.asarray(obs0)]
  for action in _ACTIONS:
    obs, state, _, _, _ = step(keys, state, jnp.broadcast_to(
        action, (len(_SEEDS), 3)), params)
    observations.append(np.asarray(obs))
    where.append(np.stack([state.flight.x_m, state.flight.y_m], -1))
  where, observations = np.stack(where, 1), np.stack(observations, 1)
  # On VAE winds the same seeds measure other winds: ERA5 is what is flown.
  reset = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))
  era5_wind = np.asarray(reset(keys, params)[1].wind_u)
  vae_wind = np.asarray(reset(keys, params.replace(wind_grid=None))[1].wind_u)
  assert np.all(np.abs(era5_wind - vae_wind) > 1e-3)
  data = gridded.load(gin_era5)

  # gymnasium.make, single balloon.
  single = gymnasium.make('ble_latex/LatexBalloon-v0', normalize_actions=False)
  assert single.unwrapped.params.wind_grid is params.wind_grid
  assert single.unwrapped._wind_field is None  # pylint: disable=protected-access  # No callbacks.
  for i, seed in enumerate(_SEEDS):
    obs, _ = single.reset(seed=seed)
    np.testing.assert_allclose(obs, observations[i, 0], atol=1e-4)
    start = single.unwrapped.start_date_time
    assert data.start <= start <= data.end - dt.timedelta(hours=72)
    for t, action in enumerate(_ACTIONS):
      obs = single.step(action)[0]
      np.testing.assert_allclose(obs, observations[i, t + 1], atol=1e-4)
      flight = single.unwrapped.flight
      np.testing.assert_allclose([flight['x_m'], flight['y_m']],
                                 where[i, t], atol=1.0)
  single.close()

  # gymnasium.make_vec: N balloons in one call.
  envs = gymnasium.make_vec('ble_latex/LatexBalloon-v0',
                            num_envs=len(_SEEDS), normalize_actions=False)
  assert envs.unwrapped.params.wind_grid is params.wind_grid
  obs, _ = envs.reset(seed=_SEEDS[0])
  np.testing.assert_allclose(obs, observations[:, 0], atol=1e-4)
  for t, action in enumerate(_ACTIONS):
    obs = envs.step(np.broadcast_to(action, (len(_SEEDS), 3)))[0]
    np.testing.assert_allclose(obs, observations[:, t + 1], atol=1e-4)
  envs.close()
  assert isinstance(envs.unwrapped, gymnasium_vector.LatexBalloonVectorEnv)

  # gym.make('LatexBalloon-v0'): BLE's env over the core.
  ble_env = gym.make('LatexBalloon-v0').unwrapped
  arena = ble_env.arena
  assert arena.params.wind_grid is params.wind_grid
  for i, seed in enumerate(_SEEDS):
    ble_env.reset(seed=seed)
    start = arena.driver.start_date_time
    # BLE's consumers read the ERA5 wind too (the core's field).
    ble_field = arena._wind_field  # pylint: disable=protected-access
    from balloon_learning_environment.utils import units  # pylint: disable=g-import-not-at-top
    truth = ble_field.get_ground_truth(units.Distance(m=0.0),
                                       units.Distance(m=0.0), 9000.0,
                                       dt.timedelta(hours=1))
    reference = gridded_field.GriddedWindField(path=gin_era5)
    reference.reset(jax.random.PRNGKey(0), start)
    reference.set_start_date_time(start)
    forecast = ble_field.get_forecast(units.Distance(m=0.0),
                                      units.Distance(m=0.0), 9000.0,
                                      dt.timedelta(hours=1))
    expected = reference.get_forecast(units.Distance(m=0.0),
                                      units.Distance(m=0.0), 9000.0,
                                      dt.timedelta(hours=1))
    assert forecast.u.meters_per_second == pytest.approx(
        expected.u.meters_per_second, abs=1e-3)
    assert np.isfinite(truth.u.meters_per_second)
    for t, action in enumerate(_ACTIONS):
      ble_env.step(action)
      flight = arena.driver.flight
      np.testing.assert_allclose([flight['x_m'], flight['y_m']],
                                 where[i, t], atol=1.0)


def _tiny_jax_train(base_dir, *extra):
  return [sys.executable, '-m', 'ble_latex.cli.train', '--trainer=jax',
          f'--base_dir={base_dir}', '--num_iterations=1',
          '--policy_snapshot_period=1', '--validation_episodes=2',
          '--collectors=episodes',
          '--gin_bindings=latex_episode.episode_steps = 3',
          '--gin_bindings=sac_trainer_config.num_envs = 2',
          '--gin_bindings=sac_trainer_config.num_layers = 1',
          '--gin_bindings=sac_trainer_config.hidden_units = 16',
          '--gin_bindings=sac_trainer_config.batch_size = 4',
          '--gin_bindings=sac_trainer_config.min_replay_history = 4',
          '--gin_bindings=sac_trainer_config.updates_per_step = 1', *extra]


@pytest.mark.slow
def test_jax_trainer_trains_a_round_on_era5(tmp_path, era5_path):
  run = tmp_path / 'run'
  out = subprocess.run(_tiny_jax_train(run, f'--era5_path={era5_path}'),
                       env=_ENV, capture_output=True, text=True, timeout=600,
                       cwd=REPO)
  assert out.returncode == 0, out.stderr[-3000:]
  config = (run / 'operative_config.gin').read_text()
  assert "GriddedWindField.start_dates = 'train'" in config
  assert era5_path in config
  validation = [json.loads(line) for line in
                (run / 'validation.jsonl').read_text().splitlines()]
  assert len(validation) == 1 and validation[0]['episodes'] == 2
  episodes = (run / 'episodes.jsonl').read_text().splitlines()
  assert len(episodes) == 2
  # A file without the training dates: one line, before any training.
  bad = subprocess.run(
      _tiny_jax_train(tmp_path / 'bad', f'--era5_path={era5_path}',
                      '--era5_dates=2021-01-01,2021-02-01'),
      env=_ENV, capture_output=True, text=True, timeout=600, cwd=REPO)
  assert bad.returncode == 2, bad.stderr[-3000:]
  assert bad.stderr.strip().splitlines()[-1].startswith('ble-latex-train: ')
  assert 'no flight of 72 h can start' in bad.stderr


@pytest.mark.slow
def test_eval_flies_era5_here_and_on_ray(tmp_path, era5_path):
  pytest.importorskip('ray')
  base = [sys.executable, '-m', 'ble_latex.cli.eval',
          '--agent=latex_station_seeker', '--suite=latex_micro',
          '--max_episode_length=3']
  outputs = {}
  for name, extra in (
      ('vae', []), ('era5', [f'--era5_path={era5_path}']),
      ('ray', [f'--era5_path={era5_path}', '--ray_address=local',
               '--ray_num_cpus=2'])):
    result = subprocess.run(base + [f'--output_dir={tmp_path}/{name}', *extra],
                            cwd=REPO, env=_ENV, capture_output=True,
                            text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-3000:]
    outputs[name] = (tmp_path / name / 'latex_micro' /
                     'latex_station_seeker.json').read_bytes()
  assert outputs['era5'] == outputs['ray']
  assert outputs['era5'] != outputs['vae']


# The configurable's old name (issue 66 item 4): an alias for one release.
OLD_AND_NEW = (
    ('Era5WindField', '@Era5WindField'),
    ('ble_latex.wind.era5.Era5WindField',
     '@ble_latex.wind.era5.Era5WindField'),
    ('GriddedWindField', '@GriddedWindField'),
    ('ble_latex.wind.gridded.GriddedWindField',
     '@ble_latex.wind.gridded.GriddedWindField'))


@pytest.mark.parametrize('name, reference', OLD_AND_NEW)
def test_old_and_new_gin_names_configure_the_same_settings(name, reference):
  gin.clear_config()
  try:
    gin.parse_config([f'latex_episode.wind_field_factory = {reference}',
                      f"{name}.path = 'w.nc'",
                      f'{name}.episode_hours = 6.0',
                      f"{name}.stations = 'per_seed'"])
    with warnings.catch_warnings():
      warnings.simplefilter('ignore', FutureWarning)
      factory = env_params.episode()['wind_field_factory']
      settings = gridded.settings()
    assert factory is gridded.settings and winds.is_era5(factory)
    assert settings == gridded.Era5Settings(path='w.nc', episode_hours=6.0,
                                            stations='per_seed')
    assert winds.bound_settings() == {'path': 'w.nc', 'episode_hours': 6.0,
                                      'stations': 'per_seed'}
  finally:
    gin.clear_config()


def test_the_old_name_warns_and_differing_values_are_one_line():
  gin.clear_config()
  try:
    gin.parse_config(["Era5WindField.path = 'w.nc'"])
    with pytest.warns(FutureWarning, match=r'Era5WindField\.\* is deprecated'
                      r'.*bind GriddedWindField\.path'):
      assert gridded.settings().path == 'w.nc'
    gin.parse_config(["GriddedWindField.path = 'v.nc'"])
    with pytest.raises(errors.ConfigError, match='GriddedWindField.path only'):
      gridded.settings()
  finally:
    gin.clear_config()


def test_the_old_module_name_is_the_reader_and_documented():
  with warnings.catch_warnings():
    warnings.simplefilter('ignore', FutureWarning)
    old = importlib.import_module('ble_latex.wind.era5')
  assert old is gridded and old.Era5Settings is gridded.Era5Settings
  gin.clear_config()
  try:  # A gin file of the old spelling still parses.
    gin.parse_config(['import ble_latex.wind.era5',
                      "Era5WindField.path = 'w.nc'"])
  finally:
    gin.clear_config()
  assert gin_aliases.ALIASES['Era5WindField'] == 'GriddedWindField'
  page = (pathlib.Path(configs.__file__).resolve().parent.parent / 'docs' /
          'commands.md').read_text(encoding='utf-8')
  assert '`Era5WindField`' in page and '`GriddedWindField`' in page
