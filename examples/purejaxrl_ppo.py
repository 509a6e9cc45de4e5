# coding=utf-8
r"""purejaxrl-style PPO on the functional env, the whole training in lax.scan.

  python examples/purejaxrl_ppo.py --total_timesteps=1000000 --num_envs=64
  python examples/purejaxrl_ppo.py --short   # CI's run

Written the way purejaxrl writes `ppo_continuous_action.py` (`make_train`
returns a `train(rng)` that jits: a `lax.scan` over updates, each a scan over
env steps, GAE as a reverse scan, epochs and minibatches as scans), on
`ble_latex.envs.jax_env.LatexBalloonJaxEnv` directly, with no adapter: the
env follows gymnax 1.0's contract (`reset(key, params)`, `step(key, state,
action, params)` with auto-reset returning (obs, state, reward, terminated,
truncated, info), `action_space(params)`, `num_actions`,
`params.max_steps_in_episode`). Flax and optax; the diagonal Gaussian policy
is written out (no distrax: the pins keep it out, docs/clients.md). The
policy acts in [-1, 1]; its action is mapped onto the env's
`action_space(params)` Box, so it is the same code whether that Box is the
raw one (14 000-21 000 m, ...) or already [-1, 1].
"""

import argparse
import json
import sys
import time
from typing import Any, Dict, NamedTuple, Optional, Sequence

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
import optax
from flax.training.train_state import TrainState

from ble_latex.envs import env_types
from ble_latex.envs import jax_env


class ActorCritic(nn.Module):
  """Two tanh MLPs (purejaxrl's), a state-independent log std."""
  action_dim: int

  @nn.compact
  def __call__(self, x):
    def dense(n, scale):
      return nn.Dense(n, kernel_init=nn.initializers.orthogonal(scale),
                      bias_init=nn.initializers.constant(0.0))
    a = nn.tanh(dense(64, np.sqrt(2))(x))
    a = nn.tanh(dense(64, np.sqrt(2))(a))
    mean = dense(self.action_dim, 0.01)(a)
    log_std = self.param('log_std', nn.initializers.zeros, (self.action_dim,))
    c = nn.tanh(dense(64, np.sqrt(2))(x))
    c = nn.tanh(dense(64, np.sqrt(2))(c))
    return mean, log_std, jnp.squeeze(dense(1, 1.0)(c), -1)


def gaussian_log_prob(x, mean, log_std):
  return jnp.sum(-0.5 * ((x - mean) / jnp.exp(log_std)) ** 2 - log_std -
                 0.5 * jnp.log(2 * jnp.pi), axis=-1)


def gaussian_entropy(log_std):
  return jnp.sum(log_std + 0.5 * jnp.log(2 * jnp.pi * jnp.e), axis=-1)


class Transition(NamedTuple):
  done: jax.Array
  action: jax.Array
  value: jax.Array
  reward: jax.Array
  log_prob: jax.Array
  obs: jax.Array
  episode_return: jax.Array  # Return of the episode that ended, else 0.
  episode_done: jax.Array


def make_train(config: Dict[str, Any], env: jax_env.LatexBalloonJaxEnv,
               env_params: env_types.EnvParams):
  """purejaxrl's `make_train`: a `train(rng)` to jit."""
  num_updates = (config['total_timesteps'] // config['num_steps'] //
                 config['num_envs'])
  minibatch_size = (config['num_envs'] * config['num_steps'] //
                    config['num_minibatches'])
  space = env.action_space(env_params)
  low = jnp.asarray(space.low, jnp.float32)
  high = jnp.asarray(space.high, jnp.float32)

  def to_env_action(u):  # [-1, 1] (clipped) onto the env's Box.
    return low + (jnp.clip(u, -1.0, 1.0) + 1.0) * 0.5 * (high - low)

  def linear_schedule(count):
    frac = 1.0 - (count // (config['num_minibatches'] *
                            config['update_epochs'])) / num_updates
    return config['lr'] * frac

  def train(rng):
    network = ActorCritic(env.num_actions)
    rng, init_rng = jax.random.split(rng)
    params = network.init(
        init_rng, jnp.zeros(env.observation_space(env_params).shape))
    tx = optax.chain(
        optax.clip_by_global_norm(config['max_grad_norm']),
        optax.adam(learning_rate=linear_schedule if config['anneal_lr']
                   else config['lr'], eps=1e-5))
    train_state = TrainState.create(apply_fn=network.apply, params=params,
                                    tx=tx)
    rng, reset_rng = jax.random.split(rng)
    obsv, env_state = jax.vmap(env.reset, in_axes=(0, None))(
        jax.random.split(reset_rng, config['num_envs']), env_params)
    running_return = jnp.zeros(config['num_envs'])

    def update_step(runner_state, unused):
      def env_step(runner_state, unused):
        train_state, env_state, last_obs, running_return, rng = runner_state
        rng, act_rng, step_rng = jax.random.split(rng, 3)
        mean, log_std, value = network.apply(train_state.params, last_obs)
        action = mean + jnp.exp(log_std) * jax.random.normal(act_rng,
                                                             mean.shape)
        log_prob = gaussian_log_prob(action, mean, log_std)
        obsv, env_state, reward, terminated, truncated, info = jax.vmap(
            env.step, in_axes=(0, 0, 0, None))(
                jax.random.split(step_rng, config['num_envs']), env_state,
                to_env_action(action), env_params)
        done = terminated | truncated
        running_return = running_return + reward
        transition = Transition(done, action, value, reward, log_prob,
                                last_obs, jnp.where(done, running_return, 0.0),
                                done)
        running_return = jnp.where(done, 0.0, running_return)
        return (train_state, env_state, obsv, running_return, rng), transition

      runner_state, traj_batch = jax.lax.scan(env_step, runner_state, None,
                                              config['num_steps'])
      train_state, env_state, last_obs, running_return, rng = runner_state
      _, _, last_val = network.apply(train_state.params, last_obs)

      def gae_step(carry, transition):
        gae, next_value = carry
        delta = (transition.reward + config['gamma'] * next_value *
                 (1 - transition.done) - transition.value)
        gae = delta + (config['gamma'] * config['gae_lambda'] *
                       (1 - transition.done) * gae)
        return (gae, transition.value), gae

      _, advantages = jax.lax.scan(gae_step,
                                   (jnp.zeros_like(last_val), last_val),
                                   traj_batch, reverse=True, unroll=16)
      targets = advantages + traj_batch.value

      def update_epoch(update_state, unused):
        def update_minibatch(train_state, batch):
          traj, gae, target = batch

          def loss_fn(params):
            mean, log_std, value = network.apply(params, traj.obs)
            log_prob = gaussian_log_prob(traj.action, mean, log_std)
            value_clipped = traj.value + jnp.clip(
                value - traj.value, -config['clip_eps'], config['clip_eps'])
            value_loss = 0.5 * jnp.maximum(
                jnp.square(value - target),
                jnp.square(value_clipped - target)).mean()
            ratio = jnp.exp(log_prob - traj.log_prob)
            adv = (gae - gae.mean()) / (gae.std() + 1e-8)
            actor_loss = -jnp.minimum(
                ratio * adv,
                jnp.clip(ratio, 1.0 - config['clip_eps'],
                         1.0 + config['clip_eps']) * adv).mean()
            entropy = gaussian_entropy(log_std).mean()
            total = (actor_loss + config['vf_coef'] * value_loss -
                     config['ent_coef'] * entropy)
            return total, (value_loss, actor_loss, entropy)

          (total, aux), grads = jax.value_and_grad(loss_fn, has_aux=True)(
              train_state.params)
          return train_state.apply_gradients(grads=grads), (total, aux)

        train_state, traj_batch, advantages, targets, rng = update_state
        rng, perm_rng = jax.random.split(rng)
        batch_size = minibatch_size * config['num_minibatches']
        permutation = jax.random.permutation(perm_rng, batch_size)
        batch = jax.tree.map(
            lambda x: x.reshape((batch_size,) + x.shape[2:]),
            (traj_batch, advantages, targets))
        minibatches = jax.tree.map(
            lambda x: jnp.take(x, permutation, axis=0).reshape(
                [config['num_minibatches'], -1] + list(x.shape[1:])), batch)
        train_state, losses = jax.lax.scan(update_minibatch, train_state,
                                           minibatches)
        return (train_state, traj_batch, advantages, targets, rng), losses

      update_state = (train_state, traj_batch, advantages, targets, rng)
      update_state, losses = jax.lax.scan(update_epoch, update_state, None,
                                          config['update_epochs'])
      train_state, rng = update_state[0], update_state[-1]
      metric = {
          'episode_return_sum': traj_batch.episode_return.sum(),
          'episodes': traj_batch.episode_done.sum(),
          'reward_mean': traj_batch.reward.mean(),
          'loss': losses[0].mean(),
      }
      return (train_state, env_state, last_obs, running_return, rng), metric

    rng, train_rng = jax.random.split(rng)
    runner_state = (train_state, env_state, obsv, running_return, train_rng)
    runner_state, metrics = jax.lax.scan(update_step, runner_state, None,
                                         num_updates)
    return {'runner_state': runner_state, 'metrics': metrics}

  return train


def parse_args(argv: Optional[Sequence[str]]) -> argparse.Namespace:
  parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
  parser.add_argument('--total_timesteps', type=int, default=1_000_000)
  parser.add_argument('--num_envs', type=int, default=64)
  parser.add_argument('--num_steps', type=int, default=216)
  parser.add_argument('--update_epochs', type=int, default=4)
  parser.add_argument('--num_minibatches', type=int, default=32)
  parser.add_argument('--lr', type=float, default=3e-4)
  parser.add_argument('--episode_steps', type=int, default=None,
                      help="Episode length (default: the env's 216).")
  parser.add_argument('--seed', type=int, default=0)
  parser.add_argument('--short', action='store_true',
                      help='A tiny run (CI): 2 envs x 8 steps x 2 updates, '
                      '6-step episodes.')
  args = parser.parse_args(argv)
  if args.short:
    args.total_timesteps, args.num_envs, args.num_steps = 32, 2, 8
    args.update_epochs, args.num_minibatches = 1, 2
    args.episode_steps = args.episode_steps or 6
  for name in ('total_timesteps', 'num_envs', 'num_steps', 'update_epochs',
               'num_minibatches'):
    if getattr(args, name) < 1:
      parser.error(f'--{name} must be >= 1')
  if args.total_timesteps < args.num_envs * args.num_steps:
    parser.error('--total_timesteps must be >= num_envs * num_steps')
  if (args.num_envs * args.num_steps) % args.num_minibatches:
    parser.error('num_envs * num_steps must divide into --num_minibatches')
  return args


def main(argv: Optional[Sequence[str]] = None) -> Dict[str, Any]:
  args = parse_args(argv)
  config = {
      'lr': args.lr, 'num_envs': args.num_envs, 'num_steps': args.num_steps,
      'total_timesteps': args.total_timesteps,
      'update_epochs': args.update_epochs,
      'num_minibatches': args.num_minibatches, 'gamma': 0.99,
      'gae_lambda': 0.95, 'clip_eps': 0.2, 'ent_coef': 0.0, 'vf_coef': 0.5,
      'max_grad_norm': 0.5, 'anneal_lr': True,
  }
  env = jax_env.LatexBalloonJaxEnv()
  env_params = env.default_params
  if args.episode_steps is not None:
    env_params = env_params.replace(episode_steps=args.episode_steps)
  start = time.monotonic()
  train = jax.jit(make_train(config, env, env_params))
  out = jax.block_until_ready(train(jax.random.PRNGKey(args.seed)))
  seconds = time.monotonic() - start
  metrics = jax.tree.map(np.asarray, out['metrics'])
  episodes = metrics['episodes'].sum()
  summary = {
      'updates': len(metrics['loss']),
      'env_steps': int(len(metrics['loss']) * args.num_envs * args.num_steps),
      'episodes': int(episodes),
      'mean_episode_return': (float(metrics['episode_return_sum'].sum() /
                                    episodes) if episodes else None),
      'final_loss': float(metrics['loss'][-1]),
      'seconds_with_compile': round(seconds, 1),
  }
  print(json.dumps(summary))
  return summary


if __name__ == '__main__':
  main()
  sys.exit(0)
