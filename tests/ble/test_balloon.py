# coding=utf-8
"""Tests for ble_latex.ble.balloon (LatexBalloon, its state) and validate."""

import copy
import datetime as dt
import inspect
import math
import types

from balloon_learning_environment.env import balloon_arena
from balloon_learning_environment.env import features as ble_features
from balloon_learning_environment.env import wind_field
from balloon_learning_environment.env.balloon import balloon as ble_balloon
from balloon_learning_environment.env.balloon import control
from balloon_learning_environment.utils import constants
from balloon_learning_environment.utils import units
from hypothesis import given
from hypothesis import settings
from hypothesis import strategies as st
import numpy as np
import pytest
import s2sphere as s2

from ble_latex.ble import balloon as balloon_lib
from ble_latex.flight import controller as core_controller
from ble_latex.flight import params as params_lib
from ble_latex.flight import physics
from ble_latex.flight import state as state_lib

_SETTINGS = settings(max_examples=25, deadline=None)
STRIDE = dt.timedelta(seconds=params_lib.DEFAULTS.stride_s)
Status = balloon_lib.LatexBalloonStatus
Decision = state_lib.DecisionCode
CALM = wind_field.WindVector(units.Velocity(mps=0.0), units.Velocity(mps=0.0))


def _state(atmosphere, altitude_m=17_000.0, **kwargs):
  return balloon_lib.create_state(
      center_latlng=s2.LatLng.from_degrees(1.0, -113.0),
      date_time=dt.datetime(2022, 11, 1, tzinfo=dt.timezone.utc),
      atmosphere=atmosphere, altitude_m=altitude_m, **kwargs)


def _steady_state(atmosphere, altitude_m, rate, sand=2.0, **kwargs):
  """A state moving steadily at `rate` (helium set by the vent equation)."""
  a = atmosphere.at_height(units.Distance(m=altitude_m))
  n = physics.vent_target_mols(params_lib.DEFAULTS.payload_kg, sand, rate,
                               0.25, a.temperature, a.pressure)
  return _state(atmosphere, altitude_m, ascent_rate_mps=rate, sand_kg=sand,
                helium_mols=n, **kwargs)


def _total_mass_accounted(s):
  """Mass aboard plus everything released. # [kg]"""
  return (s.payload_kg + s.sand_kg + s.helium_mols * physics.HELIUM_MOLAR_MASS
          + s.sand_dropped_kg + s.helium_vented_mols *
          physics.HELIUM_MOLAR_MASS)


def test_state_defaults_and_ble_fields(atmosphere):
  s = _state(atmosphere)
  assert isinstance(s, ble_balloon.BalloonState)
  assert s.helium_mols == pytest.approx(
      (s.payload_kg + s.sand_kg) / physics.LIFT_PER_MOL)
  assert s.free_lift_kg == pytest.approx(0.0, abs=1e-12)
  a = atmosphere.at_height(units.Distance(m=17_000.0))
  assert s.pressure == pytest.approx(a.pressure)
  assert s.ambient_temperature == pytest.approx(a.temperature)
  assert s.envelope_volume == pytest.approx(
      physics.volume(s.helium_mols, a.temperature, a.pressure))
  assert s.mols_lift_gas == s.helium_mols
  assert s.envelope_cod == s.drag_coefficient == 0.25
  assert s.payload_mass == s.payload_kg and s.envelope_mass == 0.0
  assert s.latex_status == Status.OK
  assert s.status == ble_balloon.BalloonStatus.OK
  # Enough to float anywhere in 14-21 km without bursting.
  for h in (14_000.0, 21_000.0, 22_000.0):
    amb = atmosphere.at_height(units.Distance(m=h))
    assert physics.volume(s.helium_mols, amb.temperature,
                          amb.pressure) < s.burst_volume_m3


@pytest.mark.parametrize('field,value', [
    ('sand_kg', float('nan')), ('sand_kg', -1.0), ('payload_kg', 0.0),
    ('helium_mols', float('inf')), ('drag_coefficient', -0.1),
    ('burst_volume_m3', 0.0), ('altitude_m', 1e6)])
def test_state_rejects_bad_values(atmosphere, field, value):
  with pytest.raises(ValueError, match=field):
    _state(atmosphere, **{field: value})


class _NoFeatures(ble_features.FeatureConstructor):
  """The cheapest BLE feature constructor: BLE's arena needs one."""

  def __init__(self, unused_wind_field, unused_atmosphere):
    pass

  def observe(self, observation):
    self.observation = observation

  def get_features(self):
    return np.zeros(1, np.float32)

  @property
  def observation_space(self):
    return None


def test_ble_arena_holding_a_latex_balloon_steps_it(atmosphere):
  """BLE's own `BalloonArena.step` steps the Balloon it holds: ours."""
  # BLE's arena without its __init__/reset (which cold-starts BLE's own
  # balloon, ~15 s): the attributes `step` reads, set as reset sets them.
  arena = balloon_arena.BalloonArena.__new__(balloon_arena.BalloonArena)
  s = _state(atmosphere, 17_000.0)
  b = balloon_lib.LatexBalloon(s)
  assert isinstance(b, ble_balloon.Balloon)
  # pylint: disable=protected-access
  arena._balloon = b
  arena._atmosphere = atmosphere
  # Calm (the step compiled for CALM is the other tests' too).
  arena._wind_field = types.SimpleNamespace(get_ground_truth=lambda *_: CALM)
  arena._step_duration = constants.AGENT_TIME_STEP
  # pylint: enable=protected-access
  arena.feature_constructor = _NoFeatures(None, None)
  arena.step(np.array([18_000.0, 1.0, -1.0]))  # BLE's 3-minute step.
  state = arena.get_balloon_state()
  assert state is s
  assert state.time_elapsed == dt.timedelta(minutes=3)
  assert state.last_decision == Decision.BALLAST
  assert state.ascent_rate_mps > 0.0
  assert state.pressure == pytest.approx(
      atmosphere.at_height(units.Distance(m=state.altitude_m)).pressure,
      rel=1e-4)


def test_simulate_step_signature_matches_ble():
  ours = inspect.signature(balloon_lib.LatexBalloon.simulate_step)
  ble = inspect.signature(ble_balloon.Balloon.simulate_step)
  assert list(ours.parameters) == list(ble.parameters)


@pytest.mark.slow
@pytest.mark.ci  # Out of the default suite (<= 8 min); CI runs it.
@_SETTINGS
@given(h=st.floats(14_000.0, 21_000.0), a0=st.floats(14_000.0, 21_000.0),
       a1=st.floats(1.0, 5.0))
def test_steady_ascent_rate_matches_desired(atmosphere, h, a0, a1):
  """After relaxing (8 time constants) the rate is hdot_des within 5%."""
  s = _state(atmosphere, h)
  b = balloon_lib.LatexBalloon(s)
  rate = float(core_controller.desired_ascent_rate(b.params(), h, a0, a1))
  amb = atmosphere.at_height(units.Distance(m=h))
  k = float(physics.drag_factor(s.helium_mols, 0.25, amb.temperature,
                                amb.pressure))
  tau = s.total_mass_kg / (k * max(abs(rate), 1e-3))  # [s]
  b.simulate_step(CALM, atmosphere, [a0, a1, -1.0],
                  dt.timedelta(seconds=math.ceil(8 * tau)))
  if s.last_decision == Decision.NOTHING:
    assert abs(rate) < 0.6  # Only small rates fall under the thresholds.
    return
  assert abs(s.ascent_rate_mps - rate) <= 0.05 * abs(rate)


@pytest.mark.parametrize('h,a0', [(14_200.0, 15_200.0), (17_000.0, 18_000.0),
                                  (20_000.0, 21_000.0), (21_000.0, 20_000.0),
                                  (18_000.0, 17_000.0), (15_000.0, 14_000.0)])
def test_end_of_stride_rate_within_5_percent_for_1km_moves(atmosphere, h, a0):
  s = _state(atmosphere, h)
  b = balloon_lib.LatexBalloon(s)
  b.simulate_step(CALM, atmosphere, [a0, 1.0, -1.0], STRIDE)
  assert s.last_decision in (Decision.VENT, Decision.BALLAST)
  assert abs(s.ascent_rate_mps - s.desired_ascent_rate_mps) <= 0.05 * abs(
      s.desired_ascent_rate_mps)
  assert s.altitude_m == pytest.approx(a0, abs=60.0)


@_SETTINGS
@given(h=st.floats(14_500.0, 20_500.0), a0=st.floats(14_000.0, 21_000.0),
       a1=st.floats(1.0, 5.0))
def test_float_holds_altitude(atmosphere, h, a0, a1):
  s = _state(atmosphere, h)
  b = balloon_lib.LatexBalloon(s)
  b.simulate_step(CALM, atmosphere, [a0, a1, -1.0], STRIDE)
  b.simulate_step(CALM, atmosphere, [a0, a1, 1.0], STRIDE)
  assert s.last_decision == Decision.FLOAT
  assert abs(s.ascent_rate_mps) < 0.05
  # n and m_s are float32 in the core: ~1e-7 kg of lift rounding.
  assert s.free_lift_kg == pytest.approx(0.0, abs=1e-6)
  h_float = s.altitude_m
  b.simulate_step(CALM, atmosphere, [a0, a1, 1.0], STRIDE)
  assert abs(s.ascent_rate_mps) < 0.05
  assert abs(s.altitude_m - h_float) < 60.0


@_SETTINGS
@given(actions=st.lists(
    st.tuples(st.floats(14_000.0, 21_000.0), st.floats(1.0, 5.0),
              st.floats(-1.0, 1.0)), min_size=1, max_size=6),
       sand=st.floats(0.0, 2.0), valve=st.sampled_from([None, 0.05]),
       ballast=st.sampled_from([None, 0.002]))
def test_mass_conserved_and_resources_never_negative(atmosphere, actions, sand,
                                                     valve, ballast):
  s = _state(atmosphere, 17_500.0, sand_kg=sand)
  b = balloon_lib.LatexBalloon(s, valve_flow_mols_per_s=valve,
                               ballast_rate_kg_per_s=ballast)
  total = _total_mass_accounted(s)
  n0, sand0 = s.helium_mols, s.sand_kg
  for action in actions:
    if s.latex_status != Status.OK:
      break
    b.simulate_step(CALM, atmosphere, action, STRIDE)
    # float32 core: mass accounted to float32 rounding of ~90 mol.
    assert _total_mass_accounted(s) == pytest.approx(total, rel=1e-6)
    assert s.sand_kg >= 0.0 and s.helium_mols >= 0.0
    assert s.pending_vent_mols >= 0.0 and s.pending_drop_kg >= 0.0
    assert s.helium_vented_mols <= n0 * (1 + 1e-6)
    assert s.sand_dropped_kg <= sand0 + 1e-6


def test_thresholds_do_nothing(atmosphere):
  s = _state(atmosphere, 17_000.0)
  b = balloon_lib.LatexBalloon(s)
  b.simulate_step(CALM, atmosphere, [17_050.0, 5.0, -1.0], STRIDE)
  assert s.last_decision == Decision.NOTHING
  assert s.helium_vented_mols == 0.0 and s.sand_dropped_kg == 0.0
  assert s.altitude_m == pytest.approx(17_000.0, abs=1e-6)


def test_guard_floats_when_drifting_out_of_band_within_stride(atmosphere):
  # 0.3 m/s up at 21.9 km; "do nothing" (under the vent threshold) lets it
  # drift across 22 km, where the in-stride guard floats it.
  s = _steady_state(atmosphere, 21_900.0, 0.3)
  b = balloon_lib.LatexBalloon(s)
  b.simulate_step(CALM, atmosphere, [21_000.0, 5.0, -1.0], STRIDE)
  assert s.last_decision == Decision.NOTHING
  assert s.guard_engaged
  # n and m_s are float32 in the core: ~1e-7 kg of lift rounding.
  assert s.free_lift_kg == pytest.approx(0.0, abs=1e-6)
  assert 22_000.0 < s.altitude_m < 22_100.0
  assert abs(s.ascent_rate_mps) < 0.05
  # Without the in-stride guard (paper), it keeps drifting up.
  s2_ = _steady_state(atmosphere, 21_900.0, 0.3)
  b2 = balloon_lib.LatexBalloon(s2_, guard_within_stride=False)
  b2.simulate_step(CALM, atmosphere, [21_000.0, 5.0, -1.0], STRIDE)
  assert not s2_.guard_engaged
  assert s2_.altitude_m > 22_200.0
  # At the next action, outside the band, the paper's guard floats it.
  b2.simulate_step(CALM, atmosphere, [21_000.0, 5.0, -1.0], STRIDE)
  assert s2_.last_decision == Decision.FLOAT and s2_.guard_engaged


def test_guard_at_lower_edge(atmosphere):
  # 0.3 m/s down at 13.1 km; the command (0.15 m/s up) needs less sand than
  # m_s_min, so the controller does nothing and the in-stride guard floats
  # the balloon once it sinks below 13 km.
  s = _steady_state(atmosphere, 13_100.0, -0.3)
  b = balloon_lib.LatexBalloon(s)
  b.simulate_step(CALM, atmosphere, [14_000.0, 5.0, -1.0], STRIDE)
  assert s.last_decision == Decision.NOTHING and s.guard_engaged
  assert 12_900.0 < s.altitude_m < 13_000.0
  assert abs(s.ascent_rate_mps) < 0.05
  # With smaller thresholds the same command ballasts back up: no guard.
  s = _steady_state(atmosphere, 12_950.0, -0.3)
  b = balloon_lib.LatexBalloon(s, min_drop_kg=0.001)
  b.simulate_step(CALM, atmosphere, [14_000.0, 5.0, -1.0], STRIDE)
  assert s.last_decision == Decision.BALLAST and not s.guard_engaged
  assert s.ascent_rate_mps > 0.0


def _bad_calls():
  good = [17_500.0, 1.0, -1.0]
  return [
      (dict(action=[float('nan'), 1.0, -1.0]), 'a0'),
      (dict(action=[17_500.0, float('inf'), -1.0]), 'a1'),
      (dict(action=[25_000.0, 1.0, -1.0]), 'a0'),
      (dict(action=[17_500.0, 1.0, 2.0]), 'a2'),
      (dict(action=[17_500.0, 1.0]), r'shape \(3,\)'),
      (dict(action=good, time_delta=dt.timedelta(0)), 'time_delta'),
      (dict(action=good, time_delta=1200), 'time_delta'),
      (dict(action=good, stride=dt.timedelta(seconds=-1)), 'stride'),
      (dict(action=good, wind=42.0), 'wind_vector'),
      (dict(action=good, wind=lambda x, y, p, t: wind_field.WindVector(
          units.Velocity(mps=float('nan')), units.Velocity(mps=0.0))),
       'wind must be finite'),
  ]


@pytest.mark.parametrize('call,match', _bad_calls())
def test_bad_inputs_raise_and_leave_state_untouched(atmosphere, call, match):
  s = _state(atmosphere, 17_000.0)
  b = balloon_lib.LatexBalloon(s)
  b.simulate_step(CALM, atmosphere, [17_800.0, 1.0, -1.0], STRIDE)
  before = copy.deepcopy(s)
  kwargs = {}
  if 'stride' in call:
    kwargs['stride'] = call['stride']
  with pytest.raises(ValueError, match=match):
    b.simulate_step(call.get('wind', CALM), atmosphere, call['action'],
                    call.get('time_delta', STRIDE), **kwargs)
  assert s == before


def test_wind_requeried_every_substep_as_altitude_changes(atmosphere):
  s = _state(atmosphere, 17_000.0)
  b = balloon_lib.LatexBalloon(s)
  calls = []

  def wind(x, y, pressure, time_elapsed):
    calls.append((x.meters, y.meters, pressure, time_elapsed))
    return wind_field.WindVector(units.Velocity(mps=10.0),
                                 units.Velocity(mps=-5.0))

  b.simulate_step(wind, atmosphere, [18_000.0, 1.0, -1.0], STRIDE)
  assert len(calls) == 7  # ceil(20 min / 3 min) sub-steps.
  pressures = [c[2] for c in calls]
  assert all(p1 < p0 for p0, p1 in zip(pressures, pressures[1:]))  # Rising.
  times = [c[3] for c in calls]
  assert times[0] == dt.timedelta(0) and max(
      t1 - t0 for t0, t1 in zip(times, times[1:])) <= dt.timedelta(minutes=3)
  assert s.x.meters == pytest.approx(10.0 * 1200.0)
  assert s.y.meters == pytest.approx(-5.0 * 1200.0)
  assert s.time_elapsed == STRIDE
  assert s.date_time == dt.datetime(2022, 11, 1, 0, 20,
                                    tzinfo=dt.timezone.utc)
  assert s.pressure == pytest.approx(
      atmosphere.at_height(units.Distance(m=s.altitude_m)).pressure)
  assert s.last_command == control.AltitudeControlCommand.STAY


def test_burst_is_terminal(atmosphere):
  s = _state(atmosphere, 20_000.0)
  amb = atmosphere.at_height(units.Distance(m=20_500.0))
  s.burst_volume_m3 = float(physics.volume(s.helium_mols, amb.temperature,
                                           amb.pressure))
  b = balloon_lib.LatexBalloon(s)
  b.simulate_step(CALM, atmosphere, [21_000.0, 1.0, -1.0], STRIDE)
  assert s.latex_status == Status.BURST
  assert s.status == ble_balloon.BalloonStatus.BURST
  assert s.altitude_m == pytest.approx(20_500.0, abs=60.0)
  assert s.time_elapsed < STRIDE
  with pytest.raises(RuntimeError, match='BURST'):
    b.simulate_step(CALM, atmosphere, [21_000.0, 1.0, 1.0], STRIDE)


def test_out_of_sand_is_terminal(atmosphere):
  s = _state(atmosphere, 14_500.0, sand_kg=0.05)
  b = balloon_lib.LatexBalloon(s)
  b.simulate_step(CALM, atmosphere, [21_000.0, 1.0, -1.0], STRIDE)
  assert s.last_decision == Decision.BALLAST
  assert s.sand_kg == 0.0 and s.sand_dropped_kg == pytest.approx(0.05)
  assert s.latex_status == Status.OUT_OF_SAND
  assert s.latex_status in state_lib.OUT_OF_RESOURCES
  assert s.status == ble_balloon.BalloonStatus.OK


def test_out_of_helium_is_terminal(atmosphere):
  s = _state(atmosphere, 21_000.0, sand_kg=0.1)
  b = balloon_lib.LatexBalloon(s)
  b.simulate_step(CALM, atmosphere, [14_000.0, 1.0, -1.0], STRIDE)
  assert s.last_decision == Decision.VENT
  assert s.helium_mols * physics.LIFT_PER_MOL < s.payload_kg
  assert s.latex_status == Status.OUT_OF_HELIUM


def test_finite_valve_flow_spreads_the_vent(atmosphere):
  instant = _state(atmosphere, 18_000.0)
  balloon_lib.LatexBalloon(instant).simulate_step(
      CALM, atmosphere, [17_000.0, 1.0, -1.0], STRIDE)
  slow = _state(atmosphere, 18_000.0)
  b = balloon_lib.LatexBalloon(slow, valve_flow_mols_per_s=0.01)
  b.simulate_step(CALM, atmosphere, [17_000.0, 1.0, -1.0], STRIDE)
  assert slow.helium_vented_mols == pytest.approx(instant.helium_vented_mols)
  assert slow.pending_vent_mols == pytest.approx(0.0, abs=1e-6)
  # Released gradually: after 30 s part of it is still pending.
  part = _state(atmosphere, 18_000.0)
  balloon_lib.LatexBalloon(part, valve_flow_mols_per_s=0.01).simulate_step(
      CALM, atmosphere, [17_000.0, 1.0, -1.0], dt.timedelta(seconds=30))
  assert 0.0 < part.helium_vented_mols < instant.helium_vented_mols
  assert part.pending_vent_mols > 0.0
  assert slow.altitude_m > instant.altitude_m  # Later start of the descent.
  # Too slow to finish in one stride: the remainder stays pending.
  s = _state(atmosphere, 18_000.0)
  balloon_lib.LatexBalloon(s, valve_flow_mols_per_s=1e-4).simulate_step(
      CALM, atmosphere, [17_000.0, 1.0, -1.0], STRIDE)
  assert s.helium_vented_mols == pytest.approx(0.12)
  assert s.pending_vent_mols > 0.0


def test_deterministic(atmosphere):
  results = []
  for _ in range(2):
    s = _state(atmosphere, 16_000.0)
    b = balloon_lib.LatexBalloon(s)
    for a in ([17_000, 1, -1], [16_000, 2, -1], [16_000, 1, 1]):
      b.simulate_step(CALM, atmosphere, a, STRIDE)
    results.append(s)
  assert results[0] == results[1]


def test_validate_script_writes_figure(tmp_path, capsys):
  from ble_latex.cli import validate  # pylint: disable=g-import-not-at-top
  status = validate.main(['--output_dir', str(tmp_path), '--no_reference'])
  out = capsys.readouterr().out
  assert status == 0
  assert (tmp_path / validate.OUTPUT_FILENAME).stat().st_size > 10_000
  line = [l for l in out.splitlines() if l.startswith('max ascent-rate error')]
  assert len(line) == 1
  assert float(line[0].split(':')[1].strip().rstrip('%')) < 5.0
