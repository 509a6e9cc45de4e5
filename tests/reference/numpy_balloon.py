# coding=utf-8
# The retired NumPy float64 model (ble_latex before the JAX flight core,
# commit dcfa0e1), kept only as an independent oracle for the tests
# (the core's tests in tests/flight compare the core against it, setup in
# oracle_cases.py; test_physics.py and test_controller.py also keep the oracle
# honest). Not part of the package;
# gin registrations removed (the package owns those names).
"""A latex balloon that vents helium and drops sand, steppable by BLE's arena.

`LatexBalloonState` subclasses BLE's `balloon.BalloonState` (so BLE's arena,
features, renderers and `SimulatorState` accept it) and adds the latex
balloon's vertical state and resources. `LatexBalloon` keeps BLE's
`simulate_step(wind_vector, atmosphere, action, time_delta, stride=...)`
interface: the action is the paper's (a0, a1, a2); the altitude controller
(gin `latex_controller.*`) acts once at the start of the step
(the 20-min action), then the physics runs in sub-steps of at most 3 simulated
minutes, each re-querying the wind at the balloon's new altitude, with the
vertical motion integrated from Eq. fullN2L by `physics.relax` (exact for a
frozen drag factor, k re-evaluated every `vertical_step`).

Terminal statuses (`LatexBalloonStatus`, field `latex_status`): out of sand
(sand aboard < m_s_min), out of helium (n (M_air - M_He) < m_p: cannot float
even with all sand gone), envelope burst (V > burst volume; BLE's `status`
becomes BURST too) and grounded (h <= 0). BLE's `status` stays OK otherwise.
"""

import dataclasses
import datetime as dt
import enum
import math
import numbers
from typing import Any, Callable, List, NamedTuple, Optional, Tuple, Union

from balloon_learning_environment.env import wind_field
from balloon_learning_environment.env.balloon import balloon
from balloon_learning_environment.env.balloon import control
from balloon_learning_environment.env.balloon import standard_atmosphere
from balloon_learning_environment.utils import units
import s2sphere as s2

from . import numpy_controller as controller_lib
from . import numpy_physics as physics

# Default flight system (README, "Physics and altitude controller").
DEFAULT_PAYLOAD_KG = 2.2  # [kg] 1.2 kg TA-1200-class envelope + 1.0 kg avionics
DEFAULT_SAND_KG = 2.0  # [kg]
DEFAULT_DRAG_COEFFICIENT = 0.25  # [.] BLE / Bellemare et al.
DEFAULT_BURST_VOLUME_M3 = 336.5  # [m^3] Totex TA-1200, 8.63 m burst diameter
DEFAULT_ALTITUDE_M = 17_000.0  # [m]

# BLE's standard atmosphere is defined on [-610 m, 85 km).
_ATMOSPHERE_MIN_M = -600.0  # [m]
_ATMOSPHERE_MAX_M = 84_000.0  # [m]
# Free lift below this counts as neutral for the in-stride guard. # [kg]
_NEUTRAL_LIFT_KG = 1e-9

WindSource = Union[wind_field.WindVector,
                   Callable[[units.Distance, units.Distance, float,
                             dt.timedelta], wind_field.WindVector]]


class LatexBalloonStatus(enum.Enum):
  """Status of the latex balloon (BLE's BalloonStatus cannot be extended)."""
  OK = 0
  OUT_OF_SAND = 1
  OUT_OF_HELIUM = 2
  BURST = 3
  GROUNDED = 4


OUT_OF_RESOURCES = frozenset(
    {LatexBalloonStatus.OUT_OF_SAND, LatexBalloonStatus.OUT_OF_HELIUM})


@dataclasses.dataclass
class LatexBalloonState(balloon.BalloonState):
  """BLE's balloon state plus the latex balloon's vertical state and resources.

  BLE fields kept in sync after every step: `pressure` and
  `ambient_temperature` / `internal_temperature` (at the balloon's altitude),
  `mols_lift_gas` (= helium_mols), `envelope_volume` (= nRT/P),
  `superpressure` (0), `envelope_cod` (= drag_coefficient), `payload_mass`
  (= payload_kg) and `envelope_mass` (0: included in payload_kg).
  `last_command` stays STAY (no air pump). Use `create_state` to build one
  with `pressure` consistent with `altitude_m`.

  Attributes:
    altitude_m: Altitude h. # [m]
    ascent_rate_mps: Ascent rate hdot. # [m/s]
    payload_kg: Payload m_p, including the latex envelope. # [kg]
    sand_kg: Sand ballast aboard m_s. # [kg]
    helium_mols: Helium in the envelope n; None means neutrally buoyant,
      (m_p + m_s) / (M_air - M_He). # [mol]
    drag_coefficient: c_d. # [.]
    burst_volume_m3: Envelope volume at which the latex bursts. # [m^3]
    helium_vented_mols: Cumulative helium vented. # [mol]
    sand_dropped_kg: Cumulative sand dropped. # [kg]
    pending_vent_mols: Helium still to vent (finite valve flow only). # [mol]
    pending_drop_kg: Sand still to drop (finite ballast rate only). # [kg]
    latex_status: OK or the terminal reason.
    last_decision: The controller's decision at the last action.
    last_action: The last (a0 [m], a1, a2) applied.
    last_float_action: a2 of the last action. # [.]
    desired_ascent_rate_mps: hdot_des of the last action (0 when floating).
      # [m/s]
    guard_engaged: Whether the altitude-band guard floated the balloon
      during the last step.
  """
  altitude_m: float = DEFAULT_ALTITUDE_M  # [m]
  ascent_rate_mps: float = 0.0  # [m/s]
  payload_kg: float = DEFAULT_PAYLOAD_KG  # [kg]
  sand_kg: float = DEFAULT_SAND_KG  # [kg]
  helium_mols: Optional[float] = None  # [mol]
  drag_coefficient: float = DEFAULT_DRAG_COEFFICIENT  # [.]
  burst_volume_m3: float = DEFAULT_BURST_VOLUME_M3  # [m^3]
  helium_vented_mols: float = 0.0  # [mol]
  sand_dropped_kg: float = 0.0  # [kg]
  pending_vent_mols: float = 0.0  # [mol]
  pending_drop_kg: float = 0.0  # [kg]
  latex_status: LatexBalloonStatus = LatexBalloonStatus.OK
  last_decision: controller_lib.Decision = controller_lib.Decision.NOTHING
  last_action: Tuple[float, float, float] = (0.0, 0.0, 0.0)
  last_float_action: float = 0.0  # [.]
  desired_ascent_rate_mps: float = 0.0  # [m/s]
  guard_engaged: bool = False

  def __post_init__(self):
    super().__post_init__()
    if self.helium_mols is None:
      self.helium_mols = float(
          physics.neutral_helium_mols(self.payload_kg, self.sand_kg))
    self.validate()
    self.mols_lift_gas = self.helium_mols
    self.mols_air = 0.0
    self.superpressure = 0.0
    self.envelope_cod = self.drag_coefficient
    self.payload_mass = self.payload_kg
    self.envelope_mass = 0.0

  def validate(self) -> None:
    """Raises ValueError naming any non-finite or non-physical field."""
    finite = ('altitude_m', 'ascent_rate_mps', 'payload_kg', 'sand_kg',
              'helium_mols', 'drag_coefficient', 'burst_volume_m3',
              'helium_vented_mols', 'sand_dropped_kg', 'pending_vent_mols',
              'pending_drop_kg')
    for name in finite:
      value = getattr(self, name)
      if (not isinstance(value, numbers.Real) or isinstance(value, bool) or
          not math.isfinite(value)):
        raise ValueError(f'LatexBalloonState.{name} must be a finite number, '
                         f'got {value!r}')
    for name in ('payload_kg', 'helium_mols', 'drag_coefficient',
                 'burst_volume_m3'):
      if getattr(self, name) <= 0:
        raise ValueError(f'LatexBalloonState.{name} must be > 0, got '
                         f'{getattr(self, name)}')
    for name in ('sand_kg', 'helium_vented_mols', 'sand_dropped_kg',
                 'pending_vent_mols', 'pending_drop_kg'):
      if getattr(self, name) < 0:
        raise ValueError(f'LatexBalloonState.{name} must be >= 0, got '
                         f'{getattr(self, name)}')
    if not _ATMOSPHERE_MIN_M <= self.altitude_m <= _ATMOSPHERE_MAX_M:
      raise ValueError(f'LatexBalloonState.altitude_m must be in '
                       f'[{_ATMOSPHERE_MIN_M}, {_ATMOSPHERE_MAX_M}] m, got '
                       f'{self.altitude_m}')

  @property
  def total_mass_kg(self) -> float:
    """m_p + m_s + n M_He. # [kg]"""
    return float(physics.total_mass(self.payload_kg, self.sand_kg,
                                    self.helium_mols))

  @property
  def free_lift_kg(self) -> float:
    """n (M_air - M_He) - m_p - m_s. # [kg]"""
    return float(physics.free_lift(self.helium_mols, self.payload_kg,
                                   self.sand_kg))

  def sync_ambient(self, atmosphere: standard_atmosphere.Atmosphere) -> None:
    """Sets pressure, temperatures and envelope volume from the altitude."""
    ambient = atmosphere.at_height(units.Distance(m=self.altitude_m))
    self.pressure = float(ambient.pressure)
    self.ambient_temperature = float(ambient.temperature)
    self.internal_temperature = float(ambient.temperature)
    self.envelope_volume = float(
        physics.volume(self.helium_mols, ambient.temperature,
                       ambient.pressure))
    self.mols_lift_gas = self.helium_mols


def create_state(
    *,
    center_latlng: s2.LatLng,
    date_time: dt.datetime,
    atmosphere: standard_atmosphere.Atmosphere,
    altitude_m: float = DEFAULT_ALTITUDE_M,
    x: Optional[units.Distance] = None,
    y: Optional[units.Distance] = None,
    ascent_rate_mps: float = 0.0,
    payload_kg: float = DEFAULT_PAYLOAD_KG,
    sand_kg: float = DEFAULT_SAND_KG,
    helium_mols: Optional[float] = None,
    drag_coefficient: float = DEFAULT_DRAG_COEFFICIENT,
    burst_volume_m3: float = DEFAULT_BURST_VOLUME_M3) -> LatexBalloonState:
  """Builds a LatexBalloonState with BLE's pressure fields set from altitude.

  Args:
    center_latlng: Station (target) location.
    date_time: Start time.
    atmosphere: BLE atmosphere used to map altitude to P, T.
    altitude_m: Start altitude. # [m]
    x: Start offset east of the station (default 0).
    y: Start offset north of the station (default 0).
    ascent_rate_mps: Start ascent rate. # [m/s]
    payload_kg: m_p including the envelope. # [kg]
    sand_kg: Initial sand. # [kg]
    helium_mols: Initial helium; None = neutrally buoyant. # [mol]
    drag_coefficient: c_d. # [.]
    burst_volume_m3: Latex burst volume. # [m^3]

  Returns:
    The new state.
  """
  state = LatexBalloonState(
      center_latlng=center_latlng,
      date_time=date_time,
      x=x if x is not None else units.Distance(m=0.0),
      y=y if y is not None else units.Distance(m=0.0),
      altitude_m=float(altitude_m),
      ascent_rate_mps=float(ascent_rate_mps),
      payload_kg=float(payload_kg),
      sand_kg=float(sand_kg),
      helium_mols=None if helium_mols is None else float(helium_mols),
      drag_coefficient=float(drag_coefficient),
      burst_volume_m3=float(burst_volume_m3))
  state.sync_ambient(atmosphere)
  return state


class TrajectoryPoint(NamedTuple):
  """One sample of the vertical state inside a step (for plots/validation)."""
  time_s: float  # [s] since the start of the step
  altitude_m: float  # [m]
  ascent_rate_mps: float  # [m/s]
  helium_mols: float  # [mol]
  sand_kg: float  # [kg]


class _StepAtmosphere:
  """The atmosphere during one step, remembering `at_height` answers.

  The physics asks for the ambient at the same altitude several times (the end
  of one vertical step is the start of the next, the burst check and the next
  wind query); each distinct altitude is computed once by BLE's atmosphere.
  Only valid while the atmosphere does not change (one `simulate_step`).
  """

  def __init__(self, atmosphere: standard_atmosphere.Atmosphere):
    self._atmosphere = atmosphere
    self._known = {}

  def at_height(
      self, height: units.Distance) -> standard_atmosphere.AtmosphericValues:
    h = height.meters
    key = (h, type(h))
    ambient = self._known.get(key)
    if ambient is None:
      ambient = self._known[key] = self._atmosphere.at_height(height)
    return ambient


@dataclasses.dataclass
class _Flight:
  """Mutable working copy of the state during a step (committed at the end)."""
  h: float  # [m]
  v: float  # [m/s]
  n: float  # [mol]
  sand: float  # [kg]
  x_m: float  # [m]
  y_m: float  # [m]
  pending_vent: float  # [mol]
  pending_drop: float  # [kg]
  vented: float  # [mol]
  dropped: float  # [kg]
  status: LatexBalloonStatus = LatexBalloonStatus.OK
  guard_engaged: bool = False


class LatexBalloon:
  """Equations of motion of the vent/ballast latex balloon (BLE interface)."""

  def __init__(
      self,
      balloon_state: LatexBalloonState,
      *,
      controller: Optional[controller_lib.AltitudeController] = None,
      max_substep: dt.timedelta = dt.timedelta(minutes=3),
      vertical_step: dt.timedelta = dt.timedelta(seconds=60),
      valve_flow_mols_per_s: Optional[float] = None,
      ballast_rate_kg_per_s: Optional[float] = None,
      actuation_chunk: dt.timedelta = dt.timedelta(seconds=10),
      guard_within_stride: bool = True):
    """Constructor.

    Args:
      balloon_state: The state to step (mutated in place by simulate_step).
      controller: The altitude controller; a (gin-configured) default one if
        None.
      max_substep: Longest physics sub-step; the wind is re-queried at the
        balloon's position and altitude at every sub-step.
      vertical_step: Longest step with the drag factor k(h) frozen (evaluated
        at the step's predicted midpoint altitude).
      valve_flow_mols_per_s: Finite valve flow; None = instantaneous venting
        as in the paper. # [mol/s]
      ballast_rate_kg_per_s: Finite ballast drop rate; None = instantaneous
        as in the paper. # [kg/s]
      actuation_chunk: With finite rates, the release is applied in pieces of
        at most this duration (each at its midpoint).
      guard_within_stride: Also apply the altitude-band guard between actions:
        when the balloon leaves the band moving outward it is floated (neutral
        buoyancy) at once. The paper applies the guard at actions only.

    Raises:
      ValueError: for a non-LatexBalloonState state or bad options.
    """
    if not isinstance(balloon_state, LatexBalloonState):
      raise ValueError('LatexBalloon needs a LatexBalloonState, got '
                       f'{type(balloon_state).__name__}')
    for name, value in (('max_substep', max_substep),
                        ('vertical_step', vertical_step),
                        ('actuation_chunk', actuation_chunk)):
      if not isinstance(value, dt.timedelta) or value.total_seconds() <= 0:
        raise ValueError(f'{name} must be a positive timedelta, got {value!r}')
    for name, value in (('valve_flow_mols_per_s', valve_flow_mols_per_s),
                        ('ballast_rate_kg_per_s', ballast_rate_kg_per_s)):
      if value is not None and (not math.isfinite(value) or value <= 0):
        raise ValueError(f'{name} must be None or a finite rate > 0, got '
                         f'{value}')
    self.state = balloon_state
    self.controller = (controller if controller is not None else
                       controller_lib.AltitudeController())
    self.max_substep = max_substep
    self.vertical_step_s = vertical_step.total_seconds()
    self.valve_flow_mols_per_s = valve_flow_mols_per_s
    self.ballast_rate_kg_per_s = ballast_rate_kg_per_s
    self.actuation_chunk_s = actuation_chunk.total_seconds()
    self.guard_within_stride = guard_within_stride
    # Samples of the last step (vertical steps), for plots and validation.
    self.last_trajectory: List[TrajectoryPoint] = []

  def simulate_step(
      self,
      wind_vector: WindSource,
      atmosphere: standard_atmosphere.Atmosphere,
      action: Any,
      time_delta: dt.timedelta,
      stride: dt.timedelta = dt.timedelta(minutes=3),
  ) -> None:
    """Applies one controller action, then advances the physics by time_delta.

    Args:
      wind_vector: A constant `wind_field.WindVector`, or a callable
        (x, y, pressure [Pa], time_elapsed) -> WindVector (e.g. a wind field's
        `get_ground_truth`) queried at every sub-step.
      atmosphere: BLE atmosphere (T, P, rho by altitude).
      action: (a0 desired altitude [m], a1 time factor, a2 float flag).
      time_delta: Simulated time to advance (normally the 20-min stride).
      stride: Longest physics sub-step (capped at `max_substep`).

    Raises:
      ValueError: bad action, time_delta, stride or wind; the state is left
        untouched.
      RuntimeError: stepping a balloon in a terminal status.
    """
    s = self.state
    if s.latex_status != LatexBalloonStatus.OK:
      raise RuntimeError('Stepping a latex balloon after a terminal event '
                         f'({s.latex_status.name}); reset it first.')
    a = controller_lib.validate_action(action)
    for name, value in (('time_delta', time_delta), ('stride', stride)):
      if not isinstance(value, dt.timedelta) or value.total_seconds() <= 0:
        raise ValueError(f'{name} must be a positive timedelta, got {value!r}')
    if not (isinstance(wind_vector, wind_field.WindVector) or
            callable(wind_vector)):
      raise ValueError('wind_vector must be a WindVector or a callable '
                       f'(x, y, pressure, time_elapsed), got {wind_vector!r}')
    s.validate()

    atmosphere = _StepAtmosphere(atmosphere)
    ambient = atmosphere.at_height(units.Distance(m=s.altitude_m))
    actuation = self.controller.decide(
        a, altitude_m=s.altitude_m, ascent_rate_mps=s.ascent_rate_mps,
        helium_mols=s.helium_mols, sand_kg=s.sand_kg, payload_kg=s.payload_kg,
        drag_coefficient=s.drag_coefficient,
        temperature=float(ambient.temperature),
        pressure=float(ambient.pressure))

    f = _Flight(h=s.altitude_m, v=s.ascent_rate_mps, n=s.helium_mols,
                sand=s.sand_kg, x_m=s.x.meters, y_m=s.y.meters,
                pending_vent=s.pending_vent_mols,
                pending_drop=s.pending_drop_kg, vented=s.helium_vented_mols,
                dropped=s.sand_dropped_kg, guard_engaged=actuation.guarded)
    self._actuate(f, actuation)
    trajectory = [TrajectoryPoint(0.0, f.h, f.v, f.n, f.sand)]

    sub = min(stride, self.max_substep)
    n_sub = max(1, math.ceil(time_delta / sub - 1e-9))
    elapsed = dt.timedelta()
    for i in range(1, n_sub + 1):
      boundary = time_delta * i / n_sub
      step = boundary - elapsed
      pressure = float(
          atmosphere.at_height(units.Distance(m=self._clamp(f.h))).pressure)
      wind = self._wind(wind_vector, f, pressure, s.time_elapsed + elapsed)
      t0 = elapsed.total_seconds()
      self._advance_vertical(f, step.total_seconds(), atmosphere, s,
                             trajectory, t0)
      f.x_m += wind.u.meters_per_second * step.total_seconds()
      f.y_m += wind.v.meters_per_second * step.total_seconds()
      elapsed = boundary
      if f.status != LatexBalloonStatus.OK:
        break

    if f.status == LatexBalloonStatus.OK:
      f.status = self._resource_status(f, s.payload_kg)
    self._commit(f, a, actuation, elapsed, atmosphere)
    self.last_trajectory = trajectory

  # --- internals -------------------------------------------------------------

  @staticmethod
  def _clamp(h: float) -> float:
    return min(max(h, _ATMOSPHERE_MIN_M), _ATMOSPHERE_MAX_M)

  @staticmethod
  def _wind(wind_vector: WindSource, f: _Flight, pressure: float,
            time_elapsed: dt.timedelta) -> wind_field.WindVector:
    if isinstance(wind_vector, wind_field.WindVector):
      wind = wind_vector
    else:
      wind = wind_vector(units.Distance(m=f.x_m), units.Distance(m=f.y_m),
                         pressure, time_elapsed)
    u, v = wind.u.meters_per_second, wind.v.meters_per_second
    if not (math.isfinite(u) and math.isfinite(v)):
      raise ValueError(f'wind must be finite, got u={u}, v={v} [m/s]')
    return wind

  def _actuate(self, f: _Flight, actuation: controller_lib.Actuation) -> None:
    """Replaces the pending release by this actuation (instant if no rate)."""
    f.pending_vent = min(actuation.vent_mols, f.n)
    f.pending_drop = min(actuation.drop_kg, f.sand)
    if self.valve_flow_mols_per_s is None:
      self._release(f, vent=f.pending_vent, drop=0.0)
    if self.ballast_rate_kg_per_s is None:
      self._release(f, vent=0.0, drop=f.pending_drop)

  @staticmethod
  def _release(f: _Flight, *, vent: float, drop: float) -> None:
    """Vents / drops (capped at the pending amount and what is aboard)."""
    vent = max(0.0, min(vent, f.pending_vent, f.n))
    drop = max(0.0, min(drop, f.pending_drop, f.sand))
    f.n -= vent
    f.vented += vent
    f.pending_vent = max(0.0, f.pending_vent - vent)
    f.sand -= drop
    f.dropped += drop
    f.pending_drop = max(0.0, f.pending_drop - drop)

  def _advance_vertical(self, f: _Flight, duration: float,
                        atmosphere: standard_atmosphere.Atmosphere,
                        s: LatexBalloonState,
                        trajectory: List[TrajectoryPoint],
                        t0: float) -> None:
    """Integrates Eq. fullN2L over `duration` s (with any pending release)."""
    c_d = s.drag_coefficient

    def drag_k_at(h: float) -> float:
      ambient = atmosphere.at_height(units.Distance(m=self._clamp(h)))
      return float(physics.drag_factor(f.n, c_d, ambient.temperature,
                                       ambient.pressure))

    def integrate(dt_s: float) -> None:
      lift = float(physics.free_lift(f.n, s.payload_kg, f.sand)) * (
          physics.GRAVITY)  # [N]
      mass = float(physics.total_mass(s.payload_kg, f.sand, f.n))  # [kg]
      f.h, f.v = physics.integrate_vertical(
          f.h, f.v, dt_s, lift_force=lift, mass=mass, drag_k_at=drag_k_at,
          max_step=self.vertical_step_s)

    done = 0.0
    while duration - done > 1e-9:
      chunk = min(self.vertical_step_s, duration - done)
      releasing = self._releasing(f)
      if releasing:
        chunk = min(chunk, self.actuation_chunk_s, self._time_to_release(f))
        integrate(0.5 * chunk)
        self._release(
            f, vent=(self.valve_flow_mols_per_s or 0.0) * chunk,
            drop=(self.ballast_rate_kg_per_s or 0.0) * chunk)
        integrate(0.5 * chunk)
      else:
        integrate(chunk)
      done += chunk
      trajectory.append(TrajectoryPoint(t0 + done, f.h, f.v, f.n, f.sand))
      if self._check_envelope(f, atmosphere, s.burst_volume_m3):
        return
      if self.guard_within_stride and self._heading_out_of_band(
          f, s.payload_kg):
        guard = self.controller.float_actuation(
            helium_mols=f.n, sand_kg=f.sand, payload_kg=s.payload_kg,
            guarded=True)
        if guard.vent_mols > 0.0 or guard.drop_kg > 0.0:
          f.guard_engaged = True
          self._actuate(f, guard)

  def _heading_out_of_band(self, f: _Flight, payload_kg: float) -> bool:
    """Outside the band with the steady motion pointing further out.

    The direction is that of the free lift (the terminal velocity), or of the
    current velocity when the balloon is neutral, so a balloon that is still
    decelerating after a command back into the band is not floated.
    """
    lift = float(physics.free_lift(f.n, payload_kg, f.sand))  # [kg]
    if f.pending_vent > 0.0 or f.pending_drop > 0.0:
      return False  # A (finite-rate) actuation is still under way.
    direction = lift if abs(lift) > _NEUTRAL_LIFT_KG else f.v
    return self.controller.outside_band_moving_out(f.h, direction)

  def _releasing(self, f: _Flight) -> bool:
    return ((f.pending_vent > 0.0 and
             self.valve_flow_mols_per_s is not None) or
            (f.pending_drop > 0.0 and
             self.ballast_rate_kg_per_s is not None))

  def _time_to_release(self, f: _Flight) -> float:
    """Seconds until the pending release that finishes last is done."""
    times = []
    if f.pending_vent > 0.0 and self.valve_flow_mols_per_s:
      times.append(f.pending_vent / self.valve_flow_mols_per_s)
    if f.pending_drop > 0.0 and self.ballast_rate_kg_per_s:
      times.append(f.pending_drop / self.ballast_rate_kg_per_s)
    return max(max(times), 1e-6)

  @staticmethod
  def _check_envelope(f: _Flight, atmosphere: standard_atmosphere.Atmosphere,
                      burst_volume_m3: float) -> bool:
    """Sets BURST / GROUNDED; returns True when the flight ended."""
    if f.h <= 0.0:
      f.status = LatexBalloonStatus.GROUNDED
      return True
    ambient = atmosphere.at_height(units.Distance(m=LatexBalloon._clamp(f.h)))
    if physics.volume(f.n, ambient.temperature,
                      ambient.pressure) > burst_volume_m3:
      f.status = LatexBalloonStatus.BURST
      return True
    return False

  def _resource_status(self, f: _Flight,
                       payload_kg: float) -> LatexBalloonStatus:
    if f.n * physics.LIFT_PER_MOL < payload_kg:
      return LatexBalloonStatus.OUT_OF_HELIUM
    if f.sand + 1e-12 < self.controller.min_drop_kg:
      return LatexBalloonStatus.OUT_OF_SAND
    return LatexBalloonStatus.OK

  def _commit(self, f: _Flight, action: Any,
              actuation: controller_lib.Actuation, elapsed: dt.timedelta,
              atmosphere: standard_atmosphere.Atmosphere) -> None:
    """Writes the step's result into the state (only after it succeeded)."""
    s = self.state
    s.altitude_m = float(f.h)
    s.ascent_rate_mps = float(f.v)
    s.helium_mols = float(f.n)
    s.sand_kg = float(max(f.sand, 0.0))
    s.helium_vented_mols = float(f.vented)
    s.sand_dropped_kg = float(f.dropped)
    s.pending_vent_mols = float(f.pending_vent)
    s.pending_drop_kg = float(f.pending_drop)
    s.x = units.Distance(m=f.x_m)
    s.y = units.Distance(m=f.y_m)
    s.date_time = s.date_time + elapsed
    s.time_elapsed = s.time_elapsed + elapsed
    s.latex_status = f.status
    if f.status == LatexBalloonStatus.BURST:
      s.status = balloon.BalloonStatus.BURST
    s.last_decision = actuation.decision
    s.last_action = tuple(float(v) for v in action)
    s.last_float_action = float(action[2])
    s.desired_ascent_rate_mps = float(actuation.desired_ascent_rate)
    s.guard_engaged = bool(f.guard_engaged)
    s.last_command = control.AltitudeControlCommand.STAY
    s.sync_ambient(atmosphere)
