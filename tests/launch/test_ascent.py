"""A launch from the ground (issue 65 item 2, `ble_latex.launch.ascent`).

In a uniform wind the ascent's drift is the wind times its time, its time
the integral of the references' steady ascent rate (the realistic mode that
matches ASTRA), its burst the references' burst altitude, its descent
CUSF's; in the launch planner the ascent leg is the realistic ascent flown
stride by stride in the same winds, and the float phase starts where it
ends."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex.flight import atmosphere
from ble_latex.flight import dynamics
from ble_latex.flight import params as params_lib
from ble_latex.flight import physics
from ble_latex.flight import reference
from ble_latex.flight import state as state_lib
from ble_latex.launch import ascent as ascent_lib

GFS = 'tests/data/realwinds/gfs_2010-10-26T12Z_uv_10-300hPa_1deg_subset.nc'
U, V = 10.0, -3.0  # [m/s]


@pytest.fixture(scope='module', name='calm')
def _calm():
  params = ascent_lib.ascent_flight_params(params_lib.make_flight_params())
  atm = atmosphere.params_from_alpha(jnp.float32(0.5))
  config = ascent_lib.Ascent()
  helium = ascent_lib.launch_helium_mols(params, atm, 5.0,
                                         config.launch_altitude_m)

  def wind(x, y, p, t):
    del y, p, t
    return jnp.full_like(x, U), jnp.full_like(x, V)

  fly = jax.jit(lambda altitude, key: ascent_lib.fly(
      params, atm, wind, x_m=jnp.float32(0.0), y_m=jnp.float32(0.0),
      time_s=jnp.float32(3600.0), float_altitude_m=altitude,
      helium_mols=helium, burst_key=key, ascent=config))
  return params, atm, config, helium, fly


def _integral(rate, low, high, n=4000):
  """The time to cross [low, high] at `rate(h)`, trapezoids. # [s]"""
  h = np.linspace(low, high, n)
  return float(np.trapezoid(1.0 / rate(h), h))


def test_fill_gives_the_asked_ascent_rate(calm):
  params, atm, config, helium, _ = calm
  with jax.enable_x64(True):
    rate = reference.steady_ascent_rate(
        params, atm, jnp.float64(helium), params.payload_kg,
        params.initial_sand_kg, jnp.float64(config.launch_altitude_m))
  assert float(rate) == pytest.approx(5.0, abs=1e-6)
  with pytest.raises(ValueError, match='ascent_rate_mps must be a finite '
                     'number > 0'):
    ascent_lib.Ascent(ascent_rate_mps=0.0)


def test_ascent_to_float_drifts_with_the_wind(calm):
  params, atm, config, helium, fly = calm
  for altitude in (10_000.0, 17_500.0):
    leg = ascent_lib.leg_to_host(fly(jnp.float32(altitude),
                                     jax.random.PRNGKey(0)))
    assert leg['floats'] and not leg['bursts']
    climb_s = float(leg['float_time_s']) - 3600.0
    assert float(leg['float_x_m']) == pytest.approx(U * climb_s, rel=1e-4)
    assert float(leg['float_y_m']) == pytest.approx(V * climb_s, rel=1e-4)
  # Below the drag crisis (at ~16-17.3 km two steady rates hold for this
  # balloon: the flight keeps the fast one, the references' bisection finds
  # the slow one), the time is the references' steady rate (ASTRA's within
  # 0.3 %) integrated: 0..10 km.
  leg = ascent_lib.leg_to_host(fly(jnp.float32(10_000.0),
                                   jax.random.PRNGKey(0)))
  with jax.enable_x64(True):
    steady = jax.jit(jax.vmap(lambda h: reference.steady_ascent_rate(
        params, atm, jnp.float64(helium), params.payload_kg,
        params.initial_sand_kg, h)))
    expected = _integral(lambda h: np.asarray(steady(jnp.asarray(h))),
                         config.launch_altitude_m, 10_000.0)
  assert float(leg['float_time_s']) - 3600.0 == pytest.approx(expected,
                                                              rel=0.005)


def test_burst_and_landing(calm):
  params, atm, config, helium, fly = calm
  key = jax.random.PRNGKey(7)
  leg = ascent_lib.leg_to_host(fly(jnp.float32(np.inf), key))
  assert leg['bursts'] and not leg['floats']
  volume = state_lib.initial_state(params, 1.0, atm_params=atm,
                                   key=key).burst_volume_m3
  with jax.enable_x64(True):
    expected = reference.burst_altitude_m(params, atm, jnp.float64(helium),
                                          jnp.float64(volume))
  # Found at the end of a 10 s vertical step: ~60 m above at most.
  assert float(leg['burst_altitude_m']) - float(expected) == pytest.approx(
      30.0, abs=60.0)
  burst_s = float(leg['burst_time_s'])
  assert float(leg['burst_x_m']) == pytest.approx(U * (burst_s - 3600.0),
                                                  rel=1e-4)
  # CUSF's descent, v0 sqrt(rho0 / rho), integrated from the burst.
  sea = float(atmosphere.at_height(atm, 0.0).density)

  def rate(h):
    rho = np.asarray(atmosphere.at_height(atm, jnp.asarray(h)).density)
    return config.descent_rate_mps * np.sqrt(sea / rho)

  fall_s = float(leg['land_time_s']) - burst_s
  assert fall_s == pytest.approx(
      _integral(rate, 0.0, float(leg['burst_altitude_m'])), rel=0.02)
  assert float(leg['land_x_m']) == pytest.approx(
      U * (float(leg['land_time_s']) - 3600.0), rel=1e-4)
  assert float(leg['land_y_m']) == pytest.approx(
      V * (float(leg['land_time_s']) - 3600.0), rel=1e-4)


@pytest.mark.slow
def test_plan_ascent_leg_is_the_realistic_ascent(tmp_path):
  """The planner's ascent leg, flown stride by stride by hand in the same
  winds; the scored float phase is a launch afloat where it ends."""
  from ble_latex.agents import baselines  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import env_types  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import jax_env  # pylint: disable=g-import-not-at-top
  from ble_latex.launch import controllers  # pylint: disable=g-import-not-at-top
  from ble_latex.launch import scoring  # pylint: disable=g-import-not-at-top
  world = scoring.era5_world(GFS, center_lat=40.0, center_lon=-100.0,
                             max_hours=0.0, steps=3)
  config = ascent_lib.Ascent()
  launches = scoring.Launches.from_array(
      np.array([[-100.0, 50.0, 0.0, 17_500.0], [0.0, 0.0, 0.0, 45_000.0]],
               np.float32))
  legs = scoring.ascent_legs(world, launches, config)
  assert legs['floats'].tolist() == [True, False]
  assert legs['bursts'].tolist() == [False, True]
  # By hand: dynamics.step in the world's truth with draw 0's noise.
  noise_u, noise_v = scoring.noise_draws(world, 1)
  noise_u, noise_v = jax.tree.map(lambda a: a[0], (noise_u, noise_v))
  state = scoring.launch_state(world.params, world.state, noise_u, noise_v,
                               *launches.array()[0])
  wind = world.env.wind_for(world.params)
  params = ascent_lib.ascent_flight_params(
      env_types.flight_params_of(world.params, state))
  flight = state_lib.initial_state(
      params, 1.0, -100_000.0, 50_000.0, atm_params=world.state.atmosphere,
      helium_mols=scoring.launch_helium(world, config),
      key=jax.random.fold_in(jax.random.PRNGKey(0),
                             world.state.start_time_offset_s))
  step = jax.jit(lambda f: dynamics.step(
      params, world.state.atmosphere, f, jnp.asarray(
          ascent_lib.controller_lib.ACTION_LOW),
      lambda x, y, p, t: wind.ground_truth(state, x, y, p, t),
      config.step_s, decide_fn=ascent_lib._idle))  # pylint: disable=protected-access
  while True:
    before, flight = flight, step(flight)
    if float(flight.altitude_m) >= 17_500.0:
      break
  frac = (17_500.0 - float(before.altitude_m)) / float(
      flight.altitude_m - before.altitude_m)
  for name, field in (('float_x_m', 'x_m'), ('float_y_m', 'y_m'),
                      ('float_time_s', 'time_s')):
    a, b = float(getattr(before, field)), float(getattr(flight, field))
    assert float(legs[name][0]) == pytest.approx(a + frac * (b - a),
                                                 abs=0.5), name
  # The planner scores the float phase from there: a launch afloat at the
  # float point and time scores the same in every draw.
  agent = baselines.GeometricStationSeeker(
      3, (71,), action_low=jax_env.ACTION_LOW,
      action_high=jax_env.ACTION_HIGH)
  controller = controllers.controller_for(agent)
  from_ground = scoring.score(world, controller, launches.take([0]), draws=2,
                              ascent=config)
  afloat = scoring.score(world, controller, scoring.Launches.from_array(
      np.array([[legs['float_x_m'][0] / 1000.0, legs['float_y_m'][0] / 1000.0,
                 legs['float_time_s'][0] / 3600.0, 17_500.0]], np.float32)),
                         draws=2)
  np.testing.assert_allclose(from_ground.tw50, afloat.tw50, atol=1e-6)
  # The command: the ranked launches carry their way up, in lat/lon and UTC.
  from ble_latex.cli import launch as launch_command  # pylint: disable=g-import-not-at-top
  out = tmp_path / 'out'
  assert launch_command.main([
      f'--output_dir={out}', f'--wind_file={GFS}', '--station_lat=40',
      '--station_lon=-100', '--east_km=-100,-100', '--north_km=50,50',
      '--hours=0,0', '--grid=1,1,1', '--draws=1', '--max_steps=3',
      '--paths=1', '--from_ground']) == 0
  best = json.loads((out / 'launches.json').read_text())['ranked'][0]
  assert best['ascent']['floats']
  assert best['ascent']['float_utc'].startswith('2010-10-26T12:')
  assert best['ascent']['ascent_drift_km'] == pytest.approx(
      np.hypot(legs['float_x_m'][0] + 100_000.0,
               legs['float_y_m'][0] - 50_000.0) / 1000.0, rel=1e-4)


@pytest.mark.parametrize('args, match', [
    (['--ascent_rate_mps=4'], '--ascent_rate_mps needs --from_ground'),
    (['--descent_rate_mps=4'], '--descent_rate_mps needs --from_ground'),
    (['--from_ground', '--ascent_rate_mps=-1'],
     '--from_ground: ascent ascent_rate_mps must be a finite number > 0 in '
     'float32 (>= 1.2e-38), got -1.0'),
])
def test_command_ascent_flags_are_one_line(tmp_path, capsys, args, match):
  from ble_latex.cli import launch as launch_command  # pylint: disable=g-import-not-at-top
  status = launch_command.main([f'--output_dir={tmp_path}', '--grid=2,2,1',
                                '--max_steps=2', *args])
  err = capsys.readouterr().err.strip().splitlines()
  assert status == 2 and len(err) == 1, err
  assert err[0] == f'ble-latex-launch: {match}'


@pytest.mark.slow  # Imports the launch planner (~15 s on 2 busy cores).
def test_launch_map_draws_the_way_up():
  from ble_latex.launch import launch_map  # pylint: disable=g-import-not-at-top
  from ble_latex.launch import scoring  # pylint: disable=g-import-not-at-top
  launches = scoring.Launches.from_array(np.array(
      [[e, n, 0.0, 17_500.0] for n in (-50.0, 50.0) for e in (-50.0, 50.0)],
      np.float32))
  scores = scoring.Scores(launches, np.array([[0.1, 0.4, 0.2, 0.0]]), 3)
  base = {'hours': 0.0, 'tw50_mean': 0.4}
  best = [{**base, 'rank': 1, 'east_km': 50.0, 'north_km': -50.0,
           'ascent': {'floats': True, 'float_east_km': 180.0,
                      'float_north_km': -60.0, 'ascent_min': 51.0}},
          {**base, 'rank': 2, 'east_km': -50.0, 'north_km': 50.0,
           'ascent': {'floats': False, 'landing_east_km': -20.0,
                      'landing_north_km': 260.0}}]
  paths = np.array([[[50.0, -50.0], [190.0, -55.0], [200.0, -50.0],
                     [210.0, -40.0]], [[-50.0, 50.0]] * 4])
  fig = launch_map.launch_map(scores, (2, 2, 1), 50.0, best, paths,
                              title='t', delay_panel=False)
  ax = fig.axes[0]
  assert ax.get_xlim()[1] > 210.0 and ax.get_ylim()[1] > 260.0
  labels = ax.get_legend_handles_labels()[1]
  assert '1: reaches float (51 min)' in labels and '2: bursts, lands' in labels
