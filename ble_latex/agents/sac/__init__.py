# coding=utf-8
"""Soft Actor-Critic: the algorithm, its networks, files and agents.

- `core`: the update in pure JAX, optimizers, the hyperparameters
  (`SACHyperparameters`, their one home) and file checks.
- `networks`: the actor and critics in Flax (Dopamine's `SACNetwork`).
- `trainer`: the jitted trainer on the batched env (gin `sac_trainer_config`;
  its driver is `ble_latex.run.jax_train`).
- `checkpoint`: the BLE agent's checkpoints (Dopamine's bundle API, msgpack).
- `agent`: `SACAgent` and `SACPretrainedAgent`, BLE agents (gin module string
  `ble_latex.agents.sac`, as before the package).
- `pretrained`: policy files and the shipped policies (`agents/policies/`).
- `ensemble`: `SACEnsembleAgent`, SAC policies whose critics choose (gin module
  string `ble_latex.agents.ensemble`, as before the package).

Importing the package imports none of them.
"""
