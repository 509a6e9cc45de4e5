# coding=utf-8
"""The realistic physics' sensitivity grid: a cell's params, flights, summary.

Issue 44, item 6 (`benchmarks/realistic_sensitivity.py` parses the grid and
writes the record): each cell (lift disturbance sigma [g/sqrt(s)] x the
helium's day-night swing S [K]) flies the same seeds under
gin_configs/latex_realistic.gin with that sigma and swing, everything else
as calibrated.
- `env_params`: the realistic preset's EnvParams for `steps`-stride flights;
- `cell_params`: a cell's sigma and swing (S split in the calibrated
  proportion);
- `flier`: a pure JAX controller (`launch.controllers`, built by the
  script) flying all seeds of a cell in one jitted, vmapped scan (each
  seed's world is the gym env's);
- `summarize`: days aloft, the share aloft at the end, TW50 over the whole
  flight, sand dropped.
"""

from typing import Any, Dict

import gin
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import configs
from ble_latex.envs import env_params as env_params_lib
from ble_latex.envs import jax_env
from ble_latex.flight import params as params_lib
from ble_latex.flight import state as state_lib

SECONDS_PER_DAY = 86_400.0  # [s]
GIN_FILES = ('latex_physics.gin', 'latex_realistic.gin')


def env_params(steps: int):
  """EnvParams of the realistic physics for `steps`-stride flights."""
  gin.clear_config()
  try:
    gin.parse_config_files_and_bindings(
        [configs.gin_file(name) for name in GIN_FILES],
        [f'latex_episode.episode_steps = {steps}'])
    return env_params_lib.params_from_gin()
  finally:
    gin.clear_config()


def cell_params(params, sigma_g: float, swing_k: float):
  """`params` with disturbance sigma [g/sqrt(s)] and day-night swing [K].

  Since issue 68 the preset's disturbance is the bounded heating; the walk
  at sigma (switched on here: a static field) flies on top of it.
  """
  day = params_lib.REALISTIC['superheat_day_k']
  night = params_lib.REALISTIC['cooling_night_k']
  share = day / (day + night)
  return params.replace(flight=params.flight.replace(
      lift_walk=float(sigma_g) > 0.0,
      lift_walk_kg_per_sqrt_s=float(sigma_g) * 1e-3,
      superheat_day_k=float(swing_k) * share,
      cooling_night_k=float(swing_k) * (1.0 - share)))


def flier(controller, steps: int):
  """Jitted (params, keys [N]) -> per-seed strides aloft, within, sand."""
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  ok = int(state_lib.FlightStatus.OK)

  def one(params, key):
    obs, state = env.reset(key, params)

    def stride(carry, _):
      state, obs, control, aloft, within = carry
      alive = state.flight.status == ok
      action, control = controller.act(control, obs, state,
                                        jnp.zeros((), jnp.int32))
      obs, state, _, _, info = env.step_env(None, state, action, params)
      aloft = aloft + alive
      within = within + (alive & (info['distance_km'] <= params.radius_km))
      return (state, obs, control, aloft, within), None

    zero = jnp.zeros((), jnp.int32)
    carry = (state, obs, controller.init(obs, state), zero, zero)
    (state, _, _, aloft, within), _ = jax.lax.scan(stride, carry, None,
                                                    length=steps)
    return aloft, within, state.flight.sand_dropped_kg, state.flight.status

  return jax.jit(jax.vmap(one, in_axes=(None, 0)))


def summarize(aloft, within, sand, status, steps: int,
              stride_s: float) -> Dict[str, Any]:
  days = np.asarray(aloft, np.float64) * stride_s / SECONDS_PER_DAY
  tw50 = np.asarray(within, np.float64) / steps
  status = np.asarray(status)
  return {
      'days_aloft_mean': float(days.mean()),
      'days_aloft_std': float(days.std()),
      'aloft_at_end_pct': float(
          100.0 * (status == int(state_lib.FlightStatus.OK)).mean()),
      'tw50_mean': float(tw50.mean()),
      'tw50_std': float(tw50.std()),
      'sand_dropped_kg_mean': float(np.asarray(sand).mean()),
      'days_aloft': [round(float(d), 3) for d in days],
  }
