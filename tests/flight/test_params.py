# coding=utf-8
"""A flight value is one declaration (issue 66): its gin keyword, its
`make_flight_params` argument, its gin name and its check come from its
`FlightParams` field (`flight.params._param`); `REALISTIC` is read from
gin_configs/latex_realistic.gin, its one home.
"""

import datetime as dt
import functools
import importlib.util
import inspect
import pathlib
import sys
import warnings

import gin
import jax
import numpy as np
import pytest

from ble_latex import configs
from ble_latex import errors
from ble_latex.flight import params as params_lib

_FIELDS = params_lib._FIELDS  # pylint: disable=protected-access
_BINDINGS = params_lib._FIELD_BINDINGS  # pylint: disable=protected-access
_SHIMS = {'latex_launch': params_lib.launch,
          'latex_controller': params_lib.controller,
          'latex_flight': params_lib.simulation}


def _parameters(function):
  return inspect.signature(function).parameters


@pytest.mark.parametrize('name', list(_FIELDS))
def test_each_field_is_declared_with_its_keyword_and_check(name):
  meta = _FIELDS[name].metadata
  assert meta['kind'] in params_lib.KINDS, name
  if 'gin' not in meta:  # Set by another field's keyword.
    assert 'gin' in _FIELDS[meta['set_by']].metadata, name
    return
  keyword = meta.get('keyword', name)
  assert params_lib.gin_name(name) == f'{meta["gin"]}.{keyword}'
  for function in (_SHIMS[meta['gin']], params_lib.make_flight_params):
    parameter = _parameters(function)[keyword]
    assert parameter.kind is inspect.Parameter.KEYWORD_ONLY
  default = _parameters(params_lib.make_flight_params)[keyword].default
  if meta['kind'] not in (params_lib.SWITCHED, params_lib.CLOCK):
    assert default == _FIELDS[name].default, name
  if 'limits' in meta:
    assert params_lib.PHYSICAL_RANGES[name] == meta['limits']


@pytest.mark.parametrize('name', list(_FIELDS))
def test_each_field_is_checked_naming_its_binding(name):
  # A SWITCHED value is checked where its switch is on.
  switch = params_lib._SETS.get(name)  # pylint: disable=protected-access
  on = ({switch: True} if switch and
        _FIELDS[switch].metadata['kind'] == params_lib.SWITCH else {})
  bad = params_lib.DEFAULTS.replace(**{name: 'x', **on})
  with pytest.raises(errors.ConfigError) as raised:
    params_lib.check_flight_params(bad)
  message = str(raised.value)
  named = (params_lib.binding(name) if name in _BINDINGS else
           f'FlightParams.{name}')
  assert message.startswith(named) and '\n' not in message, message


def test_the_keywords_are_the_declared_fields_and_nothing_else():
  declared = {meta.get('keyword', name) for name, meta in
              ((n, f.metadata) for n, f in _FIELDS.items()) if 'gin' in meta}
  shims = [set(_parameters(f)) for f in _SHIMS.values()]
  assert set().union(*shims) == declared == set(
      _parameters(params_lib.make_flight_params))
  assert sum(map(len, shims)) == len(declared)  # Each in one configurable.
  assert set(params_lib.PHYSICAL_RANGES) == {
      n for n, f in _FIELDS.items() if 'limits' in f.metadata}
  with pytest.raises(TypeError, match="unexpected keyword argument 'nope'"):
    params_lib.make_flight_params(nope=1.0)
  with pytest.raises(TypeError, match="launch.*unexpected keyword"):
    params_lib.launch(stride=1.0)  # latex_controller's.


@functools.lru_cache(maxsize=None)
def _copy_with_a_new_field():
  """flight/params.py with one field added (its gin names renamed)."""
  source = pathlib.Path(params_lib.__file__).read_text()
  edits = [
      ('  @property\n  def realistic_lift',
       "  test_ballast_kg: float = _param(\n"
       "      0.5, gin=_LAUNCH, keyword='test_ballast',\n"
       "      limits=(0.0, 2.0, 'kg: the test\\'s'))  # [kg]\n\n"
       '  @property\n  def realistic_lift'),
      ("_LAUNCH = 'latex_launch'", "_LAUNCH = 'copy_latex_launch'"),
      ("_CONTROLLER = 'latex_controller'",
       "_CONTROLLER = 'copy_latex_controller'"),
      ("_SIMULATION = 'latex_flight'", "_SIMULATION = 'copy_latex_flight'"),
      ("_OLD_NAMES = {_LAUNCH: 'create_state', _CONTROLLER: 'AltitudeController',\n"
       "              _SIMULATION: 'LatexBalloon'}",
       "_OLD_NAMES = {_LAUNCH: 'copy_create_state',\n"
       "              _CONTROLLER: 'copy_AltitudeController',\n"
       "              _SIMULATION: 'copy_LatexBalloon'}"),
      ("_GIN_MODULE = 'ble_latex.flight.params'",
       "_GIN_MODULE = 'tests.flight_params_copy'"),
      ("REALISTIC = gin_file_arguments(configs.gin_file("
       "'latex_realistic.gin'))", 'REALISTIC = {}'),
  ]
  for old, new in edits:
    assert source.count(old) == 1, old
    source = source.replace(old, new)
  spec = importlib.util.spec_from_loader('tests_flight_params_copy',
                                         loader=None)
  module = importlib.util.module_from_spec(spec)
  sys.modules[spec.name] = module  # For the dataclass machinery.
  exec(compile(source, 'params_copy.py', 'exec'), module.__dict__)  # pylint: disable=exec-used
  return module


def test_a_new_field_is_one_declaration():
  # One field added to a copy of the module: its gin keyword, maker
  # argument, gin name, range check and gin binding all follow.
  copy = _copy_with_a_new_field()
  assert copy.gin_name('test_ballast_kg') == 'copy_latex_launch.test_ballast'
  assert copy.launch()['test_ballast'] == 0.5
  assert 'test_ballast' in inspect.signature(copy.make_flight_params).parameters
  assert copy.make_flight_params(test_ballast=1.5).test_ballast_kg == 1.5
  assert copy.PHYSICAL_RANGES['test_ballast_kg'][:2] == (0.0, 2.0)
  with pytest.raises(errors.ConfigError,
                     match=r'^gin binding copy_latex_launch.test_ballast must '
                     r'.*3\.0.*the test\'s'):
    copy.make_flight_params(test_ballast=3.0)
  gin.clear_config()
  try:
    gin.parse_config('copy_latex_launch.test_ballast = 0.25')
    assert copy.flight_params_from_gin().test_ballast_kg == 0.25
    gin.clear_config()  # The old name (an alias) takes the new field too.
    gin.parse_config('copy_create_state.test_ballast = 0.75')
    with warnings.catch_warnings():
      warnings.simplefilter('ignore', FutureWarning)
      assert copy.flight_params_from_gin().test_ballast_kg == 0.75
    with pytest.raises(ValueError, match='no_such'):
      gin.parse_config('copy_latex_launch.no_such = 0.25')
  finally:
    gin.clear_config()


def test_gin_sees_the_declared_keywords():
  gin.clear_config()
  try:
    gin.parse_config(['latex_launch.sand_kg = 1.5',
                      'latex_flight.start_time = "2022-11-02T06:00:00"'])
    params = params_lib.flight_params_from_gin()
    assert params.initial_sand_kg == 1.5
    assert params.start_second_of_day == 6 * 3600.0
    with pytest.raises(ValueError, match='sand'):
      gin.parse_config('latex_controller.sand_kg = 1.5')
  finally:
    gin.clear_config()


def test_realistic_is_read_from_its_gin_file():
  assert params_lib.REALISTIC == params_lib.gin_file_arguments(
      configs.gin_file('latex_realistic.gin'))
  assert params_lib.REALISTIC['gas_state'] is True
  assert params_lib.REALISTIC['overpressure_pa'] is None  # Off, explicitly.
  assert params_lib.make_flight_params(**params_lib.REALISTIC).realistic


def test_a_realistic_file_with_other_bindings_is_refused(tmp_path):
  path = tmp_path / 'other.gin'
  path.write_text('import ble_latex.flight.params\n'
                  'latex_flight.superheat_day_k = 8.1\n'
                  'sac_trainer_config.gamma = 0.9\n')
  with pytest.raises(errors.ConfigError,
                     match=r'other.gin:3: .*sac_trainer_config.gamma') as e:
    params_lib.gin_file_arguments(str(path))
  assert '\n' not in str(e.value)


def test_paper_mode_switches_off_what_the_realistic_file_binds():
  # Under latex_realistic.gin (and a walk on top) the paper's model is the
  # gin-bound system with every realistic value at its default: the gas
  # state and the heating noise (issue 68) too, which a hand-written list
  # of switches had missed (ble-latex-validate --modes=paper flew them).
  gin.clear_config()
  try:
    plain = params_lib.paper_flight_params()
    gin.parse_config_files_and_bindings(
        [configs.gin_file('latex_physics.gin'),
         configs.gin_file('latex_realistic.gin')],
        ['latex_flight.lift_walk_kg_per_sqrt_s = 0.67e-3',
         'latex_flight.lift_walk_calm_kg_per_sqrt_s = 0.07e-3',
         'latex_launch.sand_kg = 1.5'])
    paper = params_lib.paper_flight_params()
  finally:
    gin.clear_config()
  assert not paper.realistic and not paper.stochastic
  assert plain == params_lib.DEFAULTS
  assert paper == plain.replace(initial_sand_kg=1.5)


# --- the flight parameters' checks (from tests/flight/test_core.py) -----------


def test_params_defaults_have_one_home():
  p = params_lib.FlightParams()
  assert p.initial_helium_mols is None
  assert not p.finite_valve and not p.finite_ballast
  assert params_lib.make_flight_params() == p
  # Numeric constants are leaves, structure is static.
  leaves = jax.tree.leaves(p)
  # 12 of the paper's model, 23 of the realistic physics (issues 28, 44: the
  # lift walk's time constant, the gas's thermal lag and the intermittent
  # disturbance's calm intensity and two dwell times; issue 68: the heating
  # disturbance's rms and correlation time).
  assert len(leaves) == 35 and all(isinstance(v, float) for v in leaves)
  assert not p.realistic


def test_flight_params_from_gin_reads_existing_bindings():
  gin.clear_config()
  try:
    assert params_lib.flight_params_from_gin() == params_lib.FlightParams()
    gin.parse_config_files_and_bindings(
        [configs.gin_file('latex_physics.gin')],
        ['latex_launch.payload_kg = 2.5',
         'latex_launch.helium_mols = 180.0',
         'latex_controller.band_low_m = 12000.0',
         'latex_controller.min_vent_mols = 0.3',
         'latex_flight.valve_flow_mols_per_s = 0.1',
         'latex_flight.guard_within_stride = False'])
    p = params_lib.flight_params_from_gin(burst_volume_m3=300.0)
    assert p.payload_kg == 2.5 and p.initial_helium_mols == 180.0
    assert p.band_low_m == 12000.0 and p.min_vent_mols == 0.3
    assert p.finite_valve and p.valve_flow_mols_per_s == 0.1
    assert not p.finite_ballast and not p.guard_within_stride
    assert p.burst_volume_m3 == 300.0 and p.initial_sand_kg == 2.0
  finally:
    gin.clear_config()


def test_make_flight_params_validates():
  with pytest.raises(ValueError, match='band'):
    params_lib.make_flight_params(band_low_m=22_000.0, band_high_m=13_000.0)
  with pytest.raises(ValueError, match='valve_flow'):
    params_lib.make_flight_params(valve_flow_mols_per_s=0.0)
  with pytest.raises(ValueError, match='payload'):
    params_lib.make_flight_params(payload_kg=float('nan'))
  p = params_lib.make_flight_params(stride=dt.timedelta(minutes=10),
                                    ballast_rate_kg_per_s=0.002)
  assert p.stride_s == 600.0 and p.finite_ballast


_BAD_FLIGHT_VALUES = [
    ('sand_kg', True, 'latex_launch.sand_kg'),
    ('sand_kg', 'abc', 'latex_launch.sand_kg'),
    ('payload_kg', None, 'latex_launch.payload_kg'),
    ('payload_kg', 'abc', 'latex_launch.payload_kg'),
    ('drag_coefficient', float('inf'), 'latex_launch.drag_coefficient'),
    ('burst_volume_m3', -1.0, 'latex_launch.burst_volume_m3'),
    ('helium_mols', 0.0, 'latex_launch.helium_mols'),
    ('helium_mols', False, 'latex_launch.helium_mols'),
    ('min_vent_mols', None, 'latex_controller.min_vent_mols'),
    ('min_drop_kg', float('nan'), 'latex_controller.min_drop_kg'),
    ('band_low_m', 'low', 'latex_controller.band_low_m'),
    ('stride', 0.5, 'latex_controller.stride'),
    ('max_substep', 1e-9, 'latex_flight.max_substep'),
    ('max_substep', dt.timedelta(microseconds=1), 'latex_flight.max_substep'),
    ('vertical_step', None, 'latex_flight.vertical_step'),
    ('actuation_chunk', -10.0, 'latex_flight.actuation_chunk'),
    ('valve_flow_mols_per_s', 'fast', 'latex_flight.valve_flow_mols_per_s'),
    ('ballast_rate_kg_per_s', True, 'latex_flight.ballast_rate_kg_per_s'),
    ('guard_within_stride', 'yes', 'latex_flight.guard_within_stride'),
]


@pytest.mark.parametrize('arg, value, binding', _BAD_FLIGHT_VALUES)
def test_make_flight_params_refuses_non_numbers_naming_the_binding(
    arg, value, binding):
  """bool/str/None/out of range: a ValueError naming the gin binding."""
  with pytest.raises(ValueError, match=f'^gin binding {binding} must be '):
    params_lib.make_flight_params(**{arg: value})
  # The same check for params built as they are (FlightParams directly).
  field = {'sand_kg': 'initial_sand_kg', 'helium_mols': 'initial_helium_mols',
           'stride': 'stride_s', 'max_substep': 'max_substep_s',
           'vertical_step': 'vertical_step_s',
           'actuation_chunk': 'actuation_chunk_s'}.get(arg, arg)
  if isinstance(value, dt.timedelta):
    value = value.total_seconds()
  flags = {'valve_flow_mols_per_s': {'finite_valve': True},
           'ballast_rate_kg_per_s': {'finite_ballast': True}}.get(arg, {})
  with pytest.raises(ValueError, match=f'^gin binding {binding} must be '):
    params_lib.check_flight_params(params_lib.FlightParams(
        **{field: value}, **flags))


def test_flight_params_from_gin_names_the_binding():
  """A gin-bound 'abc' or None is a ValueError naming it, not a TypeError."""
  import ble_latex.ble.balloon  # pylint: disable=g-import-not-at-top,unused-import
  gin.clear_config()
  try:
    for binding, value in (('latex_launch.sand_kg', 'True'),
                           ('latex_launch.payload_kg', "'abc'"),
                           ('latex_launch.drag_coefficient', 'None')):
      gin.clear_config()
      gin.parse_config(f'{binding} = {value}')
      with pytest.raises(ValueError, match=f'gin binding {binding} must be'):
        params_lib.flight_params_from_gin()
  finally:
    gin.clear_config()


def test_make_flight_params_valid_values_unchanged():
  """Valid values (NumPy scalars too) give the same Python floats."""
  p = params_lib.make_flight_params(
      payload_kg=np.float32(2.5), sand_kg=np.float64(1.5), helium_mols=170,
      max_substep=dt.timedelta(minutes=3), vertical_step=1.0)
  assert p.payload_kg == 2.5 and p.initial_sand_kg == 1.5
  assert p.initial_helium_mols == 170.0 and p.vertical_step_s == 1.0
  assert all(type(v) is float for v in jax.tree.leaves(p))  # pylint: disable=unidiomatic-typecheck
  assert params_lib.make_flight_params() == params_lib.FlightParams()
