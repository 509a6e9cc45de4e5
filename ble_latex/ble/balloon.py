# coding=utf-8
"""The latex balloon as BLE objects: a thin adapter over the flight core.

`LatexBalloonState` subclasses BLE's `balloon.BalloonState` (so BLE's arena
interface, features, renderers and `SimulatorState` accept it) and adds the
latex balloon's vertical state and resources. It is a view: the flight core
(`ble_latex.flight`) computes, `write_flight` copies a core `FlightState`
into it (BLE's fields are written there and nowhere else).

`LatexBalloon` is a BLE `balloon.Balloon` whose `simulate_step(wind_vector,
atmosphere, action, time_delta)` is the override, for code that drives one
balloon object (BLE's `BalloonArena.step` holds one; the action is the paper's
(a0, a1, a2), not BLE's `AltitudeControlCommand`): it runs the core's
`flight.dynamics.step` (controller once per action, sub-steps of at most 3
simulated minutes re-querying the wind, the exact vertical relax of Eq.
fullN2L, finite-rate releases, the in-stride band guard) and writes the result
back. The envs do not use it: the gym envs fly the same core through
`ble_latex.ble.arena`.

Terminal statuses (`LatexBalloonStatus` = the core's `FlightStatus`, field
`latex_status`): out of sand (sand aboard < m_s_min), out of helium
(n (M_air - M_He) < m_p: cannot float even with all sand gone), envelope
burst (V > burst volume; BLE's `status` becomes BURST too) and grounded
(h <= 0). BLE's `status` stays OK otherwise.
"""

import dataclasses
import datetime as dt
import functools
import math
import numbers
from typing import Any, Callable, Mapping, Optional, Tuple, Union

from balloon_learning_environment.env import wind_field
from balloon_learning_environment.env.balloon import balloon
from balloon_learning_environment.env.balloon import control
from balloon_learning_environment.env.balloon import standard_atmosphere
from balloon_learning_environment.utils import units
import jax
import jax.numpy as jnp
import numpy as np
import s2sphere as s2

from ble_latex import errors
from ble_latex.ble import wind as wind_lib
from ble_latex.envs import gymnasium_env
from ble_latex.envs import jax_env
from ble_latex.flight import atmosphere as atmosphere_lib
from ble_latex.flight import dynamics
from ble_latex.flight import params as params_lib
from ble_latex.flight import physics as core_physics
from ble_latex.flight import state as state_lib

# The flight system's defaults live in `flight.params.FlightParams`.
_FLIGHT = params_lib.DEFAULTS
DEFAULT_ALTITUDE_M = 17_000.0  # [m] The view's altitude if none is given.

# BLE's standard atmosphere is defined on [-610 m, 85 km).
_ATMOSPHERE_MIN_M = -600.0  # [m]
_ATMOSPHERE_MAX_M = 84_000.0  # [m]

WindSource = Union[wind_field.WindVector,
                   Callable[[units.Distance, units.Distance, float,
                             dt.timedelta], wind_field.WindVector]]

LatexBalloonStatus = state_lib.FlightStatus


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
  payload_kg: float = _FLIGHT.payload_kg  # [kg]
  sand_kg: float = _FLIGHT.initial_sand_kg  # [kg]
  helium_mols: Optional[float] = None  # [mol]
  drag_coefficient: float = _FLIGHT.drag_coefficient  # [.]
  burst_volume_m3: float = _FLIGHT.burst_volume_m3  # [m^3]
  helium_vented_mols: float = 0.0  # [mol]
  sand_dropped_kg: float = 0.0  # [kg]
  pending_vent_mols: float = 0.0  # [mol]
  pending_drop_kg: float = 0.0  # [kg]
  latex_status: LatexBalloonStatus = LatexBalloonStatus.OK
  last_decision: state_lib.DecisionCode = state_lib.DecisionCode.NOTHING
  last_action: Tuple[float, float, float] = (0.0, 0.0, 0.0)
  last_float_action: float = 0.0  # [.]
  desired_ascent_rate_mps: float = 0.0  # [m/s]
  guard_engaged: bool = False

  def __post_init__(self):
    super().__post_init__()
    if self.helium_mols is None:
      self.helium_mols = float(
          core_physics.neutral_helium_mols(self.payload_kg, self.sand_kg))
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
    return float(core_physics.total_mass(self.payload_kg, self.sand_kg,
                                         self.helium_mols))

  @property
  def free_lift_kg(self) -> float:
    """n (M_air - M_He) - m_p - m_s. # [kg]"""
    return float(core_physics.free_lift(self.helium_mols, self.payload_kg,
                                        self.sand_kg))

  def sync_ambient(self, atmosphere: standard_atmosphere.Atmosphere) -> None:
    """Sets pressure, temperatures and envelope volume from the altitude."""
    ambient = atmosphere.at_height(units.Distance(m=self.altitude_m))
    self.pressure = float(ambient.pressure)
    self.ambient_temperature = float(ambient.temperature)
    self.internal_temperature = float(ambient.temperature)
    self.envelope_volume = float(
        core_physics.volume(self.helium_mols, float(ambient.temperature),
                            float(ambient.pressure)))
    self.mols_lift_gas = self.helium_mols


def write_flight(state: LatexBalloonState, flight: Mapping[str, Any], *,
                 start_date_time: dt.datetime,
                 volume_m3: Optional[float] = None) -> None:
  """Copies a core `FlightState` (host values) into the BLE state view.

  The one place BLE's fields are written: position, date and time elapsed,
  `pressure` / temperatures (the core's ambient at the balloon),
  `mols_lift_gas`, `envelope_volume`, BLE's `status` (BURST on a burst).

  Args:
    state: The view to update (in place).
    flight: `FlightState` fields as host scalars (the arena's `flight()`).
    start_date_time: Date and time of the flight's start.
    volume_m3: Envelope volume nRT/P; computed by the core if None. # [m^3]
  """
  get = lambda name: float(np.asarray(flight[name]))  # pylint: disable=unnecessary-lambda-assignment
  status = LatexBalloonStatus(int(np.asarray(flight['status'])))
  elapsed = dt.timedelta(seconds=get('time_s'))
  s = state
  s.x = units.Distance(m=get('x_m'))
  s.y = units.Distance(m=get('y_m'))
  for name in ('altitude_m', 'ascent_rate_mps', 'helium_mols', 'sand_kg',
               'helium_vented_mols', 'sand_dropped_kg', 'pending_vent_mols',
               'pending_drop_kg', 'desired_ascent_rate_mps'):
    setattr(s, name, get(name))
  s.date_time = start_date_time + elapsed
  s.time_elapsed = elapsed
  s.latex_status = status
  s.status = (balloon.BalloonStatus.BURST if
              status == LatexBalloonStatus.BURST else balloon.BalloonStatus.OK)
  s.last_decision = state_lib.DecisionCode(
      int(np.asarray(flight['last_decision'])))
  action = np.asarray(flight['last_action'], np.float64)
  s.last_action = tuple(float(v) for v in action)
  s.last_float_action = float(action[2])
  s.guard_engaged = bool(np.asarray(flight['guard_engaged']))
  s.last_command = control.AltitudeControlCommand.STAY
  s.pressure = get('pressure_pa')
  s.ambient_temperature = get('temperature_k')
  s.internal_temperature = s.ambient_temperature
  s.mols_lift_gas = s.helium_mols
  s.envelope_volume = (float(volume_m3) if volume_m3 is not None else float(
      core_physics.volume(s.helium_mols, s.ambient_temperature, s.pressure)))


def atmosphere_params(
    atmosphere: standard_atmosphere.Atmosphere
) -> atmosphere_lib.AtmosphereParams:
  """The core's atmosphere of a BLE `Atmosphere` (its lapse-rate blend)."""
  lapse = np.asarray(atmosphere._lapse_rates, np.float64)  # pylint: disable=protected-access
  low = np.asarray(atmosphere_lib.LAPSE_RATES_LOW, np.float64)
  high = np.asarray(atmosphere_lib.LAPSE_RATES_HIGH, np.float64)
  i = int(np.argmax(np.abs(high - low)))
  return atmosphere_lib.params_from_alpha((lapse[i] - low[i]) /
                                          (high[i] - low[i]))


def create_state(
    *,
    center_latlng: s2.LatLng,
    date_time: dt.datetime,
    atmosphere: standard_atmosphere.Atmosphere,
    altitude_m: float = DEFAULT_ALTITUDE_M,
    x: Optional[units.Distance] = None,
    y: Optional[units.Distance] = None,
    ascent_rate_mps: float = 0.0,
    **launch: Any) -> LatexBalloonState:
  """Builds a LatexBalloonState with BLE's pressure fields set from altitude.

  Args:
    center_latlng: Station (target) location.
    date_time: Start time.
    atmosphere: BLE atmosphere used to map altitude to P, T.
    altitude_m: Start altitude. # [m]
    x: Start offset east of the station (default 0).
    y: Start offset north of the station (default 0).
    ascent_rate_mps: Start ascent rate. # [m/s]
    **launch: The balloon at launch, as the gin configurable
      `flight.params.launch` (`latex_launch.*`) names it: `payload_kg`,
      `sand_kg`, `helium_mols` (None = neutrally buoyant),
      `drag_coefficient`, `burst_volume_m3`; the gin-bound values where not
      given.

  Returns:
    The new state.
  """
  bound = params_lib.launch()
  unknown = sorted(set(launch) - set(bound))
  if unknown:
    raise TypeError(f'create_state() got an unexpected keyword argument '
                    f'{unknown[0]!r}')
  v = {**bound, **launch}
  state = LatexBalloonState(
      center_latlng=center_latlng,
      date_time=date_time,
      x=x if x is not None else units.Distance(m=0.0),
      y=y if y is not None else units.Distance(m=0.0),
      altitude_m=float(altitude_m),
      ascent_rate_mps=float(ascent_rate_mps),
      payload_kg=float(v['payload_kg']),
      sand_kg=float(v['sand_kg']),
      helium_mols=(None if v['helium_mols'] is None else
                   float(v['helium_mols'])),
      drag_coefficient=float(v['drag_coefficient']),
      burst_volume_m3=float(v['burst_volume_m3']))
  state.sync_ambient(atmosphere)
  return state


# The view's fields `flight_state` reads (with the payload of the params).
_FLIGHT_INPUTS = ('x', 'y', 'altitude_m', 'ascent_rate_mps', 'sand_kg',
                  'helium_mols', 'payload_kg', 'time_elapsed',
                  'pending_vent_mols', 'pending_drop_kg', 'helium_vented_mols',
                  'sand_dropped_kg', 'latex_status', 'last_action',
                  'desired_ascent_rate_mps')


def flight_inputs(state: LatexBalloonState) -> Tuple[Any, ...]:
  """What `flight_state` rebuilds the core state from, as one tuple."""
  return tuple(getattr(state, name) for name in _FLIGHT_INPUTS)


def flight_state(state: LatexBalloonState, params: params_lib.FlightParams,
                 atm: atmosphere_lib.AtmosphereParams
                 ) -> state_lib.FlightState:
  """The core's `FlightState` of a BLE state view (inverse of write_flight)."""
  f = state_lib.initial_state(
      params, state.altitude_m, state.x.meters, state.y.meters,
      atm_params=atm, ascent_rate_mps=state.ascent_rate_mps,
      sand_kg=state.sand_kg, helium_mols=state.helium_mols,
      time_s=state.time_elapsed.total_seconds())
  f = f.replace(
      pending_vent_mols=jnp.asarray(state.pending_vent_mols, f.x_m.dtype),
      pending_drop_kg=jnp.asarray(state.pending_drop_kg, f.x_m.dtype),
      helium_vented_mols=jnp.asarray(state.helium_vented_mols, f.x_m.dtype),
      sand_dropped_kg=jnp.asarray(state.sand_dropped_kg, f.x_m.dtype),
      status=jnp.asarray(int(state.latex_status), jnp.int32),
      last_action=jnp.asarray(state.last_action, f.x_m.dtype),
      desired_ascent_rate_mps=jnp.asarray(state.desired_ascent_rate_mps,
                                          f.x_m.dtype))
  # The settled free lift in float64 from the view's values (as
  # initial_state forms it), less the releases still pending.
  lift = (core_physics.free_lift(float(state.helium_mols), state.payload_kg,
                                 float(state.sand_kg)) -
          state.pending_vent_mols * core_physics.LIFT_PER_MOL +
          state.pending_drop_kg)
  return f.replace(settled_lift_kg=jnp.asarray(lift, f.x_m.dtype))


@functools.lru_cache(maxsize=64)
def _jitted_step(wind: Any) -> Callable[..., Any]:
  """The core step with a constant wind (u, v) or a host-callback wind.

  The stride is a traced `dynamics.padded_schedule` argument: other stride
  lengths reuse the compiled step (one compile per power of two of
  sub-steps), not one compile per `time_delta`.
  """
  if isinstance(wind, tuple):
    u, v = wind

    def wind_fn(x, y, p, t):
      del y, p, t
      return jnp.full_like(x, u), jnp.full_like(x, v)
  else:
    # A non-finite wind makes the step's position non-finite: simulate_step
    # raises then (an exception in the callback would surface as an XLA
    # runtime error).
    wind_fn = wind_lib.callback_wind_fn(wind)
  return dynamics.make_scheduled_step(wind_fn)


class LatexBalloon(balloon.Balloon):
  """A BLE `Balloon` stepped by the flight core (`simulate_step` overridden)."""

  def __init__(self, balloon_state: LatexBalloonState, **settings: Any):
    """Constructor.

    Args:
      balloon_state: The state to step (updated in place by simulate_step).
      **settings: The controller's and actuators' settings, as the gin
        configurables `flight.params.controller` (`latex_controller.*`:
        `stride`, `min_vent_mols`, `min_drop_kg`, `band_low_m`,
        `band_high_m`) and `flight.params.simulation` (`latex_flight.*`:
        `max_substep`, `vertical_step`, `valve_flow_mols_per_s`,
        `ballast_rate_kg_per_s`, `actuation_chunk`, `guard_within_stride`)
        name them; the gin-bound values where not given.

    Raises:
      ValueError: for a non-LatexBalloonState state or bad settings.
    """
    if not isinstance(balloon_state, LatexBalloonState):
      raise ValueError('LatexBalloon needs a LatexBalloonState, got '
                       f'{type(balloon_state).__name__}')
    super().__init__(balloon_state)  # BLE's: holds the state as `state`.
    gin_settings = {**params_lib.controller(), **params_lib.simulation()}
    unknown = sorted(set(settings) - set(gin_settings))
    if unknown:
      raise ValueError(f'LatexBalloon has no setting {unknown[0]!r}; '
                       f'settings: {sorted(gin_settings)}')
    self._settings = {**gin_settings, **settings}
    self.params()  # Validates every setting (ValueError naming it).
    # The core state of the last step and the view's `flight_inputs` it
    # wrote: reused while those are unchanged (keeps the core's exact free
    # lift, which the float32 view of n and m_s cannot carry).
    self._flight: Optional[state_lib.FlightState] = None
    self._written: Optional[Tuple[Any, ...]] = None

  def params(self) -> params_lib.FlightParams:
    """The core's `FlightParams` of this balloon and its settings."""
    s = self.state
    params = params_lib.make_flight_params(
        payload_kg=s.payload_kg, sand_kg=s.sand_kg,
        drag_coefficient=s.drag_coefficient,
        burst_volume_m3=s.burst_volume_m3, **self._settings)
    if params.realistic:
      raise errors.ConfigError(
          'realistic latex physics (gin_configs/latex_realistic.gin: '
          'latex_flight.superheat_day_k / lift_walk_kg_per_sqrt_s) flies in '
          'the functional env (envs/jax_env.py and its Gymnasium envs), not '
          "in BLE's LatexBalloon.simulate_step: unbind them for BLE's arena")
    return params

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
    a = gymnasium_env.validate_actions(action, None, jax_env.ACTION_LOW,
                                       jax_env.ACTION_HIGH)
    for name, value in (('time_delta', time_delta), ('stride', stride)):
      if not isinstance(value, dt.timedelta) or value.total_seconds() <= 0:
        raise ValueError(f'{name} must be a positive timedelta, got {value!r}')
    if isinstance(wind_vector, wind_field.WindVector):
      wind = (wind_vector.u.meters_per_second, wind_vector.v.meters_per_second)
      if not all(math.isfinite(w) for w in wind):
        raise ValueError(f'wind must be finite, got u={wind[0]}, v={wind[1]} '
                         '[m/s]')
    elif callable(wind_vector):
      wind = wind_vector
    else:
      raise ValueError('wind_vector must be a WindVector or a callable '
                       f'(x, y, pressure, time_elapsed), got {wind_vector!r}')
    s.validate()
    params = self.params().replace(
        initial_sand_kg=s.sand_kg)
    params = dataclasses.replace(params, max_substep_s=min(
        params.max_substep_s, stride.total_seconds()))
    atm = atmosphere_params(atmosphere)
    start = s.date_time - s.time_elapsed
    flight = (self._flight if self._written == flight_inputs(s) else
              flight_state(s, params, atm))
    grid = dynamics.padded_schedule(time_delta.total_seconds(),
                                    params.max_substep_s,
                                    params.vertical_step_s)
    new = _jitted_step(wind)(params, atm, flight, jnp.asarray(a, jnp.float32),
                             grid)
    if not np.isfinite(float(new.x_m)) or not np.isfinite(float(new.y_m)):
      raise ValueError('wind must be finite: the wind callable returned a '
                       'non-finite wind; the state is left untouched')
    write_flight(s, {f.name: getattr(host, f.name)
                     for host in [jax.device_get(new)]
                     for f in dataclasses.fields(host)},
                 start_date_time=start)
    self._flight, self._written = new, flight_inputs(s)
