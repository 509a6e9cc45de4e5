# coding=utf-8
"""The planners' batched flights on the JAX core, without BLE's gym env.

`fly_batch` flies N seeds of a planner (`plan_config.PLANNERS`) together:
each flight starts from the core's own `jax_env.LatexBalloonJaxEnv.reset`
(the same worlds as the gym env's reset for the same seeds), one vmapped
`planning.plan_batch` call plans for the whole batch, then the batch flies
`replan_every` strides in one jitted `lax.scan`. The records are
`eval_lib.fly`'s (flight paths included), in seed order.

This is `run/batch_eval.py`'s batched eval for the planners where BLE's gym
env cannot be built: that module registers BLE's agents and gym env, which
import TensorFlow, and a lent GPU's image has none
(`tests/test_no_tensorflow.py`). This module imports only the core, the
planners' pure JAX modules and the records, so `benchmarks/planners.py` and
`benchmarks/real_winds.py` fly the planners here; `batch_eval` shares its
batch size and flight fields (`BATCH_SIZE`, `FLIGHT_FIELDS`).
"""

import sys
import time
from typing import Any, Dict, List, Sequence, Set, Tuple

import numpy as np

# Seeds flown together. The planners' batched call grows with it (the
# oracle's beam: ~0.4 GB per balloon); `run/batch_eval.py` flies as many.
BATCH_SIZE = 25
# Flight-state fields of a flight point (`runner.flight_point`).
FLIGHT_FIELDS = ('time_s', 'x_m', 'y_m', 'altitude_m', 'ascent_rate_mps',
                 'last_decision', 'helium_mols', 'sand_kg')


def _fly_functions(config: Any, env: Any):
  """Jitted: [N] new flights; [N] plans flown `replan_every` strides."""
  # pylint: disable=g-import-not-at-top
  import jax
  from ble_latex.agents.planning import planner as planning
  from ble_latex.envs import jax_env
  from ble_latex.envs import rollout
  # pylint: enable=g-import-not-at-top

  def fly(states, plans, params):
    def record(carry, actions, observations, action, step):
      del actions, observations, action
      _, states, reward, _, info = step
      return carry, (reward, info, states.flight)

    (states, _, _), outputs = rollout.fly(
        env, params, states, None, rollout.planned, record,
        xs=planning.flown_actions(config, plans))
    return states, outputs

  def start(keys, params):
    _, states = rollout.reset_batch(env, keys, params)
    info = jax.vmap(jax_env.step_info, in_axes=(0, None))(states, params)
    return states, info, states.flight

  return jax.jit(start), jax.jit(fly)


def _flight_arrays(flight: Any) -> Dict[str, np.ndarray]:
  import jax  # pylint: disable=g-import-not-at-top
  return {k: np.asarray(jax.device_get(getattr(flight, k)))
          for k in FLIGHT_FIELDS}


def fly_batch(config: Any, seeds: Sequence[int], max_steps: int,
              agent_seed: int, timing: Dict[str, Any],
              compiled: Set[int]) -> List[Dict[str, Any]]:
  """Flies `seeds` together on gin's env; their eval records (seed order).

  Args:
    config: The planner's settings (`plan_config.from_gin`).
    seeds: Env seeds.
    max_steps: Strides per flight at most.
    agent_seed: The planner's seed (an int32).
    timing: Gets this batch's entry appended under 'batches' (wall [s],
      first planning call [s], warm calls [s]).
    compiled: The batch sizes whose planning call this process has already
      compiled (updated); a batch's first call counts as a warm decision
      when its size is among them (a planner that plans once per episode
      has no other).

  Returns:
    `eval_lib.fly`'s record of each seed (without 'episode' and
    'wall_time_s'), in the order of `seeds`.
  """
  # pylint: disable=g-import-not-at-top
  import jax
  import jax.numpy as jnp
  from ble_latex.agents.planning import planner as planning
  from ble_latex.envs import env_params
  from ble_latex.envs import jax_env
  from ble_latex.run import metrics
  from ble_latex.run import records as records_lib
  # pylint: enable=g-import-not-at-top

  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  params = env_params.params_from_gin()
  wind = env.wind_for(params)
  start, fly = _fly_functions(config, env)
  n = len(seeds)
  keys = jnp.stack([jax.random.PRNGKey(s) for s in seeds])
  states, _, flight0 = start(keys, params)
  window = min(int(params.episode_steps), max_steps)
  trackers = [metrics.EpisodeTracker(i, s, params.radius_km,
                                     window_steps=window)
              for i, s in enumerate(seeds)]
  f0 = _flight_arrays(flight0)
  paths = [[records_lib.batch_flight_point(f0, i)] for i in range(n)]
  done = np.zeros(n, bool)
  ended = np.zeros(n, bool)  # By the env (not by the max_steps cap).
  previous = planning.initial_plans(config, states)
  seed = jnp.int32(agent_seed)
  steps = 0
  warm_first = n in compiled
  plan_s, first, episode_start = [], None, time.perf_counter()
  while steps < max_steps and not done.all():
    t0 = time.perf_counter()
    plans = jax.block_until_ready(
        planning.plan_batch(config, params, states, seed, previous, wind))
    elapsed = time.perf_counter() - t0
    if first is None:
      first = elapsed  # The batch's first call (compilation in the first).
    else:
      plan_s.append(elapsed)
    states, (reward, info, flight) = fly(states, plans, params)
    previous = plans
    reward, info = jax.device_get((reward, info))
    flight = _flight_arrays(flight)
    for k in range(config.replan_every):
      if steps >= max_steps:
        break
      steps += 1
      for i in range(n):
        if done[i]:
          continue
        one = {key: np.asarray(v)[k, i] for key, v in info.items()}
        info_i = jax_env.info_dict(one)
        trackers[i].step(float(reward[k, i]), info_i)
        paths[i].append(records_lib.batch_flight_point(
            {key: v[k] for key, v in flight.items()}, i))
        ended[i] = (info_i['out_of_resources'] or info_i['envelope_burst'] or
                    info_i['terminal_reason'] != 'ok' or info_i['time_limit'])
        if ended[i] or steps >= max_steps:
          done[i] = True
  wall = time.perf_counter() - episode_start
  timing.setdefault('batches', []).append({
      'seeds': [int(s) for s in seeds], 'wall_s': wall, 'first_plan_s': first,
      'plan_calls': len(plan_s) + 1, 'plan_s_sum_after_first': sum(plan_s),
      'plan_s_mean_after_first': float(np.mean(plan_s)) if plan_s else None,
      # The calls without compilation (the first one too when warm).
      'plan_s_warm': ([first] if warm_first else []) + plan_s})
  compiled.add(n)
  return eval_records(trackers, ended, paths)


def eval_records(trackers: Sequence[Any], ended: Sequence[bool],
                 paths: Sequence[List[Dict[str, Any]]]
                 ) -> List[Dict[str, Any]]:
  """Batched flights' eval records, as `eval_lib.fly` writes one.

  Args:
    trackers: Each flight's `metrics.EpisodeTracker`.
    ended: Whether each ended by the env (not by the strides' cap).
    paths: Each flight's points (`records.batch_flight_point`).

  Returns:
    Each tracker's summary without 'episode' and 'wall_time_s', with its
    'flight_path'.
  """
  records = []
  for tracker, end, path in zip(trackers, ended, paths):
    record = tracker.summary(bool(end)).to_json()
    del record['episode'], record['wall_time_s']
    record['flight_path'] = path
    records.append(record)
  return records


def fly_planner(agent: str, bindings: Sequence[str], seeds: Sequence[int],
                max_steps: int, batch_size: int = BATCH_SIZE
                ) -> Tuple[List[Dict[str, Any]], str, float]:
  """A planner's flights on gin `bindings` alone, `batch_size` at a time.

  The same worlds and records as `eval_lib.evaluate` (batched: the gym
  env's reset, then the core) without BLE's gym env: gin is cleared first
  (as `eval_lib.build`: only these bindings count), then the env defaults
  and `bindings` are bound.

  Args:
    agent: A planner of `plan_config.PLANNERS`.
    bindings: Gin bindings of the flights (e.g. `wind_file.cell_bindings`).
    seeds: Env seeds.
    max_steps: Strides per flight at most.
    batch_size: Seeds flown together.

  Returns:
    (records in seed order, the winds' description
    (`env_params.wind_source`), seconds flown).
  """
  # pylint: disable=g-import-not-at-top
  import gin
  from ble_latex.agents.planning import config as plan_config
  from ble_latex.envs import env_params
  from ble_latex.run import gin_binding
  # pylint: enable=g-import-not-at-top
  gin.clear_config()
  gin_binding.bind_gin(None, None, [], list(bindings))
  config = plan_config.from_gin(agent)
  began = time.perf_counter()
  records, timing, compiled = [], {}, set()
  for b in range(0, len(seeds), batch_size):
    records += fly_batch(config, seeds[b:b + batch_size], max_steps, 0,
                         timing, compiled)
    print(f'{agent}: {len(records)}/{len(seeds)} seeds', file=sys.stderr,
          flush=True)
  return records, env_params.wind_source(), time.perf_counter() - began
