"""Where the first reset's compile time goes: the parts of `jax_env.draw`.

Compiles (`jax.jit(f).lower(...).compile()`, no persistent cache) each
random draw of a new world separately and then the whole `draw`, in one
process, and prints compile seconds and HLO lines per part with the
machine's load average:

  python benchmarks/reset_compile_parts.py --json benchmarks/records/reset_compile_parts.json
"""

import argparse
import json
import os
import time

import jax

from ble_latex import safe_io
from ble_latex.envs import jax_env
from ble_latex.flight import atmosphere as atmosphere_lib
from ble_latex.wind import generative
from ble_latex.wind import simplex


def main() -> None:
  parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
  parser.add_argument('--json', default='', help='Also write the report here.')
  args = parser.parse_args()
  if args.json and safe_io.output_problem(args.json):
    parser.error(f'--json: {safe_io.output_problem(args.json)}')
  env = jax_env.LatexBalloonJaxEnv()
  params = env.default_params
  key = jax.random.PRNGKey(0)
  parts = {
      # BLE's start distance: radius * Beta(a, b) (`jax_env._START_BETA`).
      'jax.random.beta (start distance)': (
          lambda k: jax.random.beta(k, *jax_env._START_BETA), (key,)),  # pylint: disable=protected-access
      'jax.random.choice (start time)': (
          lambda k: jax.random.choice(k, jax_env._START_TIME_RANGE_S, ()),  # pylint: disable=protected-access
          (key,)),
      'atmosphere.reset': (atmosphere_lib.reset, (key,)),
      'simplex.reset_uv_noise_params': (simplex.reset_uv_noise_params,
                                        (key,)),
      'generative.reset_forecast (VAE decode)': (
          generative.reset_forecast, (key, params.decoder)),
      'jax_env draw (all of the above)': (env.draw, (key, params)),
  }
  report = {'loadavg_before': os.getloadavg(), 'parts': {}}
  for name, (fn, fn_args) in parts.items():
    start = time.perf_counter()
    compiled = jax.jit(fn).lower(*fn_args).compile()
    seconds = time.perf_counter() - start
    lines = len(compiled.as_text().splitlines())
    report['parts'][name] = {'compile_s': seconds, 'hlo_lines': lines}
    print(f'{name:42s} compile {seconds:6.2f} s  HLO {lines:6d} lines',
          flush=True)
  report['loadavg_after'] = os.getloadavg()
  print('load average before/after:', report['loadavg_before'][0],
        report['loadavg_after'][0])
  if args.json:
    safe_io.atomic_write(args.json, json.dumps(report, indent=1))


if __name__ == '__main__':
  main()
