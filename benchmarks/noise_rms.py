r"""BLE's simplex wind noise: its rms per component (issue 64 item 4).

  nice -n 10 python benchmarks/noise_rms.py

The noise of 1024 reset keys (`simplex.reset_uv_noise_params`), each at 500
points uniform in +-300 km east and north, 40-165 hPa (the flight band) and
0-72 h (`simplex.wind_noise_uv`, the JAX port of BLE's `SimplexWindNoise`).
Prints the rms of u and v, the vector rms, and the 5/50/95 % of each key's
rms of u, with the command, date, machine and load. The result is
`wind.forecast_error.BLE_NOISE_RMS_MPS`.
"""

import datetime as dt
import os
import platform

import jax
import jax.numpy as jnp
import numpy as np

from ble_latex.wind import simplex


def main():
  rng = np.random.default_rng(0)
  noise = jax.jit(jax.vmap(lambda k, x, y, p, h: simplex.wind_noise_uv(
      *simplex.reset_uv_noise_params(k), x, y, p, h)))
  us, vs = [], []
  for batch in range(4):
    keys = jax.random.split(jax.random.PRNGKey(batch), 256)
    points = [rng.uniform(low, high, (256, 500)).astype(np.float32)
              for low, high in ((-300, 300), (-300, 300), (4000, 16500),
                                (0, 72))]
    u, v = noise(keys, *map(jnp.asarray, points))
    us.append(np.asarray(u, np.float64))
    vs.append(np.asarray(v, np.float64))
  u, v = np.concatenate(us), np.concatenate(vs)
  now = dt.datetime.now(dt.timezone.utc)
  print(f'command: python benchmarks/noise_rms.py; {now:%Y-%m-%d %H:%M} UTC; '
        f'{platform.node()} ({os.cpu_count()} cores), load '
        f'{os.getloadavg()[0]:.1f}')
  per_key = np.sqrt((u ** 2).mean(axis=1))
  print(f'{u.shape[0]} keys x {u.shape[1]} points: rms u '
        f'{np.sqrt((u ** 2).mean()):.3f} m/s, v {np.sqrt((v ** 2).mean()):.3f}'
        f' m/s, vector {np.sqrt((u ** 2 + v ** 2).mean()):.3f} m/s; per key '
        f'(u) 5/50/95 %: '
        f'{", ".join(f"{q:.3f}" for q in np.percentile(per_key, [5, 50, 95]))}'
        ' m/s')


if __name__ == '__main__':
  main()
