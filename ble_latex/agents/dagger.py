# coding=utf-8
r"""DAgger: a planner distilled into a policy over the 71 observations.

"Learning by cheating" (issue 47): the student, SAC's actor network
(`networks.make_network`; its mean action tanh(mu(s)) in [-1, 1]^3, flown
through `jax_env.to_box`), learns to act as a planner (the teacher,
`latex_mpc` by default: the forecast beam-search MPC, which reads no future
truth) by DAgger (Ross, Gordon & Bagnell, AISTATS 2011). Round r:

1. N balloons fly `episode_steps` strides on training seeds no other round
   flies (`jax_train.round_seeds`). Each block of the planner's
   `replan_every` strides, each balloon flies the teacher's actions with
   probability beta_r = beta0 x beta_decay^r, else the student's (the
   mixture policy of DAgger; round 0 with beta0 = 1 is behaviour cloning).
2. The teacher labels every state visited: `planning.plan_batch` plans from
   the visited states every `replan_every` strides (warm-started by its
   previous plan and its wind memory along the same flight, as it would be
   had it flown), and the label of a stride is the action its plan flies
   there, in the normalised box (`from_box`).
3. The labels join the aggregate (a ring of `dataset_capacity` rows).
4. The student is fitted to the aggregate: `fit_steps` Adam steps (optax)
   on minibatches of the mean squared error of its mean action.
5. Its deterministic policy flies the first `validation_seeds` seeds of
   `latex_validation` (`sac_trainer.validate`); the best round by TW50 over
   the window, among those at most `max_out_of_resources_pct` out of
   resources, is kept and exported as a SAC policy file
   (`best_policy.msgpack`: the student as the actor, the critics as
   initialised and unused), which `ble-latex-eval --agent=sac_pretrained
   --gin_bindings="SACPretrainedAgent.policy_path='RUN/best_policy.msgpack'"`
   flies.

The driver (run directory, checkpoints, resume, the best round) and the
settings (`DaggerConfig`, gin `dagger_config.*`) are `ble_latex.run.dagger`.
"""

import functools
from typing import Any, Callable, Dict, List, Mapping, NamedTuple, Tuple

import jax
import jax.numpy as jnp
import numpy as np
import optax

from ble_latex.agents.planning import config as plan_config
from ble_latex.agents.planning import planner as planning
from ble_latex.agents.sac import networks
from ble_latex.agents.sac import pretrained
from ble_latex.agents.sac import trainer as sac_trainer
from ble_latex.envs import env_types
from ble_latex.envs import jax_env
from ble_latex.envs import rollout

Array = jax.Array


class Student(NamedTuple):
  """The static parts (hashable, for jit): the network, the optimizer."""
  network_def: networks.LatexSACNetwork
  optimizer: optax.GradientTransformation
  learner: sac_trainer.Learner  # The same network, for `validate`.


@functools.lru_cache(maxsize=8)
def student_for(num_layers: int, hidden_units: int,
                learning_rate: float) -> Student:
  """The student of these sizes, one object per sizes (shared compiles)."""
  learner = sac_trainer.learner_for(sac_trainer.TrainerConfig(
      num_layers=num_layers, hidden_units=hidden_units))
  return Student(learner.network_def, optax.adam(learning_rate), learner)


def init_params(student: Student, key: Array, *,
                num_features: int = jax_env.LatexBalloonJaxEnv.num_features
                ) -> Any:
  """Fresh network parameters (SAC's actor and critics; critics unused)
  for observations of `num_features` (`env_params.num_features`)."""
  obs = jnp.zeros((num_features,), jnp.float32)
  return student.network_def.init(key, obs, key)


def from_box(action: Array) -> Array:
  """Box actions (a0 [m], a1, a2) onto [-1, 1]^3: `jax_env.to_box`'s inverse."""
  low = jnp.asarray(jax_env.ACTION_LOW, jnp.float32)
  high = jnp.asarray(jax_env.ACTION_HIGH, jnp.float32)
  return jnp.clip(2.0 * (action - low) / (high - low) - 1.0, -1.0, 1.0)


def mean_actions(student: Student, params: Any, obs: Array) -> Array:
  """The student's actions tanh(mu(s)) in [-1, 1]^3 of [N, 71] observations."""
  key = jax.random.PRNGKey(0)  # The mean does not depend on it.
  return jax.vmap(lambda o: student.network_def.apply(
      params, o, key, method=student.network_def.actor).mean_action)(obs)


def imitation_loss(student: Student, params: Any, obs: Array,
                   labels: Array) -> Array:
  """Mean over rows of the squared error of the mean action (summed over a)."""
  error = mean_actions(student, params, obs) - labels
  return jnp.mean(jnp.sum(jnp.square(error), axis=-1))


@functools.partial(jax.jit, static_argnums=(0, 6, 7))
def fit(student: Student, params: Any, opt_state: Any, obs: Array,
        labels: Array, size: Array, steps: int, batch_size: int,
        key: Array) -> Tuple[Any, Any, Array]:
  """`steps` Adam steps on minibatches drawn from the first `size` rows.

  Args:
    student: The network and optimizer (static).
    params: Network parameters.
    opt_state: Adam's state.
    obs: [C, 71] observations (rows past `size` unused).
    labels: [C, 3] teacher actions in [-1, 1]^3.
    size: Rows filled (int32 scalar, > 0).
    steps: Adam steps (static).
    batch_size: Rows per minibatch (static).
    key: PRNG key of the minibatches.

  Returns:
    The parameters, Adam's state and the mean minibatch loss.
  """
  loss_grad = jax.value_and_grad(functools.partial(imitation_loss, student))

  def one(carry, step_key):
    params, opt_state = carry
    rows = jax.random.randint(step_key, (batch_size,), 0, size)
    loss, grads = loss_grad(params, obs[rows], labels[rows])
    updates, opt_state = student.optimizer.update(grads, opt_state, params)
    return (optax.apply_updates(params, updates), opt_state), loss

  (params, opt_state), losses = jax.lax.scan(
      one, (params, opt_state), jax.random.split(key, steps))
  return params, opt_state, jnp.mean(losses)


class Aggregate(NamedTuple):
  """DAgger's data set, a host ring of labelled states.

  Attributes:
    obs: [C, 71] observations.
    labels: [C, 3] the teacher's actions there, in [-1, 1]^3.
    size: Rows filled.
    cursor: The next row written.
  """
  obs: np.ndarray
  labels: np.ndarray
  size: int
  cursor: int


def empty_aggregate(capacity: int, num_features: int = (
    jax_env.LatexBalloonJaxEnv.num_features)) -> Aggregate:
  """An aggregate of `capacity` rows of `num_features`, none filled."""
  return Aggregate(
      np.zeros((capacity, num_features), np.float32),
      np.zeros((capacity, len(jax_env.ACTION_LOW)), np.float32), 0, 0)


def aggregate(data: Aggregate, obs: np.ndarray,
              labels: np.ndarray) -> Aggregate:
  """`data` with rows (`obs`, `labels`) added (the oldest replaced)."""
  capacity, n = len(data.obs), len(obs)
  new_obs, new_labels = data.obs.copy(), data.labels.copy()
  kept = slice(max(0, n - capacity), n)  # More than fit: the newest.
  rows = ((data.cursor + np.arange(n)) % capacity)[kept]
  new_obs[rows], new_labels[rows] = obs[kept], labels[kept]
  return Aggregate(new_obs, new_labels, min(capacity, data.size + n),
                   int((data.cursor + n) % capacity))


@functools.lru_cache(maxsize=8)
def _programs(env: jax_env.LatexBalloonJaxEnv,
              teacher: plan_config.PlannerConfig, student: Student
              ) -> Tuple[Callable[..., Any], Callable[..., Any]]:
  """Jitted: the batch's reset, and one block of `replan_every` strides.

  The block flies each balloon the teacher's actions (where `use_teacher`)
  or the student's, and returns each stride's (observation, teacher label
  in [-1, 1]^3, whether the balloon was still flying).
  """
  reset = jax.jit(functools.partial(rollout.reset_batch, env))

  def fly(params, states, obs, active, plans, student_params, use_teacher):
    def policy(carry, states, obs, teacher_action):
      del states
      own = jax_env.to_box(mean_actions(student, student_params, obs))
      return jnp.where(use_teacher[:, None], teacher_action, own), carry

    def record(carry, teacher_action, obs, action, step):
      del action
      active, within = carry
      _, _, _, terminated, info = step
      within = within + (active & (info['distance_km'] <= params.radius_km))
      row = (obs, from_box(teacher_action), active)
      active = active & ~(terminated | info['time_limit'])
      return (active, within), row
    zeros = jnp.zeros(active.shape, jnp.int32)
    (states, obs, (active, within)), rows = rollout.fly(
        env, params, states, obs, policy, record, carry=(active, zeros),
        xs=planning.flown_actions(teacher, plans))
    return states, obs, active, within, rows
  return reset, jax.jit(fly)


def fly_round(student: Student, student_params: Any,
              teacher: plan_config.PlannerConfig,
              env: jax_env.LatexBalloonJaxEnv, params: env_types.EnvParams,
              seeds: List[int], steps: int, beta: float, key: Array,
              planner_seed: int) -> Dict[str, Any]:
  """One round's flights under the beta-mixture, labelled by the teacher.

  Args:
    student: The student (static parts).
    student_params: Its parameters.
    teacher: The planner (its `replan_every` strides are a block).
    env: The core, raw Box actions (`normalize_actions=False`).
    params: The env parameters.
    seeds: Env seeds, one per balloon.
    steps: Strides per flight at most (a multiple of `replan_every`).
    beta: Probability that a balloon flies the teacher in a block.
    key: PRNG key of the mixture.
    planner_seed: The teacher's seed (`planning.plan_key`).

  Returns:
    obs [M, 71] and labels [M, 3] of the M strides flown, `within` [N]
    strides ended within the radius, `steps` [N] strides flown,
    `teacher_fraction`: of the balloon-blocks flown, those the teacher flew.
  """
  reset, block = _programs(env, teacher, student)
  wind = env.wind_for(params)
  obs, states = reset(
      jax.vmap(jax.random.PRNGKey)(jnp.asarray(seeds, jnp.int32)), params)
  n = len(seeds)
  active = jnp.ones((n,), bool)
  plans = planning.initial_plans(teacher, states)
  within, flown = np.zeros(n, np.int64), np.zeros(n, np.int64)
  rows, mixed = [], []
  for _ in range(0, steps, teacher.replan_every):
    plans = planning.plan_batch(teacher, params, states,
                                jnp.int32(planner_seed), plans, wind)
    key, mix_key = jax.random.split(key)
    use_teacher = jax.random.uniform(mix_key, (n,)) < beta
    was_active = active
    states, obs, active, block_within, (b_obs, b_labels, b_valid) = block(
        params, states, obs, active, plans, student_params, use_teacher)
    b_obs, b_labels, b_valid, block_within, use, was = jax.device_get(
        (b_obs, b_labels, b_valid, block_within, use_teacher, was_active))
    mixed.append(use[was])
    valid = b_valid.reshape(-1)
    rows.append((b_obs.reshape(-1, b_obs.shape[-1])[valid],
                 b_labels.reshape(-1, b_labels.shape[-1])[valid]))
    within += block_within
    flown += b_valid.sum(axis=0)
    if not bool(np.asarray(active).any()):
      break
  mixed = np.concatenate(mixed)
  return {'obs': np.concatenate([r[0] for r in rows]),
          'labels': np.concatenate([r[1] for r in rows]),
          'within': within, 'steps': flown,
          'teacher_fraction': float(mixed.mean()) if len(mixed) else 0.0}




class _Acting(NamedTuple):
  """What `sac_trainer.acting_bundle` reads of a train state."""
  network_params: Any
  updates: Any
  log_alpha: Any


def export_policy(student: Student, params: Any, round_index: int,
                  fit_steps_done: int, path: str, note: str, *,
                  observation: Mapping[str, int]) -> None:
  """Writes the student as a SAC policy file (`sac_pretrained` flies it).

  The actor is the student; the critics are as initialised (unused by the
  policy) and log_alpha is 0 (alpha 1, SAC's start if it is fine-tuned).
  """
  bundle = sac_trainer.acting_bundle(
      student.learner, _Acting(params, np.int64(fit_steps_done),
                               np.zeros((1,), np.float32)), round_index,
      observation=observation)
  policy = pretrained.policy_from_bundle(
      bundle, f'dagger round {round_index}', note, what='DAgger student')
  pretrained.write_policy(policy, path)
