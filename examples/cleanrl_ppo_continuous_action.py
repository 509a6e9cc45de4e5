# coding=utf-8
r"""CleanRL-style single-file PPO (continuous actions) on a ble_latex id.

  python examples/cleanrl_ppo_continuous_action.py \
      --env-id ble_latex:ble_latex/LatexBalloon-v0 --total-timesteps 100000
  python examples/cleanrl_ppo_continuous_action.py --short   # CI's run

Written the way CleanRL writes `ppo_continuous_action.py` (one file: args,
`make_env` with CleanRL's wrappers, the agent, rollout, GAE, clipped PPO
update), for Gymnasium 1.x (CleanRL pins 0.29): `TransformObservation` and
`TransformReward` take their spaces, `NormalizeObservation` and
`NormalizeReward` are the 1.x wrappers, episode statistics come from
`infos['episode']` with its `'_episode'` mask, and the vector env's default
next-step auto-reset is kept (the step after an episode's end carries the
reset observation; PPO's `next_done` handles it as CleanRL does). The id is
written `module:id` (`ble_latex:ble_latex/...`), which imports ble_latex
inside `gymnasium.make`. A Gaussian policy wants actions near [-1, 1]:
`make_env` adds `RescaleAction(-1, 1)` when the env's Box is another one
(the raw 14 000-21 000 m Box), and adds nothing when it is already [-1, 1].
Torch on CPU.
"""

import argparse
import dataclasses
import json
import random
import sys
import time
from typing import Any, Callable, Dict, Optional, Sequence

import gymnasium as gym
import numpy as np
import torch
from torch import nn
from torch import optim


@dataclasses.dataclass
class Args:
  env_id: str = 'ble_latex:ble_latex/LatexBalloon-v0'
  """The environment id (CleanRL's --env-id)."""
  seed: int = 1
  torch_deterministic: bool = True
  total_timesteps: int = 100_000
  learning_rate: float = 3e-4
  num_envs: int = 1
  num_steps: int = 2048
  anneal_lr: bool = True
  gamma: float = 0.99
  gae_lambda: float = 0.95
  num_minibatches: int = 32
  update_epochs: int = 10
  norm_adv: bool = True
  clip_coef: float = 0.2
  clip_vloss: bool = True
  ent_coef: float = 0.0
  vf_coef: float = 0.5
  max_grad_norm: float = 0.5
  target_kl: Optional[float] = None
  max_episode_steps: Optional[int] = None
  """Shorter episodes than the env's 216 steps (gymnasium's TimeLimit)."""
  torch_threads: int = 1
  short: bool = False
  """A tiny run (CI): 2 envs x 16 steps x 2 iterations, 12-step episodes."""


def parse_args(argv: Optional[Sequence[str]] = None) -> Args:
  """CleanRL's `--kebab-case` flags from the dataclass (tyro's style)."""
  parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
  for field in dataclasses.fields(Args):
    flag = '--' + field.name.replace('_', '-')
    kind = str(field.type)
    if field.type is bool:
      parser.add_argument(flag, action=argparse.BooleanOptionalAction,
                          default=field.default)
    elif 'float' in kind:
      parser.add_argument(flag, type=float, default=field.default)
    elif 'int' in kind:
      parser.add_argument(flag, type=int, default=field.default)
    else:
      parser.add_argument(flag, type=str, default=field.default)
  args = Args(**vars(parser.parse_args(argv)))
  if args.short:
    args = dataclasses.replace(
        args, total_timesteps=64, num_envs=2, num_steps=16, num_minibatches=2,
        update_epochs=2, max_episode_steps=args.max_episode_steps or 12)
  return args


def make_env(env_id: str, gamma: float, max_episode_steps: Optional[int]
             ) -> Callable[[], gym.Env]:
  def thunk():
    kwargs = {} if max_episode_steps is None else {
        'max_episode_steps': max_episode_steps}
    env = gym.make(env_id, **kwargs)
    box = env.action_space
    if not (np.all(box.low == -1) and np.all(box.high == 1)):
      one = np.ones(box.shape, np.float32)  # float32: no precision warning.
      env = gym.wrappers.RescaleAction(env, -one, one)
    env = gym.wrappers.FlattenObservation(env)
    env = gym.wrappers.RecordEpisodeStatistics(env)
    env = gym.wrappers.ClipAction(env)
    env = gym.wrappers.NormalizeObservation(env)
    env = gym.wrappers.TransformObservation(
        env, lambda obs: np.clip(obs, -10, 10), env.observation_space)
    env = gym.wrappers.NormalizeReward(env, gamma=gamma)
    env = gym.wrappers.TransformReward(env, lambda r: float(np.clip(r, -10,
                                                                    10)))
    return env
  return thunk


def layer_init(layer: nn.Linear, std: float = np.sqrt(2),
               bias_const: float = 0.0) -> nn.Linear:
  torch.nn.init.orthogonal_(layer.weight, std)
  torch.nn.init.constant_(layer.bias, bias_const)
  return layer


class Agent(nn.Module):

  def __init__(self, envs: gym.vector.VectorEnv):
    super().__init__()
    obs_dim = int(np.prod(envs.single_observation_space.shape))
    act_dim = int(np.prod(envs.single_action_space.shape))
    self.critic = nn.Sequential(
        layer_init(nn.Linear(obs_dim, 64)), nn.Tanh(),
        layer_init(nn.Linear(64, 64)), nn.Tanh(),
        layer_init(nn.Linear(64, 1), std=1.0))
    self.actor_mean = nn.Sequential(
        layer_init(nn.Linear(obs_dim, 64)), nn.Tanh(),
        layer_init(nn.Linear(64, 64)), nn.Tanh(),
        layer_init(nn.Linear(64, act_dim), std=0.01))
    self.actor_logstd = nn.Parameter(torch.zeros(1, act_dim))

  def get_value(self, x: torch.Tensor) -> torch.Tensor:
    return self.critic(x)

  def get_action_and_value(self, x: torch.Tensor,
                           action: Optional[torch.Tensor] = None):
    action_mean = self.actor_mean(x)
    action_std = torch.exp(self.actor_logstd.expand_as(action_mean))
    probs = torch.distributions.Normal(action_mean, action_std)
    if action is None:
      action = probs.sample()
    return (action, probs.log_prob(action).sum(1), probs.entropy().sum(1),
            self.critic(x))


def main(argv: Optional[Sequence[str]] = None) -> Dict[str, Any]:
  args = parse_args(argv)
  batch_size = int(args.num_envs * args.num_steps)
  minibatch_size = int(batch_size // args.num_minibatches)
  num_iterations = max(1, args.total_timesteps // batch_size)
  random.seed(args.seed)
  np.random.seed(args.seed)
  torch.manual_seed(args.seed)
  torch.backends.cudnn.deterministic = args.torch_deterministic
  torch.set_num_threads(args.torch_threads)
  device = torch.device('cpu')

  envs = gym.vector.SyncVectorEnv(
      [make_env(args.env_id, args.gamma, args.max_episode_steps)
       for _ in range(args.num_envs)])
  assert isinstance(envs.single_action_space, gym.spaces.Box), (
      'only continuous action space is supported')

  agent = Agent(envs).to(device)
  optimizer = optim.Adam(agent.parameters(), lr=args.learning_rate, eps=1e-5)

  obs_shape = envs.single_observation_space.shape
  act_shape = envs.single_action_space.shape
  obs = torch.zeros((args.num_steps, args.num_envs) + obs_shape)
  actions = torch.zeros((args.num_steps, args.num_envs) + act_shape)
  logprobs = torch.zeros((args.num_steps, args.num_envs))
  rewards = torch.zeros((args.num_steps, args.num_envs))
  dones = torch.zeros((args.num_steps, args.num_envs))
  values = torch.zeros((args.num_steps, args.num_envs))

  global_step = 0
  start_time = time.time()
  returns, stats = [], {}
  next_obs, _ = envs.reset(seed=args.seed)
  next_obs = torch.Tensor(next_obs).to(device)
  next_done = torch.zeros(args.num_envs).to(device)

  for iteration in range(1, num_iterations + 1):
    if args.anneal_lr:
      frac = 1.0 - (iteration - 1.0) / num_iterations
      optimizer.param_groups[0]['lr'] = frac * args.learning_rate

    for step in range(args.num_steps):
      global_step += args.num_envs
      obs[step] = next_obs
      dones[step] = next_done
      with torch.no_grad():
        action, logprob, _, value = agent.get_action_and_value(next_obs)
        values[step] = value.flatten()
      actions[step] = action
      logprobs[step] = logprob

      next_obs, reward, terminations, truncations, infos = envs.step(
          action.cpu().numpy())
      next_done = np.logical_or(terminations, truncations)
      rewards[step] = torch.tensor(reward).to(device).view(-1)
      next_obs = torch.Tensor(next_obs).to(device)
      next_done = torch.Tensor(next_done).to(device)
      if '_episode' in infos:
        for i in np.flatnonzero(infos['_episode']):
          returns.append(float(infos['episode']['r'][i]))
          print(f'global_step={global_step}, episodic_return='
                f'{returns[-1]:.2f}')

    # Generalized advantage estimation.
    with torch.no_grad():
      next_value = agent.get_value(next_obs).reshape(1, -1)
      advantages = torch.zeros_like(rewards).to(device)
      lastgaelam = 0
      for t in reversed(range(args.num_steps)):
        if t == args.num_steps - 1:
          nextnonterminal = 1.0 - next_done
          nextvalues = next_value
        else:
          nextnonterminal = 1.0 - dones[t + 1]
          nextvalues = values[t + 1]
        delta = (rewards[t] + args.gamma * nextvalues * nextnonterminal -
                 values[t])
        advantages[t] = lastgaelam = (
            delta + args.gamma * args.gae_lambda * nextnonterminal *
            lastgaelam)
      returns_t = advantages + values

    b_obs = obs.reshape((-1,) + obs_shape)
    b_logprobs = logprobs.reshape(-1)
    b_actions = actions.reshape((-1,) + act_shape)
    b_advantages = advantages.reshape(-1)
    b_returns = returns_t.reshape(-1)
    b_values = values.reshape(-1)

    b_inds = np.arange(batch_size)
    clipfracs = []
    for _ in range(args.update_epochs):
      np.random.shuffle(b_inds)
      for start in range(0, batch_size, minibatch_size):
        mb_inds = b_inds[start:start + minibatch_size]
        _, newlogprob, entropy, newvalue = agent.get_action_and_value(
            b_obs[mb_inds], b_actions[mb_inds])
        logratio = newlogprob - b_logprobs[mb_inds]
        ratio = logratio.exp()
        with torch.no_grad():
          approx_kl = ((ratio - 1) - logratio).mean()
          clipfracs.append(
              ((ratio - 1.0).abs() > args.clip_coef).float().mean().item())
        mb_advantages = b_advantages[mb_inds]
        if args.norm_adv:
          mb_advantages = ((mb_advantages - mb_advantages.mean()) /
                           (mb_advantages.std() + 1e-8))
        pg_loss1 = -mb_advantages * ratio
        pg_loss2 = -mb_advantages * torch.clamp(ratio, 1 - args.clip_coef,
                                                1 + args.clip_coef)
        pg_loss = torch.max(pg_loss1, pg_loss2).mean()
        newvalue = newvalue.view(-1)
        if args.clip_vloss:
          v_loss_unclipped = (newvalue - b_returns[mb_inds]) ** 2
          v_clipped = b_values[mb_inds] + torch.clamp(
              newvalue - b_values[mb_inds], -args.clip_coef, args.clip_coef)
          v_loss_clipped = (v_clipped - b_returns[mb_inds]) ** 2
          v_loss = 0.5 * torch.max(v_loss_unclipped, v_loss_clipped).mean()
        else:
          v_loss = 0.5 * ((newvalue - b_returns[mb_inds]) ** 2).mean()
        entropy_loss = entropy.mean()
        loss = pg_loss - args.ent_coef * entropy_loss + v_loss * args.vf_coef
        optimizer.zero_grad()
        loss.backward()
        nn.utils.clip_grad_norm_(agent.parameters(), args.max_grad_norm)
        optimizer.step()
      if args.target_kl is not None and approx_kl > args.target_kl:
        break

    stats = {'value_loss': v_loss.item(), 'policy_loss': pg_loss.item(),
             'entropy': entropy_loss.item(), 'approx_kl': approx_kl.item(),
             'clipfrac': float(np.mean(clipfracs))}
    print(f'iteration={iteration}, SPS='
          f'{int(global_step / (time.time() - start_time))}, {stats}')

  envs.close()
  summary = {'episodic_returns': returns, 'global_step': global_step,
             **stats, 'steps_per_second': global_step /
                                         (time.time() - start_time)}
  print(json.dumps(summary))
  return summary


if __name__ == '__main__':
  main()
  sys.exit(0)
