# coding=utf-8
"""ble_latex agents, added to BLE's agent registry by `register()`.

- 'sac': `sac.agent.SACAgent`, Soft Actor-Critic for the Box action of
  LatexBalloon-v0; no default gin file (its hyperparameters' defaults are
  `sac.core.SACHyperparameters`';
  bind `ble_latex.agents.sac.SACAgent.*`).
- 'sac_pretrained': `sac.agent.SACPretrainedAgent`, SAC with the policy
  shipped in `agents/policies/sac_latex.msgpack`.
- 'sac_ensemble': `sac.ensemble.SACEnsembleAgent`, SAC policies whose critics
  choose among their actions, each member on its own view of the wind
  column (the shipped twelve fly under gin_configs/latex_wind_memory.gin);
  eval only.
- 'latex_random', 'latex_station_seeker': the Box baselines of
  `baselines.py` (no gin file).
- 'latex_mpc', 'latex_mpc_oracle', 'latex_mpc_grad': the planners of
  `planning/agents.py` (forecast CEM MPC, the same on the true wind as an upper
  bound, first-order MPC); no gin file (gin `LatexMpcAgent.*`, ...). They
  read the env's core state (`attach_env`, called by
  `run.runner.create_agent`).

The algorithms are subpackages (`sac/`, `planning/`) and `dagger.py`
(DAgger's algorithm; its driver is `run/dagger.py`). Importing this package
is cheap; `register()` imports BLE's registry and the
agents (TensorFlow, JAX, Dopamine).
"""

from typing import FrozenSet

# Registered agents that take a Box action (constructor keywords action_low,
# action_high, seed); the others are BLE's discrete-action agents.
BOX_AGENTS: FrozenSet[str] = frozenset(
    {'sac', 'sac_pretrained', 'sac_ensemble', 'latex_random',
     'latex_station_seeker', 'latex_mpc', 'latex_mpc_oracle',
     'latex_mpc_grad'})
# Box agents that plan on the env's core state (`attach_env(env)`).
PLANNER_AGENTS: FrozenSet[str] = frozenset(
    {'latex_mpc', 'latex_mpc_oracle', 'latex_mpc_grad'})
# Agents that only act, reading the env's core state (`attach_env`), which
# BLE's own train/eval do not give an agent: `ble-latex-eval` and
# `ble-latex-ble eval --env_name=...` fly them.
EVAL_ONLY_AGENTS: FrozenSet[str] = PLANNER_AGENTS | {'sac_ensemble'}


def check_agent(name: str) -> None:
  """Raises errors.UsageError (exit 2) unless `name` is a registered agent
  (BLE's or ble_latex's, `register`)."""
  # pylint: disable=g-import-not-at-top
  from ble_latex import errors
  from ble_latex import quiet
  # pylint: enable=g-import-not-at-top
  with quiet.third_party_noise():  # Imports dopamine's SAC, TF's GPU probe.
    # pylint: disable-next=g-import-not-at-top
    from balloon_learning_environment.agents import agent_registry
    register()
  if name not in agent_registry.REGISTRY:
    raise errors.UsageError(
        errors.unknown('agent', name, agent_registry.REGISTRY))


def register() -> None:
  """Adds the ble_latex agents to BLE's `agent_registry.REGISTRY`.

  Idempotent: calling it again rewrites the same entries. No agent of
  ble_latex has a default gin file: their settings' defaults are the code's
  (importing the agents here declares their gin names before BLE parses
  `--gin_bindings`).
  """
  # pylint: disable=g-import-not-at-top
  from balloon_learning_environment.agents import agent_registry
  from ble_latex.agents import baselines
  from ble_latex.agents.planning import agents as planners
  from ble_latex.agents.sac import agent as sac
  from ble_latex.agents.sac import ensemble
  from ble_latex.agents.sac import pretrained
  # pylint: enable=g-import-not-at-top
  agent_registry.REGISTRY['sac'] = (sac.SACAgent, None)
  agent_registry.REGISTRY['sac_pretrained'] = (sac.SACPretrainedAgent, None)
  agent_registry.REGISTRY['sac_ensemble'] = (ensemble.SACEnsembleAgent, None)
  agent_registry.REGISTRY['latex_random'] = (baselines.LatexRandomAgent, None)
  agent_registry.REGISTRY['latex_station_seeker'] = (
      baselines.GeometricStationSeeker, None)
  for name, constructor in planners.AGENTS.items():
    agent_registry.REGISTRY[name] = (constructor, None)
