# coding=utf-8
"""What the speed benchmarks share: timing, the timed flights, the record.

The scripts of benchmarks/ that time the package (`batch_speed.py`,
`noise_speed.py`, `core_profile.py`, `autoreset_speed.py`,
`gas_step_speed.py`, `estimator_cost.py`) parse their flags and call these:
- `time_compiled`: compile time, program size and best call of a jitted
  function;
- `rollout_speed`: balloon-steps/s of the batched env's `jax_env.rollout`
  (on BLE's VAE wind, or ERA5 in JAX on `paper_size_grid`);
- `STRIDE_SETUP` / `stride_setup`: the flight core's timed stride (calm
  air, balloons at 16-18 km under a ballast command), as source text, so
  the same text also runs against another tree's `ble_latex` in a
  subprocess (`gas_step_speed.py --compare_tree`);
- `record_header` and `write_results`: a record's command, date, machine
  and load (a speed is only read with the load it ran under).
"""

import datetime as dt
import json
import os
import platform
import resource
import sys
import time
from typing import Any, Callable, Dict, Optional, Sequence, Tuple

from ble_latex import safe_io

STRIDE_H = 20.0 / 60.0  # [h] simulated per latex step

# The timed stride's flights (`gas_step_speed.py`'s and `estimator_cost.py`'s):
# `calm(x, y, p, t)`, a windless field [m/s]; `flights(p, batch)`, the
# atmosphere, `batch` neutral balloons at 16-18 km, their ballast command and
# keys. Source text: it runs against other trees' ble_latex too.
STRIDE_SETUP = r'''
import jax, jax.numpy as jnp
from ble_latex.flight import atmosphere, dynamics, launch, params, state

def calm(x, y, p, t):
  return jnp.zeros_like(x), jnp.zeros_like(x)

def flights(p, batch):
  atm = atmosphere.reset(jax.random.PRNGKey(0))
  new = lambda h: launch.neutral_launch(p, atm, state.initial_state(
      p, h, atm_params=atm, key=jax.random.PRNGKey(1)))
  states = jax.vmap(new)(jnp.linspace(16000.0, 18000.0, batch))
  actions = jnp.tile(jnp.asarray([17500.0, 1.0, -1.0]), (batch, 1))
  keys = jax.random.split(jax.random.PRNGKey(2), batch)
  return atm, states, actions, keys
'''


def stride_setup() -> Tuple[Callable[..., Any], Callable[..., Any]]:
  """`STRIDE_SETUP`'s (calm, flights), defined against this ble_latex."""
  namespace: Dict[str, Any] = {}
  exec(STRIDE_SETUP, namespace)  # pylint: disable=exec-used
  return namespace['calm'], namespace['flights']


def record_header(script: str, argv: Optional[Sequence[str]],
                  batch: int) -> dict:
  """A record's command, date, machine, batch and load before the work.

  `script` is the file name under benchmarks/; `argv` its arguments
  (None: this process's).
  """
  return {
      'command': f'python benchmarks/{script} ' + ' '.join(
          sys.argv[1:] if argv is None else argv),
      'date': dt.datetime.now(dt.timezone.utc).isoformat(timespec='seconds'),
      'machine': f'{platform.machine()}, {os.cpu_count()} CPUs',
      'batch': batch, 'load_before': round(os.getloadavg()[0], 1)}


def write_results(results: dict, load_before: Sequence[float],
                  path: Optional[str], note: str = '') -> None:
  """Adds the machine and its load to `results`, prints it, writes JSON.

  The one ending of the speed benchmarks (batch_speed, noise_speed,
  core_profile, autoreset_speed): their numbers are only read with the load
  they ran under.
  """
  results['machine'] = {
      'cpus': os.cpu_count(), 'platform': platform.platform(),
      'loadavg_before': tuple(load_before), 'loadavg_after': os.getloadavg(),
      'command': ' '.join(sys.argv)}
  print(f'{note}load average before/after: {tuple(load_before)} / '
        f'{os.getloadavg()}')
  if path:
    safe_io.atomic_write(path, json.dumps(results, indent=1))


def time_compiled(fn: Callable[..., Any], args: Sequence[Any],
                  repeats: int) -> dict:
  """Compile time, program size and best call time of jax.jit(fn)(*args).

  Returns lower_s and compile_s [s] (wall time of lowering and of
  compiling), stablehlo_lines and hlo_lines (lines of the lowered StableHLO
  and of the optimised HLO), best_s and all_s [s] (the `repeats` calls
  after a warm-up call).
  """
  import jax  # pylint: disable=g-import-not-at-top

  t = time.perf_counter()
  lowered = jax.jit(fn).lower(*args)
  lower_s = time.perf_counter() - t
  t = time.perf_counter()
  compiled = lowered.compile()
  compile_s = time.perf_counter() - t
  jax.block_until_ready(compiled(*args))  # warm-up
  times = []
  for _ in range(repeats):
    t = time.perf_counter()
    jax.block_until_ready(compiled(*args))
    times.append(time.perf_counter() - t)
  return {'lower_s': lower_s, 'compile_s': compile_s,
          'stablehlo_lines': len(lowered.as_text().splitlines()),
          'hlo_lines': len(compiled.as_text().splitlines()),
          'best_s': min(times), 'all_s': times}


def paper_size_grid(era5_path: Optional[str] = None):
  """An ERA5 grid of the paper's size (random winds), or a file's.

  368 times (1 Nov 2022 - 31 Jan 2023, 6-hourly) x the request's pressure
  levels x +-5 deg at the paper's grid step, winds drawn N(0, 10 m/s) with
  seed 0; with `era5_path`, that file's grid.
  """
  import numpy as np  # pylint: disable=g-import-not-at-top
  from ble_latex.wind import era5_requests  # pylint: disable=g-import-not-at-top
  from ble_latex.wind import gridded  # pylint: disable=g-import-not-at-top
  from ble_latex.wind import gridded_jax  # pylint: disable=g-import-not-at-top
  if era5_path:
    return gridded_jax.grid_from_data(gridded.load(era5_path))
  hours = np.arange(368) * 6.0  # [h] 1 Nov 2022 - 31 Jan 2023 18:00.
  times = np.datetime64('2022-11-01T00:00', 'ns') + (
      hours * 3600).astype('timedelta64[s]')
  pressure = np.array(era5_requests.pressure_levels_hpa(),
                      np.float64) * 100.0  # [Pa]
  grid_deg = era5_requests.PAPER_GRID_DEG  # [deg]
  lats = np.round(np.arange(-4.0, 6.0 + 1e-9, grid_deg), 6)
  lons = np.round(np.arange(-118.0, -108.0 + 1e-9, grid_deg), 6)
  uv = np.random.default_rng(0).normal(
      0.0, 10.0, (len(hours), len(pressure), len(lats), len(lons), 2))
  data = gridded.Era5Data(('synthetic',), times, hours * 3600.0, pressure,
                          lats, lons, uv)
  return gridded_jax.grid_from_data(data)


def rollout_speed(batch: int, steps: int, repeats: int, wind: str = 'vae',
                  era5_path: Optional[str] = None) -> dict:
  """Times `jax_env.rollout` of `batch` balloons for `steps` strides.

  `wind`: 'vae' (BLE's generative field) or 'era5' (`paper_size_grid`).
  The first call (compile + run), then the best of `repeats` calls with
  fresh keys and random actions; balloon-steps/s and simulated hours per
  wall second of the best.
  """
  import jax  # pylint: disable=g-import-not-at-top
  import jax.numpy as jnp  # pylint: disable=g-import-not-at-top
  import ble_latex  # noqa: F401  pylint: disable=g-import-not-at-top,unused-import
  from ble_latex.envs import env_params  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import jax_env  # pylint: disable=g-import-not-at-top
  from ble_latex.run import gin_binding  # pylint: disable=g-import-not-at-top

  gin_binding.bind_gin(None, None, [], [])
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  params = env.default_params
  grid_shape = None
  if wind == 'era5':
    params = env_params.check_params(params.replace(
        wind_grid=paper_size_grid(era5_path)))
    grid_shape = list(params.wind_grid.uv.shape)
  low = jnp.asarray(jax_env.ACTION_LOW)
  high = jnp.asarray(jax_env.ACTION_HIGH)

  def run(seed):
    key = jax.random.PRNGKey(seed)
    keys = jax.random.split(key, batch)
    actions = jax.random.uniform(jax.random.fold_in(key, 1), (steps, batch, 3),
                                 minval=low, maxval=high)
    out = jax_env.rollout(env, keys, actions, params, steps)
    jax.block_until_ready(out)
    return out

  t = time.perf_counter()
  obs, _, _ = run(0)
  first = time.perf_counter() - t
  times = []
  for r in range(repeats):
    t = time.perf_counter()
    run(r + 1)
    times.append(time.perf_counter() - t)
  wall = min(times)
  return {
      'env': 'LatexBalloonJaxEnv', 'wind': wind, 'grid_shape': grid_shape,
      'era5_path': era5_path, 'batch': batch, 'steps': steps,
      'first_call_s': first, 'wall_s': wall, 'all_wall_s': times,
      'balloon_steps_per_s': batch * steps / wall,
      'sim_hours_per_wall_s': batch * steps * STRIDE_H / wall,
      'finite_obs': bool(jnp.all(jnp.isfinite(obs))),
      'peak_rss_mb': resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
      'device': str(jax.devices()[0]),
  }
