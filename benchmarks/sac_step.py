r"""SAC cost: today's agent, Dopamine's update and the jitted trainer, one run.

Part 1 (`train_step`): Dopamine's replay sampling and target update vs ours.

One `ble_latex.agents.sac.SACAgent` (the paper's 2 x 256 networks, batch 256,
71 features, 3 actions) with a replay buffer of --transitions random
transitions in 216-step episodes times `_train_step()` (replay sample, jitted
SAC update, soft target update; blocked until the new parameters are ready)
in two configurations, alternating in the same process for --rounds rounds:

- dopamine: Dopamine's own `OutOfGraphReplayBuffer.sample_transition_batch`
  (per-index Python loop, `sample_index_batch`) and its eager
  `_maybe_sync_weights` (one JAX op per parameter leaf and operation);
- ble_latex: `VectorReplayBuffer` (array indexing, same batches) and the one
  jitted `optax.incremental_update`.

Part 2 (`update`): one SAC update on the same batch of 256: Dopamine's
`sac_agent.train` (per-transition gradients, averaged) vs `sac_core.update`
(the gradient of the batch mean; the update both the agent and the trainer
run), each jitted, --steps calls per round; also `sac_core.update` with the
LayerNorm and the CrossQ critics (`networks.CRITICS`, same sizes).

Part 3 (`per_env_step`): what one environment step of training costs.
- agent: `LatexBalloon-v0` (gym, one balloon) stepped with `SACAgent.step`
  in train mode (one update per step), --env_steps steps per round;
- jax trainer: `sac_trainer.train_round` with --num_envs balloons (16)
  and --updates_per_step updates per step (8), timed for one 216-step round without updates
  (min_replay_history above the round) and one with, so per balloon-step
  and per update costs are separated.

  python benchmarks/sac_step.py --steps=200 --rounds=3 \
      --json=benchmarks/records/sac_step.json
"""

import functools
import json
import os
import statistics
import sys
import time
from typing import Optional, Sequence

from absl import flags

from ble_latex import safe_io
from ble_latex.cli import common as cli

FLAGS = flags.FlagValues()
flags.DEFINE_integer('steps', 200, 'Training steps timed per round and '
                     'config.', lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('rounds', 3, 'Rounds timed.', lower_bound=1,
                     flag_values=FLAGS)
flags.DEFINE_integer('transitions', 20_000, 'Transitions in the replay '
                     'buffer.', lower_bound=2000, flag_values=FLAGS)
flags.DEFINE_integer('env_steps', 216, 'Gym env steps of the agent timed per '
                     'round.', lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('num_envs', 16, 'Balloons of the jitted trainer.',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_integer('updates_per_step', 8, 'Updates per step of the jitted '
                     'trainer.', lower_bound=1, flag_values=FLAGS)
flags.DEFINE_string('json', None, 'Also write the numbers here.',
                    flag_values=FLAGS)


def _main(argv: Sequence[str]) -> int:
  args = FLAGS

  import ble_latex  # noqa: F401  pylint: disable=g-import-not-at-top,unused-import
  from ble_latex.agents.sac import agent as sac  # pylint: disable=g-import-not-at-top
  from dopamine.jax.agents.sac import sac_agent  # pylint: disable=g-import-not-at-top
  from dopamine.replay_memory import circular_replay_buffer  # pylint: disable=g-import-not-at-top
  import jax  # pylint: disable=g-import-not-at-top
  import numpy as np  # pylint: disable=g-import-not-at-top

  agent = sac.SACAgent(3, (71,), seed=0, min_replay_history=1000,
                       replay_capacity=max(100_000, args.transitions))
  rng = np.random.default_rng(0)
  for i in range(args.transitions):
    agent._replay.add(  # pylint: disable=protected-access
        rng.normal(size=71).astype(np.float32),
        rng.uniform(-1, 1, 3).astype(np.float32), rng.random(), False,
        episode_end=(i % 216 == 215))
  agent.state = rng.normal(size=(71, 1)).astype(np.float32)

  def use_dopamine(on: bool) -> None:
    replay = agent._replay  # pylint: disable=protected-access
    if on:
      replay.__class__ = circular_replay_buffer.OutOfGraphReplayBuffer
      agent._sample_from_replay_buffer = functools.partial(  # pylint: disable=protected-access
          sac_agent.SACAgent._sample_from_replay_buffer, agent)  # pylint: disable=protected-access
      agent._maybe_sync_weights = functools.partial(  # pylint: disable=protected-access
          sac_agent.SACAgent._maybe_sync_weights, agent)  # pylint: disable=protected-access
    else:
      replay.__class__ = sac.VectorReplayBuffer
      agent.__dict__.pop('_sample_from_replay_buffer', None)
      agent.__dict__.pop('_maybe_sync_weights', None)

  def time_steps(config: str) -> float:
    use_dopamine(config == 'dopamine')
    for _ in range(5):  # Warm-up (compilation on the first call).
      agent._train_step()  # pylint: disable=protected-access
    jax.block_until_ready(agent.target_params)
    start = time.perf_counter()
    for _ in range(args.steps):
      agent._train_step()  # pylint: disable=protected-access
    jax.block_until_ready(agent.target_params)
    return (time.perf_counter() - start) / args.steps * 1e3

  times = {'dopamine': [], 'ble_latex': []}
  for _ in range(args.rounds):
    for config in times:
      times[config].append(time_steps(config))
  best = {k: min(v) for k, v in times.items()}
  result = {
      'ms_per_train_step_best': best,
      'ms_per_train_step_median': {k: statistics.median(v)
                                   for k, v in times.items()},
      'speedup_best': best['dopamine'] / best['ble_latex'],
      'steps': args.steps, 'rounds': args.rounds,
      'transitions': args.transitions,
  }
  print('| replay sampling + target update | ms per SAC training step (best '
        'of rounds) |')
  print('|---|---|')
  for k, v in best.items():
    print(f'| {k} | {v:.2f} |')
  print(f'speed-up: {result["speedup_best"]:.2f}x')
  result['update'] = _time_updates(agent, args.steps, args.rounds)
  result['per_env_step'] = _time_env_steps(args)
  result['load_average'] = os.getloadavg()
  print(json.dumps({k: result[k] for k in ('update', 'per_env_step',
                                           'load_average')}, indent=1))
  if args.json:
    safe_io.atomic_write(args.json, json.dumps(result, indent=2))
  return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/sac_step.py', FLAGS, argv,
                      doc=__doc__)


def _time_updates(agent, steps: int, rounds: int) -> dict:
  """ms per SAC update: Dopamine's `sac_agent.train` vs `sac_core.update`."""
  # pylint: disable=g-import-not-at-top
  from ble_latex.agents.sac import core as sac_core
  from ble_latex.agents.sac import networks
  from dopamine.jax.agents.sac import sac_agent
  import jax
  # pylint: enable=g-import-not-at-top
  agent._sample_from_replay_buffer()  # pylint: disable=protected-access
  e = agent.replay_elements

  def args(key):
    return (agent.network_def, agent.network_optimizer, agent.alpha_optimizer,
            agent.optimizer_state, agent.alpha_optimizer_state,
            agent.network_params, agent.target_params, agent.log_alpha, key,
            e['state'], e['action'], e['next_state'], e['reward'],
            e['terminal'], agent.cumulative_gamma, agent.target_entropy,
            agent.reward_scale_factor)

  # The same update with the other critics (`networks.CRITICS`), same sizes.
  critics = {}
  for critic in ('layernorm', 'crossq'):
    net = networks.make_network(3, agent._num_layers, agent._hidden_units,  # pylint: disable=protected-access
                                critic)
    init_key = jax.random.PRNGKey(1)
    params = net.init(init_key, e['state'][0], init_key)
    opt, alpha_opt = sac_core.make_optimizers(params, 3e-4, 3e-4, 3e-4)
    critics[f'ble_latex_update_{critic}'] = (
        net, opt, alpha_opt, opt.init(params),
        alpha_opt.init(agent.log_alpha), params, params)

  def call(name, key):
    if name == 'dopamine_train':
      return sac_agent.train(*args(key))
    if name == 'ble_latex_update':
      return sac_core.update(*args(key))
    return sac_core.update(*critics[name], *args(key)[7:])

  times = {name: [] for name in ('dopamine_train', 'ble_latex_update',
                                 *critics)}
  key = jax.random.PRNGKey(0)
  for name in times:
    jax.block_until_ready(call(name, key)['network_params'])  # Compile.
  for _ in range(rounds):
    for name in times:
      start = time.perf_counter()
      for _ in range(steps):
        out = call(name, key)
      jax.block_until_ready(out['network_params'])
      times[name].append((time.perf_counter() - start) / steps * 1e3)
  best = {k: min(v) for k, v in times.items()}
  return {'ms_per_update_best': best,
          'speedup_best': best['dopamine_train'] / best['ble_latex_update']}


def _time_env_steps(args) -> dict:
  """ms per env step of the agent's loop and of the jitted trainer."""
  # pylint: disable=g-import-not-at-top
  import gym
  from ble_latex.agents.sac import trainer as sac_trainer
  from ble_latex.envs import jax_env
  from ble_latex.run import gin_binding
  from ble_latex.run import runner
  import jax
  import jax.numpy as jnp
  # pylint: enable=g-import-not-at-top
  gin_binding.bind_gin('sac', None, [], [])
  env = gym.make('LatexBalloon-v0').unwrapped
  agent = runner.create_agent('sac', env, seed=0)
  obs = env.reset(seed=0)
  action = agent.begin_episode(obs)
  agent_ms = []
  steps_done = 0

  def fly(num_steps):
    nonlocal obs, action, steps_done
    for _ in range(num_steps):
      obs, reward, done, _ = env.step(action)
      steps_done += 1
      if done:
        agent.end_episode(reward, True)
        action = agent.begin_episode(env.reset(seed=steps_done))
      else:
        action = agent.step(reward, obs)

  # Fill min_replay_history (uniform actions, no updates) and compile.
  fly(agent.min_replay_history + 10)
  for _ in range(args.rounds):
    start = time.perf_counter()
    fly(args.env_steps)
    agent_ms.append((time.perf_counter() - start) / args.env_steps * 1e3)

  env_j = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  params = env_j.default_params
  steps = int(params.episode_steps)
  n, k = args.num_envs, args.updates_per_step
  timed = {}
  for name, min_history in (('env_only', 10 * n * steps), ('learning', 1000)):
    config = sac_trainer.TrainerConfig(
        num_envs=n, updates_per_step=k, min_replay_history=min_history,
        replay_capacity=(args.rounds + 2) * n * steps)
    learner, state = sac_trainer.make_learner(config, jax.random.PRNGKey(0))
    times = []
    for r in range(args.rounds + 1):
      seeds = jnp.arange(r * n, (r + 1) * n, dtype=jnp.int32)
      start = time.perf_counter()
      state, _ = sac_trainer.train_round(learner, env_j, state, seeds, steps,
                                         params)
      jax.block_until_ready(state.key)
      if r:  # Round 0 compiles (and, learning, fills the replay).
        times.append(time.perf_counter() - start)
    timed[name] = min(times)
  balloon_steps = n * steps
  updates = k * steps
  env_ms = timed['env_only'] / balloon_steps * 1e3
  update_ms = (timed['learning'] - timed['env_only']) / updates * 1e3
  return {
      'agent_ms_per_env_step_best': min(agent_ms),
      'agent_updates_per_env_step': 1,
      'jax_trainer_round_s_best': timed,
      'jax_trainer_ms_per_balloon_step_env_only': env_ms,
      'jax_trainer_ms_per_update': update_ms,
      'jax_trainer_ms_per_balloon_step_learning':
          timed['learning'] / balloon_steps * 1e3,
      'jax_trainer_updates_per_balloon_step': k / n,
      'num_envs': n, 'updates_per_step': k,
  }


if __name__ == '__main__':
  sys.exit(main())
