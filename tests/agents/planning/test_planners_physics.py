"""The planners' model of the physics they face (issue 63 item 4).

- The model flight is the env's: the flight's own sun clock and station
  (`plan_objective.model_flight`, `env_types.flight_params_of`).
- The sunset cost-to-go: the sand the sunsets left in the episode need
  (`plan_objective.sunset_sand_kg`), zero under the paper's physics.
- The oracle is a bound under stochastic physics: it flies the env's own
  disturbance draws, so the env flies its plan exactly.
"""

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex.agents.planning import config as plan_config
from ble_latex.agents.planning import objective as plan_objective
from ble_latex.agents.planning import planner as planning
from ble_latex.envs import env_types
from ble_latex.envs import jax_env
from ble_latex.flight import atmosphere as atmosphere_lib
from ble_latex.flight import calibration
from ble_latex.flight import dynamics
from ble_latex.flight import envelope
from ble_latex.flight import launch
from ble_latex.flight import params as params_lib
from ble_latex.flight import physics
from ble_latex.flight import solar
from ble_latex.flight import state as state_lib

REALISTIC = params_lib.realistic_flight_params()
HOUR_S = 3600.0


@functools.lru_cache(maxsize=4)
def _world(noisy: bool, seed: int = 1_000_003):
  """(env, params, one reset state) under realistic physics (its heating
  disturbance on or held)."""
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  flight = REALISTIC if noisy else REALISTIC.noiseless()
  params = env.default_params.replace(flight=flight)
  _, state = jax.jit(env.reset)(jax.random.PRNGKey(seed), params)
  return env, params, state


def _flown(env, params, state, actions):
  """The env's flight over `actions`: [T] distances [km], altitudes [m]."""
  def stride(s, action):
    s = env.step_env(None, s, action, params)[1]
    return s, (jnp.hypot(s.flight.x_m, s.flight.y_m) / 1000.0,
               s.flight.altitude_m)
  return jax.jit(lambda s, a: jax.lax.scan(stride, s, a)[1])(state, actions)


def _actions(state, strides, rise_m=1500.0):
  """Climb `rise_m` above the start, then float."""
  target = state.flight.altitude_m + rise_m
  climb = jnp.stack([target, jnp.float32(2.0), jnp.float32(-1.0)])
  hold = climb.at[2].set(1.0)
  return jnp.stack([climb] * (strides // 2) + [hold] * (strides - strides // 2))


@pytest.mark.slow
def test_model_flight_is_the_flights_own():
  """Under realistic physics the planners fly the flight's sun clock and
  station; with no disturbance the model's flight is the env's."""
  env, params, state = _world(noisy=False)
  flight = plan_objective.model_flight(params, state)
  assert flight == env_types.flight_params_of(params, state).noiseless()
  assert float(flight.start_second_of_day) != float(
      params.flight.start_second_of_day) or float(
          flight.start_day_j2000) != float(params.flight.start_day_j2000)
  actions = _actions(state, 4)
  wind_fn = functools.partial(env.wind_for(params).ground_truth, state)
  model = jax.jit(lambda s, a: plan_objective.fly(params, s, wind_fn,
                                                  s.flight, a)[0].altitude_m)
  distances, altitudes = _flown(env, params, state, actions)
  np.testing.assert_allclose(float(model(state, actions)),
                             float(altitudes[-1]), rtol=0, atol=1e-3)
  # The check can fail: the launch-day clock (what `fly` flew before) is
  # another sun, another gas temperature, another flight.
  old = jax.jit(lambda s, a: jax.lax.scan(
      lambda f, x: (dynamics.step(params.flight.noiseless(), s.atmosphere, f,
                                  x, wind_fn, params.stride_s), None),
      s.flight, a)[0].altitude_m)
  assert abs(float(old(state, actions)) - float(altitudes[-1])) > 1.0


def _neutral_flight(params, altitude_m, time_s):
  """A neutral balloon at rest at the station at `time_s` (alpha 0.5)."""
  atm = atmosphere_lib.params_from_alpha(jnp.float32(0.5))
  f = launch.neutral_launch(params, atm, state_lib.initial_state(
      params, altitude_m, atm_params=atm, key=jax.random.PRNGKey(0)))
  return f.replace(time_s=jnp.asarray(time_s, f.time_s.dtype))


def test_sunset_sand_is_zero_under_the_paper_physics():
  paper = params_lib.paper_flight_params()
  f = _neutral_flight(paper, 17_000.0, 0.0)
  need, per_day = plan_objective.sunset_sand_kg(paper, f, 3 * 86_400.0)
  assert float(need) == 0.0 and float(per_day) == 0.0


def _sunset_s(params):
  """The flight time of the first sunset at the station (elevation 0). # [s]"""
  times = np.arange(0.0, 2 * 86_400.0, 60.0)
  elevation = np.asarray(solar.sun_elevation_deg(
      params.start_day_j2000, params.start_second_of_day, jnp.asarray(times),
      params.latitude_deg, params.longitude_deg))
  return float(times[np.nonzero((elevation[:-1] > 0.0) &
                                (elevation[1:] <= 0.0))[0][0]])


def _at_float(altitude_m, time_s):
  """A neutral balloon at `altitude_m`, its air T and P set (alpha 0.5)."""
  atm = atmosphere_lib.params_from_alpha(jnp.float32(0.5))
  ambient = atmosphere_lib.at_height(atm, jnp.float32(altitude_m))
  return _neutral_flight(REALISTIC, altitude_m, time_s).replace(
      temperature_k=ambient.temperature, pressure_pa=ambient.pressure)


SAND = jax.jit(plan_objective.sunset_sand_kg)


def test_sunset_sand_before_a_sunset():
  """Before a sunset: n M_air dT / T of the sun's whole swing dT on the
  helium; none over a span without a sunset; one more per day."""
  t_set = _sunset_s(REALISTIC)
  f = _at_float(17_000.0, t_set - 3 * HOUR_S)
  need, per_day = SAND(REALISTIC, f, t_set + 2 * HOUR_S)
  swing = REALISTIC.superheat_day_k + REALISTIC.cooling_night_k  # [K]
  expected = float(f.helium_mols * physics.AIR_MOLAR_MASS * swing /
                   f.temperature_k)
  assert 0.1 < expected < 1.0
  np.testing.assert_allclose(float(need), expected, rtol=0.02)
  np.testing.assert_allclose(float(per_day), expected, rtol=0.02)
  # After the night has set in, until before the next sunset: no sunset.
  late = f.replace(time_s=f.time_s + 6 * HOUR_S)
  assert float(SAND(REALISTIC, late, t_set + 18 * HOUR_S)[0]) < 1e-3
  # Three more days: three more sunsets.
  three = SAND(REALISTIC, f, t_set + 2 * HOUR_S + 3 * 86_400.0)[0]
  np.testing.assert_allclose(float(three), 4 * float(need), rtol=0.01)


@pytest.mark.slow
def test_sunset_sand_is_the_envelopes_sunset_loss():
  """The lift a sunset takes from a neutral balloon, from the envelope's
  lagged gas temperature over ValBal's window (`calibration.sunset_loss_kg`)."""
  table = calibration.sunset_loss_kg(REALISTIC, 17_000.0)
  t_set = table['sunset_h_after_start'] * HOUR_S
  f = _at_float(17_000.0, t_set - 3 * HOUR_S)
  assert table['loss_kg'] > 0.1
  np.testing.assert_allclose(float(SAND(REALISTIC, f, t_set + 2 * HOUR_S)[0]),
                             table['loss_kg'], rtol=0.05)


def test_the_sunsets_reserve_prices_the_sand():
  """Under realistic physics the sand the episode's sunsets need raises the
  price of sand (and a plan leaving less than that pays for it); without a
  sunset (no swing) the terms are as they were."""
  f0 = _at_float(17_000.0, _sunset_s(REALISTIC) - 3 * HOUR_S)
  # The parts of an env state the resource terms read (the world is unused).
  state = env_types.EnvState(
      flight=f0, atmosphere=None, forecast=None, noise_u=None, noise_v=None,
      initial=None, history=None, wind_u=0.0, wind_v=0.0,
      start_time_offset_s=jnp.int32(0), steps=jnp.int32(100),
      pending_world=jnp.int32(-1))
  config = plan_config.PlannerConfig(horizon=4, num_segments=2,
                                     grid_levels=2, num_samples=8).checked()
  f_end = f0.replace(sand_dropped_kg=f0.sand_dropped_kg + 0.1,
                     time_s=f0.time_s + 4 * 1200.0)
  d, ok = jnp.float32(100.0), jnp.bool_(False)

  @jax.jit
  def cost(flight, f_end):
    params = env_types.EnvParams(flight=flight, decoder=None)
    return plan_objective.end_terms(config, params, state, f_end, d, ok)[1]

  unlit = REALISTIC.replace(superheat_day_k=0.0, cooling_night_k=0.0)
  sun = float(cost(REALISTIC, f_end))
  assert sun > float(cost(unlit, f_end)) > 0.0
  # A flight with less sand than its sunsets need pays pro rata of a day's.
  poor = f_end.replace(sand_kg=jnp.asarray(REALISTIC.min_drop_kg + 0.05,
                                           f_end.sand_kg.dtype))
  assert float(cost(REALISTIC, poor)) > sun + 1.0
  assert float(cost(unlit, poor)) < sun


def test_night_margin_is_the_out_of_helium_condition():
  """`night_margin_kg` is L + m_s of the gas as it is, the margin the env
  ends a flight on (`envelope.free_lift_kg`): a gas warmer than the air by
  dT adds n M_air dT / T to it, a cooler one takes it away; the paper's
  ledger (`resource_margins`) counts neither."""
  margin = jax.jit(plan_objective.night_margin_kg)
  f = _at_float(17_000.0, _sunset_s(REALISTIC) + 4 * HOUR_S)
  t = f.temperature_k
  lift = lambda f: float(envelope.free_lift_kg(REALISTIC, f, envelope.of_state(
      REALISTIC, f, f.temperature_k, f.pressure_pa, f.time_s)))
  paper = float(plan_objective.resource_margins(
      env_types.EnvParams(flight=REALISTIC, decoder=None), f)[1])
  for d_k in (-3.0, 0.0, 4.0):
    g = f.replace(gas_temperature_k=t + d_k)
    assert float(margin(REALISTIC, g)) == pytest.approx(
        max(lift(g) + float(g.sand_kg), 0.0), abs=1e-6)
    expected = paper + float(f.helium_mols * physics.AIR_MOLAR_MASS * d_k / t)
    assert float(margin(REALISTIC, g)) == pytest.approx(expected, rel=0.02)
  # Out of helium by night: no margin, never a negative one.
  cold = f.replace(gas_temperature_k=t - 20.0, sand_kg=f.sand_kg * 0.0 + 0.1)
  assert float(margin(REALISTIC, cold)) == 0.0


def test_the_sunsets_reserve_keeps_helium():
  """With `helium_reserve` a plan that ends with less ventable lift than
  the later sunsets take pays for it (pro rata of a day's sunset); with
  enough, or with the reserve off, it pays nothing more; a
  `resource_buffer_kg` adds to what both reserves keep."""
  f0 = _at_float(17_000.0, _sunset_s(REALISTIC) - 3 * HOUR_S)
  state = env_types.EnvState(
      flight=f0, atmosphere=None, forecast=None, noise_u=None, noise_v=None,
      initial=None, history=None, wind_u=0.0, wind_v=0.0,
      start_time_offset_s=jnp.int32(0), steps=jnp.int32(100),
      pending_world=jnp.int32(-1))
  d, ok = jnp.float32(100.0), jnp.bool_(False)
  params = env_types.EnvParams(flight=REALISTIC, decoder=None)

  def cost(reserve, f_end, buffer_kg=0.0):
    config = plan_config.PlannerConfig(
        horizon=4, num_segments=2, grid_levels=2, num_samples=8,
        helium_reserve=reserve, resource_buffer_kg=buffer_kg).checked()
    return float(jax.jit(lambda f: plan_objective.end_terms(
        config, params, state, f, d, ok)[1])(f_end))

  f_end = f0.replace(time_s=f0.time_s + 4 * 1200.0)
  need = float(plan_objective.sunset_sand_kg(REALISTIC.noiseless(), f_end,
                                             f0.time_s + 116 * 1200.0)[0])
  assert need > 0.1
  # Vented down to half the sunsets' need: heavy by night, out of helium.
  margin = float(plan_objective.night_margin_kg(REALISTIC, f_end))
  vent_mols = (margin - 0.5 * need) / physics.LIFT_PER_MOL
  vented = f_end.replace(
      helium_mols=f_end.helium_mols - vent_mols,
      settled_lift_kg=f_end.settled_lift_kg - vent_mols * physics.LIFT_PER_MOL,
      helium_vented_mols=f_end.helium_vented_mols + vent_mols)
  assert cost(1.0, vented) > cost(0.0, vented) + 1.0
  # Kept: the reserve costs little more than its pricing.
  assert cost(1.0, f_end) < cost(0.0, f_end) + 0.1
  # A buffer beyond the ventable lift and the sand left costs a shortfall.
  left_kg = min(float(plan_objective.night_margin_kg(REALISTIC, f_end)),
                float(plan_objective.resource_margins(params, f_end)[0]))
  assert cost(1.0, f_end, left_kg - need + 0.2) > cost(1.0, f_end) + 1.0
  assert cost(1.0, f_end, 0.01) < cost(1.0, f_end) + 0.1


@pytest.mark.slow
def test_oracle_is_a_bound_under_stochastic_physics():
  """The oracle flies the env's own disturbance draws: under realistic
  physics with its heating disturbance on, the env flies the oracle's plan
  exactly, stride by stride (its model is the env); a forecast model (the
  disturbance held) does not."""
  env, params, state = _world(noisy=True)
  assert params.flight.stochastic
  config = plan_config.PlannerConfig(
      mode=plan_config.ORACLE, search=plan_config.BEAM, horizon=6,
      num_segments=3, replan_every=6, beam_width=2, grid_levels=2,
      num_samples=8, iterations=1).checked()
  batch = jax.tree.map(lambda a: a[None], state)
  plan = jax.device_get(planning.plan_batch(
      config, params, batch, jnp.int32(0),
      planning.initial_plans(config, batch), env.wind_for(params)))
  actions = plan_objective.plan_actions(config, jnp.asarray(plan.targets_m[0]),
                                        jnp.asarray(plan.floats[0]))
  wind_fn = plan_objective.planning_wind(config, env.wind_for(params), state)

  def planned(exact):
    return jax.jit(lambda s, a: plan_objective.fly(
        params, s, wind_fn, s.flight, a, exact=exact)[0].altitude_m)(
            state, actions)

  _, altitudes = _flown(env, params, state, actions)
  np.testing.assert_allclose(float(planned(True)), float(altitudes[-1]),
                             rtol=0, atol=1e-3)
  # The check can fail: the disturbance held is another flight.
  assert abs(float(planned(False)) - float(altitudes[-1])) > 0.5
