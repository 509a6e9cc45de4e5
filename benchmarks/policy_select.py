# coding=utf-8
r"""Test-time action selection over SAC policies (issue 47): a measurement.

Flies the first `--num_seeds` seeds of a suite, batched on the functional
env (as `sac_trainer.validate` does), with one of these deciders over the
policy files given (all of the same `latex_observation.*` settings):

- `mean`: the first policy's deterministic action tanh(mu(o)) (what
  `sac_pretrained` flies; reproduces the trainer's validation);
- `average`: the mean of the policies' deterministic actions (an ensemble);
- `critic`: candidates = each policy's deterministic action and
  `--samples` draws from each policy's stochastic actor; the candidate with
  the largest mean over the policies of min(Q1, Q2)(o, a) is flown
  (policy improvement by the learned critics at decision time).

Writes a JSON record: per seed, the within-radius steps, steps flown and
the flight's status; the mean TW50 over the window and % out of resources.

  python benchmarks/policy_select.py --mode=critic --samples=8 \
      --policy=benchmarks/sac_jax/wind_lookahead12/seed_0/chosen_policy.msgpack \
      --gin_file=gin_configs/latex_wind_lookahead.gin --suite=latex_validation \
      --output=/tmp/select.json
"""

import json
import os
import sys
import time
from typing import Any, List, Sequence

from absl import app
from absl import flags
import gin
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex.agents import plan_value
from ble_latex.envs import env_params
from ble_latex.envs import jax_env
from ble_latex.run import jax_train
from ble_latex.run import metrics
from ble_latex.run import suites

FLAGS = flags.FlagValues()
flags.DEFINE_multi_string('policy', [], 'SAC policy files (or "shipped").',
                          flag_values=FLAGS)
flags.DEFINE_multi_string('gin_file', [], 'gin files of the env.',
                          flag_values=FLAGS)
flags.DEFINE_enum('mode', 'mean', ['mean', 'average', 'critic'], 'decider.',
                  flag_values=FLAGS)
flags.DEFINE_integer('samples', 0, 'critic: stochastic draws per policy.',
                     flag_values=FLAGS)
flags.DEFINE_enum('score', 'mean', ['mean', 'min'], 'critic: how the '
                  "policies' critics combine.", flag_values=FLAGS)
flags.DEFINE_string('suite', 'latex_validation', 'seeds of this suite.',
                    flag_values=FLAGS)
flags.DEFINE_integer('num_seeds', 100, 'first seeds of the suite.',
                     flag_values=FLAGS)
flags.DEFINE_integer('batch', 100, 'balloons per compiled call.',
                     flag_values=FLAGS)
flags.DEFINE_string('output', '', 'JSON record.', flag_values=FLAGS)


def decider(mode: str, samples: int, nets: List[Any], weights: List[Any],
            score: str = 'mean'):
  """obs [N, F], key -> normalised actions [N, 3]."""

  def actor(m, obs, key):
    return jax.vmap(lambda o, k: nets[m].apply(
        weights[m], o, k, method=nets[m].actor))(
            obs, jax.random.split(key, obs.shape[0]))

  def q(m, obs, actions):
    out = jax.vmap(lambda o, a: nets[m].apply(
        weights[m], o, a, method=nets[m].critic))(obs, actions)
    return jnp.minimum(out.q_value1, out.q_value2).reshape(obs.shape[0])

  def decide(obs, key):
    keys = jax.random.split(key, len(nets) * max(samples, 1))
    means = [actor(m, obs, keys[0]).mean_action for m in range(len(nets))]
    if mode == 'mean':
      return means[0]
    if mode == 'average':
      return jnp.mean(jnp.stack(means), axis=0)
    candidates = list(means)
    for m in range(len(nets)):
      for s in range(samples):
        candidates.append(
            actor(m, obs, keys[m * samples + s]).sampled_action)
    cands = jnp.stack(candidates)  # [C, N, 3]
    combine = jnp.mean if score == 'mean' else jnp.min
    scores = combine(jnp.stack([
        jax.vmap(lambda a, m=m: q(m, obs, a))(cands)
        for m in range(len(nets))]), axis=0)  # [C, N]
    best = jnp.argmax(scores, axis=0)
    return jnp.take_along_axis(cands, best[None, :, None], axis=0)[0]

  return decide


def fly(env, params, decide, seeds: Sequence[int], num_steps: int):
  """Within-radius steps, steps and status of each seed's flight."""

  @jax.jit
  def run(seeds, key):
    obs, state = jax.vmap(env.reset, in_axes=(0, None))(
        jax.vmap(jax.random.PRNGKey)(seeds), params)
    n = seeds.shape[0]

    def one_step(carry, key):
      state, obs, active, within, steps = carry
      action = decide(obs, key)
      obs, state, _, terminated, info = jax.vmap(
          env.step_env, in_axes=(None, 0, 0, None))(
              None, state, env.env_action(action), params)
      done = terminated | info['time_limit']
      within = within + (active & (info['distance_km'] <= params.radius_km))
      steps = steps + active
      return (state, obs, active & ~done, within, steps), None

    zeros = jnp.zeros((n,), jnp.int32)
    (state, _, _, within, steps), _ = jax.lax.scan(
        one_step, (state, obs, jnp.ones((n,), bool), zeros, zeros),
        jax.random.split(key, num_steps))
    return {'within_steps': within, 'steps': steps,
            'status': state.flight.status}

  return jax.device_get(run(jnp.asarray(seeds, jnp.int32),
                            jax.random.PRNGKey(0)))


def main(argv: Sequence[str]) -> int:
  FLAGS(argv)
  if not FLAGS.policy:
    print('policy_select: give at least one --policy', file=sys.stderr)
    return 2
  gin.parse_config_files_and_bindings(FLAGS.gin_file, [])
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  params = env.default_params
  mine = env_params.observation_of(params)
  nets, weights = [], []
  for path in FLAGS.policy:
    net, w, observation = plan_value.load(path)
    if dict(observation) != mine:
      print(f'policy_select: {path} observed {dict(observation)}, the env '
            f'{mine}', file=sys.stderr)
      return 2
    nets.append(net)
    weights.append(w)
  decide = decider(FLAGS.mode, FLAGS.samples, nets, weights, FLAGS.score)
  seeds = list(suites.get_eval_suite(FLAGS.suite).seeds)[:FLAGS.num_seeds]
  window = int(params.episode_steps)
  began = time.time()
  parts = [fly(env, params, decide, seeds[i:i + FLAGS.batch], window)
           for i in range(0, len(seeds), FLAGS.batch)]
  result = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
  wall = time.time() - began
  summary = jax_train.validation_summary(result, window)
  tw50 = [metrics.tw50_fractions(int(w), int(s), window)['tw50_window']
          for w, s in zip(result['within_steps'], result['steps'])]
  record = {'mode': FLAGS.mode, 'samples': FLAGS.samples, 'score': FLAGS.score,
            'policies': list(FLAGS.policy), 'gin_files': list(FLAGS.gin_file),
            'suite': FLAGS.suite, 'seeds': seeds, 'tw50_window': tw50,
            'status': [int(x) for x in result['status']],
            'wall_s': wall, 'load': os.getloadavg()[0],
            'date': time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime()),
            **summary}
  print(json.dumps({k: v for k, v in record.items()
                    if k not in ('seeds', 'tw50_window', 'status')}))
  if FLAGS.output:
    with open(FLAGS.output, 'w', encoding='utf-8') as f:
      json.dump(record, f)
  return 0


if __name__ == '__main__':
  sys.exit(main(sys.argv))
