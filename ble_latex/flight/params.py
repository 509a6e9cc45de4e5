# coding=utf-8
"""`FlightParams`: every constant of the latex flight system, in one pytree.

Each flight value is declared once, as a `FlightParams` field (`_param`): its
default, the gin configurable and keyword that bind it, what kind of value
it is (a number, a duration, a value whose None switches an effect off, a
date, ...) and its physical range. From these declarations come the gin
configurables' keywords (`launch`, `controller`, `simulation`, gin names
`latex_launch.*`, `latex_controller.*`, `latex_flight.*`; their old names
`create_state`, `AltitudeController`, `LatexBalloon` are aliases until the
next release, `gin_aliases`), `make_flight_params`' keywords, `gin_name` and the single-value
checks of `check_flight_params` (its cross-field checks are written out).
Adding a flight value is adding a field; `flight_params_from_gin()` builds
the parameters from gin. `gin_configs/latex_physics.gin` spells the defaults
out; `gin_configs/latex_realistic.gin` is the one home of `REALISTIC`.

Numeric constants are pytree leaves (so a batch of flight systems can be
vmapped); what decides the structure of the computation (finite-rate
releases on or off, the in-stride guard, the sub-step and vertical-step
lengths, the initial helium rule) is static (`pytree_node=False`) and part of
the jit cache key.
"""

import dataclasses
import datetime as dt
import inspect
from typing import Any, Callable, Dict, Optional, Sequence, Tuple

from flax import struct
import gin
from gin import config_parser

from ble_latex import configs
from ble_latex import errors
from ble_latex import gin_aliases
from ble_latex import gin_values
from ble_latex.flight import solar

# The gin configurables of the flight system, by the parts they set.
_LAUNCH = 'latex_launch'
_CONTROLLER = 'latex_controller'
_SIMULATION = 'latex_flight'
# Their old names (of the classes that once held the values), aliases until
# the next release (`gin_aliases.renamed`).
_OLD_NAMES = {_LAUNCH: 'create_state', _CONTROLLER: 'AltitudeController',
              _SIMULATION: 'LatexBalloon'}

# What a declared value is (`_param`'s kind): how its keyword becomes the
# field and which check the field gets.
NUMBER = 'number'  # A number as bound (checked against `limits`, if given).
DURATION = 'duration'  # Keyword: a timedelta or seconds >= MIN_DURATION_S.
SWITCHED = 'switched'  # Keyword None = off: the field keeps its default and
#                        the SWITCH field set by it is False.
SWITCH = 'switch'  # A static flag: whether `set_by`'s keyword is not None.
FLAG = 'flag'  # A bool keyword.
CHOICE = 'choice'  # One of `choices`.
CLOCK = 'clock'  # Keyword: a UTC date, setting this field (the day) and the
#                  field set by it (the second of the day).
KINDS = (NUMBER, DURATION, SWITCHED, SWITCH, FLAG, CHOICE, CLOCK)

# `FlightParams.drag_model` values.
DRAG_MODELS = ('constant', 'two_regime', 'smooth')
_DAYS_10 = 864_000.0  # [s]


def _param(default: Any, *, gin: Optional[str] = None,
           keyword: Optional[str] = None, kind: str = NUMBER,
           limits: Optional[Tuple[float, float, str]] = None,
           choices: Optional[Sequence[str]] = None,
           set_by: Optional[str] = None, static: bool = False) -> Any:
  """One flight value's declaration: a `FlightParams` field with metadata.

  Args:
    default: The field's default (the one home of the value's default).
    gin: The gin configurable that binds it ('latex_launch',
      'latex_controller', 'latex_flight'); None: not bound itself (set by
      `set_by`'s keyword).
    keyword: Its gin and `make_flight_params` keyword, where it differs from
      the field's name ('sand_kg' for initial_sand_kg).
    kind: One of `KINDS`.
    limits: (minimum, maximum, why): the physical range (issue 67: finite in
      float32 is not enough), inclusive, in the field's unit; a value
      outside it is refused naming its binding (`PHYSICAL_RANGES`).
    choices: The allowed values of a CHOICE.
    set_by: The field whose keyword sets this one (a SWITCH, or the second
      of the day of a CLOCK).
    static: Not a pytree leaf (part of the jit cache key).

  Returns:
    The `struct.field`.
  """
  assert kind in KINDS, kind
  metadata = {'gin': gin, 'keyword': keyword, 'limits': limits,
              'choices': choices, 'set_by': set_by}
  return struct.field(
      pytree_node=not static, default=default,
      metadata={'kind': kind, **{k: v for k, v in metadata.items()
                                 if v is not None}})


@struct.dataclass
class FlightParams:
  """The latex balloon's flight system (paper "Method", docs/physics-model.md).

  Each field is one declaration (`_param`): its default, the gin keyword
  that binds it, its kind and its physical range; the unit is its comment's.

  Attributes:
    payload_kg: m_p, including the 1.2 kg latex envelope. # [kg]
    initial_sand_kg: Sand at launch m_s. # [kg]
    drag_coefficient: c_d. # [.]
    burst_volume_m3: Envelope volume at which the latex bursts. # [m^3]
    min_vent_mols: n_min, smallest ventable helium. # [mol]
    min_drop_kg: m_s_min, smallest droppable sand; also the out-of-sand
      level. # [kg]
    band_low_m: Lower edge of the altitude-band guard. # [m]
    band_high_m: Upper edge of the altitude-band guard. # [m]
    stride_s: Delta t of hdot_des = (a0 - h) / (a1 Delta t). # [s]
    valve_flow_mols_per_s: Finite valve flow (used when finite_valve).
      # [mol/s]
    ballast_rate_kg_per_s: Finite ballast rate (used when finite_ballast).
      # [kg/s]
    actuation_chunk_s: Longest piece of a finite-rate release. # [s]
    initial_helium_mols: Helium at launch; None = neutrally buoyant,
      (m_p + m_s) / (M_air - M_He). Static. # [mol]
    finite_valve: Venting at valve_flow_mols_per_s (else instantaneous, as
      in the paper). Static.
    finite_ballast: Dropping at ballast_rate_kg_per_s (else instantaneous).
      Static.
    guard_within_stride: Apply the altitude-band guard between actions too.
      Static.
    max_substep_s: Longest physics sub-step; the wind is re-queried at each.
      Static. # [s]
    vertical_step_s: Longest step with the drag factor frozen. Static. # [s]
    drag_model: 'constant' (c_d = drag_coefficient, the paper and BLE),
      'two_regime' (ASTRA: drag_coefficient_subcritical below
      reynolds_transition, drag_coefficient_supercritical above) or
      'smooth' (ASTRA's linear ramp between them over reynolds_band).
      Static.
    drag_coefficient_subcritical: c_d below the drag crisis (ASTRA
      simulator.py:812, 0.425). # [.]
    drag_coefficient_supercritical: c_d above the drag crisis (ASTRA
      simulator.py:811, 0.225). # [.]
    reynolds_transition: Re where the drag crisis starts (ASTRA
      simulator.py:813, 3.296e5). # [.]
    reynolds_band: Width of ASTRA's ramp (simulator.py:814, 0.363e5). # [.]
    overpressure_pa: Latex overpressure dP of the helium over the air (used
      when latex_overpressure; ~150 Pa). # [Pa]
    superheat_day_k: Helium temperature above the air by day (used when
      gas_superheat). # [K]
    cooling_night_k: Helium temperature below the air at night (used when
      gas_superheat). # [K]
    sun_elevation_night_deg: Sun elevation at and below which the helium
      has its night temperature. # [deg]
    sun_elevation_day_deg: Sun elevation at and above which the helium has
      its day temperature. # [deg]
    latitude_deg: Latitude of the flight, for the sun. # [deg]
    longitude_deg: Longitude of the flight (east positive), for the sun.
      # [deg]
    start_day_j2000: Julian date of 0h UTC of the flight's start day minus
      2451545.0 (J2000.0), for the sun. # [day]
    start_second_of_day: UTC second of the day at time_s = 0. # [s]
    lift_walk_kg_per_sqrt_s: Intensity sigma of the free-lift disturbance,
      dW = -W / tau dt + sigma dB (used when lift_walk; `disturbance`).
      # [kg/sqrt(s)]
    lift_walk_time_constant_s: Reversion time tau of the disturbance (an
      Ornstein-Uhlenbeck process); 0 = none (a random walk). # [s]
    lift_walk_calm_kg_per_sqrt_s: Intensity sigma_c of the disturbance in
      its calm regime (used when lift_walk_intermittent; then
      lift_walk_kg_per_sqrt_s is the gusty regime's). # [kg/sqrt(s)]
    lift_walk_calm_mean_s: Mean dwell time tau_c of the calm regime (used
      when lift_walk_intermittent). # [s]
    lift_walk_gusty_mean_s: Mean dwell time tau_g of the gusty regime (used
      when lift_walk_intermittent). # [s]
    gas_thermal_lag_s: First-order thermal lag tau of the helium's
      temperature behind the sun's forcing (`thermal`) and, with gas_state,
      behind the air (`gas`); 0 = none. # [s]
    heating_noise_k: Stationary rms of the heating disturbance dT_h, an
      Ornstein-Uhlenbeck process added to the gas's relaxation target (used
      when heating_noise; `gas`). # [K]
    heating_noise_time_s: Correlation time of dT_h. # [s]
    burst_weibull_scale_m: Weibull scale lambda of the burst diameter
      (used when burst_spread). # [m]
    burst_weibull_shape: Weibull shape k of the burst diameter. # [.]
    gas_superheat: Helium temperature follows the sun (else ambient, the
      paper). Static.
    latex_overpressure: Helium at P + overpressure_pa (else P). Static.
    lift_walk: Random walk of the free lift (needs a PRNG key per stride).
      Static.
    lift_walk_intermittent: The disturbance switches between a calm and a
      gusty regime (a two-state Markov chain, `disturbance.switch`); needs
      lift_walk. Static.
    gas_state: The helium's temperature is a state of the flight
      (`FlightState.gas_temperature_k`): adiabatic compression under the
      pressure the balloon sees plus relaxation toward the air (and the
      sun's forcing) with gas_thermal_lag_s (`gas`); else it is the air's
      plus the lagged forcing at once (`thermal`). Static.
    heating_noise: The bounded heating disturbance dT_h (needs gas_state
      and a PRNG key per stride). Static.
    burst_spread: Burst diameter drawn per flight from the Weibull law
      (needs a PRNG key at launch; else burst_volume_m3). Static.
  """
  payload_kg: float = _param(
      2.2, gin=_LAUNCH,
      limits=(0.05, 100.0, 'kg: a latex envelope alone weighs > 50 g'))  # [kg]
  initial_sand_kg: float = _param(2.0, gin=_LAUNCH, keyword='sand_kg',
                                  limits=(0.0, 100.0, 'kg'))  # [kg]
  drag_coefficient: float = _param(
      0.25, gin=_LAUNCH, limits=(0.01, 2.0, 'a sphere: 0.07-0.5'))  # [.]
  burst_volume_m3: float = _param(
      336.5, gin=_LAUNCH,
      limits=(0.01, 1.0e5, 'm^3: TA-1200 bursts at ~340'))  # [m^3]
  min_vent_mols: float = _param(0.2, gin=_CONTROLLER,
                                limits=(0.0, 1.0e3, 'mol'))  # [mol]
  min_drop_kg: float = _param(0.005, gin=_CONTROLLER,
                              limits=(0.0, 10.0, 'kg'))  # [kg]
  band_low_m: float = _param(13_000.0, gin=_CONTROLLER)  # [m]
  band_high_m: float = _param(22_000.0, gin=_CONTROLLER)  # [m]
  stride_s: float = _param(1200.0, gin=_CONTROLLER, keyword='stride',
                           kind=DURATION)  # [s]
  valve_flow_mols_per_s: float = _param(0.0, gin=_SIMULATION,
                                        kind=SWITCHED)  # [mol/s]
  ballast_rate_kg_per_s: float = _param(0.0, gin=_SIMULATION,
                                        kind=SWITCHED)  # [kg/s]
  actuation_chunk_s: float = _param(10.0, gin=_SIMULATION,
                                    keyword='actuation_chunk',
                                    kind=DURATION)  # [s]
  initial_helium_mols: Optional[float] = _param(
      None, gin=_LAUNCH, keyword='helium_mols', static=True)  # [mol]
  finite_valve: bool = _param(False, kind=SWITCH, static=True,
                              set_by='valve_flow_mols_per_s')
  finite_ballast: bool = _param(False, kind=SWITCH, static=True,
                                set_by='ballast_rate_kg_per_s')
  guard_within_stride: bool = _param(True, gin=_SIMULATION, kind=FLAG,
                                     static=True)
  max_substep_s: float = _param(180.0, gin=_SIMULATION, keyword='max_substep',
                                kind=DURATION, static=True)  # [s]
  vertical_step_s: float = _param(60.0, gin=_SIMULATION,
                                  keyword='vertical_step', kind=DURATION,
                                  static=True)  # [s]
  # Realistic latex physics (issue 28); the defaults are the paper's model.
  drag_coefficient_subcritical: float = _param(
      0.425, gin=_LAUNCH, limits=(0.01, 2.0, 'ASTRA: 0.425'))  # [.]
  drag_coefficient_supercritical: float = _param(
      0.225, gin=_LAUNCH, limits=(0.01, 2.0, 'ASTRA: 0.225'))  # [.]
  reynolds_transition: float = _param(
      3.296e5, gin=_LAUNCH, limits=(1.0e3, 1.0e8, 'ASTRA: 3.3e5'))  # [.]
  reynolds_band: float = _param(
      0.363e5, gin=_LAUNCH, limits=(0.0, 1.0e8, 'ASTRA: 3.6e4'))  # [.]
  overpressure_pa: float = _param(
      0.0, gin=_LAUNCH, kind=SWITCHED,
      limits=(0.0, 4999.0, 'latex holds ~150 Pa; more would burst it')
  )  # [Pa]
  superheat_day_k: float = _param(
      0.0, gin=_SIMULATION, kind=SWITCHED,
      limits=(0.0, 60.0, 'kelvin: the calibrated 8.1'))  # [K]
  cooling_night_k: float = _param(
      0.0, gin=_SIMULATION,
      limits=(0.0, 60.0, 'kelvin: the calibrated 3.3; more would take the '
              'gas toward 0 K'))  # [K]
  sun_elevation_night_deg: float = _param(-16.0, gin=_SIMULATION)  # [deg]
  sun_elevation_day_deg: float = _param(24.0, gin=_SIMULATION)  # [deg]
  latitude_deg: float = _param(1.0, gin=_SIMULATION)  # [deg]
  longitude_deg: float = _param(-113.0, gin=_SIMULATION)  # [deg]
  # 2022-11-01 0h UTC; bound as a date, `latex_flight.start_time`.
  start_day_j2000: float = _param(8339.5, gin=_SIMULATION,
                                  keyword='start_time', kind=CLOCK)  # [day]
  start_second_of_day: float = _param(0.0, set_by='start_day_j2000')  # [s]
  lift_walk_kg_per_sqrt_s: float = _param(
      0.0, gin=_SIMULATION, kind=SWITCHED,
      limits=(0.0, 0.05, 'kg/sqrt(s): 35x ValBal\'s 1.4e-3 stress value')
  )  # [kg/sqrt(s)]
  lift_walk_time_constant_s: float = _param(
      0.0, gin=_SIMULATION,
      limits=(0.0, _DAYS_10, 'seconds, <= 10 days'))  # [s]
  # The intermittent option (off): SSI-71's calm float, 0.05-0.1 g/sqrt(s)
  # (issue 44), and its ~2 h length; the gusty dwell time makes the long-run
  # rate of LIFT_WALK_INTERMITTENT the calibrated 0.35 g/sqrt(s) (see there).
  lift_walk_calm_kg_per_sqrt_s: float = _param(
      0.07e-3, gin=_SIMULATION, kind=SWITCHED,
      limits=(0.0, 0.05, 'kg/sqrt(s)'))  # [kg/sqrt(s)]
  lift_walk_calm_mean_s: float = _param(
      7200.0, gin=_SIMULATION,
      limits=(1.0, _DAYS_10, 'seconds, 1 s to 10 days'))  # [s]
  lift_walk_gusty_mean_s: float = _param(
      2600.0, gin=_SIMULATION,
      limits=(1.0, _DAYS_10, 'seconds, 1 s to 10 days'))  # [s]
  gas_thermal_lag_s: float = _param(
      0.0, gin=_SIMULATION,
      limits=(0.0, _DAYS_10, 'seconds, <= 10 days'))  # [s]
  # More than ~30 K would be a day-night swing of its own (11.4 K).
  heating_noise_k: float = _param(0.0, gin=_SIMULATION, kind=SWITCHED,
                                  limits=(0.0, 30.0, 'kelvin, <= 30'))  # [K]
  heating_noise_time_s: float = _param(
      1800.0, gin=_SIMULATION,
      limits=(1.0, _DAYS_10, 'seconds, 1 s to 10 days'))  # [s]
  burst_weibull_scale_m: float = _param(
      9.6758, gin=_LAUNCH, kind=SWITCHED,
      limits=(0.1, 100.0, 'm: TA-1200 9.7'))  # [m]
  burst_weibull_shape: float = _param(
      14.3577, gin=_LAUNCH, limits=(0.5, 1000.0, 'TA-1200 14.4'))  # [.]
  drag_model: str = _param('constant', gin=_LAUNCH, kind=CHOICE,
                           choices=DRAG_MODELS, static=True)
  gas_superheat: bool = _param(False, kind=SWITCH, static=True,
                               set_by='superheat_day_k')
  latex_overpressure: bool = _param(False, kind=SWITCH, static=True,
                                    set_by='overpressure_pa')
  lift_walk: bool = _param(False, kind=SWITCH, static=True,
                           set_by='lift_walk_kg_per_sqrt_s')
  lift_walk_intermittent: bool = _param(
      False, kind=SWITCH, static=True, set_by='lift_walk_calm_kg_per_sqrt_s')
  burst_spread: bool = _param(False, kind=SWITCH, static=True,
                              set_by='burst_weibull_scale_m')
  gas_state: bool = _param(False, gin=_SIMULATION, kind=FLAG, static=True)
  heating_noise: bool = _param(False, kind=SWITCH, static=True,
                               set_by='heating_noise_k')

  @property
  def realistic_lift(self) -> bool:
    """The free lift depends on altitude, time or a disturbance. Static."""
    return (self.gas_superheat or self.latex_overpressure or self.lift_walk
            or self.gas_state)

  @property
  def stochastic(self) -> bool:
    """A stride draws random numbers (needs a PRNG key). Static."""
    return self.lift_walk or self.heating_noise

  def noiseless(self) -> 'FlightParams':
    """These params with the disturbances held: no new draws per stride.

    What planners and lookaheads fly (the disturbance so far, carried in
    the state, is kept as it is).
    """
    return self.replace(lift_walk=False, lift_walk_intermittent=False,
                        heating_noise=False)

  @property
  def realistic(self) -> bool:
    """Any of the realistic-physics switches is on. Static."""
    return (self.realistic_lift or self.burst_spread or
            self.drag_model != 'constant')


# The defaults (the one home of each: the field defaults above).
DEFAULTS = FlightParams()

# The declarations, by field name, in field order.
_FIELDS = {f.name: f for f in dataclasses.fields(FlightParams)}
# Field -> its gin and `make_flight_params` keyword, for each field bound
# by gin ('initial_sand_kg' -> 'sand_kg').
_KEYWORDS = {name: f.metadata.get('keyword', name)
             for name, f in _FIELDS.items() if 'gin' in f.metadata}
# Field -> the field its keyword also sets ('heating_noise_k' ->
# 'heating_noise', 'start_day_j2000' -> 'start_second_of_day').
_SETS = {f.metadata['set_by']: name for name, f in _FIELDS.items()
         if 'set_by' in f.metadata}
# The physical range of each numeric flight parameter that has one (issue
# 67), from the declarations: field -> (minimum, maximum, why), inclusive.
# # [field's unit]
PHYSICAL_RANGES = {name: f.metadata['limits'] for name, f in _FIELDS.items()
                   if 'limits' in f.metadata}
# The default start of the sun's clock, as `latex_flight.start_time` binds
# it ('2022-11-01T00:00:00': the default start_day_j2000 and second).
DEFAULT_START_TIME = (solar.J2000 + dt.timedelta(
    days=DEFAULTS.start_day_j2000,
    seconds=DEFAULTS.start_second_of_day)).strftime('%Y-%m-%dT%H:%M:%S')

# Shortest duration of a stride, sub-step, vertical step or release chunk:
# shorter ones only multiply the work (a 20-minute stride in 1 s sub-steps is
# already 1200 wind queries) and 1e-9 s would never finish. # [s]
MIN_DURATION_S = 1.0


def seconds(value: Any, name: str) -> float:
  """A duration (timedelta or number of seconds) >= `MIN_DURATION_S`.

  Args:
    value: A `datetime.timedelta` or a number of seconds.
    name: What it is in the message, e.g. 'gin binding
      latex_flight.max_substep'.

  Returns:
    The duration in seconds.

  Raises:
    ValueError: Naming `name` (not a duration, non-finite or too short).
  """
  if isinstance(value, dt.timedelta):
    value = value.total_seconds()
  gin_values.require(
      gin_values.is_number(value) and float(value) >= MIN_DURATION_S, name,
      f'a duration (timedelta or seconds) >= {MIN_DURATION_S:g} s', value)
  return float(value)



def gin_name(field: str) -> str:
  """The gin name that sets a `FlightParams` field ('latex_launch.sand_kg')."""
  return _FIELD_BINDINGS[field]


def binding(field: str) -> str:
  """'gin binding <gin_name(field)>', how messages name a field."""
  return f'gin binding {gin_name(field)}'


def check_flight_params(params: FlightParams) -> None:
  """Checks every value of a `FlightParams` (types and ranges).

  The one check of the flight system's values, whoever built them
  (`make_flight_params`, `env_params.check_params` for params given as is):
  each field's declared check (its `limits`, or its kind's), then the
  checks of values against each other.

  Raises:
    ValueError: Naming the gin binding of the first bad value (a bool,
      string or None where a number belongs, a non-finite, non-positive or
      inconsistent value).
  """
  p = params
  for name, field in _FIELDS.items():  # The declared checks.
    value, kind = getattr(p, name), field.metadata['kind']
    if 'limits' in field.metadata:
      low, high, why = field.metadata['limits']
      gin_values.check_number(binding(name), value, minimum=low, maximum=high,
                              why=f' ({why})')
    elif kind == FLAG:
      gin_values.check_bool(binding(name), value)
    elif kind == SWITCH:
      gin_values.check_bool(f'FlightParams.{name}', value)
    elif kind == CHOICE:
      choices = field.metadata['choices']
      gin_values.require(value in choices, binding(name),
                         f'one of {", ".join(map(repr, choices))}', value)
    elif kind == DURATION:
      seconds(value, binding(name))
  # The special checks: a value's range that depends on another's.
  if p.initial_helium_mols is not None:
    gin_values.check_number(binding('initial_helium_mols'),
                            p.initial_helium_mols, above=0.0,
                            why=' (or None: neutrally buoyant)')
  low = gin_values.check_number(binding('band_low_m'), p.band_low_m)
  gin_values.check_number(
      binding('band_high_m'), p.band_high_m, above=low,
      why=f': the band must end above {gin_name("band_low_m")}')
  for field, flag in (('valve_flow_mols_per_s', 'finite_valve'),
                      ('ballast_rate_kg_per_s', 'finite_ballast')):
    if getattr(p, flag):
      gin_values.check_number(binding(field), getattr(p, field),
                              minimum=1e-7, maximum=1e3,
                              why=' (or None: instantaneous)')
  night = gin_values.check_number(binding('sun_elevation_night_deg'),
                                  p.sun_elevation_night_deg, minimum=-90.0)
  gin_values.check_number(
      binding('sun_elevation_day_deg'), p.sun_elevation_day_deg, above=night,
      maximum=90.0,
      why=f': above {gin_name("sun_elevation_night_deg")}')
  gin_values.check_number(binding('latitude_deg'), p.latitude_deg,
                          minimum=-90.0, maximum=90.0)
  gin_values.check_number(binding('longitude_deg'), p.longitude_deg,
                          minimum=-180.0, maximum=360.0)
  gin_values.check_number(binding('start_day_j2000'), p.start_day_j2000)
  gin_values.check_number(binding('start_second_of_day'),
                          p.start_second_of_day, minimum=0.0, below=86400.0)
  gin_values.require(
      p.gas_state or not p.heating_noise, binding('heating_noise_k'),
      f'None unless {gin_name("gas_state")} is True (the disturbance heats '
      'the gas state)', p.heating_noise_k)
  gin_values.require(
      p.lift_walk or not p.lift_walk_intermittent,
      binding('lift_walk_calm_kg_per_sqrt_s'),
      f'None unless {gin_name("lift_walk_kg_per_sqrt_s")} is set (the gusty '
      'regime\'s intensity)', p.lift_walk_calm_kg_per_sqrt_s)


def _keyword_default(name: str) -> Any:
  """The default of field `name`'s keyword (None: a SWITCHED effect off)."""
  field = _FIELDS[name]
  kind = field.metadata['kind']
  return (None if kind == SWITCHED else
          DEFAULT_START_TIME if kind == CLOCK else field.default)


def _annotation(name: str) -> Any:
  """The type of field `name`'s keyword."""
  field = _FIELDS[name]
  kind = field.metadata['kind']
  return (Optional[float] if kind == SWITCHED else
          Any if kind in (DURATION, CLOCK) else field.type)


def _signature(fields: Sequence[str]) -> inspect.Signature:
  """The keyword-only signature taking the keywords of `fields`."""
  return inspect.Signature([
      inspect.Parameter(_KEYWORDS[name], inspect.Parameter.KEYWORD_ONLY,
                        default=_keyword_default(name),
                        annotation=_annotation(name)) for name in fields])


def _with_defaults(function: str, signature: inspect.Signature,
                   values: Dict[str, Any]) -> Dict[str, Any]:
  """`values` over `signature`'s defaults; Python's TypeError if unknown."""
  for name in values:
    if name not in signature.parameters:
      raise TypeError(
          f'{function}() got an unexpected keyword argument {name!r}')
  return {**{name: p.default for name, p in signature.parameters.items()},
          **values}


_MAKER_SIGNATURE = _signature(list(_KEYWORDS))


def make_flight_params(**arguments: Any) -> FlightParams:
  """Validated `FlightParams` from the keywords of the declared values.

  Its keywords (keyword-only; `inspect.signature` shows them) are the gin
  keywords of `FlightParams`' fields (`_param`: 'sand_kg' for
  initial_sand_kg, ...), defaulting to the fields' defaults. Durations
  (stride, actuation_chunk, max_substep, vertical_step) may be numbers of
  seconds or `datetime.timedelta`s (at least `MIN_DURATION_S`); a rate of
  None means instantaneous (static flag off). Likewise None switches a
  realistic-physics effect off (the paper's model): overpressure_pa
  (latex_overpressure), burst_weibull_scale_m (burst_spread),
  superheat_day_k (gas_superheat), lift_walk_kg_per_sqrt_s (lift_walk),
  lift_walk_calm_kg_per_sqrt_s (lift_walk_intermittent), heating_noise_k
  (heating_noise). start_time (a UTC datetime or ISO string) sets the sun's
  clock (start_day_j2000, start_second_of_day).

  Returns:
    The parameters (Python floats, so they follow JAX's default precision).

  Raises:
    ValueError: for a value that is not a number (bool, string, None),
      non-finite, non-positive or inconsistent, naming its gin binding
      (`check_flight_params`).
    TypeError: for a keyword that is not one.
  """
  given = _with_defaults('make_flight_params', _MAKER_SIGNATURE, arguments)
  values = {}
  # The clock first (then the fields in order), as the errors always came.
  for name in sorted(_KEYWORDS, key=lambda n: _FIELDS[n].metadata['kind']
                     != CLOCK):
    value, kind = given[_KEYWORDS[name]], _FIELDS[name].metadata['kind']
    if kind == CLOCK:
      values[name], values[_SETS[name]] = solar.solar_clock(value,
                                                            binding(name))
    elif kind == DURATION:
      values[name] = seconds(value, binding(name))
    elif kind == SWITCHED:
      values[name] = _FIELDS[name].default if value is None else value
      values[_SETS[name]] = value is not None
    else:
      values[name] = value
  raw = FlightParams(**values)
  check_flight_params(raw)
  return raw.replace(
      initial_helium_mols=(None if raw.initial_helium_mols is None else
                           float(raw.initial_helium_mols)),
      **{name: bool(getattr(raw, name)) for name, f in _FIELDS.items()
         if f.metadata['kind'] == FLAG},
      **{name: float(getattr(raw, name)) for name, f in _FIELDS.items()
         if f.type in (float, 'float')})


make_flight_params.__signature__ = _MAKER_SIGNATURE


# The gin configurables of the flight system: each takes the keywords of
# the fields declared with its gin name (`_param`) and returns them as
# `make_flight_params` arguments; its defaults are `FlightParams`'.
_GIN_MODULE = 'ble_latex.flight.params'


def _gin_configurable(name: str) -> Callable[[Callable[..., Any]], Any]:
  """Makes a function the gin configurable `name` of its declared fields.

  The function's own body is not used: the configurable returns its
  keywords (those of the fields declared with `gin=name`, as a real
  keyword-only signature that gin and `inspect.signature` see) over their
  defaults. Unchecked: `make_flight_params` checks them.
  """
  signature = _signature([f for f in _KEYWORDS
                          if _FIELDS[f].metadata['gin'] == name])

  def decorate(function: Callable[..., Any]) -> Any:
    def configurable(**values: Any) -> Dict[str, Any]:
      return _with_defaults(function.__name__, signature, values)
    for attribute in ('__module__', '__name__', '__qualname__', '__doc__'):
      setattr(configurable, attribute, getattr(function, attribute))
    configurable.__signature__ = signature
    return gin_aliases.renamed(name, module=_GIN_MODULE,
                               old_name=_OLD_NAMES[name],
                               old_module=_GIN_MODULE)(configurable)
  return decorate


@_gin_configurable(_LAUNCH)
def launch(**values: Any) -> Dict[str, Any]:
  """The balloon at launch (gin `latex_launch.*`).

  Its keywords: those of the `FlightParams` fields declared with
  gin='latex_launch' (payload_kg, sand_kg, helium_mols, drag_coefficient,
  burst_volume_m3, drag_model and the realistic drag, overpressure and
  burst values), described there.

  Returns:
    These values as `make_flight_params` arguments (unchecked).
  """
  return values


@_gin_configurable(_CONTROLLER)
def controller(**values: Any) -> Dict[str, Any]:
  """The altitude controller (gin `latex_controller.*`).

  Its keywords: those of the `FlightParams` fields declared with
  gin='latex_controller' (stride, min_vent_mols, min_drop_kg, band_low_m,
  band_high_m), described there.

  Returns:
    These values as `make_flight_params` arguments (unchecked).
  """
  return values


@_gin_configurable(_SIMULATION)
def simulation(**values: Any) -> Dict[str, Any]:
  """Actuators, the step structure and the gas (gin `latex_flight.*`).

  Its keywords: those of the `FlightParams` fields declared with
  gin='latex_flight' (max_substep, vertical_step, the actuator rates, the
  sun's clock and place, the gas and the disturbances), described there.

  Returns:
    These values as `make_flight_params` arguments (unchecked).
  """
  return values


# FlightParams field -> the gin binding that sets it, e.g.
# 'initial_sand_kg' -> 'latex_launch.sand_kg' (a field set by another's
# keyword, start_second_of_day, -> that keyword's; a SWITCH has none).
_FIELD_BINDINGS = {name: f'{_FIELDS[name].metadata["gin"]}.{keyword}'
                   for name, keyword in _KEYWORDS.items()}
_FIELD_BINDINGS.update({
    name: _FIELD_BINDINGS[f.metadata['set_by']]
    for name, f in _FIELDS.items()
    if 'set_by' in f.metadata and f.metadata['kind'] != SWITCH})


def flight_params_from_gin(**overrides: Any) -> FlightParams:
  """`FlightParams` from the current gin bindings (the one place gin is read).

  Values bound for `latex_launch.*`, `latex_controller.*` and
  `latex_flight.*` (e.g. by gin_configs/latex_physics.gin) replace the
  defaults; keyword `overrides` replace both.

  Args:
    **overrides: `make_flight_params` arguments.

  Returns:
    The validated parameters.

  Raises:
    ValueError: A bad value, naming its gin binding.
  """
  return make_flight_params(**{**launch(), **controller(), **simulation(),
                               **overrides})


def gin_file_arguments(path: str) -> Dict[str, Any]:
  """The `make_flight_params` arguments a gin file binds.

  The file is parsed, not bound: gin's global configuration is untouched.

  Args:
    path: A gin file binding only flight values (and importing modules).

  Returns:
    Keyword -> the bound value, in file order.

  Raises:
    errors.ConfigError: A statement that is not an import or a binding of
      a flight value, naming it.
  """
  keywords = {gin_name(field): keyword for field, keyword in _KEYWORDS.items()}
  arguments = {}
  with open(path) as f:
    for statement in config_parser.ConfigParser(f,
                                                gin.config.ParserDelegate()):
      if isinstance(statement, config_parser.ImportStatement):
        continue
      bound = (isinstance(statement, config_parser.BindingStatement) and
               not statement.scope and
               keywords.get(f'{statement.selector}.{statement.arg_name}'))
      if not bound:
        where = getattr(statement, 'location', None)
        line = f':{where.line_num}' if where else ''
        raise errors.ConfigError(
            f'{path}{line}: only bindings of flight values (latex_launch.*, '
            'latex_controller.*, latex_flight.* keywords) belong here, got '
            f'{type(statement).__name__} '
            f'{getattr(statement, "selector", "")}.'
            f'{getattr(statement, "arg_name", "")}')
      arguments[bound] = statement.value
  return arguments


# The realistic latex physics (issues 28, 44, 68), as `make_flight_params`
# arguments: read from their one home, gin_configs/latex_realistic.gin
# (with each value's source; docs/physics.md).
REALISTIC = gin_file_arguments(configs.gin_file('latex_realistic.gin'))

# The stress setting of the disturbance: ValBal's simulator's 1.4 g/sqrt(s)
# (hootl/lasagna/PastaSim.cpp since a November 2018 refactor; 0.67 before),
# about 4x a physical value; bind it on top of latex_realistic.gin with
#   --gin_bindings='latex_flight.lift_walk_kg_per_sqrt_s = 1.4e-3'
# or `realistic_flight_params(**LIFT_WALK_STRESS)`. # [kg/sqrt(s)]
LIFT_WALK_STRESS = {'lift_walk_kg_per_sqrt_s': 1.4e-3}

# The default disturbance before issue 68, kept as a named stress setting: a
# random walk of the free lift at 0.35 g/sqrt(s) (the geometric middle of the
# plausible 0.2-0.67 g/sqrt(s), `disturbance`), unbounded (rms 103 g after a
# day, 272 g after 7 days, for any balloon size). Bind
#   latex_flight.lift_walk_kg_per_sqrt_s = 0.35e-3
# on top of latex_realistic.gin, or `realistic_flight_params(
# **LIFT_WALK_RANDOM)`. # [kg/sqrt(s)]
LIFT_WALK_RANDOM = {'lift_walk_kg_per_sqrt_s': 0.35e-3}

# The intermittent disturbance (issue 44, off by default; `disturbance`):
# calm spells at 0.07 g/sqrt(s) (SSI-71's 2 h calm float is typical of
# 0.05-0.1 g/sqrt(s)), mean 2 h (that float's length: one observation), and
# gusty spells at 0.67 g/sqrt(s) (the top of the plausible range, ValBal's
# simulator value before its 2018 refactor), mean 2600 s: the dwell time
# that makes the long-run rate sqrt(f 0.67^2 + (1 - f) 0.07^2), f = 2600 /
# 9800, equal the calibrated walk's 0.35 g/sqrt(s) (no flight data fixes it;
# so switching intermittency on changes the disturbance's texture, not its
# long-run strength). The dwell times are the field defaults. Bind
#   latex_flight.lift_walk_kg_per_sqrt_s = 0.67e-3
#   latex_flight.lift_walk_calm_kg_per_sqrt_s = 0.07e-3
# on top of latex_realistic.gin, or `realistic_flight_params(
# **LIFT_WALK_INTERMITTENT)`. # [kg/sqrt(s)]
LIFT_WALK_INTERMITTENT = {'lift_walk_kg_per_sqrt_s': 0.67e-3,
                          'lift_walk_calm_kg_per_sqrt_s': 0.07e-3}


def realistic_flight_params(**overrides: Any) -> FlightParams:
  """`flight_params_from_gin` with `REALISTIC` on top (then `overrides`).

  What `gin_configs/latex_realistic.gin` binds, without touching gin's
  global configuration (so one process can fly both modes side by side).
  """
  return flight_params_from_gin(**{**REALISTIC, **overrides})


def paper_flight_params(**overrides: Any) -> FlightParams:
  """`flight_params_from_gin` with every realistic switch off (the paper).

  The gin-bound flight system (payload, sand, band, ...) in the paper's
  model, whatever realistic bindings gin holds: each value `REALISTIC`
  binds (latex_realistic.gin) and the free-lift disturbance bound on top of
  it (`LIFT_WALK_INTERMITTENT`'s two keywords) at its default.
  """
  paper = {keyword: _MAKER_SIGNATURE.parameters[keyword].default
           for keyword in (*REALISTIC, *LIFT_WALK_INTERMITTENT)}
  return flight_params_from_gin(**{**paper, **overrides})
