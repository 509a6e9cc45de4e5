"""The batched JAX env's speed on whatever device JAX finds (a GPU run).

`jax_env.rollout` of N balloons through 216 strides (3 days, a constant
action): the first call (compile and run), then the best of two timed calls.
Writes $OUT/env_speed.json. Run on a lent NVIDIA H100 on 2026-11-26 by
`planners_sweep.py` (`benchmarks/records/planners/gpu_h100/env_speed.json`); on this
project's 2-core CPU, `benchmarks/batch_speed.py` measures the same rollout.

  OUT=/tmp/speed SIZES=1024,8192,32768 python benchmarks/gpu/env_speed_gpu.py
"""
import json
import os
import time

import jax
import jax.numpy as jnp

from ble_latex import safe_io
from ble_latex.envs import jax_env


def main() -> None:
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  params = env.default_params
  out = {}
  sizes = os.environ.get('SIZES', '1024,8192,32768').split(',')
  for n in [int(s) for s in sizes]:
    keys = jax.random.split(jax.random.PRNGKey(0), n)
    actions = jnp.tile(jnp.array([17_500.0, 2.0, 1.0]), (n, 1))
    start = time.time()
    jax.block_until_ready(jax_env.rollout(env, keys, actions, params, 216))
    first = time.time() - start
    best = float('inf')
    for _ in range(2):
      start = time.time()
      jax.block_until_ready(jax_env.rollout(env, keys, actions, params, 216))
      best = min(best, time.time() - start)
    out[n] = {'first_s': first, 'best_s': best,
              'balloon_steps_per_s': n * 216 / best}
    print(n, out[n], flush=True)
  safe_io.atomic_write(os.path.join(os.environ['OUT'], 'env_speed.json'),
                       json.dumps(out, indent=1))


if __name__ == '__main__':
  main()
