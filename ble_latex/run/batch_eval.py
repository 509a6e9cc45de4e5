# coding=utf-8
"""Eval episodes of agents that fly the JAX core, many balloons at once.

`ble-latex-eval` (`eval_lib.evaluate`) and Ray eval (`distributed`) fly an
agent one balloon at a time through BLE's gym env: a Python loop per stride
per seed. An agent whose eval policy can act for N balloons at once flies
here instead, `BATCH_SIZE` seeds together: each seed's flight starts from
the gym env's own reset (the same world and state, bit for bit), then every
stride is one jitted, `vmap`-ed `jax_env.LatexBalloonJaxEnv.step_env` call
for the batch and one policy call for the batch. The records are
`eval_lib.fly`'s (same fields, seeds and order, flight paths included),
equal per seed within float32 noise: a `vmap`-ed step and a batched policy
call sum in other orders than the single ones (`tests/run/test_batch_eval.py`).

The protocol is one small class, `CorePolicy`: `begin` and `step` act for
N balloons from their env states and observations, as BLE's
`Agent.begin_episode` / `Agent.step` act for one. `core_policy(agent, ...)`
(a `functools.singledispatch` function) gives an agent's; it is registered
here for the JAX-core agents:

- `sac.SACAgent` in eval mode (`sac`, `sac_pretrained`): its mean action
  `tanh(mu(s))` for the batch in one jitted call, mapped onto the Box by the
  agent's own `_to_box`;
- `ensemble.SACEnsembleAgent` (`sac_ensemble`): the members' critics'
  choice (`ensemble.choices`), mapped the same way;
- `planners.PlannerAgent` (`latex_mpc`, `latex_mpc_oracle`,
  `latex_mpc_grad`): one `planning.plan_batch` call for the batch every
  `replan_every` strides (as `planner_batch.fly_batch`, the planners'
  batched flights without BLE's gym env, which `benchmarks/planners.py`
  flies), the actions in between from `planning.next_action`; at most as
  many balloons as `plan_config.MAX_PLAN_STRIDES` allows in one call;
- `baselines.GeometricStationSeeker` (`latex_station_seeker`): one copy of
  the agent per balloon (it reads only its observation; a copy per balloon
  runs the agent's own code on it).

A new agent flies batched by registering its policy:
`@batch_eval.core_policy.register(MyAgent)`. Every other agent, and any env
this core cannot fly alone (the discrete env, a BLE feature constructor or
reward function, a BLE wind field flown through host callbacks), keeps the
one-at-a-time path. `latex_random` keeps it too: its one random stream runs
through the seeds in order, so its records depend on the order it flies.
"""

import copy
import dataclasses
import functools
from typing import Any, Callable, Dict, List, Optional, Sequence

from balloon_learning_environment.agents import agent as base_agent
import jax
import jax.numpy as jnp
import numpy as np
import tqdm

from ble_latex import jax_cache
from ble_latex.agents import baselines
from ble_latex.agents.planning import agents as planners
from ble_latex.agents.planning import config as plan_config
from ble_latex.agents.planning import planner as planning
from ble_latex.agents.sac import agent as sac
from ble_latex.agents.sac import core as sac_core
from ble_latex.agents.sac import ensemble
from ble_latex.ble import gym_env
from ble_latex.envs import env_types
from ble_latex.envs import gymnasium_env
from ble_latex.envs import jax_env
from ble_latex.envs import rollout
from ble_latex.envs import winds
from ble_latex.run import metrics
from ble_latex.run import planner_batch
from ble_latex.run import records as records_lib
from ble_latex.run import runner

# Seeds flown together (the planners' batched flights' too).
BATCH_SIZE = planner_batch.BATCH_SIZE


class CorePolicy:
  """An agent's eval policy for N balloons of the JAX core at once.

  `begin` starts N episodes (as `Agent.begin_episode`), `step` acts after
  each stride (as `Agent.step`); both return the N actions (a0 [m], a1, a2)
  inside the env's Box, shape [N, 3]. Balloons whose episode has ended are
  still passed (their actions are not used).

  Attributes:
    max_batch: The most balloons it acts for at once (None: no bound).
  """

  max_batch: Optional[int] = None

  def begin(self, states: env_types.EnvState,
            observations: np.ndarray) -> np.ndarray:
    """The first actions of N new episodes.

    Args:
      states: [N] env states after the reset (device arrays).
      observations: [N, 71] observations.

    Returns:
      [N, 3] actions.
    """
    raise NotImplementedError

  def step(self, states: env_types.EnvState, observations: np.ndarray,
           rewards: np.ndarray) -> np.ndarray:
    """The next actions, after a stride.

    Args:
      states: [N] env states after the stride.
      observations: [N, 71] observations after the stride.
      rewards: [N] rewards of the stride.

    Returns:
      [N, 3] actions.
    """
    raise NotImplementedError


@dataclasses.dataclass(frozen=True)
class CoreEnv:
  """What the batched episodes fly: the gym env's core, params and wind."""
  env: jax_env.LatexBalloonJaxEnv
  params: env_types.EnvParams
  wind: winds.Wind


@functools.singledispatch
def core_policy(agent: Any, core: CoreEnv) -> Optional[CorePolicy]:
  """The agent's batched eval policy, or None (one balloon at a time).

  Args:
    agent: A BLE agent, in eval mode.
    core: The env it flies (`core_env`).

  Returns:
    A `CorePolicy`, or None for agents without one.
  """
  del agent, core
  return None


def core_env(env: Any) -> Optional[CoreEnv]:
  """The JAX core a gym env flies, if the batched episodes equal its own.

  Args:
    env: A gym env (wrapped or not).

  Returns:
    The core, or None unless `env` is `LatexBalloon-v0` with the core's
    features, reward and winds (generative or ERA5 in its params).
  """
  env = getattr(env, 'unwrapped', env)
  # pylint: disable=protected-access
  if (type(env) is not gym_env.LatexBalloonEnv or  # pylint: disable=unidiomatic-typecheck
      getattr(env, '_reward_fn', True) is not None or
      not getattr(env.arena, '_core_features', False) or
      env.arena.driver.host_wind_field is not None):
    return None
  # pylint: enable=protected-access
  core = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  params = env.arena.params
  return CoreEnv(core, params, core.wind_for(params))


def policy_for(agent: base_agent.Agent, env: Any) -> Optional[CorePolicy]:
  """The batched policy of `agent` on `env` (eval mode), or None."""
  core = core_env(env)
  if core is None:
    return None
  agent.set_mode(base_agent.AgentMode.EVAL)
  return core_policy(agent, core)


def flies_batched(agent: base_agent.Agent, env: Any) -> bool:
  """Whether `evaluate` flies `agent` on `env` batched."""
  return policy_for(agent, env) is not None


# --- The policies of the JAX-core agents. ---------------------------------


@functools.partial(jax.jit, static_argnums=0)
def _mean_actions(network_def: Any, network_params: Any,
                  observations: jax.Array) -> jax.Array:
  """SAC's eval action tanh(mu(s)) in [-1, 1]^3 of [N] observations.

  Row by row (`lax.map`): the agent's own one-observation program, so the
  actions are its actions bit for bit (a batched matmul sums in another
  order); the MLP is a small part of a stride's cost.
  """
  def one(observation):
    # The actor also draws a sample; its key does not change the mean.
    return network_def.apply(network_params, observation,
                             jax.random.PRNGKey(0),
                             method=network_def.actor).mean_action
  return jax.lax.map(one, observations)


class _SacPolicy(CorePolicy):
  """SAC's deterministic eval policy (`SACAgent` in eval mode)."""

  def __init__(self, agent: sac.SACAgent):
    self._agent = agent

  def _normalized(self, observations: jax.Array) -> jax.Array:
    """The batch's actions in the normalised box [N, 3]."""
    return _mean_actions(self._agent.network_def, self._agent.network_params,
                         observations)

  def _act(self, observations: np.ndarray) -> np.ndarray:
    normalized = np.asarray(self._normalized(
        jnp.asarray(observations, jnp.float32)), np.float32)
    bad = ~np.isfinite(normalized).all(axis=1)
    if bad.any():
      raise sac_core.TrainingDiverged(
          f'{self._agent.get_name()} produced a non-finite action '
          f'{normalized[bad][0].tolist()}: the network parameters have '
          'diverged')
    return self._agent._to_box(normalized)  # pylint: disable=protected-access

  def begin(self, states, observations):
    return self._act(observations)

  def step(self, states, observations, rewards):
    return self._act(observations)


@core_policy.register
def _sac_policy(agent: sac.SACAgent, core: CoreEnv) -> Optional[CorePolicy]:
  del core
  return _SacPolicy(agent) if agent.eval_mode else None


class _EnsemblePolicy(_SacPolicy):
  """`sac_ensemble`: the members' critics choose (`ensemble.choices`).

  Members that observe otherwise than the env, or a lookahead, read the
  states (`ensemble.choices_from_states`).
  """

  def __init__(self, agent: ensemble.SACEnsembleAgent, core: CoreEnv):
    super().__init__(agent)
    self._core = core
    self._states = None

  def _normalized(self, observations: jax.Array) -> jax.Array:
    agent = self._agent
    if not agent.needs_env:
      return ensemble.choices(agent.network_def, agent.members, observations)
    return ensemble.choices_from_states(
        agent.network_def, agent.group, agent.views, agent.lookahead,
        self._core.wind, agent.members, self._states, self._core.params)

  def begin(self, states, observations):
    self._states = states
    return super().begin(states, observations)

  def step(self, states, observations, rewards):
    self._states = states
    return super().step(states, observations, rewards)


@core_policy.register
def _ensemble_policy(agent: ensemble.SACEnsembleAgent,
                     core: CoreEnv) -> Optional[CorePolicy]:
  return _EnsemblePolicy(agent, core)


class _PlannerPolicy(CorePolicy):
  """A planner: `plan_batch` every `replan_every` strides, for the batch."""

  def __init__(self, agent: planners.PlannerAgent, core: CoreEnv):
    self._config = agent.config
    self._seed = jnp.int32(agent._seed)  # pylint: disable=protected-access
    self._low = np.asarray(agent._low)  # pylint: disable=protected-access
    self._high = np.asarray(agent._high)  # pylint: disable=protected-access
    self._core = core
    self._plans: Optional[planning.Plan] = None
    self._host: Optional[planning.Plan] = None
    self._since = 0
    self.max_batch = max(
        1, plan_config.MAX_PLAN_STRIDES // self._config.plan_strides())

  def begin(self, states, observations):
    self._plans = None
    return self.step(states, observations, None)

  def step(self, states, observations, rewards):
    config = self._config
    if self._plans is None or self._since >= config.replan_every:
      previous = (planning.initial_plans(config, states)
                  if self._plans is None else self._plans)
      self._plans = jax.block_until_ready(planning.plan_batch(
          config, self._core.params, states, self._seed, previous,
          self._core.wind))
      self._host = jax.device_get(self._plans)
      self._since = 0
    actions = np.stack([
        planning.next_action(config, jax.tree.map(lambda a: a[i], self._host),
                             self._since)
        for i in range(len(observations))])
    self._since += 1
    return np.clip(actions, self._low, self._high)


@core_policy.register
def _planner_policy(agent: planners.PlannerAgent,
                    core: CoreEnv) -> Optional[CorePolicy]:
  return _PlannerPolicy(agent, core)


class _CopiesPolicy(CorePolicy):
  """One copy of an observation-only agent per balloon, its own code."""

  def __init__(self, agent: base_agent.Agent):
    self._agent = agent
    self._copies: List[base_agent.Agent] = []

  def begin(self, states, observations):
    self._copies = [copy.deepcopy(self._agent) for _ in observations]
    return np.stack([np.asarray(c.begin_episode(o), np.float64)
                     for c, o in zip(self._copies, observations)])

  def step(self, states, observations, rewards):
    return np.stack([np.asarray(c.step(float(r), o), np.float64)
                     for c, o, r in zip(self._copies, observations, rewards)])


@core_policy.register
def _seeker_policy(agent: baselines.GeometricStationSeeker,
                   core: CoreEnv) -> Optional[CorePolicy]:
  del core
  return _CopiesPolicy(agent)


# --- The batched episodes. -------------------------------------------------


@functools.lru_cache(maxsize=2)
def _stepper(env: jax_env.LatexBalloonJaxEnv):
  """Jitted: [N] states and actions -> states, (obs, reward, info, flight)."""
  def step(states, actions, params):
    obs, states, reward, _, info = rollout.step_batch(env, states, actions,
                                                      params)
    flight = {k: getattr(states.flight, k)
              for k in planner_batch.FLIGHT_FIELDS}
    return states, (obs, reward, info, flight)
  return jax.jit(step, donate_argnums=0,
                 compiler_options=jax_cache.fast_compile_options())


def fly_batch(policy: CorePolicy, env: Any, seeds: Sequence[int],
              max_steps: int) -> List[Dict[str, Any]]:
  """One deterministic episode per seed, all together; their records.

  Args:
    policy: The agent's batched policy (`policy_for(agent, env)`).
    env: The agent's gym env (`LatexBalloon-v0`): each flight starts from
      its `reset(seed=s)`.
    seeds: Env seeds.
    max_steps: Strides per episode at most.

  Returns:
    `eval_lib.fly`'s record of each seed, in the order of `seeds`.
  """
  unwrapped = env.unwrapped
  core = core_env(unwrapped)
  states, observations, paths = [], [], []
  driver = unwrapped.arena.driver
  # The flights fly batched (`_stepper`): the reset compiles no single step.
  step_ahead, driver.compile_step_ahead = driver.compile_step_ahead, False
  try:
    for seed in seeds:  # The gym env's own reset: its world, bit for bit.
      observations.append(np.asarray(env.reset(seed=int(seed)), np.float32))
      states.append(driver.state)
      paths.append([runner.flight_point(unwrapped)])
  finally:
    driver.compile_step_ahead = step_ahead
  states = jax.tree.map(lambda *leaves: jnp.stack(leaves), *states)
  observations = np.stack(observations)
  n = len(seeds)
  window = min(unwrapped.episode_steps, max_steps)
  trackers = [metrics.EpisodeTracker(i, s, unwrapped.radius.kilometers,
                                     window_steps=window)
              for i, s in enumerate(seeds)]
  done = np.zeros(n, bool)
  step = _stepper(core.env)
  low, high = unwrapped.action_space.low, unwrapped.action_space.high
  actions = policy.begin(states, observations)
  for i in range(max_steps):
    actions = gymnasium_env.validate_actions(actions, n, low, high)
    states, out = step(states, jnp.asarray(actions, jnp.float32), core.params)
    observations, rewards, info, flight = jax.device_get(out)
    for b in np.flatnonzero(~done):
      info_b = jax_env.info_dict({k: v[b] for k, v in info.items()})
      trackers[b].step(float(rewards[b]), info_b)
      paths[b].append(records_lib.batch_flight_point(flight, b))
      done[b] = (info_b['terminal_reason'] != 'ok' or info_b['time_limit'])
    if done.all() or i == max_steps - 1:
      break
    actions = policy.step(states, observations, rewards)
  return planner_batch.eval_records(trackers, done, paths)


def evaluate(agent: base_agent.Agent, env: Any, seeds: Sequence[int],
             max_steps: int, description: str = 'eval',
             batch_size: Optional[int] = None,
             postfix: Optional[Callable[[List[Dict[str, Any]]],
                                        Dict[str, str]]] = None
             ) -> List[Dict[str, Any]]:
  """`eval_lib.evaluate` for an agent with a batched policy.

  Args:
    agent: The agent (`flies_batched(agent, env)`).
    env: Its gym env.
    seeds: Env seeds.
    max_steps: Strides per episode at most.
    description: Progress-bar label.
    batch_size: Seeds flown together (None: `BATCH_SIZE`), at most the
      policy's `max_batch`.
    postfix: The progress bar's running numbers of the records so far
      (`eval_lib.progress_postfix`), or None.

  Returns:
    One record per seed, in the order of `seeds`.

  Raises:
    ValueError: `agent` has no batched policy on `env`.
  """
  policy = policy_for(agent, env)
  if policy is None:
    raise ValueError(f'{type(agent).__name__} on {env}: no batched policy '
                     '(use eval_lib.evaluate)')
  batch_size = batch_size or BATCH_SIZE
  batch_size = min(batch_size, policy.max_batch or batch_size)
  records: List[Dict[str, Any]] = []
  with tqdm.tqdm(total=len(seeds), desc=f'{description} (batched)',
                 unit='episode', dynamic_ncols=True) as bar:
    for start in range(0, len(seeds), batch_size):
      chunk = list(seeds[start:start + batch_size])
      records += fly_batch(policy, env, chunk, max_steps)
      bar.update(len(chunk))
      if postfix is not None:
        bar.set_postfix(postfix(records))
  return records
