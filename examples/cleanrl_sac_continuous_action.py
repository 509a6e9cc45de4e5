# coding=utf-8
r"""CleanRL-style single-file SAC (continuous actions) on a ble_latex id.

  python examples/cleanrl_sac_continuous_action.py \
      --env-id ble_latex:ble_latex/LatexBalloon-v0 --total-timesteps 20000
  python examples/cleanrl_sac_continuous_action.py --short   # CI's run

Written the way CleanRL writes `sac_continuous_action.py` (one file: args,
`make_env`, the networks, the loop), for Gymnasium 1.x (CleanRL pins 0.29):
the vector env auto-resets in the same step (`AutoresetMode.SAME_STEP`), so
the replay buffer stores `infos['final_obs']` as the next observation where an
episode ended, and episode statistics come from `infos['final_info']`'s
`'episode'` with its `'_episode'` mask. The id is written `module:id` (`ble_latex:ble_latex/...`),
which imports ble_latex (registering its ids) inside `gymnasium.make`; with a
bare `ble_latex/LatexBalloon-v0` add `import ble_latex` instead. The actor's
tanh output is scaled to the env's action Box, so it works with the raw Box
(14 000-21 000 m, ...) as with a normalized one. Torch on CPU.
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
import torch.nn.functional as F
from torch import optim


@dataclasses.dataclass
class Args:
  env_id: str = 'ble_latex:ble_latex/LatexBalloon-v0'
  """The environment id (CleanRL's --env-id)."""
  seed: int = 1
  torch_deterministic: bool = True
  total_timesteps: int = 20_000
  num_envs: int = 1
  buffer_size: int = 100_000
  gamma: float = 0.99
  tau: float = 0.005
  batch_size: int = 256
  learning_starts: int = 1_000
  policy_lr: float = 3e-4
  q_lr: float = 1e-3
  policy_frequency: int = 2
  target_network_frequency: int = 1
  alpha: float = 0.2
  autotune: bool = True
  max_episode_steps: Optional[int] = None
  """Shorter episodes than the env's 216 steps (gymnasium's TimeLimit)."""
  torch_threads: int = 1
  short: bool = False
  """A tiny run (CI): 64 steps, 16-step episodes, batch 16."""


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
        args, total_timesteps=64, learning_starts=16, batch_size=16,
        buffer_size=64, max_episode_steps=args.max_episode_steps or 16)
  return args


def make_env(env_id: str, seed: int, max_episode_steps: Optional[int]
             ) -> Callable[[], gym.Env]:
  def thunk():
    kwargs = {} if max_episode_steps is None else {
        'max_episode_steps': max_episode_steps}
    env = gym.make(env_id, **kwargs)
    env = gym.wrappers.RecordEpisodeStatistics(env)
    env.action_space.seed(seed)
    return env
  return thunk


class SoftQNetwork(nn.Module):

  def __init__(self, envs: gym.vector.VectorEnv):
    super().__init__()
    obs_dim = int(np.prod(envs.single_observation_space.shape))
    act_dim = int(np.prod(envs.single_action_space.shape))
    self.fc1 = nn.Linear(obs_dim + act_dim, 256)
    self.fc2 = nn.Linear(256, 256)
    self.fc3 = nn.Linear(256, 1)

  def forward(self, x: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
    x = torch.cat([x, a], 1)
    x = F.relu(self.fc1(x))
    x = F.relu(self.fc2(x))
    return self.fc3(x)


LOG_STD_MAX = 2
LOG_STD_MIN = -5


class Actor(nn.Module):

  def __init__(self, envs: gym.vector.VectorEnv):
    super().__init__()
    obs_dim = int(np.prod(envs.single_observation_space.shape))
    act_dim = int(np.prod(envs.single_action_space.shape))
    self.fc1 = nn.Linear(obs_dim, 256)
    self.fc2 = nn.Linear(256, 256)
    self.fc_mean = nn.Linear(256, act_dim)
    self.fc_logstd = nn.Linear(256, act_dim)
    high = envs.single_action_space.high.astype(np.float32)
    low = envs.single_action_space.low.astype(np.float32)
    # The Box's centre and half-width: tanh's (-1, 1) spans the Box.
    self.register_buffer('action_scale', torch.tensor((high - low) / 2.0))
    self.register_buffer('action_bias', torch.tensor((high + low) / 2.0))

  def forward(self, x: torch.Tensor):
    x = F.relu(self.fc1(x))
    x = F.relu(self.fc2(x))
    mean = self.fc_mean(x)
    log_std = torch.tanh(self.fc_logstd(x))
    log_std = LOG_STD_MIN + 0.5 * (LOG_STD_MAX - LOG_STD_MIN) * (log_std + 1)
    return mean, log_std

  def get_action(self, x: torch.Tensor):
    mean, log_std = self(x)
    normal = torch.distributions.Normal(mean, log_std.exp())
    x_t = normal.rsample()  # Reparameterized.
    y_t = torch.tanh(x_t)
    action = y_t * self.action_scale + self.action_bias
    log_prob = normal.log_prob(x_t)
    # The tanh squashing's change of variables.
    log_prob -= torch.log(self.action_scale * (1 - y_t.pow(2)) + 1e-6)
    log_prob = log_prob.sum(1, keepdim=True)
    mean = torch.tanh(mean) * self.action_scale + self.action_bias
    return action, log_prob, mean


class ReplayBuffer:
  """A NumPy ring buffer of (obs, next_obs, action, reward, done)."""

  def __init__(self, size: int, obs_dim: int, act_dim: int):
    self.obs = np.zeros((size, obs_dim), np.float32)
    self.next_obs = np.zeros((size, obs_dim), np.float32)
    self.actions = np.zeros((size, act_dim), np.float32)
    self.rewards = np.zeros((size, 1), np.float32)
    self.dones = np.zeros((size, 1), np.float32)
    self.size, self.pos, self.full = size, 0, False

  def add(self, obs, next_obs, actions, rewards, terminations) -> None:
    for i in range(len(obs)):
      self.obs[self.pos] = obs[i]
      self.next_obs[self.pos] = next_obs[i]
      self.actions[self.pos] = actions[i]
      self.rewards[self.pos] = rewards[i]
      self.dones[self.pos] = terminations[i]
      self.pos = (self.pos + 1) % self.size
      self.full = self.full or self.pos == 0

  def sample(self, batch_size: int, rng: np.random.Generator):
    idx = rng.integers(0, self.size if self.full else self.pos, batch_size)
    return [torch.as_tensor(a[idx]) for a in (
        self.obs, self.actions, self.next_obs, self.dones, self.rewards)]


def main(argv: Optional[Sequence[str]] = None) -> Dict[str, Any]:
  args = parse_args(argv)
  random.seed(args.seed)
  np.random.seed(args.seed)
  torch.manual_seed(args.seed)
  torch.backends.cudnn.deterministic = args.torch_deterministic
  torch.set_num_threads(args.torch_threads)
  device = torch.device('cpu')
  rng = np.random.default_rng(args.seed)

  envs = gym.vector.SyncVectorEnv(
      [make_env(args.env_id, args.seed + i, args.max_episode_steps)
       for i in range(args.num_envs)],
      autoreset_mode=gym.vector.AutoresetMode.SAME_STEP)
  assert isinstance(envs.single_action_space, gym.spaces.Box), (
      'only continuous action space is supported')

  actor = Actor(envs).to(device)
  qf1, qf2 = SoftQNetwork(envs).to(device), SoftQNetwork(envs).to(device)
  qf1_target, qf2_target = SoftQNetwork(envs), SoftQNetwork(envs)
  qf1_target.load_state_dict(qf1.state_dict())
  qf2_target.load_state_dict(qf2.state_dict())
  q_optimizer = optim.Adam(list(qf1.parameters()) + list(qf2.parameters()),
                           lr=args.q_lr)
  actor_optimizer = optim.Adam(list(actor.parameters()), lr=args.policy_lr)
  if args.autotune:
    target_entropy = -float(np.prod(envs.single_action_space.shape))
    log_alpha = torch.zeros(1, requires_grad=True, device=device)
    alpha = log_alpha.exp().item()
    a_optimizer = optim.Adam([log_alpha], lr=args.q_lr)
  else:
    alpha = args.alpha

  obs_dim = int(np.prod(envs.single_observation_space.shape))
  act_dim = int(np.prod(envs.single_action_space.shape))
  rb = ReplayBuffer(args.buffer_size, obs_dim, act_dim)
  start_time = time.time()
  returns, losses = [], {}

  obs, _ = envs.reset(seed=args.seed)
  for global_step in range(args.total_timesteps):
    if global_step < args.learning_starts:
      actions = np.array([envs.single_action_space.sample()
                          for _ in range(envs.num_envs)])
    else:
      actions, _, _ = actor.get_action(torch.Tensor(obs).to(device))
      actions = actions.detach().cpu().numpy()
    actions = np.clip(actions, envs.single_action_space.low,
                      envs.single_action_space.high)

    next_obs, rewards, terminations, truncations, infos = envs.step(actions)

    # SAME_STEP: the finished episodes' infos are in infos['final_info'].
    final = infos.get('final_info', {})
    if '_episode' in final:
      for i in np.flatnonzero(final['_episode']):
        returns.append(float(final['episode']['r'][i]))
        print(f'global_step={global_step}, episodic_return={returns[-1]:.2f}'
              f', episodic_length={int(final["episode"]["l"][i])}')

    # SAME_STEP auto-reset: next_obs is the new episode's first observation
    # where one ended; the transition's true next observation is final_obs.
    real_next_obs = next_obs.copy()
    if '_final_obs' in infos:
      for i in np.flatnonzero(infos['_final_obs']):
        real_next_obs[i] = infos['final_obs'][i]
    rb.add(obs, real_next_obs, actions, rewards, terminations)
    obs = next_obs

    if global_step > args.learning_starts:
      (b_obs, b_actions, b_next_obs, b_dones,
       b_rewards) = rb.sample(args.batch_size, rng)
      with torch.no_grad():
        next_actions, next_log_pi, _ = actor.get_action(b_next_obs)
        qf1_next = qf1_target(b_next_obs, next_actions)
        qf2_next = qf2_target(b_next_obs, next_actions)
        min_qf_next = torch.min(qf1_next, qf2_next) - alpha * next_log_pi
        next_q_value = (b_rewards.flatten() + (1 - b_dones.flatten()) *
                        args.gamma * min_qf_next.view(-1))
      qf1_a_values = qf1(b_obs, b_actions).view(-1)
      qf2_a_values = qf2(b_obs, b_actions).view(-1)
      qf_loss = (F.mse_loss(qf1_a_values, next_q_value) +
                 F.mse_loss(qf2_a_values, next_q_value))
      q_optimizer.zero_grad()
      qf_loss.backward()
      q_optimizer.step()
      losses['qf_loss'] = qf_loss.item()

      if global_step % args.policy_frequency == 0:  # Delayed (TD3-style).
        for _ in range(args.policy_frequency):
          pi, log_pi, _ = actor.get_action(b_obs)
          min_qf_pi = torch.min(qf1(b_obs, pi), qf2(b_obs, pi))
          actor_loss = ((alpha * log_pi) - min_qf_pi).mean()
          actor_optimizer.zero_grad()
          actor_loss.backward()
          actor_optimizer.step()
          losses['actor_loss'] = actor_loss.item()
          if args.autotune:
            with torch.no_grad():
              _, log_pi, _ = actor.get_action(b_obs)
            alpha_loss = (-log_alpha.exp() * (log_pi + target_entropy)).mean()
            a_optimizer.zero_grad()
            alpha_loss.backward()
            a_optimizer.step()
            alpha = log_alpha.exp().item()

      if global_step % args.target_network_frequency == 0:
        for net, target in ((qf1, qf1_target), (qf2, qf2_target)):
          for param, target_param in zip(net.parameters(),
                                         target.parameters()):
            target_param.data.copy_(args.tau * param.data +
                                    (1 - args.tau) * target_param.data)
      if global_step % 100 == 0:
        print(f'global_step={global_step}, SPS='
              f'{int(global_step / (time.time() - start_time))}, '
              f'qf_loss={losses["qf_loss"]:.3f}, alpha={alpha:.3f}')

  envs.close()
  summary = {'episodic_returns': returns, 'alpha': alpha, **losses,
             'steps_per_second': args.total_timesteps /
                                 (time.time() - start_time)}
  print(json.dumps(summary))
  return summary


if __name__ == '__main__':
  main()
  sys.exit(0)
