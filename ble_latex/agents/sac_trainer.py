# coding=utf-8
r"""Jitted Soft Actor-Critic on the batched env (purejaxrl / rejax style).

`ble-latex-train --trainer=jax` flies `num_envs` balloons of the functional
env (`ble_latex.envs.jax_env`) in parallel and runs the SAC updates inside one
`jax.lax.scan` per round: no Python per step, no host copies of transitions.

  ble-latex-train --trainer=jax --base_dir=/tmp/latex/jax \
      --num_iterations=40 --seeds=0,1,2,3,4

The SAC itself is not written again: the update is `sac.update` (Dopamine's
`sac_agent.train` computed on the whole batch at once; the update
`sac.SACAgent` runs too), the network Dopamine's `SACNetwork` with the
critic chosen by `critic` (`networks.make_network`), the optimizers and the
soft target update those of `sac.SACAgent` (`sac.make_optimizers`,
`sac._polyak_update`).
What this module adds is the loop, as pure functions of a `TrainState`:

- One round (an iteration) flies `num_envs` new episodes of
  `episode_steps` strides (216 = 3 days). Episode e of a training seed flies
  env seed `suites.train_seed(e)`, as `ble-latex-train` does, so the
  episodes are those of the gym env with the same seeds. A balloon whose
  flight ends early (out of sand or helium, burst) is masked for the rest of
  the round: it adds no transitions.
- Every vector step stores the step's transitions in a replay buffer on the
  device (a ring of arrays) and then runs `updates_per_step` SAC updates on
  uniform batches, once `min_replay_history` transitions are stored (actions
  are uniform random before that, as in Dopamine). The update-to-data ratio
  is `updates_per_step / num_envs`.
- A transition cut by the time limit is bootstrapped (not terminal); out of
  resources and burst are terminal.

Several training seeds (`train_seeds`, `ble-latex-train --seeds`) run one
after another, or with `vmap=True` (`--vmap_seeds`) as one `jax.vmap` of
the round over their stacked `TrainState`s (`train_round_seeds`); each seed
keeps its own run directory either way.

A run directory holds what `ble-latex-train` writes: `episodes.jsonl` (with
env seeds and both TW50s), tensorboard scalars, `checkpoints/` (msgpack,
`safe_io`; the whole `TrainState` including the replay and the PRNG key, so a
killed run resumes after its last checkpoint with no episode lost or
repeated), `policies/policy_NNNNN.msgpack` snapshots that
`ble-latex-eval --gin_bindings='SACPretrainedAgent.policy_path="..."'` and
`sac_pretrained` load, `run.json` and `operative_config.gin`.
"""

import contextlib
import dataclasses
import functools
import json
import os
import time
from typing import Any, Callable, Dict, List, Mapping, NamedTuple, Optional, Sequence, Tuple

from absl import logging
import flax
import gin
import jax
import jax.numpy as jnp
import numpy as np
import optax

from ble_latex.agents import networks
from ble_latex.agents import pretrained
from ble_latex.agents import sac
from ble_latex.envs import host_env
from ble_latex.envs import jax_env
from ble_latex.flight import state as state_lib
from ble_latex.run import episode_log
from ble_latex.run import metrics
from ble_latex.run import suites
from ble_latex.run import train_lib
from ble_latex import errors
from ble_latex import safe_io

Array = jax.Array
CHECKPOINT_FORMAT = 'ble_latex.sac_trainer/1'  # msgpack (`safe_io`).
RUN_INFO = 'run.json'


@gin.configurable('sac_trainer_config')
@dataclasses.dataclass(frozen=True, kw_only=True)
class TrainerConfig:
  """The jitted trainer's settings (gin: `sac_trainer_config.*`).

  Built with no arguments it takes gin's bindings (`gin_configs/sac_jax.gin`);
  arguments given override them.

  Attributes:
    num_envs: Balloons flown in parallel; one round is one episode of each.
    updates_per_step: SAC updates after each step of all `num_envs`
      balloons (update-to-data ratio `updates_per_step / num_envs`).
    batch_size: Transitions per SAC update.
    replay_capacity: Replay ring size in transitions.
    min_replay_history: Transitions of uniform random actions before the
      first update.
    gamma: Discount factor.
    actor_learning_rate: Adam learning rate of the actor.
    critic_learning_rate: Adam learning rate of the twin critics.
    alpha_learning_rate: Adam learning rate of log(temperature).
    target_smoothing_coefficient: Polyak factor tau of the target critics.
    target_entropy: Target entropy [nats] of the [-1, 1]^d action.
    reward_scale_factor: Rewards are multiplied by this in the TD target.
    num_layers: Hidden layers of the actor and of each critic.
    hidden_units: Units per hidden layer.
    critic: The twin critics (`networks.CRITICS`): 'mlp' (Dopamine's, the
      paper's), 'layernorm' (LayerNorm after each hidden layer) or 'crossq'
      (batch norm, no target networks; `target_smoothing_coefficient` is
      then unused).
  """
  num_envs: int = 32
  updates_per_step: int = 8
  batch_size: int = 256
  replay_capacity: int = 1_000_000
  min_replay_history: int = 1000
  gamma: float = 0.99
  actor_learning_rate: float = 3e-4
  critic_learning_rate: float = 3e-4
  alpha_learning_rate: float = 3e-4
  target_smoothing_coefficient: float = 0.005
  target_entropy: float = 0.0
  reward_scale_factor: float = 1.0
  num_layers: int = 2
  hidden_units: int = 256
  critic: str = 'mlp'

  def __post_init__(self):
    fields = dataclasses.asdict(self)
    networks.check_critic('sac_trainer_config', self.critic)
    sac.check_hyperparameters(
        'sac_trainer_config',
        **{k: v for k, v in fields.items()
           if k not in ('num_envs', 'updates_per_step', 'critic')})
    for name in ('num_envs', 'updates_per_step'):
      value = fields[name]
      if (isinstance(value, bool) or not isinstance(value, (int, np.integer))
          or value < 1):
        raise ValueError(f'sac_trainer_config.{name} must be an integer >= 1, '
                         f'got {value!r}')


@flax.struct.dataclass
class Replay:
  """A ring of transitions on the device.

  Attributes:
    obs: Observations [capacity, 71].
    action: Actions in the normalised box [capacity, 3].
    reward: Rewards [capacity].
    next_obs: Next observations [capacity, 71].
    terminal: 1.0 where the flight ended (not by the time limit) [capacity].
    size: Transitions stored (at most capacity).
    cursor: Next slot to write.
  """
  obs: Array
  action: Array
  reward: Array
  next_obs: Array
  terminal: Array
  size: Array
  cursor: Array


@flax.struct.dataclass
class TrainState:
  """Everything a run carries from round to round (one frozen pytree)."""
  network_params: Any
  target_params: Any
  optimizer_state: Any
  log_alpha: Array
  alpha_optimizer_state: Any
  replay: Replay
  key: Array
  updates: Array  # SAC updates done.
  env_steps: Array  # Transitions stored in total.


class RoundOutput(NamedTuple):
  """Per-balloon results of one round, and the round's mean losses."""
  reward: Array  # [N] episode return.
  within_steps: Array  # [N] steps ending within the radius.
  steps: Array  # [N] steps flown.
  info: Dict[str, Array]  # `jax_env.step_info` of the last flown step, [N].
  losses: Dict[str, Array]  # Mean over the round's updates.
  # NaN / inf values the round produced, by what holds them (`_NONFINITE`):
  # scalar counts computed in the round, for `check_round`.
  nonfinite: Dict[str, Array]


class Learner(NamedTuple):
  """The static parts: network, optimizers, config (hashable, for jit)."""
  network_def: networks.LatexSACNetwork
  optimizer: optax.GradientTransformation
  alpha_optimizer: optax.GradientTransformation
  config: TrainerConfig


_LOSS_KEYS = ('Losses/Critic', 'Losses/Actor', 'Losses/Alpha',
              'Values/CriticValues1', 'Values/Alpha')
# `RoundOutput.nonfinite`'s entries, in the order `check_round` names them.
_NONFINITE = ('critic loss', 'actor loss', 'alpha loss', 'critic values',
              'temperature', 'network parameters', 'target parameters',
              'optimizer state', 'log_alpha', 'actions', 'rewards')


@functools.lru_cache(maxsize=8)
def learner_for(config: TrainerConfig) -> Learner:
  """The network and optimizers of `config`, one object per config.

  `train_round` and `validate` take the learner as a static argument, so
  equal configs (e.g. the seeds of one command) share their compiled code.
  """
  num_actions = len(jax_env.ACTION_LOW)
  network_def = networks.make_network(num_actions, config.num_layers,
                                      config.hidden_units, config.critic)
  obs = jnp.zeros((jax_env.LatexBalloonJaxEnv.num_features,), jnp.float32)
  key = jax.random.PRNGKey(0)  # Only the parameters' structure is used.
  optimizer, alpha_optimizer = sac.make_optimizers(
      network_def.init(key, obs, key), config.actor_learning_rate,
      config.critic_learning_rate, config.alpha_learning_rate)
  return Learner(network_def, optimizer, alpha_optimizer, config)


def make_learner(config: TrainerConfig, key: Array
                 ) -> Tuple[Learner, TrainState]:
  """The learner of `config` and a fresh `TrainState` from `key`."""
  learner = learner_for(config)
  num_actions = len(jax_env.ACTION_LOW)
  key, init_key = jax.random.split(key)
  obs = jnp.zeros((jax_env.LatexBalloonJaxEnv.num_features,), jnp.float32)
  params = learner.network_def.init(init_key, obs, init_key)
  log_alpha = jnp.zeros(1)  # Temperature 1, as `sac.SACAgent`.
  c, d = config.replay_capacity, obs.shape[0]
  replay = Replay(
      obs=jnp.zeros((c, d), jnp.float32),
      action=jnp.zeros((c, num_actions), jnp.float32),
      reward=jnp.zeros((c,), jnp.float32),
      next_obs=jnp.zeros((c, d), jnp.float32),
      terminal=jnp.zeros((c,), jnp.float32),
      size=jnp.zeros((), jnp.int32), cursor=jnp.zeros((), jnp.int32))
  state = TrainState(
      network_params=params, target_params=params,
      optimizer_state=learner.optimizer.init(params), log_alpha=log_alpha,
      alpha_optimizer_state=learner.alpha_optimizer.init(log_alpha),
      replay=replay, key=key, updates=jnp.zeros((), jnp.int32),
      env_steps=jnp.zeros((), jnp.int32))
  return learner, state


def to_box(normalized: Array) -> Array:
  """[-1, 1]^3 actions onto the env's Box (as `sac.SACAgent._to_box`)."""
  low = jnp.asarray(jax_env.ACTION_LOW, jnp.float32)
  high = jnp.asarray(jax_env.ACTION_HIGH, jnp.float32)
  u = jnp.clip(normalized, -1.0, 1.0)
  return jnp.clip(low + 0.5 * (u + 1.0) * (high - low), low, high)


def _add(replay: Replay, obs: Array, action: Array, reward: Array,
         next_obs: Array, terminal: Array, valid: Array) -> Replay:
  """Writes the valid rows of a [N] batch of transitions into the ring."""
  capacity = replay.reward.shape[0]
  offset = jnp.cumsum(valid.astype(jnp.int32)) - 1
  slots = jnp.where(valid, (replay.cursor + offset) % capacity, capacity)
  put = lambda a, x: a.at[slots].set(x.astype(a.dtype), mode='drop')
  added = jnp.sum(valid.astype(jnp.int32))
  return replay.replace(
      obs=put(replay.obs, obs), action=put(replay.action, action),
      reward=put(replay.reward, reward),
      next_obs=put(replay.next_obs, next_obs),
      terminal=put(replay.terminal, terminal),
      size=jnp.minimum(replay.size + added, capacity),
      cursor=(replay.cursor + added) % capacity)


def _update(learner: Learner, state: TrainState, key: Array
            ) -> Tuple[TrainState, Dict[str, Array]]:
  """One SAC update (`sac.update`) on a uniform batch of the replay."""
  c = learner.config
  sample_key, train_key = jax.random.split(key)
  idx = jax.random.randint(sample_key, (c.batch_size,), 0,
                           jnp.maximum(state.replay.size, 1))
  r = state.replay
  out = sac.update(
      learner.network_def, learner.optimizer, learner.alpha_optimizer,
      state.optimizer_state, state.alpha_optimizer_state,
      state.network_params, state.target_params, state.log_alpha, train_key,
      r.obs[idx], r.action[idx], r.next_obs[idx], r.reward[idx],
      r.terminal[idx], c.gamma, c.target_entropy, c.reward_scale_factor)
  if networks.uses_target_network(learner.network_def):
    target = sac._polyak_update(out['network_params'], state.target_params,  # pylint: disable=protected-access
                                c.target_smoothing_coefficient)
  else:  # CrossQ: the targets are the online critics (unused by the update).
    target = out['network_params']
  state = state.replace(
      network_params=out['network_params'], target_params=target,
      optimizer_state=out['optimizer_state'], log_alpha=out['log_alpha'],
      alpha_optimizer_state=out['alpha_optimizer_state'],
      updates=state.updates + 1)
  return state, {k: jnp.mean(out[k]) for k in _LOSS_KEYS}


def _act(learner: Learner, state: TrainState, obs: Array, key: Array
         ) -> Array:
  """Normalised actions: policy samples, or uniform before learning starts."""
  n, d = obs.shape[0], len(jax_env.ACTION_LOW)
  policy_key, uniform_key = jax.random.split(key)
  sampled = jax.vmap(
      lambda o, k: learner.network_def.apply(
          state.network_params, o, k,
          method=learner.network_def.actor).sampled_action)(
              obs, jax.random.split(policy_key, n))
  uniform = jax.random.uniform(uniform_key, (n, d), minval=-1.0, maxval=1.0)
  learning = state.replay.size >= learner.config.min_replay_history
  return jnp.where(learning, sampled, uniform)


@functools.partial(jax.jit, static_argnums=(0, 1, 4))
def train_round(learner: Learner, env: jax_env.LatexBalloonJaxEnv,
                state: TrainState, seeds: Array, num_steps: int,
                params: jax_env.EnvParams) -> Tuple[TrainState, RoundOutput]:
  """Flies one episode on each of N balloons while learning (one XLA call).

  Args:
    learner: Network, optimizers and config (static).
    env: The functional env (static).
    state: The trainer's state.
    seeds: [N] env seeds of the round's episodes (gym seeds).
    num_steps: Strides per episode (static; `params.episode_steps`).
    params: Env parameters.

  Returns:
    The new state and the round's per-balloon results.
  """
  c = learner.config
  obs, env_state = jax.vmap(env.reset, in_axes=(0, None))(
      jax.vmap(jax.random.PRNGKey)(seeds), params)
  n = seeds.shape[0]
  zeros = jnp.zeros((n,), jnp.float32)
  info0 = jax.vmap(jax_env.step_info, in_axes=(0, None))(env_state, params)

  def one_step(carry, _):
    (state, env_state, obs, active, ep_reward, within, steps, last,
     bad_actions) = carry
    key, act_key, update_key = jax.random.split(state.key, 3)
    state = state.replace(key=key)
    action = _act(learner, state, obs, act_key)
    bad_actions = bad_actions + jnp.sum(
        ~jnp.isfinite(action) & active[:, None])
    next_obs, env_state, reward, terminated, info = jax.vmap(
        env.step_env, in_axes=(None, 0, 0, None))(
            act_key, env_state, to_box(action), params)
    done = terminated | info['time_limit']
    terminal = terminated.astype(jnp.float32)
    state = state.replace(
        replay=_add(state.replay, obs, action, reward, next_obs, terminal,
                    active),
        env_steps=state.env_steps + jnp.sum(active.astype(jnp.int32)))
    ep_reward = ep_reward + jnp.where(active, reward, 0.0)
    within = within + (active & (info['distance_km'] <= params.radius_km))
    steps = steps + active
    last = jax.tree.map(lambda new, old: jnp.where(active, new, old), info,
                        last)
    active = active & ~done

    def learn(state):
      return jax.lax.scan(lambda s, k: _update(learner, s, k), state,
                          jax.random.split(update_key, c.updates_per_step))

    def wait(state):
      return state, {k: jnp.zeros((c.updates_per_step,)) for k in _LOSS_KEYS}

    ready = state.replay.size >= jnp.maximum(c.min_replay_history,
                                             c.batch_size)
    state, losses = jax.lax.cond(ready, learn, wait, state)
    losses = {k: v.mean() for k, v in losses.items()}
    return ((state, env_state, next_obs, active, ep_reward, within, steps,
             last, bad_actions), (losses, ready))

  carry = (state, env_state, obs, jnp.ones((n,), bool), zeros,
           jnp.zeros((n,), jnp.int32), jnp.zeros((n,), jnp.int32), info0,
           jnp.zeros((), jnp.int32))
  carry, (losses, ready) = jax.lax.scan(one_step, carry, None,
                                        length=num_steps)
  state, _, _, _, ep_reward, within, steps, last, bad_actions = carry
  learned = jnp.maximum(jnp.sum(ready), 1)
  losses = {k: jnp.sum(v) / learned for k, v in losses.items()}
  counted = [losses[k] for k in _LOSS_KEYS] + [
      state.network_params, state.target_params, state.optimizer_state,
      state.log_alpha]
  nonfinite = dict(zip(_NONFINITE, [sac.nonfinite_count(x) for x in counted]
                       + [bad_actions, sac.nonfinite_count(ep_reward)]))
  return state, RoundOutput(ep_reward, within, steps, last, losses, nonfinite)


@functools.partial(jax.jit, static_argnums=(0, 1, 4))
def validate(learner: Learner, env: jax_env.LatexBalloonJaxEnv,
             network_params: Any, seeds: Array, num_steps: int,
             params: jax_env.EnvParams) -> Dict[str, Array]:
  """Flies the deterministic policy (tanh of the mean) from each seed.

  The batched counterpart of `ble-latex-eval` for choosing among snapshots
  while training (the vmapped env matches the gym env to ~1e-4; results are
  reported with `ble-latex-eval`).

  Returns:
    [N] arrays: `within_steps`, `steps`, `status` (`FlightStatus`).
  """
  obs, env_state = jax.vmap(env.reset, in_axes=(0, None))(
      jax.vmap(jax.random.PRNGKey)(seeds), params)
  mean_action = jax.vmap(lambda o: learner.network_def.apply(
      network_params, o, jax.random.PRNGKey(0),
      method=learner.network_def.actor).mean_action)
  n = seeds.shape[0]

  def one_step(carry, _):
    env_state, obs, active, within, steps = carry
    obs, env_state, _, terminated, info = jax.vmap(
        env.step_env, in_axes=(None, 0, 0, None))(
            None, env_state, to_box(mean_action(obs)), params)
    done = terminated | info['time_limit']
    within = within + (active & (info['distance_km'] <= params.radius_km))
    steps = steps + active
    return (env_state, obs, active & ~done, within, steps), None

  zeros = jnp.zeros((n,), jnp.int32)
  (env_state, _, _, within, steps), _ = jax.lax.scan(
      one_step, (env_state, obs, jnp.ones((n,), bool), zeros, zeros), None,
      length=num_steps)
  return {'within_steps': within, 'steps': steps,
          'status': env_state.flight.status}


def validation_summary(result: Dict[str, Array], window_steps: int
                       ) -> Dict[str, float]:
  """Mean TW50 (window and flown) and % out of resources of `validate`."""
  r = jax.device_get(result)
  fractions = [metrics.tw50_fractions(int(w), int(s), window_steps)
               for w, s in zip(r['within_steps'], r['steps'])]
  out_of_resources = [
      state_lib.FlightStatus(int(x)) in state_lib.OUT_OF_RESOURCES
      for x in r['status']]
  return {'episodes': len(fractions),
          'tw50_window_mean': float(np.mean([f['tw50_window']
                                             for f in fractions])),
          'tw50_mean': float(np.mean([f['tw50'] for f in fractions])),
          'out_of_resources_pct': 100.0 * float(np.mean(out_of_resources))}


# --- Host side: records, checkpoints, policies ------------------------------


def acting_bundle(learner: Learner, state: TrainState,
                  iteration: int) -> Dict[str, Any]:
  """What `sac.SACAgent.acting_bundle` holds, for `pretrained` policies."""
  c = learner.config
  config = {
      'observation_shape': [jax_env.LatexBalloonJaxEnv.num_features],
      'num_actions': len(jax_env.ACTION_LOW),
      'action_low': np.asarray(jax_env.ACTION_LOW, np.float64).tolist(),
      'action_high': np.asarray(jax_env.ACTION_HIGH, np.float64).tolist(),
      'num_layers': c.num_layers, 'hidden_units': c.hidden_units,
      'critic': c.critic, 'replay_capacity': c.replay_capacity}
  return {'format': sac.CHECKPOINT_FORMAT, 'iteration': int(iteration),
          'config': config, 'training_steps': int(state.updates),
          'network_params': sac._to_numpy(state.network_params),  # pylint: disable=protected-access
          'log_alpha': np.asarray(state.log_alpha)}


def episode_records(out: RoundOutput, seeds: Sequence[int],
                    first_episode: int, window_steps: int,
                    wall_time_s: float
                    ) -> List[Tuple[metrics.EpisodeSummary, Dict[str, Any]]]:
  """The round's (`EpisodeSummary`, last info) pairs, in balloon order."""
  out = jax.device_get(out)
  records = []
  for i, seed in enumerate(seeds):
    info = host_env.info_dict({k: v[i] for k, v in out.info.items()})
    summary = metrics.EpisodeSummary(
        episode=first_episode + i, seed=int(seed),
        reward=float(out.reward[i]),
        **metrics.tw50_fractions(int(out.within_steps[i]), int(out.steps[i]),
                                 window_steps),
        window_steps=window_steps, steps=int(out.steps[i]),
        helium_vented_mols=info['helium_vented_mols'],
        sand_dropped_kg=info['sand_dropped_kg'],
        terminal_reason=metrics.terminal_reason(info, done=True),
        final_distance_km=info['distance_km'],
        wall_time_s=wall_time_s / len(seeds))
    records.append((summary, info))
  return records


def checkpoint_path(base_dir: str, iteration: int) -> str:
  return sac.checkpoint_path(os.path.join(base_dir, 'checkpoints'), iteration)


def check_round(out: RoundOutput, iteration: int, base_dir: str) -> None:
  """Raises `sac.TrainingDiverged` if the round produced NaN / inf.

  Called before anything of the round is written: the newest checkpoint in
  `base_dir` stays the last good one.

  Args:
    out: One seed's round output (its `nonfinite` counts).
    iteration: The round.
    base_dir: The seed's run directory.
  """
  counts = jax.device_get(out.nonfinite)
  bad = [name for name in _NONFINITE if int(counts[name])]
  if not bad:
    return
  done = sac.checkpoint_iterations(os.path.join(base_dir, 'checkpoints'))
  kept = (f'last good checkpoint: {checkpoint_path(base_dir, done[-1])} kept'
          if done else f'no checkpoint was written in {base_dir}')
  raise sac.TrainingDiverged(
      f'training diverged at round {iteration}: non-finite '
      f'{", ".join(bad)}; {kept}')


def save_checkpoint(base_dir: str, iteration: int, state: TrainState,
                    elapsed_s: float = 0.0, keep: int = 2) -> None:
  """The whole state (replay cut to its filled part), atomically.

  Args:
    base_dir: Run directory.
    iteration: The round just finished.
    state: The trainer's state.
    elapsed_s: Training wall time so far, resumes included. # [s]
    keep: Checkpoints kept (the newest ones).
  """
  host = jax.device_get(state)
  filled = int(host.replay.size)
  replay = {k: np.asarray(getattr(host.replay, k))[:filled]
            for k in ('obs', 'action', 'reward', 'next_obs', 'terminal')}
  replay.update(size=int(host.replay.size), cursor=int(host.replay.cursor))
  leaves = lambda t: [np.asarray(x) for x in jax.tree_util.tree_leaves(t)]
  tree = {'iteration': int(iteration),
          'network_params': leaves(host.network_params),
          'target_params': leaves(host.target_params),
          'optimizer_state': leaves(host.optimizer_state),
          'log_alpha': np.asarray(host.log_alpha),
          'alpha_optimizer_state': leaves(host.alpha_optimizer_state),
          'replay': replay, 'key': np.asarray(host.key),
          'updates': int(host.updates), 'env_steps': int(host.env_steps),
          'elapsed_s': float(elapsed_s)}
  path = checkpoint_path(base_dir, iteration)
  os.makedirs(os.path.dirname(path), exist_ok=True)
  safe_io.write_tree(path, tree, file_format=CHECKPOINT_FORMAT)
  folder = os.path.dirname(path)
  for old in sac.checkpoint_iterations(folder)[:-keep]:
    os.remove(checkpoint_path(base_dir, old))


def load_checkpoint(path: str, template: TrainState
                    ) -> Tuple[TrainState, float]:
  """A checkpoint's state (checked against `template`) and elapsed [s].

  Raises:
    errors.BadFileError: The file is unreadable, or an entry is missing, of
      another shape or dtype, non-finite or out of range (named with the
      file).
  """
  tree = safe_io.read_tree(path, file_format=CHECKPOINT_FORMAT,
                           what='SAC trainer checkpoint')
  with safe_io.checking():
    return _restore_checkpoint(tree, path, template)


def _restore_checkpoint(tree: Dict[str, Any], path: str, template: TrainState
                        ) -> Tuple[TrainState, float]:
  """`load_checkpoint` of a read tree."""
  what = f'{path}'
  restore = lambda name, t: sac._restore_like(t, tree[name], f'{what}: {name}')  # pylint: disable=protected-access
  missing = [k for k in ('iteration', 'network_params', 'target_params',
                         'optimizer_state', 'log_alpha',
                         'alpha_optimizer_state', 'replay', 'key', 'updates',
                         'env_steps') if k not in tree]
  if missing:
    raise ValueError(f'{what} misses {missing}')
  r = tree['replay']
  if not isinstance(r, dict):
    raise ValueError(f'{what}: replay is not a mapping')
  capacity = template.replay.reward.shape[0]
  size = safe_io.checked_count(r.get('size'), f'{what}: replay size',
                               high=capacity)
  cursor = safe_io.checked_count(r.get('cursor'), f'{what}: replay cursor',
                                 high=capacity - 1)
  counters = {k: safe_io.checked_count(tree[k], f'{what}: {k}',
                                       high=np.iinfo(np.int32).max)
              for k in ('iteration', 'updates', 'env_steps')}
  arrays = {}
  for name in ('obs', 'action', 'reward', 'next_obs', 'terminal'):
    ref = getattr(template.replay, name)
    value = safe_io.checked_array(r.get(name), f'{what}: replay {name}',
                                  shape=(size,) + ref.shape[1:])
    arrays[name] = jnp.asarray(ref).at[:size].set(value.astype(ref.dtype))
  replay = Replay(size=jnp.asarray(size, jnp.int32),
                  cursor=jnp.asarray(cursor, jnp.int32), **arrays)
  elapsed = safe_io.checked_array(tree.get('elapsed_s', 0.0),
                                  f'{what}: elapsed_s', shape=())
  return TrainState(
      network_params=restore('network_params', template.network_params),
      target_params=restore('target_params', template.target_params),
      optimizer_state=restore('optimizer_state', template.optimizer_state),
      log_alpha=restore('log_alpha', template.log_alpha),
      alpha_optimizer_state=restore('alpha_optimizer_state',
                                    template.alpha_optimizer_state),
      replay=replay, key=restore('key', template.key),
      updates=jnp.asarray(counters['updates'], jnp.int32),
      env_steps=jnp.asarray(counters['env_steps'], jnp.int32)), float(elapsed)


def recorded_config(config: Mapping[str, Any]) -> Dict[str, Any]:
  """A `run.json` config with the settings added since it was written.

  Settings added since a run started count with their defaults (e.g.
  `critic`: 'mlp').
  """
  defaults = {f.name: f.default for f in dataclasses.fields(TrainerConfig)}
  return {**defaults, **config}


def round_seeds(iteration: int, num_envs: int) -> List[int]:
  """Env seeds of a round's episodes: episode e flies `train_seed(e)`."""
  return [suites.train_seed(iteration * num_envs + i)
          for i in range(num_envs)]


def _check_resume(base_dir: str, run_info: Dict[str, Any],
                  start_iteration: int, num_envs: int) -> None:
  """Refuses a resume that would change settings or lose logged episodes."""
  path = os.path.join(base_dir, RUN_INFO)
  if os.path.exists(path):
    try:
      with open(path, encoding='utf-8') as f:
        recorded = json.load(f)
    except (OSError, ValueError) as e:
      raise errors.ResumeError(f'{path} is unreadable ({e}); not resuming'
                               ) from e
    if isinstance(recorded.get('config'), dict):
      recorded['config'] = recorded_config(recorded['config'])
    for key, value in run_info.items():
      if key in recorded and recorded[key] != value:
        raise errors.ResumeError(
            f'{base_dir} was started with {key}={recorded[key]!r}, this run '
            f'asks for {key}={value!r}; use the same settings or a new '
            '--base_dir. Nothing was changed.')
  logged = len(episode_log.read(os.path.join(base_dir,
                                             episode_log.EPISODE_LOG)))
  covered = start_iteration * num_envs
  if logged < covered:
    raise errors.ResumeError(
        f'{base_dir}/{episode_log.EPISODE_LOG} holds {logged} episodes but '
        f'the newest checkpoint covers {covered}: episodes would be missing. '
        'Nothing was changed.')


class _RunDir:
  """The host side of one training seed: its run directory and logs.

  Opening one checks a resume (same settings, no episode lost), restores the
  newest checkpoint and cuts `validation.jsonl` back to it; `record` then
  writes what a round leaves: episodes, tensorboard scalars, the validation
  record, checkpoint and policy snapshot.
  """

  def __init__(self, *, base_dir: str, seed: int, learner: Learner,
               num_iterations: int, collectors: Sequence[str],
               window: int, validation_seeds: Sequence[int]):
    config = learner.config
    self.base_dir, self.seed, self.learner = base_dir, seed, learner
    _, self.state = make_learner(config, jax.random.PRNGKey(seed))
    done_iterations = sac.checkpoint_iterations(
        os.path.join(base_dir, 'checkpoints'))
    self.start = done_iterations[-1] + 1 if done_iterations else 0
    run_info = {'trainer': 'jax', 'seed': seed,
                'config': dataclasses.asdict(config), 'episode_steps': window}
    os.makedirs(base_dir, exist_ok=True)
    _check_resume(base_dir, run_info, self.start, config.num_envs)
    self.elapsed = 0.0
    if self.start:
      self.state, self.elapsed = load_checkpoint(
          checkpoint_path(base_dir, self.start - 1), self.state)
      logging.info('%s: resuming after round %d.', base_dir, self.start - 1)
    self.validation_path = os.path.join(base_dir, episode_log.VALIDATION_LOG)
    validated = [r for r in episode_log.read(self.validation_path)
                 if r['iteration'] < self.start]
    safe_io.atomic_write(self.validation_path,
                         ''.join(json.dumps(r) + '\n' for r in validated))
    safe_io.atomic_write(os.path.join(base_dir, RUN_INFO),
                         json.dumps(run_info, indent=1) + '\n')
    self.validation_seeds = list(validation_seeds)
    self._validation_seeds = jnp.asarray(self.validation_seeds, jnp.int32)
    n = config.num_envs
    self.dispatcher = metrics.dispatcher(
        base_dir, len(jax_env.ACTION_LOW), collectors, self.start * n,
        num_iterations * n, f'train sac (jax, seed {seed})')
    self.writer = self.dispatcher.get_summary_writer()
    self.dispatcher.pre_training()

  def record(self, *, iteration: int, state: TrainState, out: RoundOutput,
             wall: float, env: jax_env.LatexBalloonJaxEnv,
             params: jax_env.EnvParams, checkpoint: bool,
             policy_snapshot_period: int) -> Optional[Dict[str, Any]]:
    """Logs a finished round of this seed; returns its validation record.

    Args:
      iteration: The round.
      state: This seed's state after the round (its replay may be None
        without `checkpoint`).
      out: This seed's round output.
      wall: The round's wall time (for vmapped seeds, that of all). # [s]
      env: The functional env.
      params: Env parameters.
      checkpoint: Whether to write a checkpoint after this round.
      policy_snapshot_period: Rounds between policy snapshots (0: never).
    """
    self.elapsed += wall
    n, window = self.learner.config.num_envs, int(params.episode_steps)
    for summary, info in episode_records(out, round_seeds(iteration, n),
                                         iteration * n, window,
                                         wall):
      self.dispatcher.begin_episode()
      self.dispatcher.end_episode(metrics.LatexStatistics(
          step=summary.steps, action=[], reward=summary.reward,
          terminal=summary.terminal_reason != 'time_limit', info=info,
          summary=summary))
    if self.writer is not None:
      for k, v in jax.device_get(out.losses).items():
        self.writer.scalar(k, float(v), int(state.updates))
      self.writer.scalar('Train/RoundSeconds', wall, iteration)
      self.writer.flush()
    snapshot = bool(policy_snapshot_period and
                    (iteration + 1) % policy_snapshot_period == 0)
    record = None
    if snapshot and self.validation_seeds:
      began = time.monotonic()
      result = validation_summary(
          validate(self.learner, env, state.network_params,
                   self._validation_seeds, window, params), window)
      self.elapsed += time.monotonic() - began
      record = {'iteration': iteration,
                'training_episodes': (iteration + 1) * n,
                'updates': int(state.updates), 'elapsed_s': self.elapsed,
                'seeds': [int(self.validation_seeds[0]),
                          int(self.validation_seeds[-1])], **result}
      with open(self.validation_path, 'a', encoding='utf-8') as f:
        f.write(json.dumps(record) + '\n')
      if self.writer is not None:
        for k in ('tw50_window_mean', 'tw50_mean', 'out_of_resources_pct'):
          self.writer.scalar(f'Validation/{k}', record[k], (iteration + 1) * n)
        self.writer.flush()
    if checkpoint:
      save_checkpoint(self.base_dir, iteration, state, self.elapsed)
    if snapshot:
      policy = pretrained.policy_from_bundle(
          acting_bundle(self.learner, state, iteration),
          f'{self.base_dir} round {iteration}',
          note=f'sac (jax trainer, seed {self.seed}) after '
          f'{(iteration + 1) * n} training episodes')
      pretrained.write_policy(
          policy, train_lib.policy_snapshot_path(self.base_dir, iteration))
    return record

  def close(self) -> None:
    self.dispatcher.end_training()
    safe_io.atomic_write(os.path.join(self.base_dir, 'operative_config.gin'),
                         gin.operative_config_str())


def _stack(trees: Sequence[Any]) -> Any:
  return jax.tree.map(lambda *xs: jnp.stack(xs), *trees)


def _unstack(tree: Any, count: int) -> List[Any]:
  return [jax.tree.map(lambda x, i=i: x[i], tree) for i in range(count)]


@functools.partial(jax.jit, static_argnums=(0, 1, 4))
def train_round_seeds(learner: Learner, env: jax_env.LatexBalloonJaxEnv,
                      states: TrainState, seeds: Array, num_steps: int,
                      params: jax_env.EnvParams
                      ) -> Tuple[TrainState, RoundOutput]:
  """`train_round` for K training seeds at once (`jax.vmap` over states).

  Every training seed flies the same env seeds (as one after another would);
  `states` are K `TrainState`s stacked on a leading axis, as are the results.
  Equal to K `train_round` calls up to float rounding of the batched matrix
  products (tested).
  """
  return jax.vmap(lambda s: train_round(learner, env, s, seeds, num_steps,
                                        params))(states)


def train(*, base_dir: str, num_iterations: int, seed: int = 0,
          config: Optional[TrainerConfig] = None,
          collectors: Sequence[str] = ('progress', 'episodes', 'tensorboard'),
          policy_snapshot_period: int = 1, checkpoint_period: int = 1,
          validation_seeds: Sequence[int] = (),
          env_params: Optional[jax_env.EnvParams] = None,
          on_validation: Optional[Callable[[Dict[str, Any]], None]] = None,
          lock_wait_s: float = 0.0) -> TrainState:
  """Runs (or resumes) one jitted training run; gin must already be bound.

  Args:
    base_dir: Run directory.
    num_iterations: Rounds in total (a resumed run counts the finished ones);
      each flies `config.num_envs` episodes.
    seed: Training seed (network init, exploration, replay sampling).
    config: Trainer settings (default: gin's `sac_trainer_config.*`).
    collectors: Names from `metrics.AVAILABLE_COLLECTORS`.
    policy_snapshot_period: Every this many rounds export the policy to
      `base_dir/policies/` (0: never).
    checkpoint_period: Every this many rounds (and after the last) write a
      checkpoint; a resumed run re-flies the rounds after it.
    validation_seeds: If given, each policy snapshot is also flown
      deterministically from these env seeds in one batched call
      (`validate`); the results go to `base_dir/validation.jsonl` (with the
      training wall time so far) and tensorboard (`Validation/*`).
    env_params: Env parameters (default: `jax_env.params_from_gin()`).
    on_validation: Called with each `validation.jsonl` record once its round
      is done (policy snapshot written; the checkpoint too when the periods
      coincide), e.g. to report it to
      Ray Tune (`ble_latex.run.sweep_lib`).
    lock_wait_s: How long to wait for another writer of `base_dir` to end
      before giving up (a sweep's trial waits out the worker of a killed
      sweep); 0: refuse at once. # [s]

  Returns:
    The final `TrainState`.

  Raises:
    safe_io.InUseError: If another process (or another run in this one)
      trains in `base_dir` (`safe_io.locked_dir`, held for the whole run).
      Stale temporary files of killed writes in checkpoints/ and policies/
      are removed once the lock is held.
  """
  return train_seeds(
      runs=[(seed, base_dir)], num_iterations=num_iterations, config=config,
      collectors=collectors, policy_snapshot_period=policy_snapshot_period,
      checkpoint_period=checkpoint_period, validation_seeds=validation_seeds,
      env_params=env_params, on_validation=on_validation,
      lock_wait_s=lock_wait_s)[0]


def train_seeds(*, runs: Sequence[Tuple[int, str]], num_iterations: int,
                config: Optional[TrainerConfig] = None,
                collectors: Sequence[str] = ('progress', 'episodes',
                                             'tensorboard'),
                policy_snapshot_period: int = 1, checkpoint_period: int = 1,
                validation_seeds: Sequence[int] = (),
                env_params: Optional[jax_env.EnvParams] = None,
                on_validation: Optional[Callable[[Dict[str, Any]], None]] = None,
                vmap: bool = False, lock_wait_s: float = 0.0
                ) -> List[TrainState]:
  """Runs (or resumes) several training seeds, each in its own directory.

  With `vmap` the seeds' rounds run as one vmapped XLA call
  (`train_round_seeds`); a seed whose run is behind the others (resumed from
  an older checkpoint) first catches up alone. Otherwise the seeds run one
  after another. Either way each directory gets what `train` writes; with
  `vmap` a round's wall time (`Train/RoundSeconds`, `elapsed_s`) is that of
  all seeds together.

  Args:
    runs: (training seed, run directory) pairs, seeds distinct.
    num_iterations: Rounds per seed in total.
    config: Trainer settings (default: gin's `sac_trainer_config.*`).
    collectors: As `train`.
    policy_snapshot_period: As `train`.
    checkpoint_period: As `train`.
    validation_seeds: As `train`.
    env_params: As `train`.
    on_validation: As `train`, called with each seed's records.
    vmap: Train the seeds together with `jax.vmap`.
    lock_wait_s: As `train`.

  Returns:
    The final `TrainState` of each run, in the order of `runs` (each with
    its replay: K seeds hold K replays in memory, vmapped or not).

  Raises:
    safe_io.InUseError: As `train`, for any of the directories (all are
      locked before any training starts, and held until all are done).
  """
  config = config or TrainerConfig()
  metrics.check_collectors(collectors)
  if num_iterations < 1 or checkpoint_period < 1 or policy_snapshot_period < 0:
    raise ValueError('num_iterations and checkpoint_period must be >= 1, '
                     'policy_snapshot_period >= 0')
  seeds_of_runs = [seed for seed, _ in runs]
  if not runs or len(set(seeds_of_runs)) != len(seeds_of_runs):
    raise ValueError(f'runs need distinct training seeds, got {seeds_of_runs}')
  with contextlib.ExitStack() as locks:  # One writer per run directory.
    for _, base_dir in runs:
      locks.enter_context(safe_io.locked_dir(base_dir, wait_s=lock_wait_s))
      train_lib.remove_stale_temporaries(base_dir)
    env = jax_env.LatexBalloonJaxEnv()
    params = (jax_env.check_params(env_params) if env_params is not None
              else env.default_params)
    window = int(params.episode_steps)
    learner = learner_for(config)
    n = config.num_envs

    def env_seeds(iteration):
      return jnp.asarray(round_seeds(iteration, n), jnp.int32)

    def checkpoint_due(iteration):
      return ((iteration + 1) % checkpoint_period == 0 or
              iteration == num_iterations - 1)

    def record(run, iteration, state, out, wall):
      result = run.record(
          iteration=iteration, state=state, out=out, wall=wall, env=env,
          params=params, checkpoint=checkpoint_due(iteration),
          policy_snapshot_period=policy_snapshot_period)
      if result is not None and on_validation is not None:
        on_validation(result)

    def alone(run, stop):
      state = run.state
      for iteration in range(run.start, stop):
        began = time.monotonic()
        state, out = train_round(learner, env, state, env_seeds(iteration),
                                 window, params)
        jax.block_until_ready(state.key)
        check_round(out, iteration, run.base_dir)  # Before it is written.
        record(run, iteration, state, out, time.monotonic() - began)
      run.state = state
      return state

    together = vmap and len(runs) > 1
    opened = []
    for seed, base_dir in runs:
      opened.append(_RunDir(
          base_dir=base_dir, seed=seed, learner=learner,
          num_iterations=num_iterations, collectors=collectors, window=window,
          validation_seeds=validation_seeds))
      if not together:
        alone(opened[-1], num_iterations)
        opened[-1].close()
    if not together:
      return [run.state for run in opened]
    common = min(max(run.start for run in opened), num_iterations)
    states = _stack([alone(run, common) for run in opened])
    for run in opened:
      run.state = None  # Only the stacked copy stays (each holds a replay).
    k = len(opened)
    for iteration in range(common, num_iterations):
      began = time.monotonic()
      states, outs = train_round_seeds(learner, env, states,
                                       env_seeds(iteration), window, params)
      jax.block_until_ready(states.key)
      wall = time.monotonic() - began
      # Slicing the replays out costs a copy each: only for checkpoints.
      sliced = _unstack(states if checkpoint_due(iteration)
                        else states.replace(replay=None), k)
      outs = _unstack(outs, k)
      for run, out in zip(opened, outs):  # Every seed before any is written.
        check_round(out, iteration, run.base_dir)
      for run, state, out in zip(opened, sliced, outs):
        record(run, iteration, state, out, wall)
    for run in opened:
      run.close()
    return _unstack(states, k)
