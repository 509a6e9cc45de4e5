# coding=utf-8
r"""Evaluates agents on a suite on Ray, each seed a Ray task (docs/ray.md).

  python examples/ray_eval.py --suite=latex_small \
      --agents=latex_station_seeker,sac_pretrained --output_dir=runs/ray_eval
  python examples/ray_eval.py --ray_address=auto ...   # an existing cluster
  python examples/ray_eval.py --short   # CI's run (2 seeds x 3 steps)

What `ble-latex-eval --agent=A --suite=S --ray_address=local` does, through
the same library calls (`ble_latex.run.distributed`), for several agents
on one Ray: `distributed.connect` starts (`local`, `--ray_num_cpus` CPUs)
or joins Ray once; each agent is an `eval_lib.EvalSpec` (plain values: each
worker rebuilds the agent and env from it, once); `distributed.evaluate`
flies the suite's seeds as one task each and returns the records in seed
order, the same records the serial eval writes for deterministic agents.
Writes OUTPUT_DIR/SUITE/AGENT.json in `ble-latex-eval`'s schema (so
`ble-latex-plot --eval_json` and `benchmarks/results_table.py` read them)
and prints one JSON line: each agent's summary (`metrics.summarize`).

Needs the `ray` extra (`pip install -c constraints.txt -e '.[ray]'`).
"""

import argparse
import json
import os
import sys
import tempfile
import time
from typing import Any, Dict, Optional, Sequence

from ble_latex.run import distributed
from ble_latex.run import eval_lib
from ble_latex.run import metrics
from ble_latex.run import suites


def parse_args(argv: Optional[Sequence[str]]) -> argparse.Namespace:
  parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
  parser.add_argument('--agents', default='latex_station_seeker,sac_pretrained',
                      help='Comma-separated agent names (ble-latex-eval\'s).')
  parser.add_argument('--suite', default='latex_tiny')
  parser.add_argument('--num_seeds', type=int, default=None,
                      help="Only the suite's first N seeds (default: all).")
  parser.add_argument('--max_episode_length', type=int, default=None,
                      help="Steps per episode (default: the suite's).")
  parser.add_argument('--env_name', default='LatexBalloon-v0')
  parser.add_argument('--gin_bindings', action='append', default=[],
                      help='Gin bindings for every agent (repeatable).')
  parser.add_argument('--ray_address', default='local',
                      help='local (start one here), auto, HOST:PORT or '
                      'ray://HOST:PORT.')
  parser.add_argument('--ray_num_cpus', type=int, default=None,
                      help='CPUs of a local Ray (default: all).')
  parser.add_argument('--output_dir', default=None,
                      help='Default: a temporary folder.')
  parser.add_argument('--short', action='store_true',
                      help='A tiny run (CI): latex_tiny\'s first 2 seeds, '
                      '3 steps each, a local Ray of 2 CPUs.')
  args = parser.parse_args(argv)
  if args.short:
    args.suite, args.num_seeds, args.max_episode_length = 'latex_tiny', 2, 3
    if args.ray_address == 'local' and args.ray_num_cpus is None:
      args.ray_num_cpus = 2
  return args


def main(argv: Optional[Sequence[str]] = None) -> Dict[str, Any]:
  args = parse_args(argv)
  start = time.time()
  suite = suites.get_eval_suite(args.suite)
  seeds = list(suite.seeds)[:args.num_seeds]
  max_steps = args.max_episode_length or suite.max_episode_length
  output_dir = args.output_dir or tempfile.mkdtemp(prefix='ray_eval_')
  try:
    distributed.connect(args.ray_address, args.ray_num_cpus)
  except (distributed.RayUnavailableError, ValueError) as e:
    sys.exit(f'ray_eval: {e}')
  summaries = {}
  try:
    for agent in args.agents.split(','):
      spec = eval_lib.EvalSpec(agent=agent, env_name=args.env_name,
                               gin_bindings=tuple(args.gin_bindings))
      records = distributed.evaluate(spec, seeds, max_steps,
                                     description=f'eval {agent} {args.suite}')
      path = eval_lib.output_path(output_dir, args.suite, agent, 1, 0)
      os.makedirs(os.path.dirname(path), exist_ok=True)
      eval_lib.write_results(path, records)
      summaries[agent] = {'output': path, **metrics.summarize(records)}
  finally:
    if args.ray_address == 'local':
      distributed.shutdown()
  summary = {'suite': args.suite, 'seeds': seeds, 'max_steps': max_steps,
             'agents': summaries, 'elapsed_s': round(time.time() - start, 1)}
  print(json.dumps(summary))
  return summary


if __name__ == '__main__':
  main()
