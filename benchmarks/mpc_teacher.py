"""MPC as a teacher for SAC (issue 29, stretch): a short study.

  python benchmarks/mpc_teacher.py --output=benchmarks/records/mpc_teacher.json \
      [--rounds=10] [--demo_episodes=64] [--seed=0]

Does filling SAC's replay with the forecast planner's flights first help the
jitted trainer? Two arms, the same training seed, the same env seeds, the
same trainer settings (`gin_configs/sac_jax.gin`, `sac_trainer.TrainerConfig`):

- `none`: `sac_trainer.train_round` from a fresh learner, as
  `ble-latex-train --trainer=jax` trains (uniform random actions until
  `min_replay_history` transitions are stored).
- `demos`: the same learner, its replay first holding every transition of
  --demo_episodes `latex_mpc` flights (observation, the plan's action in the
  normalised box, reward, next observation, terminal), flown on training
  seeds no round of this study flies (`suites.train_seed(100_000 + i)`).
  The replay is past `min_replay_history` from the start, so this arm acts
  with its policy from its first step.

After each round of 32 episodes, each arm's deterministic policy flies the
first --validation_seeds seeds of `latex_validation` (`sac_trainer.validate`);
the JSON keeps each round's validation TW50 (window), its % out of
resources, the training episodes' TW50 and the wall time. Resumable by arm:
an arm whose rounds are all recorded is skipped on a re-run; an unfinished
arm starts again (no checkpoints: a study, not a training run).
"""

import functools
import json
import os
import sys
import time
from typing import Any, Dict, List, Optional, Sequence

from absl import flags
import numpy as np

import ble_latex  # pylint: disable=unused-import  # Fixes first.
from ble_latex import safe_io
from ble_latex.cli import common as cli
from ble_latex.run import episode_log

FLAGS = flags.FlagValues()
flags.DEFINE_string('output', str(episode_log.RECORDS_DIR / 'mpc_teacher.json'), 'Results JSON.',
                    flag_values=FLAGS)
flags.DEFINE_integer('rounds', 10, 'Training rounds per arm.', lower_bound=1,
                     flag_values=FLAGS)
flags.DEFINE_integer('demo_episodes', 64, 'latex_mpc flights in the demos '
                     'arm\'s replay.', lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('demo_batch', 32, 'Demonstration flights planned in one '
                     'call.', lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('validation_seeds', 100, 'First seeds of '
                     'latex_validation flown after each round.',
                     lower_bound=1, upper_bound=100, flag_values=FLAGS)
flags.DEFINE_integer('seed', 0, 'Training seed of both arms.',
                     flag_values=FLAGS)
cli.define_gin_flags(FLAGS, files_help=None, bindings_help='Gin bindings '
                     '(the planner, the trainer, the env).')

ARMS = ('none', 'demos')
DEMO_EPISODE_OFFSET = 100_000  # Training seeds of the demonstrations.


def collect_demos(config, env, params, num_episodes: int, batch: int
                  ) -> Dict[str, np.ndarray]:
  """Transitions of `num_episodes` `latex_mpc` flights (host arrays).

  Returns:
    obs [T, 71], action [T, 3] (normalised box), reward [T], next_obs
    [T, 71], terminal [T] (1.0 where the flight ended, not the time limit).
  """
  import jax  # pylint: disable=g-import-not-at-top
  import jax.numpy as jnp  # pylint: disable=g-import-not-at-top
  from ble_latex.agents.planning import planner as planning  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import jax_env  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import rollout  # pylint: disable=g-import-not-at-top
  from ble_latex.run import suites  # pylint: disable=g-import-not-at-top

  low = jnp.asarray(jax_env.ACTION_LOW, jnp.float32)
  high = jnp.asarray(jax_env.ACTION_HIGH, jnp.float32)
  wind = env.wind_for(params)

  @jax.jit
  def fly(states, obs, active, plans, params):
    def record(active, planned, obs, action, step):
      del planned
      next_obs, _, reward, terminated, info = step
      normalised = jnp.clip(2.0 * (action - low) / (high - low) - 1.0,
                            -1.0, 1.0)
      row = (obs, normalised, reward, next_obs,
             terminated.astype(jnp.float32), active)
      return active & ~(terminated | info['time_limit']), row
    return rollout.fly(env, params, states, obs, rollout.planned, record,
                       carry=active, xs=planning.flown_actions(config, plans))

  reset = jax.jit(functools.partial(rollout.reset_batch, env))
  seeds = [suites.train_seed(DEMO_EPISODE_OFFSET + i)
           for i in range(num_episodes)]
  rows: List[Any] = []
  for b in range(0, len(seeds), batch):
    chunk = seeds[b:b + batch]
    keys = jnp.stack([jax.random.PRNGKey(s) for s in chunk])
    obs, states = reset(keys, params)
    active = jnp.ones((len(chunk),), bool)
    previous = planning.initial_plans(config, states)
    for _ in range(0, int(params.episode_steps), config.replan_every):
      plans = planning.plan_batch(config, params, states, jnp.int32(0),
                                  previous, wind)
      (states, obs, active), row = fly(states, obs, active, plans, params)
      previous = plans
      rows.append(jax.device_get(row))
      if not bool(active.any()):
        break
  names = ('obs', 'action', 'reward', 'next_obs', 'terminal')
  valid = np.concatenate([r[5].reshape(-1) for r in rows])
  out = {}
  for i, name in enumerate(names):
    parts = [r[i].reshape((-1,) + r[i].shape[2:]) for r in rows]
    out[name] = np.concatenate(parts)[valid]
  return out


def fill_replay(replay, demos: Dict[str, np.ndarray]):
  """`replay` holding `demos` in its first slots."""
  import jax.numpy as jnp  # pylint: disable=g-import-not-at-top
  count = len(demos['reward'])
  capacity = replay.reward.shape[0]
  if count > capacity:
    raise ValueError(f'{count} demonstration transitions exceed the replay '
                     f'capacity {capacity}')
  fields = {k: getattr(replay, k).at[:count].set(jnp.asarray(v))
            for k, v in demos.items()}
  return replay.replace(**fields, size=jnp.asarray(count, jnp.int32),
                        cursor=jnp.asarray(count % capacity, jnp.int32))


def run_arm(arm: str, demos, learner, env, params, rounds: int, seed: int,
            validation_seeds, record) -> None:
  """Trains one arm for `rounds` rounds, `record(row)` after each."""
  import jax  # pylint: disable=g-import-not-at-top
  import jax.numpy as jnp  # pylint: disable=g-import-not-at-top
  from ble_latex.agents.sac import trainer as sac_trainer  # pylint: disable=g-import-not-at-top
  from ble_latex.run import jax_train  # pylint: disable=g-import-not-at-top

  _, state = sac_trainer.make_learner(learner.config, jax.random.PRNGKey(seed))
  if arm == 'demos':
    state = state.replace(replay=fill_replay(state.replay, demos))
  window = int(params.episode_steps)
  n = learner.config.num_envs
  for iteration in range(rounds):
    began = time.monotonic()
    seeds = jnp.asarray(jax_train.round_seeds(iteration, n), jnp.int32)
    state, out = sac_trainer.train_round(learner, env, state, seeds, window,
                                         params)
    counts = jax.device_get(out.nonfinite)
    bad = [k for k in sac_trainer.NONFINITE if int(counts[k])]
    if bad:  # Nothing of a diverged round is recorded.
      raise FloatingPointError(f'arm {arm} diverged at round {iteration}: '
                               f'non-finite {", ".join(bad)}')
    wall = time.monotonic() - began
    result = jax_train.validation_summary(
        sac_trainer.validate(learner, env, state.network_params,
                             validation_seeds, window, params), window)
    within = jax.device_get(out.within_steps)
    train_tw50 = float(np.mean(np.asarray(within) / window))
    record({'arm': arm, 'round': iteration, 'train_s': wall,
            'train_tw50_window_mean': train_tw50,
            'validation': result, 'replay_size': int(state.replay.size)})
    print(f'{arm} round {iteration}: validation tw50_window '
          f'{result["tw50_window_mean"]:.3f}, out of resources '
          f'{result["out_of_resources_pct"]:.0f} %, train {wall:.0f} s',
          file=sys.stderr)


def _main(argv: Sequence[str]) -> int:
  del argv
  from ble_latex import quiet  # pylint: disable=g-import-not-at-top
  from ble_latex.run import gin_binding  # pylint: disable=g-import-not-at-top
  with quiet.third_party_noise():
    import jax.numpy as jnp  # pylint: disable=g-import-not-at-top
    from ble_latex.agents.planning import config as plan_config  # pylint: disable=g-import-not-at-top
    from ble_latex.agents.sac import trainer as sac_trainer  # pylint: disable=g-import-not-at-top
    from ble_latex.envs import env_params  # pylint: disable=g-import-not-at-top
    from ble_latex.envs import jax_env  # pylint: disable=g-import-not-at-top
    from ble_latex.run import suites  # pylint: disable=g-import-not-at-top
  gin_binding.bind_gin(None, None, [], FLAGS.gin_bindings)
  planner = plan_config.from_gin('latex_mpc')
  plan_config.check_batch(planner, FLAGS.demo_batch, 'LatexMpcAgent',
                          '--demo_batch')
  trainer = sac_trainer.TrainerConfig()
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  params = env_params.params_from_gin()
  learner = sac_trainer.learner_for(trainer)
  validation = jnp.asarray(
      list(suites.get_eval_suite('latex_validation').seeds)[
          :FLAGS.validation_seeds], jnp.int32)
  results: Dict[str, Any] = {'rows': []}
  with safe_io.locked_file(FLAGS.output, what='study output'):
    if os.path.exists(FLAGS.output):
      with open(FLAGS.output) as f:
        results = json.load(f)
    settings = {'rounds': FLAGS.rounds, 'demo_episodes': FLAGS.demo_episodes,
                'seed': FLAGS.seed, 'validation_seeds': FLAGS.validation_seeds,
                'gin_bindings': list(FLAGS.gin_bindings)}
    if results.get('settings', settings) != settings:
      raise cli.CommandUsageError(
          f'{FLAGS.output} holds a study with other settings '
          f'({results["settings"]}); give another --output')
    results['settings'] = settings
    results.update(planner=vars(planner), trainer=vars(trainer),
                   cpus=os.cpu_count())
    results.setdefault('loadavg', []).append(os.getloadavg())
    demos = None
    for arm in ARMS:
      done = [r for r in results['rows'] if r['arm'] == arm]
      if len(done) >= FLAGS.rounds:
        continue
      results['rows'] = [r for r in results['rows'] if r['arm'] != arm]
      if arm == 'demos' and demos is None:
        began = time.monotonic()
        demos = collect_demos(planner, env, params, FLAGS.demo_episodes,
                              FLAGS.demo_batch)
        results['demos'] = {'transitions': int(len(demos['reward'])),
                            'collect_s': time.monotonic() - began,
                            'mean_reward': float(demos['reward'].mean())}

      def record(row):
        results['rows'].append(row)
        results['loadavg'].append(os.getloadavg())
        safe_io.atomic_write(FLAGS.output, json.dumps(results, indent=1))

      run_arm(arm, demos, learner, env, params, FLAGS.rounds, FLAGS.seed,
              validation, record)
    safe_io.atomic_write(FLAGS.output, json.dumps(results, indent=1))
  for arm in ARMS:
    curve = [r['validation']['tw50_window_mean'] for r in results['rows']
             if r['arm'] == arm]
    print(arm, ' '.join(f'{100 * x:.1f}' for x in curve))
  return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/mpc_teacher.py', FLAGS, argv,
                      doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
