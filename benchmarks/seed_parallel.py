r"""Several SAC training seeds on one machine: one after another, vmapped, or processes.

The jitted trainer's round (`sac_trainer.train_round`: --num_envs balloons,
--updates_per_step SAC updates after each of the 216 steps, gin
`sac_jax.gin`'s network and batch) for --num_seeds training seeds, three ways,
in one run on the same machine:

- sequential: one process, the seeds' rounds one after another (what
  `ble-latex-train --trainer=jax --seeds=...` does without --vmap_seeds);
- vmap: one process, one `sac_trainer.train_round_seeds` call per round
  (`jax.vmap` over the stacked `TrainState`s; `--vmap_seeds`);
- processes: --num_seeds processes at once, one seed each
  (`benchmarks/sac_seeds.py train --parallel=N`).

Every way first runs one round that compiles and fills the replay past
`min_replay_history` (not timed), then times --rounds rounds in which every
step learns. The figure of merit is seed-rounds per hour (rounds of all
seeds divided by the wall time); ratios are to `sequential`. The replay
capacity is cut to what the rounds fill (the update cost does not depend on
it). The load average before and after is recorded: this machine is shared.

  python benchmarks/seed_parallel.py --num_seeds=2 --rounds=3 \
      --json=benchmarks/records/seed_parallel.json
"""

import json
import multiprocessing
import os
import sys
import time
from typing import Any, Dict, List, Optional, Sequence

from absl import flags

from ble_latex import safe_io
from ble_latex.cli import common as cli

FLAGS = flags.FlagValues()
flags.DEFINE_integer('num_seeds', 2, 'Training seeds.', lower_bound=2,
                     flag_values=FLAGS)
flags.DEFINE_integer('rounds', 3, 'Rounds timed per seed and way.',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('num_envs', 32, 'Balloons per round.', lower_bound=1,
                     flag_values=FLAGS)
flags.DEFINE_integer('updates_per_step', 8, 'SAC updates per step.',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_list('ways', ['sequential', 'vmap', 'processes'],
                  'Which ways to time.', flag_values=FLAGS)
flags.DEFINE_string('json', None, 'Also write the numbers here.',
                    flag_values=FLAGS)

WAYS = ('sequential', 'vmap', 'processes')


def _setup(num_envs: int, updates_per_step: int, rounds: int,
           seeds: Sequence[int]):
  """Env, learner, params, fresh states of `seeds`, env seeds per round."""
  # pylint: disable=g-import-not-at-top
  import jax
  import jax.numpy as jnp
  from ble_latex.agents.sac import trainer as sac_trainer
  from ble_latex.envs import jax_env
  # pylint: enable=g-import-not-at-top
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  params = env.default_params
  steps = int(params.episode_steps)
  config = sac_trainer.TrainerConfig(
      num_envs=num_envs, updates_per_step=updates_per_step,
      replay_capacity=(rounds + 1) * num_envs * steps,
      min_replay_history=min(1000, num_envs * steps))
  states = []
  for seed in seeds:
    learner, state = sac_trainer.make_learner(config, jax.random.PRNGKey(seed))
    states.append(state)
  env_seeds = [jnp.arange(r * num_envs, (r + 1) * num_envs, dtype=jnp.int32)
               for r in range(rounds + 1)]
  return env, learner, params, steps, states, env_seeds


def _one_seed_rounds(env, learner, params, steps, state, env_seeds,
                     rounds: range) -> Any:
  # pylint: disable=g-import-not-at-top
  import jax
  from ble_latex.agents.sac import trainer as sac_trainer
  # pylint: enable=g-import-not-at-top
  for r in rounds:
    state, _ = sac_trainer.train_round(learner, env, state, env_seeds[r],
                                       steps, params)
  jax.block_until_ready(state.key)
  return state


def _sequential(num_envs, updates_per_step, rounds, num_seeds) -> float:
  env, learner, params, steps, states, env_seeds = _setup(
      num_envs, updates_per_step, rounds, range(num_seeds))
  states = [_one_seed_rounds(env, learner, params, steps, s, env_seeds,
                             range(1)) for s in states]
  start = time.perf_counter()
  for s in states:
    _one_seed_rounds(env, learner, params, steps, s, env_seeds,
                     range(1, rounds + 1))
  return time.perf_counter() - start


def _vmap(num_envs, updates_per_step, rounds, num_seeds) -> float:
  # pylint: disable=g-import-not-at-top
  import jax
  from ble_latex.agents.sac import trainer as sac_trainer
  # pylint: enable=g-import-not-at-top
  env, learner, params, steps, states, env_seeds = _setup(
      num_envs, updates_per_step, rounds, range(num_seeds))
  stacked = sac_trainer.stack(states)
  del states
  stacked, _ = sac_trainer.train_round_seeds(learner, env, stacked,
                                             env_seeds[0], steps, params)
  jax.block_until_ready(stacked.key)
  start = time.perf_counter()
  for r in range(1, rounds + 1):
    stacked, _ = sac_trainer.train_round_seeds(learner, env, stacked,
                                               env_seeds[r], steps, params)
  jax.block_until_ready(stacked.key)
  return time.perf_counter() - start


def _process(seed, num_envs, updates_per_step, rounds, barrier, results):
  """One seed in its own process; times its rounds after the barrier."""
  env, learner, params, steps, states, env_seeds = _setup(
      num_envs, updates_per_step, rounds, [seed])
  state = _one_seed_rounds(env, learner, params, steps, states[0], env_seeds,
                           range(1))
  barrier.wait()
  start = time.perf_counter()
  _one_seed_rounds(env, learner, params, steps, state, env_seeds,
                   range(1, rounds + 1))
  results.put((seed, time.perf_counter() - start, time.time()))


def _processes(num_envs, updates_per_step, rounds, num_seeds) -> float:
  ctx = multiprocessing.get_context('spawn')
  barrier, results = ctx.Barrier(num_seeds + 1), ctx.Queue()
  procs = [ctx.Process(target=_process, args=(
      seed, num_envs, updates_per_step, rounds, barrier, results))
           for seed in range(num_seeds)]
  for p in procs:
    p.start()
  barrier.wait()
  began = time.time()
  done = [results.get() for _ in procs]
  for p in procs:
    p.join()
    if p.exitcode:
      raise RuntimeError(f'a seed process failed (exit {p.exitcode})')
  # Wall time from the barrier to the last seed's end.
  return max(end for _, _, end in done) - began


def run(num_seeds: int, rounds: int, num_envs: int, updates_per_step: int,
        ways: Sequence[str]) -> Dict[str, Any]:
  timers = {'sequential': _sequential, 'vmap': _vmap,
            'processes': _processes}
  load_before = os.getloadavg()
  wall = {}
  for way in ways:
    wall[way] = timers[way](num_envs, updates_per_step, rounds, num_seeds)
    print(f'{way}: {wall[way]:.1f} s for {num_seeds} seeds x {rounds} '
          'rounds', flush=True)
  per_hour = {w: num_seeds * rounds * 3600.0 / s for w, s in wall.items()}
  out = {'num_seeds': num_seeds, 'rounds': rounds, 'num_envs': num_envs,
         'updates_per_step': updates_per_step, 'wall_s': wall,
         'seed_rounds_per_hour': per_hour,
         'load_average_before': list(load_before),
         'load_average_after': list(os.getloadavg()),
         'cpu_count': os.cpu_count()}
  if 'sequential' in per_hour:
    out['ratio_to_sequential'] = {
        w: v / per_hour['sequential'] for w, v in per_hour.items()}
  return out


def _main(argv: Sequence[str]) -> None:
  del argv
  ways = list(FLAGS.ways)
  bad = [w for w in ways if w not in WAYS]
  if bad:
    raise cli.CommandUsageError(f'--ways: unknown {bad}; choose from '
                                f'{list(WAYS)}')
  out = run(FLAGS.num_seeds, FLAGS.rounds, FLAGS.num_envs,
            FLAGS.updates_per_step, ways)
  text = json.dumps(out, indent=2) + '\n'
  print(text, end='')
  if FLAGS.json:
    safe_io.atomic_write(FLAGS.json, text)


def main(argv: Optional[List[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/seed_parallel.py', FLAGS, argv,
                      doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
