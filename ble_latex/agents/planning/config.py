# coding=utf-8
"""What shapes a planner: `PlannerConfig`, its checks and size limits, gin.

The settings of the three planners (`planning`'s module docstring) and their
gin configurables `LatexMpcAgent`, `LatexMpcOracleAgent` and
`LatexMpcGradAgent` (gin module `ble_latex.agents.planners`, where the BLE
agents of those names lived before `agents/planning/`): each is a function
of the config fields, keyword-only, that returns the checked `PlannerConfig`
of its planner (`PLANNERS`, `from_gin`). Pure Python and gin: no
TensorFlow, Dopamine or BLE agent is imported here.

Sizes that drive memory are bounded (`MAX_SIZES`, `MAX_PLAN_STRIDES`) and
checked before anything is compiled or allocated: a beam of 1e8 would
otherwise compile and then ask XLA for 2.26 TB (issue 48).
"""

import dataclasses
import inspect
import os
from typing import Any, Callable, Dict

import gin

from ble_latex import errors
from ble_latex import gin_values
from ble_latex.envs import jax_env
from ble_latex.envs import task
from ble_latex.wind import noise_gp

FORECAST, ORACLE, GRADIENT = 'forecast', 'oracle', 'gradient'
MODES = (FORECAST, ORACLE, GRADIENT)
CEM, BEAM = 'cem', 'beam'
SEARCHES = (CEM, BEAM)

# The largest value of each size that drives a decision's memory or its
# compiled program. Each is far above any setting used (the largest flown:
# beam 512, horizon 216, 256 samples, 15 levels, 8 scenarios, memory 16).
MAX_SIZES: Dict[str, int] = {
    'num_samples': 65_536,  # Plans sampled per CEM iteration.
    'iterations': 1_000,  # CEM iterations (their samples are stacked).
    'horizon': 10_000,  # Strides planned ahead (139 days of 1200 s strides).
    'num_segments': 10_000,  # Pieces of a plan (at most horizon).
    'grid_levels': 1_024,  # Altitudes of the grid (the beam's choices).
    'beam_width': 65_536,  # Partial plans kept by the beam.
    'scenarios': 256,  # Wind scenarios each plan is flown in.
    # Measurements of the Gaussian process (K x K).
    'wind_memory': noise_gp.MAX_MEASUREMENTS,
    'grad_starts': 65_536,  # Plans refined by gradient ascent.
    'grad_steps': 10_000,  # Gradient steps per start (a scan's length).
}
# The most plan strides one planning call flies at once, all balloons of a
# batch together (`plan_strides` x balloons): 2^26. The beam of 1e8 that
# asked for 2.26 TB flew 9.6e9 of them (1e8 x 16 choices x 6 strides), about
# 235 B each, so this bound is ~16 GB: an H100's memory holds it, a host
# that has less refuses it with XLA's RESOURCE_EXHAUSTED, not a TB request.
MAX_PLAN_STRIDES = 2**26


@dataclasses.dataclass(frozen=True)
class PlannerConfig:
  """Everything that shapes a planner (hashable: a static jit argument).

  Attributes:
    mode: FORECAST, ORACLE or GRADIENT (`planning`'s module docstring).
    num_samples: Plans sampled per CEM iteration.
    iterations: CEM iterations (1: random shooting around the warm start).
    elite_fraction: Fraction of the samples that refit the CEM distribution.
    horizon: Strides planned ahead (24 = 8 h).
    num_segments: Piecewise-constant pieces of a plan (horizon split evenly).
    replan_every: Strides flown from a plan before planning again.
    time_factor: a1 of every planned action. # [.]
    plan_float: Whether plans choose float flags (else never float).
    float_probability: Initial probability of a float segment.
    altitude_low_m: Lowest altitude target. # [m]
    altitude_high_m: Highest altitude target. # [m]
    init_std_m: Initial CEM standard deviation of a target. # [m]
    min_std_m: Floor of the CEM standard deviation. # [m]
    radius_km: Radius of the in-radius term. # [km]
    radius_width_km: Width of its sigmoid. # [km]
    shaping: Weight of the 2^(-d / halflife) term. # [.]
    halflife_km: Its half-life distance. # [km]
    progress: Weight of the approach over the plan, (d_0 - d_end) / radius
      (a constant pull towards the station, also from far away). # [.]
    discount: Per-stride discount of the objective. # [.]
    sand_cost: Cost per kg of sand dropped (at a full margin). # [1/kg]
    helium_cost: Cost per kg of lift vented (at a full margin). # [1/kg]
    terminal_cost: Cost of a plan that ends the flight. # [.]
    helium_reserve: Under the sun, the multiple of the later sunsets' lift
      kept out of the helium margin (`plan_objective.end_terms`): each
      night the cooled gas lifts less, and the free lift the balloon can
      still vent (free lift + sand, at the gas's temperature) must cover
      the nights to come or the flight ends out of helium; 0: not kept
      (helium priced by its daytime margin). # [.]
    resource_buffer_kg: Under the sun, sand and ventable lift kept on top
      of what the later sunsets take (both reserves), for what the plan's
      model does not foresee (the heating's noise, the estimated
      disturbance); 0: none. # [kg]
    wind_correction_hours: e-folding time of the measured-wind correction
      of the forecast (0: none; FORECAST and GRADIENT only). # [h]
    wind_correction_pa: e-folding pressure distance of that correction. # [Pa]
    grad_starts: GRADIENT: best samples refined by gradient ascent.
    grad_steps: GRADIENT: gradient steps per start.
    grad_step_m: GRADIENT: length of a normalised step of the targets. # [m]
    grid_levels: Altitudes of a fixed grid over [altitude_low_m,
      altitude_high_m] whose plans are scored at every iteration besides
      the `num_samples` samples: for each, "go there and stay" (every
      segment targets it, no float) and "go there and float" (first segment
      targets it, then floats); 0: no grid. The grid keeps every layer of
      the band in the search when the CEM distribution has narrowed around
      one.
    scenarios: FORECAST and GRADIENT: 0 plans on the forecast alone; K > 0
      scores each plan by its mean objective over K wind scenarios, the
      forecast plus K simplex noise fields drawn afresh from BLE's noise
      model (`simplex.reset_uv_noise_params` of the planner's own keys, the
      same K for every plan of a decision: never the flight's noise), each
      corrected near the balloon to the wind it measures (as the forecast
      is). ORACLE ignores it (it flies the one true wind).
    search: CEM (the cross-entropy method over whole plans) or BEAM (a
      beam search over the plan's segments, `beam.beam_search`).
    beam_width: BEAM: partial plans kept after each segment.
    beam_cell_km: BEAM: 0 keeps the `beam_width` best partial plans; > 0
      keeps at most one per cell first (the best of those whose flights end
      in the same beam_cell_km x beam_cell_km square and `beam_cell_m`
      altitude bin, `beam.best_per_cell`), so that the beam is not spent on
      near-copies of one flight: dynamic programming's rule that of two
      paths to one state only the better one matters, on a coarse state. # [km]
    beam_cell_m: BEAM: the altitude bin of those cells. # [m]
    beam_resource_value: BEAM: 0 ranks partial plans by their objective;
      v > 0 adds v x (sand margin + helium margin,
      `plan_objective.resource_margins`) x the fraction of the episode left
      where they end: what the resources kept are worth to the strides after
      them, which a plan reaching to the episode's end (the oracle's) cannot
      otherwise see, so that the beam keeps frugal plans beside greedy ones.
      The plan flown is still the best final plan by the objective. # [1/kg]
    wind_memory: FORECAST and GRADIENT: 0 corrects the forecast by the
      current measurement with the exp-decay above; K > 0 by the Gaussian-
      process posterior mean of BLE's noise given the last K measurements,
      one per decision (`wind.noise_gp`: the covariance of BLE's simplex
      noise harmonics; the wind_correction_* fields are then unused).
    value_policy: '' (default): nothing beyond the horizon; a SAC policy
      file (or 'shipped'): a plan's score also gets value_weight x
      discount^n x V at the state where it (or the beam's partial plan)
      ends, n strides ahead, V its critics' state-value (`plan_value`).
    value_weight: The weight of that value (Q in the policy's reward units
      against the objective's per-stride terms). # [.]
  """
  mode: str = FORECAST
  num_samples: int = 256
  iterations: int = 2
  elite_fraction: float = 0.125
  horizon: int = 24
  num_segments: int = 4
  replan_every: int = 2
  time_factor: float = 2.0
  plan_float: bool = True
  float_probability: float = 0.5
  altitude_low_m: float = 14_000.0
  altitude_high_m: float = 21_000.0
  init_std_m: float = 2_000.0
  min_std_m: float = 150.0
  radius_km: float = 50.0
  radius_width_km: float = 3.0
  shaping: float = 0.3
  halflife_km: float = 100.0
  progress: float = 2.0
  discount: float = 0.98
  sand_cost: float = 0.1
  helium_cost: float = 0.1
  terminal_cost: float = 20.0
  helium_reserve: float = 1.0
  resource_buffer_kg: float = 0.0
  wind_correction_hours: float = 3.0
  wind_correction_pa: float = 1_000.0
  grad_starts: int = 4
  grad_steps: int = 5
  grad_step_m: float = 150.0
  grid_levels: int = 15
  scenarios: int = 0
  search: str = CEM
  beam_width: int = 32
  beam_cell_km: float = 0.0
  beam_cell_m: float = 250.0
  beam_resource_value: float = 0.0
  wind_memory: int = 0
  value_policy: str = ''
  value_weight: float = 1.0

  def checked(self, owner: str = '') -> 'PlannerConfig':
    """This config with its values checked (one line per bad value).

    Sizes are checked against `MAX_SIZES` and `MAX_PLAN_STRIDES` (one
    balloon) before anything is compiled.

    Args:
      owner: The gin configurable that set the values (e.g.
        'LatexMpcAgent'): messages then name the binding
        'gin binding LatexMpcAgent.beam_width'; '' names them 'planner
        parameter beam_width'.

    Raises:
      errors.ConfigError: Naming the planner's gin parameter.
    """
    def name(field):
      return (f'gin binding {owner}.{field}' if owner else
              f'planner parameter {field}')
    def size(field, minimum):
      gin_values.check_int(name(field), getattr(self, field), minimum=minimum,
                           maximum=MAX_SIZES[field])
    gin_values.require(self.mode in MODES, name('mode'), f'one of {MODES}',
                       self.mode)
    for field in ('iterations', 'horizon', 'num_segments'):
      size(field, 1)
    gin_values.check_int(name('replan_every'), self.replan_every, minimum=1)
    # Two of the samples are always the warm start and "float here".
    size('num_samples', 2)
    for field in ('grad_starts', 'grad_steps', 'grid_levels', 'scenarios',
                  'wind_memory'):
      size(field, 0)
    gin_values.require(self.num_segments <= self.horizon, name('num_segments'),
                       f'at most horizon ({self.horizon})', self.num_segments)
    gin_values.require(self.replan_every <= self.horizon, name('replan_every'),
                       f'at most horizon ({self.horizon})', self.replan_every)
    gin_values.require(self.grad_starts <= self.num_samples,
                       name('grad_starts'),
                       f'at most num_samples ({self.num_samples})',
                       self.grad_starts)
    gin_values.check_number(name('elite_fraction'), self.elite_fraction,
                            above=0.0, maximum=1.0)
    gin_values.check_number(name('float_probability'), self.float_probability,
                            minimum=0.0, maximum=1.0)
    gin_values.check_number(name('discount'), self.discount, above=0.0,
                            maximum=1.0)
    low, high = float(jax_env.ACTION_LOW[1]), float(jax_env.ACTION_HIGH[1])
    gin_values.check_number(name('time_factor'), self.time_factor,
                            minimum=low, maximum=high)
    low, high = float(jax_env.ACTION_LOW[0]), float(jax_env.ACTION_HIGH[0])
    gin_values.check_number(name('altitude_low_m'), self.altitude_low_m,
                            minimum=low, maximum=high)
    gin_values.check_number(name('altitude_high_m'), self.altitude_high_m,
                            minimum=self.altitude_low_m, maximum=high)
    for field in ('init_std_m', 'min_std_m', 'radius_km', 'radius_width_km',
                  'halflife_km', 'wind_correction_pa', 'grad_step_m'):
      gin_values.check_number(name(field), getattr(self, field), above=0.0)
    for field in ('shaping', 'progress', 'sand_cost', 'helium_cost',
                  'terminal_cost', 'helium_reserve', 'resource_buffer_kg',
                  'wind_correction_hours'):
      gin_values.check_number(name(field), getattr(self, field), minimum=0.0)
    gin_values.check_bool(name('plan_float'), self.plan_float)
    gin_values.require(self.search in SEARCHES, name('search'),
                       f'one of {SEARCHES}', self.search)
    size('beam_width', 1)
    gin_values.check_number(name('beam_cell_km'), self.beam_cell_km,
                            minimum=0.0)
    gin_values.check_number(name('beam_cell_m'), self.beam_cell_m, above=0.0)
    gin_values.check_number(name('beam_resource_value'),
                            self.beam_resource_value, minimum=0.0)
    gin_values.require(not (self.wind_memory and self.scenarios),
                       name('wind_memory'),
                       f'0 with scenarios ({self.scenarios})', self.wind_memory)
    if self.search == BEAM:
      gin_values.require(
          self.horizon % self.num_segments == 0, name('num_segments'),
          f'a divisor of horizon ({self.horizon}) for search={BEAM!r}',
          self.num_segments)
      gin_values.require(self.grid_levels >= 1, name('grid_levels'),
                         f'>= 1 for search={BEAM!r} (its choices)',
                         self.grid_levels)
    gin_values.require(
        isinstance(self.value_policy, str) and (
            self.value_policy in ('', 'shipped')
            or os.path.isfile(self.value_policy)),
        name('value_policy'), "'' (none), 'shipped' or a policy file",
        self.value_policy)
    gin_values.check_number(name('value_weight'), self.value_weight,
                            minimum=0.0)
    check_batch(self, 1, owner)
    return self

  @property
  def num_elites(self) -> int:
    return max(1, int(round(self.elite_fraction * self.num_samples)))

  def plan_strides(self) -> int:
    """Plan strides one balloon's decision flies at once (its memory).

    The largest of: the CEM's scored plans (samples, the warm start's two
    and the grid's 2 x grid_levels) x scenarios x horizon; their stacked
    samples over the iterations; the beam's children of one segment
    (beam_width x choices x the segment's strides) and its final plans
    scored over the horizon; the gradient's starts x scenarios x horizon.
    A config whose `checked` passed has only Python ints here (no
    overflow).
    """
    k = max(self.scenarios, 1) if self.mode != ORACLE else 1
    candidates = self.num_samples + 2 * self.grid_levels
    sizes = [self.iterations * candidates * self.num_segments,
             self.grad_starts * k * self.horizon]
    if self.search == BEAM:
      choices = self.grid_levels + 1
      sizes += [self.beam_width * choices * (self.horizon //
                                             self.num_segments),
                (self.beam_width + 2) * k * self.horizon]
    else:
      sizes.append(candidates * k * self.horizon)
    return max(sizes)


def check_batch(config: PlannerConfig, balloons: Any, owner: str = '',
                what: str = 'balloons per call') -> int:
  """Refuses a planning call that would fly too many plan strides at once.

  Args:
    config: The planner.
    balloons: Balloons planned in one call (a batch).
    owner: The gin configurable of `config` (named in the message), or ''.
    what: What `balloons` is (named in the message), e.g. '--batch'.

  Returns:
    `balloons` as int.

  Raises:
    errors.ConfigError: `balloons` not a positive int, or `balloons` x
      `config.plan_strides()` over `MAX_PLAN_STRIDES`; one line naming the
      setting that drives it.
  """
  balloons = gin_values.check_int(what, balloons, minimum=1,
                                  maximum=MAX_PLAN_STRIDES)
  total = balloons * config.plan_strides()
  if total > MAX_PLAN_STRIDES:
    driver = 'beam_width' if config.search == BEAM else 'num_samples'
    binding = (f'gin binding {owner}.{driver}' if owner else
               f'planner parameter {driver}')
    raise errors.ConfigError(
        f'{binding} = {getattr(config, driver)} (horizon {config.horizon}, '
        f'grid_levels {config.grid_levels}, scenarios {config.scenarios}) '
        f'with {what} = {balloons} would fly {total} plan strides at once; '
        f'at most {MAX_PLAN_STRIDES} (~16 GB)')
  return balloons


FIELDS = tuple(f.name for f in dataclasses.fields(PlannerConfig)
               if f.name != 'mode')
# The gin module of the planners' configurables: where the BLE agents of the
# same names lived (`agents/planners.py`, now `agents/planning/agents.py`), so
# `ble_latex.agents.planners.LatexMpcAgent.beam_width` keeps naming the
# binding it always named.
GIN_MODULE = 'ble_latex.agents.planners'


def _configurable(name: str, mode: str, doc: str,
                  **overrides: Any) -> Callable[..., PlannerConfig]:
  """Settings of planner `name`: config fields (keyword-only) -> its config.

  The fields' values are gin configurable `name`'s (its bindings over
  `overrides`, the planner's own defaults, over `PlannerConfig`'s), then
  the keywords given; the config is checked outside gin's call, so a bad
  value is one line naming its binding.
  """
  defaults = PlannerConfig(mode=mode, **overrides)

  def bound(**fields: Any) -> Dict[str, Any]:
    return fields

  # gin sees the config fields as keyword arguments.
  bound.__signature__ = inspect.Signature([
      inspect.Parameter(f, inspect.Parameter.KEYWORD_ONLY,
                        default=getattr(defaults, f)) for f in FIELDS])
  bound.__name__ = bound.__qualname__ = name
  bound.__doc__ = doc
  bound = gin.configurable(name, module=GIN_MODULE)(bound)

  def settings(**fields: Any) -> PlannerConfig:
    for key in fields:
      if key not in FIELDS:
        raise errors.ConfigError(f'{name}: unknown parameter {key!r} (one of '
                                 f'{list(FIELDS)})')
    merged = {f: getattr(defaults, f) for f in FIELDS}
    merged.update(bound(**fields))
    return PlannerConfig(mode=mode, **merged).checked(name)

  settings.__name__ = settings.__qualname__ = name
  settings.__doc__ = doc
  return settings


PLANNERS: Dict[str, Callable[..., PlannerConfig]] = {
    'latex_mpc': _configurable(
        'LatexMpcAgent', FORECAST,
        'Beam-search MPC on the forecast (agent latex_mpc); never reads the '
        'noise.', search=BEAM, wind_memory=16),
    'latex_mpc_oracle': _configurable(
        'LatexMpcOracleAgent', ORACLE,
        'Beam search over the whole episode on the true wind (agent '
        'latex_mpc_oracle): an upper bound.',
        search=BEAM, horizon=task.EPISODE_STEPS,
        num_segments=task.EPISODE_STEPS, replan_every=task.EPISODE_STEPS,
        beam_width=512, beam_cell_km=10.0, beam_resource_value=20.0,
        discount=1.0),
    'latex_mpc_grad': _configurable(
        'LatexMpcGradAgent', GRADIENT,
        'First-order MPC on the forecast (agent latex_mpc_grad).',
        iterations=1),
}


def from_gin(planner: str) -> PlannerConfig:
  """The checked config of `planner` ('latex_mpc', ...) under gin's bindings.

  Raises:
    errors.ConfigError: An unknown planner, or a bad binding (one line
      naming it, e.g. 'gin binding LatexMpcAgent.beam_width ...').
  """
  if planner not in PLANNERS:
    raise errors.ConfigError(
        f'unknown planner {planner!r}: one of {sorted(PLANNERS)}')
  return PLANNERS[planner]()
