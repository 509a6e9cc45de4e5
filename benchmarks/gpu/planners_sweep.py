"""The planner runs made on a lent GPU, inside a fixed time budget.

The runs behind the "On a GPU" figures of `docs/planners.md` (an NVIDIA
H100, 2026-11-26; records and both runs' logs in
`benchmarks/records/planners/gpu_h100/`). This is a tidied copy of the driver that
ran there: the same runs, order, time limits and selection rule, with flags
where that one read environment variables (BUDGET, NVAL) and had the worst
seeds written in. Each run is
`benchmarks/planners.py` in a subprocess, its records and timing under
--output_dir; runs are
started in order while --budget_s lasts, and one cut by its time limit
leaves no record file (and is named in the log).

--plan=sweep (the first run):
  1. the oracle on the first --num_validation seeds of latex_validation with
     its defaults and five wider or longer searches (ORACLE_CONFIGS);
  2. the best of them by TW50 (window) on latex_small's 100 seeds, if its
     validation time says it fits in what is left: chosen on validation
     seeds only, flown once on the held-out ones;
  3. `latex_mpc` with its defaults on latex_small (its GPU timing);
  4. the batched env's speed (`env_speed_gpu.py`).
--plan=worst (the second run):
  the oracle with a much larger search (beam 256, 36-hour horizon) re-flying
  --seeds (the 25 latex_small flights the wide oracle flew worst), then
  `latex_mpc_grad` on latex_small and `latex_mpc` with 8 noise scenarios on
  latex_validation, where time is left.

On a machine with ble_latex installed (CPU or GPU):

  python benchmarks/gpu/planners_sweep.py --plan=sweep --output_dir=/tmp/gpu

On a machine without TensorFlow (the lent GPU's image: BLE 1.0.1, gym,
gin-config, opensimplex, s2sphere, future, transitions and gymnasium copied
as source from a local venv's site-packages into a folder on PYTHONPATH,
BLE's unused perciatelli44.pb left out) the same command: the planners, the
JAX env and the env gin files import no TensorFlow
(`tests/test_no_tensorflow.py`). The 2026-11-26 runs went through a
stand-in for TensorFlow's modules (`--no_tensorflow`, since removed: the env
gin file then imported BLE's gym env):

  PYTHONPATH=$PWD/site python3 benchmarks/gpu/planners_sweep.py \
      --plan=sweep --budget_s=570 --output_dir=$OUT/r
"""

import json
import os
import subprocess
import sys
import time
from typing import List, Optional, Sequence, Tuple

from absl import app
from absl import flags

FLAGS = flags.FLAGS
flags.DEFINE_enum('plan', 'sweep', ['sweep', 'worst'], 'Which set of runs.')
flags.DEFINE_string('output_dir', None, 'Records and timing (SUITE/...).',
                    required=True)
flags.DEFINE_float('budget_s', 540.0, 'Wall time for all the runs.')
flags.DEFINE_integer('num_validation', 50, 'latex_validation seeds.')
flags.DEFINE_list('seeds', [], "--plan=worst: the latex_small seeds.")

O = 'LatexMpcOracleAgent'
# The oracle's defaults when these runs were made (2026-11-26): a receding-
# horizon beam search, 12 h ahead, replanning every 2 strides. Its default
# now plans the whole episode; these bindings fly the runs as they were.
RECEDING = [f'{O}.horizon=36', f'{O}.num_segments=6', f'{O}.replan_every=2',
            f'{O}.beam_width=32', f'{O}.beam_cell_km=0', f'{O}.discount=0.98']
_SEARCHES = [
    ('o_default', []),
    ('o_h72_d1', [f'{O}.horizon=72', f'{O}.num_segments=12',
                  f'{O}.discount=1.0']),
    ('o_beam128', [f'{O}.beam_width=128']),
    ('o_tf1', [f'{O}.time_factor=1.0']),
    ('o_h72', [f'{O}.horizon=72', f'{O}.num_segments=12']),
    ('o_h72_b128_d1', [f'{O}.horizon=72', f'{O}.num_segments=12',
                       f'{O}.discount=1.0', f'{O}.beam_width=128']),
]
ORACLE_CONFIGS: List[Tuple[str, List[str]]] = [
    (name, RECEDING + bindings) for name, bindings in _SEARCHES]
HUGE = RECEDING + [f'{O}.horizon=108', f'{O}.num_segments=18',
                   f'{O}.discount=1.0', f'{O}.beam_width=256',
                   f'{O}.replan_every=4']
HERE = os.path.dirname(os.path.abspath(__file__))
_T0 = time.time()


def _left() -> float:
  return FLAGS.budget_s - (time.time() - _T0)


def _log(*parts) -> None:
  line = ' '.join(str(p) for p in parts)
  print(line, flush=True)
  with open(os.path.join(FLAGS.output_dir, 'sweep.log'), 'a') as f:
    f.write(line + '\n')


def _python(script: str) -> List[str]:
  return [sys.executable, script]


def run(name: str, agent: str, suite: str, num_seeds: int, batch: int,
        bindings: Sequence[str], limit_s: float,
        extra: Sequence[str] = ()) -> Tuple[Optional[float], float]:
  """One planners.py run; returns (its TW50 window or None, wall [s])."""
  cmd = _python(os.path.join(HERE, '..', 'planners.py')) + [
      f'--agent={agent}', f'--suite={suite}', f'--num_seeds={num_seeds}',
      f'--batch={batch}', f'--output_dir={FLAGS.output_dir}',
      f'--name_override={name}']
  cmd += [f'--gin_bindings={b}' for b in bindings] + list(extra)
  _log(f'== {name} ({agent} {suite} {num_seeds} seeds, {list(bindings)}), '
       f'limit {limit_s:.0f} s')
  start = time.time()
  try:
    done = subprocess.run(cmd, capture_output=True, text=True,
                          timeout=max(limit_s, 1.0), check=False)
    _log(done.stderr[-1500:])
  except subprocess.TimeoutExpired:
    _log('TIMEOUT')
  wall = time.time() - start
  _log(f'-- {name}: {wall:.0f} s')
  path = os.path.join(FLAGS.output_dir, suite, f'{name}.json')
  if not os.path.exists(path):
    return None, wall
  with open(path) as f:
    records = json.load(f)
  tw50 = sum(r['tw50_window'] for r in records) / len(records)
  _log(f'RESULT {name} {suite} {len(records)} seeds tw50_window {tw50:.4f} '
       f'wall {wall:.0f}')
  return tw50, wall


def _sweep() -> None:
  n = FLAGS.num_validation
  tw50, _ = run('smoke', 'latex_mpc_oracle', 'latex_validation', 2, 2, [],
                min(150.0, _left()), extra=['--short'])
  if tw50 is None:
    raise SystemExit('the smoke run failed (see sweep.log)')
  results = {}
  for name, bindings in ORACLE_CONFIGS:
    if _left() < 60:
      break
    tw50, wall = run(name, 'latex_mpc_oracle', 'latex_validation', n, n,
                     bindings, _left() - 30)
    if tw50 is not None:
      results[name] = (tw50, wall, bindings)
  _log('VALIDATION', json.dumps(results))
  if results:
    best = max(results, key=lambda k: results[k][0])
    tw50, wall, bindings = results[best]
    need = wall * 100 / n * 1.1
    _log(f'best {best} {tw50:.4f}; latex_small needs ~{need:.0f} s, '
         f'{_left():.0f} s left')
    if need < _left() - 20:
      run(best + '_small', 'latex_mpc_oracle', 'latex_small', 100, 100,
          bindings, _left() - 10)
  if _left() > 120:
    run('mpc_small', 'latex_mpc', 'latex_small', 100, 100, [], _left() - 70)
  if _left() > 40:
    env = dict(os.environ, OUT=FLAGS.output_dir)
    try:
      done = subprocess.run(_python(os.path.join(HERE, 'env_speed_gpu.py')),
                            capture_output=True, text=True, env=env,
                            timeout=_left() - 5, check=False)
      _log(done.stdout[-2000:], done.stderr[-1500:])
    except subprocess.TimeoutExpired:
      _log('env speed: TIMEOUT')


def _worst() -> None:
  if not FLAGS.seeds:
    raise app.UsageError('--plan=worst needs --seeds')
  run('o_huge_worst25', 'latex_mpc_oracle', 'latex_small', 100,
      len(FLAGS.seeds), HUGE, min(105.0, _left() - 75),
      extra=['--seeds=' + ','.join(FLAGS.seeds)])
  if _left() > 50:
    run('grad_small', 'latex_mpc_grad', 'latex_small', 100, 100, [],
        min(55.0, _left() - 25))
  if _left() > 50:
    run('f_scen8_val', 'latex_mpc', 'latex_validation', 50, 50,
        ['LatexMpcAgent.scenarios=8'], _left() - 8)


def main(argv: Sequence[str]) -> None:
  del argv
  os.makedirs(FLAGS.output_dir, exist_ok=True)
  _log(subprocess.run('nvidia-smi -L || true', shell=True, check=False,
                      capture_output=True, text=True).stdout)
  import jax  # pylint: disable=g-import-not-at-top
  _log('jax', jax.__version__, jax.devices())
  if FLAGS.plan == 'sweep':
    _sweep()
  else:
    _worst()
  _log('done', time.time() - _T0)


if __name__ == '__main__':
  app.run(main)
