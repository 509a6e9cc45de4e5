# coding=utf-8
r"""Jitted Soft Actor-Critic on the batched env (purejaxrl / rejax style).

`ble-latex-train --trainer=jax` flies `num_envs` balloons of the functional
env (`ble_latex.envs.jax_env`) in parallel and runs the SAC updates inside one
`jax.lax.scan` per round: no Python per step, no host copies of transitions.

The SAC itself is not written again: the update is `sac_core.update`
(Dopamine's `sac_agent.train` computed on the whole batch at once; the update
`sac.SACAgent` runs too), the network Dopamine's `SACNetwork` re-written in
Flax with the critic chosen by `critic` (`networks.make_network`), the
optimizers and the soft target update those of `sac.SACAgent`
(`sac_core.make_optimizers`, `sac_core.polyak_update`). Neither imports
TensorFlow, Dopamine or BLE's agents.
What this module adds is the loop, as pure functions of a `TrainState`:

- One round (an iteration) flies `num_envs` new episodes of
  `episode_steps` strides (216 = 3 days) from the env seeds given (the
  driver gives episode e of a training seed env seed `suites.train_seed(e)`,
  as `ble-latex-train` does, so the episodes are those of the gym env with
  the same seeds). A balloon whose
  flight ends early (out of sand or helium, burst) is masked for the rest of
  the round: it adds no transitions.
- Every vector step stores the step's transitions in a replay buffer on the
  device (a ring of arrays) and then runs `updates_per_step` SAC updates on
  uniform batches, once `min_replay_history` transitions are stored (actions
  are uniform random before that, as in Dopamine). The update-to-data ratio
  is `updates_per_step / num_envs`.
- A transition cut by the time limit is bootstrapped (not terminal); out of
  resources and burst are terminal.

Several training seeds can run as one `jax.vmap` of the round over their
stacked `TrainState`s (`train_round_seeds`, `ble-latex-train --vmap_seeds`).

This module is the algorithm only, pure functions of arrays. The driver,
`ble_latex.run.jax_train` (`train`, `train_seeds`), keeps the run
directories: episode logs, checkpoints, policy snapshots, resume.
"""

import dataclasses
import functools
from typing import (Any, Callable, ClassVar, Dict, List, Mapping, NamedTuple,
                    Optional, Sequence, Tuple)

import flax
import gin
import jax
import jax.numpy as jnp
import numpy as np
import optax

from ble_latex import gin_values
from ble_latex.agents.sac import core as sac_core
from ble_latex.agents.sac import networks
from ble_latex.envs import env_params
from ble_latex.envs import env_types
from ble_latex.envs import jax_env
from ble_latex.envs import rollout

Array = jax.Array


# Its gin module string is the module's old name (records name it).
@gin.configurable('sac_trainer_config',
                  module='ble_latex.agents.sac_trainer')
@dataclasses.dataclass(frozen=True, kw_only=True)
class TrainerConfig(sac_core.SACHyperparameters):
  """The jitted trainer's settings (gin: `sac_trainer_config.*`).

  SAC's hyperparameters and their defaults are `sac_core.SACHyperparameters`'
  (the BLE agent's too); this adds the loop's settings. Built with no
  arguments it takes gin's bindings (`sac_trainer_config.*`); arguments
  given override them. Checked when built (errors name
  `sac_trainer_config.<field>`).

  Attributes:
    num_envs: Balloons flown in parallel; one round is one episode of each.
      32 learned fastest in wall time of the settings measured on a 2-core
      CPU (README, "Jitted SAC trainer").
    updates_per_step: SAC updates after each step of all `num_envs`
      balloons (update-to-data ratio `updates_per_step / num_envs`: 0.25 by
      default; the paper's agent updates once per step of one balloon,
      ratio 1).
    init_policy: '' (default): the networks start from random weights. A
      SAC policy file (`.msgpack`, e.g. a DAgger student or a trained
      policy): a new run starts from its actor, critics and temperature
      (the targets equal the critics), checked against this config and the
      env's observation (`warm_start`; the driver loads it).
    actor_warmup_updates: The first updates of a run that train only the
      critics: the actor and the temperature are held (their Adam states
      too), so that a warm-started actor is not pulled around by critics
      that have not yet learned its values. 0: none (SAC as usual).
  """
  GIN_NAME: ClassVar[str] = 'sac_trainer_config'
  num_envs: int = 32
  updates_per_step: int = 8
  init_policy: str = ''
  actor_warmup_updates: int = 0

  def __post_init__(self):
    gin_values.require(isinstance(self.init_policy, str),
                       f'{self.GIN_NAME}.init_policy',
                       "a policy file's path, or ''", self.init_policy)
    super().__post_init__()


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
  # NaN / inf values the round produced, by what holds them (`NONFINITE`):
  # scalar counts computed in the round (`jax_train.check_round`).
  nonfinite: Dict[str, Array]


class Learner(NamedTuple):
  """The static parts: network, optimizers, config (hashable, for jit)."""
  network_def: networks.LatexSACNetwork
  optimizer: optax.GradientTransformation
  alpha_optimizer: optax.GradientTransformation
  config: TrainerConfig


_LOSS_KEYS = ('Losses/Critic', 'Losses/Actor', 'Losses/Alpha',
              'Values/CriticValues1', 'Values/Alpha')
# `RoundOutput.nonfinite`'s entries, in the order errors name them.
NONFINITE = ('critic loss', 'actor loss', 'alpha loss', 'critic values',
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
  optimizer, alpha_optimizer = sac_core.make_optimizers(
      network_def.init(key, obs, key), config.actor_learning_rate,
      config.critic_learning_rate, config.alpha_learning_rate)
  return Learner(network_def, optimizer, alpha_optimizer, config)


def make_learner(config: TrainerConfig, key: Array, *,
                 num_features: int = jax_env.LatexBalloonJaxEnv.num_features
                 ) -> Tuple[Learner, TrainState]:
  """The learner of `config` and a fresh `TrainState` from `key`, for
  observations of `num_features` (`env_params.num_features` of the env's
  params; 71 without observation options)."""
  learner = learner_for(config)
  num_actions = len(jax_env.ACTION_LOW)
  key, init_key = jax.random.split(key)
  obs = jnp.zeros((num_features,), jnp.float32)
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


# [-1, 1]^3 actions onto the env's Box (as `sac.SACAgent._to_box`): the
# functional env's one mapping.
to_box = jax_env.to_box


def check_replay_counters(size: int, cursor: int, capacity: int,
                          what: str) -> None:
  """Raises ValueError unless `_add` can reach (size, cursor) in the ring.

  The ring fills from row 0: until it is full the next slot is its size
  (cursor == size); full, the cursor may be any row. A stored cursor beyond
  the size would leave unwritten (zero) rows to be sampled and overwrite
  real ones.

  Args:
    size: Transitions stored, in [0, capacity].
    cursor: The next slot to write, in [0, capacity).
    capacity: The ring's size.
    what: The file, for the message.
  """
  if not (0 <= size <= capacity and 0 <= cursor < capacity):
    raise ValueError(f'{what}: replay size {size} / cursor {cursor} outside '
                     f'a ring of capacity {capacity}')
  if size < capacity and cursor != size:
    raise ValueError(f'{what}: replay cursor is {cursor} but size {size} '
                     f'(< capacity {capacity}) puts the next transition at '
                     f'row {size}')


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
  """One SAC update (`sac_core.update`) on a uniform batch of the replay."""
  c = learner.config
  sample_key, train_key = jax.random.split(key)
  idx = jax.random.randint(sample_key, (c.batch_size,), 0,
                           jnp.maximum(state.replay.size, 1))
  r = state.replay
  out = sac_core.update(
      learner.network_def, learner.optimizer, learner.alpha_optimizer,
      state.optimizer_state, state.alpha_optimizer_state,
      state.network_params, state.target_params, state.log_alpha, train_key,
      r.obs[idx], r.action[idx], r.next_obs[idx], r.reward[idx],
      r.terminal[idx], c.gamma, c.target_entropy, c.reward_scale_factor)
  if networks.uses_target_network(learner.network_def):
    target = sac_core.polyak_update(out['network_params'], state.target_params,
                                c.target_smoothing_coefficient)
  else:  # CrossQ: the targets are the online critics (unused by the update).
    target = out['network_params']
  new = state.replace(
      network_params=out['network_params'], target_params=target,
      optimizer_state=out['optimizer_state'], log_alpha=out['log_alpha'],
      alpha_optimizer_state=out['alpha_optimizer_state'],
      updates=state.updates + 1)
  if c.actor_warmup_updates:
    new = hold_actor(new, state, state.updates < c.actor_warmup_updates)
  return new, {k: jnp.mean(out[k]) for k in _LOSS_KEYS}


def hold_actor(new: 'TrainState', old: 'TrainState',
               hold: Array) -> 'TrainState':
  """`new` with the actor, its Adam state and the temperature of `old`
  where `hold` (a bool scalar): an update that trained the critics only."""
  labels = sac_core.param_labels(new.network_params)
  keep = lambda n, o: jnp.where(hold, o, n)
  params = jax.tree.map(
      lambda label, n, o: keep(n, o) if label == 'actor' else n, labels,
      new.network_params, old.network_params)
  inner = dict(new.optimizer_state.inner_states)
  inner['actor'] = jax.tree.map(keep, inner['actor'],
                                old.optimizer_state.inner_states['actor'])
  return new.replace(
      network_params=params,
      optimizer_state=new.optimizer_state._replace(inner_states=inner),
      log_alpha=keep(new.log_alpha, old.log_alpha),
      alpha_optimizer_state=jax.tree.map(keep, new.alpha_optimizer_state,
                                         old.alpha_optimizer_state))


def warm_start(learner: Learner, state: 'TrainState', policy: Dict[str, Any],
               what: str) -> 'TrainState':
  """A fresh `state` starting from a policy file's networks (`init_policy`).

  Its actor and critics become the online networks and the targets, its
  log alpha the temperature; the optimizers start fresh, the replay and
  counters are `state`'s.

  Args:
    learner: The learner.
    state: A fresh `TrainState` (`make_learner`).
    policy: A checked policy dict (`pretrained.load_policy`).
    what: The file, for messages.

  Raises:
    ValueError: Naming `what` and the leaf, if its networks are not shaped
      as this learner's.
  """
  params = sac_core.restore_like(state.network_params,
                                 policy['network_params'],
                                 f'{what}: network_params')
  log_alpha = jnp.asarray(policy['log_alpha'], state.log_alpha.dtype).reshape(
      state.log_alpha.shape)
  return state.replace(
      network_params=params, target_params=params,
      optimizer_state=learner.optimizer.init(params), log_alpha=log_alpha,
      alpha_optimizer_state=learner.alpha_optimizer.init(log_alpha))


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
                params: env_types.EnvParams) -> Tuple[TrainState, RoundOutput]:
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
  obs, env_state = rollout.reset_batch(
      env, jax.vmap(jax.random.PRNGKey)(seeds), params)
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
    next_obs, env_state, reward, terminated, info = rollout.step_batch(
        env, env_state, env.env_action(action), params)
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
  nonfinite = dict(zip(NONFINITE, [sac_core.nonfinite_count(x) for x in counted]
                       + [bad_actions, sac_core.nonfinite_count(ep_reward)]))
  return state, RoundOutput(ep_reward, within, steps, last, losses, nonfinite)


def fly_policy(env: jax_env.LatexBalloonJaxEnv,
               act: Callable[[Array, Array], Array], seeds: Array,
               num_steps: int, params: env_types.EnvParams,
               key: Optional[Array] = None,
               observe: Optional[Callable[[Any], Array]] = None
               ) -> Dict[str, Array]:
  """Flies a batched policy from each seed for `num_steps` strides (traceable).

  Args:
    env: The functional env (`normalize_actions=False`).
    act: (observations [N, ...], key) -> actions in the normalised box
      [N, A].
    seeds: [N] episode seeds.
    num_steps: Strides (the episode window).
    params: Env parameters.
    key: Split into one key per stride for `act` (default PRNGKey(0)).
    observe: One balloon's env state -> what `act` reads of it (vmapped
      over the balloons); None: the env's observation.

  Returns:
    [N] arrays: `within_steps`, `steps`, `status` (`FlightStatus`).
  """
  obs, env_state = rollout.reset_batch(
      env, jax.vmap(jax.random.PRNGKey)(seeds), params)
  n = seeds.shape[0]

  def policy(carry, env_state, obs, step_key):
    if observe is not None:  # Read from the states, not carried.
      obs = jax.vmap(observe)(env_state)
    return env.env_action(act(obs, step_key)), carry

  def record(carry, step_key, obs, action, step):
    del step_key, obs, action
    active, within, steps = carry
    _, _, _, terminated, info = step
    done = terminated | info['time_limit']
    within = within + (active & (info['distance_km'] <= params.radius_km))
    steps = steps + active
    return (active & ~done, within, steps), None

  zeros = jnp.zeros((n,), jnp.int32)
  keys = jax.random.split(jax.random.PRNGKey(0) if key is None else key,
                          num_steps)
  (env_state, _, (_, within, steps)), _ = rollout.fly(
      env, params, env_state, None if observe is not None else obs, policy,
      record, carry=(jnp.ones((n,), bool), zeros, zeros), xs=keys)
  return {'within_steps': within, 'steps': steps,
          'status': env_state.flight.status}


@functools.partial(jax.jit, static_argnums=(0, 1, 4))
def validate(learner: Learner, env: jax_env.LatexBalloonJaxEnv,
             network_params: Any, seeds: Array, num_steps: int,
             params: env_types.EnvParams) -> Dict[str, Array]:
  """Flies the deterministic policy (tanh of the mean) from each seed.

  The batched counterpart of `ble-latex-eval` for choosing among snapshots
  while training (the vmapped env matches the gym env to ~1e-4; results are
  reported with `ble-latex-eval`).

  Returns:
    [N] arrays: `within_steps`, `steps`, `status` (`FlightStatus`).
  """
  mean_action = jax.vmap(lambda o: learner.network_def.apply(
      network_params, o, jax.random.PRNGKey(0),
      method=learner.network_def.actor).mean_action)
  return fly_policy(env, lambda obs, _: mean_action(obs), seeds, num_steps,
                    params)


# --- Policies and stacked seeds ---------------------------------------------


def acting_bundle(learner: Learner, state: TrainState, iteration: int, *,
                  observation: Mapping[str, int]) -> Dict[str, Any]:
  """What `sac.SACAgent.acting_bundle` holds, for `pretrained` policies.

  `observation` is `env_params.observation_of` the env the policy observed
  (what its features mean, and how many: `env_params.num_features`).
  """
  c = learner.config
  config = {
      'observation_shape': [env_params.num_features(dict(observation))],
      'num_actions': len(jax_env.ACTION_LOW),
      'action_low': np.asarray(jax_env.ACTION_LOW, np.float64).tolist(),
      'action_high': np.asarray(jax_env.ACTION_HIGH, np.float64).tolist(),
      'num_layers': c.num_layers, 'hidden_units': c.hidden_units,
      'critic': c.critic, 'replay_capacity': c.replay_capacity,
      **{k: int(v) for k, v in observation.items()}}
  return {'format': sac_core.CHECKPOINT_FORMAT, 'iteration': int(iteration),
          'config': config, 'training_steps': int(state.updates),
          'network_params': sac_core.to_numpy(state.network_params),
          'log_alpha': np.asarray(state.log_alpha)}


def stack(trees: Sequence[Any]) -> Any:
  """K pytrees (e.g. `TrainState`s) as one, stacked on a leading axis."""
  return jax.tree.map(lambda *xs: jnp.stack(xs), *trees)


def unstack(tree: Any, count: int) -> List[Any]:
  """The K pytrees of a `stack`ed one."""
  return [jax.tree.map(lambda x, i=i: x[i], tree) for i in range(count)]


@functools.partial(jax.jit, static_argnums=(0, 1, 4))
def train_round_seeds(learner: Learner, env: jax_env.LatexBalloonJaxEnv,
                      states: TrainState, seeds: Array, num_steps: int,
                      params: env_types.EnvParams
                      ) -> Tuple[TrainState, RoundOutput]:
  """`train_round` for K training seeds at once (`jax.vmap` over states).

  Every training seed flies the same env seeds (as one after another would);
  `states` are K `TrainState`s stacked on a leading axis, as are the results.
  Equal to K `train_round` calls up to float rounding of the batched matrix
  products (tested).
  """
  return jax.vmap(lambda s: train_round(learner, env, s, seeds, num_steps,
                                        params))(states)
