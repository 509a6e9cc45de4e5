# coding=utf-8
"""Records golden trajectories of today's `LatexBalloon-v0` (issue 11).

Before the latex balloon's physics / wind move to a pure JAX core, this script
flies today's env (`import ble_latex; gym.make('LatexBalloon-v0')`, default
gin settings = gin_configs/latex_env.gin + latex_physics.gin) and stores what
happened, so that `tests/ble/test_golden.py` can check that a new implementation
reproduces it.

  .venv/bin/python tests/data/make_golden.py            # writes tests/data/
  .venv/bin/python tests/data/make_golden.py --seeds 0 1 --output_dir /tmp/g

The committed files were recorded from the committed code (HEAD 01b45dd)
while others were editing the checkout, importing ble_latex from an export:

  git archive HEAD ble_latex gin_configs setup.py | tar -x -C /tmp/head
  PYTHONPATH=/tmp/head .venv/bin/python tests/data/make_golden.py

Seeds: 0..9 and 1000000..1000009 (20 flights; the same 20 starts, atmospheres
and wind fields in both files). Each seed is flown for up to 216 steps (3 days)
by two deterministic action sources, one file each:

- `golden_random.npz`: uniform random actions in the Box, drawn up front by
  `np.random.default_rng(seed).uniform(ACTION_LOW, ACTION_HIGH, (216, 3))`.
- `golden_scripted.npz`: `scripted_action`, a 72-step (one day) script
  rotated by seed % 72 that floats, climbs to 20 km with time factor 1, asks
  for 23 km (clipped at the Box edge, 21 km) with factors 1 and 5, descends
  to 15 km with factor 3, asks for 12 km (clipped to 14 km), uses a2 = 0 (not a
  float) and a2 = 1e-3 (a float), makes moves too small for the vent /
  ballast thresholds and holds its altitude (hdot_des = 0).

An episode ends early when the balloon runs out of sand or helium, bursts or
lands; its length is `episode_length`, later entries are padding (NaN, -1 or
'').

Layout of each npz (S = 20 seeds, T = 216 steps; float64 unless noted; no
object arrays, load with `allow_pickle=False`):

- per step t < T: `action` (S, T, 3), `reward`, `done`, `truncated` (S, T),
  `terminal_reason` and `controller_decision` (S, T) unicode = info's strings,
  `distance_km` (S, T) = info['distance_km'].
- states: `obs` (S, T + 1, 71) and `state_<field>` (S, T + 1): index 0 is
  after reset, index t + 1 after step t, so `[:, t]` is the state BEFORE step
  t and `[:, t + 1]` the state AFTER it (STATE_FIELDS lists the fields; the
  enums `state_latex_status` / `state_last_decision` / `state_status` are
  int64 codes, see `status_names`, `decision_names`, `ble_status_names`).
  `wind_u_mps`, `wind_v_mps` (S, T + 1): BLE's ground-truth wind (forecast +
  simplex noise) at the balloon for that state, as the observation sees it.
- per seed: `seeds`, `episode_length` (int64), `final_status` (unicode),
  `start_date_time` (ISO unicode), `start_posix_s`, `center_lat_deg`,
  `center_lng_deg`, `payload_kg`, `drag_coefficient`, `burst_volume_m3`,
  atmosphere `atmosphere_alpha`, `lapse_rates` (S, 7),
  `temperature_transitions`, `pressure_transitions` (S, 8); the wind field's
  `vae_latents` (S, 64, float32 values), `wind_field_sha256` (of BLE's VAE
  field array, float32 (21, 21, 10, 9, 2)); the simplex noise's
  `noise_seeds` (S, 2, 5) int64 (OpenSimplex seed of component u/v,
  harmonic k) and `noise_offsets` (S, 2, 5, 4) (x, y, pressure, time
  offsets, float32 values); and the JAX PRNG keys (uint32 pairs as int64) of
  BLE's reset chain: `key_env`, `key_arena`, `key_atmosphere`, `key_time`,
  `key_balloon` (S, 4, 2: distance, angle, location, altitude),
  `key_wind_field`, `key_noise`, `key_forecast`.
- constants: `harmonic_params` (2, 5, 5): weight, x/y [km], pressure [Pa] and
  time [h] spacings of BLE's noise harmonics; `meta`: a JSON string (versions,
  git commit, seeds, policies, field units, enum mappings).
"""

# Reads BLE / env internals (atmosphere, wind field, noise) on purpose.
# pylint: disable=protected-access

import argparse
import datetime as dt
import hashlib
import importlib.metadata
import json
import os
import pathlib
import platform
import subprocess
import sys
import time
from typing import Any, Callable, Dict, List, Optional, Sequence

os.environ.setdefault('TF_CPP_MIN_LOG_LEVEL', '3')
os.environ.setdefault('JAX_PLATFORMS', 'cpu')

# pylint: disable=g-import-not-at-top,wrong-import-position
import ble_latex  # noqa: E402  (BLE compatibility fixes first)
from balloon_learning_environment.env.balloon import balloon as ble_balloon
from balloon_learning_environment.generative import vae
from balloon_learning_environment.utils import sampling
import gym
import jax
import numpy as np

from ble_latex.ble import balloon as balloon_lib
from ble_latex.flight import state as state_lib
from ble_latex.envs import jax_env
# pylint: enable=g-import-not-at-top,wrong-import-position

ENV_ID = 'LatexBalloon-v0'
EPISODE_STEPS = 216
DEFAULT_SEEDS = tuple(range(10)) + tuple(range(1_000_000, 1_000_010))
SOURCES = ('random', 'scripted')
OBS_SIZE = 71

# The balloon state recorded at every step: (npz key suffix, unit/meaning).
# Enum fields are int64 codes (see ENUMS); the rest float64.
STATE_FIELDS = (
    ('x_m', 'm east of the station (BLE state.x)'),
    ('y_m', 'm north of the station (BLE state.y)'),
    ('altitude_m', 'm'),
    ('ascent_rate_mps', 'm/s'),
    ('helium_mols', 'mol aboard'),
    ('sand_kg', 'kg aboard'),
    ('helium_vented_mols', 'mol, cumulative'),
    ('sand_dropped_kg', 'kg, cumulative'),
    ('pending_vent_mols', 'mol still to vent (finite valve flow only)'),
    ('pending_drop_kg', 'kg still to drop (finite ballast rate only)'),
    ('time_elapsed_s', 's since reset'),
    ('date_time_posix_s', 's since 1970-01-01 UTC'),
    ('pressure_pa', 'Pa at the balloon (BLE state.pressure)'),
    ('ambient_temperature_k', 'K'),
    ('internal_temperature_k', 'K'),
    ('envelope_volume_m3', 'm^3'),
    ('mols_lift_gas', 'mol (BLE field, = helium_mols)'),
    ('last_action_a0_m', 'a0 of the last action, m'),
    ('last_action_a1', 'a1 of the last action'),
    ('last_action_a2', 'a2 of the last action'),
    ('last_float_action', 'a2 of the last action'),
    ('desired_ascent_rate_mps', 'hdot_des of the last action, m/s'),
    ('guard_engaged', '1.0 if the band guard floated in the last step'),
    ('latex_status', 'int code, status_names'),
    ('last_decision', 'int code, decision_names'),
    ('status', "int code of BLE's BalloonStatus, ble_status_names"),
)
ENUM_FIELDS = ('latex_status', 'last_decision', 'status')
STATUS_NAMES = tuple(s.name.lower() for s in balloon_lib.LatexBalloonStatus)
DECISION_NAMES = tuple(d.name.lower() for d in state_lib.DecisionCode)
BLE_STATUS_NAMES = tuple(s.name.lower() for s in ble_balloon.BalloonStatus)

# The scripted policy: (steps, a0 rule, a0 [m] or offset [m], a1, a2).
# a0 rule 'abs' = that altitude clipped to the Box, 'rel' = the current
# altitude + offset (clipped). 72 steps (one day), rotated by seed % 72.
SCRIPT = (
    (4, 'abs', 17_500.0, 1.0, 1.0),    # float
    (6, 'abs', 20_000.0, 1.0, -1.0),   # climb to 20 km, time factor 1
    (3, 'abs', 20_000.0, 1.0, 1.0),    # float
    (2, 'abs', 23_000.0, 1.0, -1.0),   # above the Box: clipped to 21 km
    (1, 'abs', 23_000.0, 5.0, -1.0),
    (3, 'abs', 20_000.0, 1.0, 1.0),    # float
    (8, 'abs', 15_000.0, 3.0, -1.0),   # descend to 15 km, time factor 3
    (3, 'abs', 15_000.0, 1.0, 1.0),    # float
    (2, 'abs', 12_000.0, 1.0, -1.0),   # below the Box: clipped to 14 km
    (1, 'abs', 12_000.0, 5.0, -1.0),
    (3, 'abs', 15_000.0, 1.0, 1.0),    # float
    (2, 'abs', 17_500.0, 2.0, 0.0),    # a2 = 0 exactly: not a float
    (4, 'abs', 17_500.0, 2.0, -1.0),   # back up, time factor 2
    (1, 'rel', 0.0, 1.0, 1e-3),        # smallest float flag
    (3, 'rel', 20.0, 5.0, -1.0),       # small moves: below the vent /
    (3, 'rel', -20.0, 5.0, -1.0),      # ballast thresholds once floating
    (2, 'rel', 0.0, 1.0, -1.0),        # hold: hdot_des = 0
    (6, 'abs', 17_500.0, 1.0, 1.0),    # float
    (15, 'rel', 0.0, 5.0, -1.0),       # hold (drift) with time factor 5
)
_SCRIPT_STEPS = [row for row in SCRIPT for _ in range(row[0])]


def scripted_action(step: int, seed: int, altitude_m: float) -> np.ndarray:
  """The scripted policy's action (a0 [m], a1, a2) at `step` of `seed`.

  Args:
    step: Step index in the episode (0-based).
    seed: Env seed (rotates the script by seed % len(script)).
    altitude_m: Balloon altitude before the step (for 'rel' rows). # [m]

  Returns:
    A float64 action inside the Box.
  """
  _, rule, value, a1, a2 = _SCRIPT_STEPS[(step + seed) % len(_SCRIPT_STEPS)]
  a0 = value if rule == 'abs' else altitude_m + value
  low, high = jax_env.ACTION_LOW, jax_env.ACTION_HIGH
  return np.array([np.clip(a0, float(low[0]), float(high[0])), a1, a2],
                  dtype=np.float64)


def random_actions(seed: int, steps: int = EPISODE_STEPS) -> np.ndarray:
  """The random policy's actions: uniform in the Box, seeded by `seed`."""
  rng = np.random.default_rng(seed)
  return rng.uniform(jax_env.ACTION_LOW, jax_env.ACTION_HIGH,
                     size=(steps, 3)).astype(np.float64)


# A policy maps (step, balloon state before the step) to an action.
Policy = Callable[[int, balloon_lib.LatexBalloonState], np.ndarray]


def make_policy(source: str, seed: int) -> Policy:
  """The deterministic policy of `source` ('random' or 'scripted')."""
  if source == 'random':
    actions = random_actions(seed)
    return lambda step, state: actions[step]
  if source == 'scripted':
    return lambda step, state: scripted_action(step, seed, state.altitude_m)
  raise ValueError(f'unknown action source {source!r}; expected {SOURCES}')


def replay_policy(actions: np.ndarray) -> Policy:
  """A policy that plays back recorded actions (NaN padding never reached)."""
  actions = np.asarray(actions, dtype=np.float64)
  return lambda step, state: actions[step]


def state_record(state: balloon_lib.LatexBalloonState) -> Dict[str, float]:
  """The STATE_FIELDS of a balloon state as floats (enums as int codes)."""
  a0, a1, a2 = state.last_action
  return {
      'x_m': state.x.meters,
      'y_m': state.y.meters,
      'altitude_m': state.altitude_m,
      'ascent_rate_mps': state.ascent_rate_mps,
      'helium_mols': state.helium_mols,
      'sand_kg': state.sand_kg,
      'helium_vented_mols': state.helium_vented_mols,
      'sand_dropped_kg': state.sand_dropped_kg,
      'pending_vent_mols': state.pending_vent_mols,
      'pending_drop_kg': state.pending_drop_kg,
      'time_elapsed_s': state.time_elapsed.total_seconds(),
      'date_time_posix_s': state.date_time.timestamp(),
      'pressure_pa': state.pressure,
      'ambient_temperature_k': state.ambient_temperature,
      'internal_temperature_k': state.internal_temperature,
      'envelope_volume_m3': state.envelope_volume,
      'mols_lift_gas': state.mols_lift_gas,
      'last_action_a0_m': a0,
      'last_action_a1': a1,
      'last_action_a2': a2,
      'last_float_action': state.last_float_action,
      'desired_ascent_rate_mps': state.desired_ascent_rate_mps,
      'guard_engaged': float(state.guard_engaged),
      'latex_status': STATUS_NAMES.index(state.latex_status.name.lower()),
      'last_decision': DECISION_NAMES.index(state.last_decision.name.lower()),
      'status': BLE_STATUS_NAMES.index(state.status.name.lower()),
  }


def make_env() -> gym.Env:
  """Today's env, as users get it.

  The construction seed only avoids BLE's time-based default seed (each
  flight re-seeds everything with `reset(seed=...)`).
  """
  return gym.make(ENV_ID, seed=0)


def fly(env: gym.Env, seed: int, policy: Policy,
        max_steps: int = EPISODE_STEPS) -> Dict[str, np.ndarray]:
  """Flies one episode from `seed`, recording every step.

  Args:
    env: A `LatexBalloon-v0` env (wrapped or not).
    seed: Passed to `env.reset(seed=seed)`.
    policy: (step, state before the step) -> action.
    max_steps: Steps at most (the env ends the episode at 216 anyway).

  Returns:
    One unpadded episode: per-step arrays of length L = episode length
    (`action` (L, 3), `reward`, `done`, `truncated`, `distance_km`,
    `terminal_reason`, `controller_decision`) and per-state arrays of length
    L + 1 (`obs` (L + 1, 71), `state_<field>`, `wind_u_mps`, `wind_v_mps`).
  """
  arena = env.unwrapped.arena
  steps: Dict[str, List[Any]] = {k: [] for k in (
      'action', 'reward', 'done', 'truncated', 'distance_km',
      'terminal_reason', 'controller_decision')}
  states: Dict[str, List[Any]] = {'obs': [], 'wind_u_mps': [],
                                  'wind_v_mps': []}
  for name, _ in STATE_FIELDS:
    states['state_' + name] = []

  def record_state(obs: np.ndarray) -> None:
    states['obs'].append(np.asarray(obs, dtype=np.float64))
    for name, value in state_record(arena.get_balloon_state()).items():
      states['state_' + name].append(value)
    # The arena's measurement (BLE's arena interface).
    wind = arena.get_measurements().wind_at_balloon
    states['wind_u_mps'].append(wind.u.meters_per_second)
    states['wind_v_mps'].append(wind.v.meters_per_second)

  record_state(env.reset(seed=seed))
  for step in range(max_steps):
    action = np.asarray(policy(step, arena.get_balloon_state()),
                        dtype=np.float64)
    obs, reward, done, info = env.step(action)
    steps['action'].append(action)
    steps['reward'].append(reward)
    steps['done'].append(float(done))
    steps['truncated'].append(float(info.get('TimeLimit.truncated', False)))
    steps['distance_km'].append(info['distance_km'])
    steps['terminal_reason'].append(info['terminal_reason'])
    steps['controller_decision'].append(info['controller_decision'])
    record_state(obs)
    if done:
      break
  episode = {}
  for key, values in {**steps, **states}.items():
    if key in ('terminal_reason', 'controller_decision'):
      episode[key] = np.asarray(values, dtype='<U16')
    elif key.replace('state_', '') in ENUM_FIELDS:
      episode[key] = np.asarray(values, dtype=np.int64)
    else:
      episode[key] = np.asarray(values, dtype=np.float64)
  return episode


def _key(key: Any) -> np.ndarray:
  return np.asarray(jax.random.key_data(key) if jax.dtypes.issubdtype(
      key.dtype, jax.dtypes.prng_key) else key).astype(np.int64)


def seed_record(env: gym.Env, seed: int) -> Dict[str, Any]:
  """What BLE samples at `reset(seed)`: keys, atmosphere, wind field, noise.

  Re-derives BLE's PRNG chain (BalloonEnv.reset -> BalloonArena.reset ->
  LatexBalloonArena._initialize_balloon -> WindField.reset) and checks every
  derived value against the env's objects, so the keys are the env's.

  Args:
    env: The env, just reset with `seed`.
    seed: The seed.

  Returns:
    Per-seed values (numpy arrays / strings).
  """
  simulator_state = env.unwrapped.arena.get_simulator_state()
  state = simulator_state.balloon_state
  atmosphere = simulator_state.atmosphere
  wind_field = simulator_state.wind_field
  key_env = jax.random.PRNGKey(seed)
  _, key_arena = jax.random.split(key_env)
  rng, key_atmosphere, key_time = jax.random.split(key_arena, 3)
  rng, *key_balloon = jax.random.split(rng, num=5)
  rng, key_wind_field = jax.random.split(rng, 2)
  key_noise, key_forecast = jax.random.split(key_wind_field, num=2)

  alpha = jax.random.uniform(key_atmosphere).item()
  lapse_rates = np.asarray(atmosphere._lapse_rates, dtype=np.float64)
  expected = ((1 - alpha) * atmosphere._LAPSE_RATES_LOW +
              alpha * atmosphere._LAPSE_RATES_HIGH)
  assert np.array_equal(lapse_rates, expected), (seed, 'atmosphere')
  start = sampling.sample_time(key_time)
  assert start == state.date_time - state.time_elapsed, (seed, 'time')

  latents = jax.random.normal(key_forecast, shape=(64,))
  field = np.asarray(wind_field.field)
  assert np.array_equal(
      np.array(vae.Decoder().apply(wind_field.params, latents)), field), (
          seed, 'wind field')

  noise_seeds = np.zeros((2, 5), dtype=np.int64)
  noise_offsets = np.zeros((2, 5, 4), dtype=np.float64)
  components = (wind_field._noise_model.noise_u,
                wind_field._noise_model.noise_v)
  for c, (component, key_c) in enumerate(
      zip(components, jax.random.split(key_noise, num=2))):
    for k, (harmonic, key_h) in enumerate(zip(
        component._harmonics, jax.random.split(key_c, num=5))):
      noise_seeds[c, k] = int(jax.random.choice(key_h, 1634753849))
      offsets = np.asarray(jax.random.uniform(key_h, (4,)) * 2.0 - 1.0)
      o = harmonic._offsets
      actual = np.array([o.x, o.y, o.pressure, o.time], dtype=np.float32)
      assert np.array_equal(offsets, actual), (seed, 'noise', c, k)
      noise_offsets[c, k] = offsets.astype(np.float64)

  return {
      'start_date_time': start.isoformat(),
      'start_posix_s': start.timestamp(),
      'center_lat_deg': state.center_latlng.lat().degrees,
      'center_lng_deg': state.center_latlng.lng().degrees,
      'payload_kg': state.payload_kg,
      'drag_coefficient': state.drag_coefficient,
      'burst_volume_m3': state.burst_volume_m3,
      'atmosphere_alpha': alpha,
      'lapse_rates': lapse_rates,
      'temperature_transitions': np.asarray(
          atmosphere._temperature_transitions, dtype=np.float64),
      'pressure_transitions': np.asarray(
          atmosphere._pressure_transitions, dtype=np.float64),
      'vae_latents': np.asarray(latents, dtype=np.float64),
      'wind_field_sha256': hashlib.sha256(
          np.ascontiguousarray(field).tobytes()).hexdigest(),
      'noise_seeds': noise_seeds,
      'noise_offsets': noise_offsets,
      'key_env': _key(key_env),
      'key_arena': _key(key_arena),
      'key_atmosphere': _key(key_atmosphere),
      'key_time': _key(key_time),
      'key_balloon': np.stack([_key(k) for k in key_balloon]),
      'key_wind_field': _key(key_wind_field),
      'key_noise': _key(key_noise),
      'key_forecast': _key(key_forecast),
  }


def harmonic_params(env: gym.Env) -> np.ndarray:
  """BLE's noise harmonics (2 components, 5 harmonics, 5 parameters)."""
  noise = env.unwrapped.arena._wind_field._noise_model
  return np.array([[[h.weight, h.x_spacing, h.y_spacing, h.pressure_spacing,
                     h.time_spacing] for h in component._harmonics]
                   for component in (noise.noise_u, noise.noise_v)],
                  dtype=np.float64)


def pad_episodes(episodes: Sequence[Dict[str, np.ndarray]],
                 steps: int = EPISODE_STEPS) -> Dict[str, np.ndarray]:
  """Stacks episodes, padding steps to `steps` and states to `steps` + 1.

  Padding: NaN for floats, -1 for int codes, '' for strings.
  """
  stacked = {}
  for key in episodes[0]:
    per_state = key == 'obs' or key.startswith('state_') or key.startswith(
        'wind_')
    length = steps + 1 if per_state else steps
    first = episodes[0][key]
    shape = (len(episodes), length) + first.shape[1:]
    if first.dtype.kind == 'U':
      out = np.full(shape, '', dtype=first.dtype)
    elif first.dtype.kind == 'i':
      out = np.full(shape, -1, dtype=np.int64)
    else:
      out = np.full(shape, np.nan, dtype=np.float64)
    for i, episode in enumerate(episodes):
      out[i, :len(episode[key])] = episode[key]
    stacked[key] = out
  return stacked


def _git(*args: str) -> str:
  repo = pathlib.Path(__file__).resolve().parents[2]
  try:
    return subprocess.run(['git', *args], cwd=repo, capture_output=True,
                          text=True, check=True).stdout.strip()
  except (OSError, subprocess.CalledProcessError):
    return 'unknown'


def _version(package: str) -> str:
  try:
    return importlib.metadata.version(package)
  except importlib.metadata.PackageNotFoundError:
    return 'not installed'


def meta_record(source: str, seeds: Sequence[int], lengths: Sequence[int],
                final: Sequence[str], seconds: float,
                source_note: str = '') -> Dict[str, Any]:
  """The `meta` JSON of one file."""
  package = pathlib.Path(ble_latex.__file__).resolve().parent
  repo = pathlib.Path(__file__).resolve().parents[2]
  dirty = ([line[3:] for line in _git('status', '--porcelain').splitlines()
            if line[3:].startswith('ble_latex/')]
           if package == repo / 'ble_latex' else 'n/a: not the checkout')
  return {
      'what': f'golden trajectories of {ENV_ID}, action source {source!r}',
      'issue': 11,
      'made_by': 'tests/data/make_golden.py ' + ' '.join(sys.argv[1:]),
      'made_at_utc': dt.datetime.now(dt.timezone.utc).isoformat(
          timespec='seconds'),
      'record_seconds': round(seconds, 1),
      'env_id': ENV_ID,
      'gin': 'none bound (defaults = gin_configs/latex_env.gin + '
             'latex_physics.gin)',
      'episode_steps': EPISODE_STEPS,
      'seeds': list(map(int, seeds)),
      'episode_length': list(map(int, lengths)),
      'final_status': list(final),
      'policy': (
          'np.random.default_rng(seed).uniform(ACTION_LOW, ACTION_HIGH, '
          '(216, 3))' if source == 'random' else
          'make_golden.scripted_action: SCRIPT rotated by seed % 72'),
      'script': [list(row) for row in SCRIPT],
      'states': 'index 0 after reset, index t + 1 after step t '
                '(before step t = [:, t], after step t = [:, t + 1])',
      'state_fields': dict(STATE_FIELDS),
      'status_names': list(STATUS_NAMES),
      'decision_names': list(DECISION_NAMES),
      'ble_status_names': list(BLE_STATUS_NAMES),
      'padding': 'NaN (floats), -1 (int codes), empty string (strings)',
      'versions': {
          'python': platform.python_version(),
          'numpy': np.__version__,
          'jax': jax.__version__,
          'jaxlib': _version('jaxlib'),
          'gym': gym.__version__,
          'balloon-learning-environment': _version(
              'balloon-learning-environment'),
          'opensimplex': _version('opensimplex'),
          'ble_latex': ble_latex.__version__,
      },
      'git_commit': _git('rev-parse', 'HEAD'),
      'ble_latex_imported_from': str(package),
      'source_note': source_note,
      'git_dirty_ble_latex_files': dirty,
  }


def record(source: str, seeds: Sequence[int], env: Optional[gym.Env] = None,
           source_note: str = '') -> Dict[str, np.ndarray]:
  """Flies `seeds` with the `source` policy; returns the npz arrays."""
  env = env if env is not None else make_env()
  start = time.time()
  episodes, per_seed = [], []
  for seed in seeds:
    episodes.append(fly(env, seed, make_policy(source, seed)))
    # Re-reset for the per-seed record (the flight changed the state).
    env.reset(seed=seed)
    per_seed.append(seed_record(env, seed))
  seconds = time.time() - start
  arrays = pad_episodes(episodes)
  for key in per_seed[0]:
    values = [record_[key] for record_ in per_seed]
    if isinstance(values[0], str):
      arrays[key] = np.asarray(values, dtype=f'<U{max(map(len, values))}')
    else:
      arrays[key] = np.asarray(values, dtype=(
          np.int64 if np.asarray(values[0]).dtype.kind in 'iu' else
          np.float64))
  lengths = [len(e['reward']) for e in episodes]
  final = [str(e['terminal_reason'][-1]) for e in episodes]
  arrays['seeds'] = np.asarray(seeds, dtype=np.int64)
  arrays['episode_length'] = np.asarray(lengths, dtype=np.int64)
  arrays['final_status'] = np.asarray(final, dtype='<U16')
  arrays['harmonic_params'] = harmonic_params(env)
  arrays['status_names'] = np.asarray(STATUS_NAMES)
  arrays['decision_names'] = np.asarray(DECISION_NAMES)
  arrays['ble_status_names'] = np.asarray(BLE_STATUS_NAMES)
  arrays['meta'] = np.asarray(json.dumps(
      meta_record(source, seeds, lengths, final, seconds, source_note),
      indent=1))
  for key, value in arrays.items():
    assert value.dtype.kind in 'fiU', (key, value.dtype)
  return arrays


def main(argv: Optional[Sequence[str]] = None) -> None:
  parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
  parser.add_argument('--seeds', type=int, nargs='+',
                      default=list(DEFAULT_SEEDS))
  parser.add_argument('--sources', nargs='+', default=list(SOURCES),
                      choices=SOURCES)
  parser.add_argument('--output_dir', default=str(
      pathlib.Path(__file__).resolve().parent))
  parser.add_argument('--source_note', default='',
                      help='Free text stored in meta (e.g. where ble_latex '
                      'was imported from).')
  args = parser.parse_args(argv)
  env = make_env()
  out = pathlib.Path(args.output_dir)
  out.mkdir(parents=True, exist_ok=True)
  for source in args.sources:
    start = time.time()
    arrays = record(source, args.seeds, env, args.source_note)
    path = out / f'golden_{source}.npz'
    np.savez_compressed(path, **arrays)
    print(f'{path}: {path.stat().st_size / 1e6:.2f} MB, '
          f'{time.time() - start:.1f} s')
    for seed, length, final in zip(args.seeds, arrays['episode_length'],
                                   arrays['final_status']):
      if length < EPISODE_STEPS:
        print(f'  seed {seed}: ended after {length} steps ({final})')


if __name__ == '__main__':
  main()
