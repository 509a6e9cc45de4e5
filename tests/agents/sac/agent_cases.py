"""What the SAC agent's tests share that is not a fixture: the latex env's
action box, small agents, and a deterministic walk task to train them on."""

import numpy as np

from ble_latex.agents.sac import agent as sac

# The latex env's action box: a0 altitude [m], a1 time factor, a2 float flag.
LOW = np.array([14_000.0, 1.0, -1.0])
HIGH = np.array([21_000.0, 5.0, 1.0])
TARGET = np.array([19_100.0, 2.0, 0.5])
OBS = np.array([0.5, -0.25, 1.0, 0.0], dtype=np.float32)

# Small networks and batches keep the tests fast on one core.
SMALL = dict(hidden_units=32, batch_size=16, min_replay_history=16,
             summary_writing_frequency=10**9)


def agent(seed=0, obs_dim=OBS.size, **kwargs):
  return sac.SACAgent(3, (obs_dim,), action_low=LOW, action_high=HIGH,
                      seed=seed, **{**SMALL, **kwargs})


class WalkEnv:
  """Deterministic 4-step task; episodes end by time limit (not terminal)."""

  steps = 4

  def reset(self):
    self._h, self._t = 0.0, 0
    return self._obs()

  def _obs(self):
    return np.array([self._h, self._t / self.steps, np.sin(self._h), 1.0],
                    dtype=np.float32)

  def step(self, action):
    u = 2.0 * (action - LOW) / (HIGH - LOW) - 1.0
    self._h = float(np.clip(self._h + 0.5 * u[0] * u[1], -2.0, 2.0))
    self._t += 1
    return self._obs(), -abs(self._h - 1.0), self._t >= self.steps


def run_episodes(agent, env, n):
  """BLE train_lib's loop; returns every action taken."""
  actions = []
  for _ in range(n):
    obs = env.reset()
    action = agent.begin_episode(obs)
    actions.append(action)
    while True:
      obs, reward, done = env.step(action)
      if done:
        break
      action = agent.step(reward, obs)
      actions.append(action)
    agent.end_episode(reward, False)  # Time limit: not a terminal state.
  return np.array(actions)

