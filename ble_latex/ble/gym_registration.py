# coding=utf-8
"""Gym registration of the ble_latex environments (the `gym.envs` entry point).

Kept light on purpose: gym calls `register_env` at `import gym`, so this module
imports nothing heavy (no TF/JAX/BLE env modules); the environments are
registered by string entry points and only built on `gym.make`.
"""

import contextlib

# env id -> entry point: builds ble_latex.ble.gym_env's LatexBalloonEnv /
# LatexBalloonDiscreteEnv (the env classes are unchanged; the factories only
# keep the known gym/BLE/TF start-up notices quiet, `ble_latex.quiet`).
ENV_IDS = {
    'LatexBalloon-v0': 'ble_latex.ble.gym_registration:make_latex_balloon',
    'LatexBalloonDiscrete-v0':
        'ble_latex.ble.gym_registration:make_latex_balloon_discrete',
}
# The ids whose action space is the (a0, a1, a2) Box (the others: Discrete(3)).
BOX_ENV_IDS = ('LatexBalloon-v0',)


def _gym_env():
  """`ble_latex.ble.gym_env`, imported quietly, even after gin's lock.

  The env gin files bind only the core's names (no BLE module, so they parse
  where TensorFlow is absent), so a script that parses them (which locks
  gin's config) and then calls `gym.make` imports the gym env's
  `@gin.configurable`s after the lock: they are declared with the config
  unlocked for the import, which binds nothing.
  """
  import gin  # pylint: disable=g-import-not-at-top
  from ble_latex import quiet  # pylint: disable=g-import-not-at-top
  with quiet.third_party_noise(), gin.unlock_config():
    from ble_latex.ble import gym_env  # pylint: disable=g-import-not-at-top
  return gym_env


def make_latex_balloon(**kwargs):
  """`ble_latex.ble.gym_env.LatexBalloonEnv(**kwargs)`, built quietly."""
  from ble_latex import quiet  # pylint: disable=g-import-not-at-top
  gym_env = _gym_env()
  with quiet.third_party_noise():
    return gym_env.LatexBalloonEnv(**kwargs)


def make_latex_balloon_discrete(**kwargs):
  """`ble_latex.ble.gym_env.LatexBalloonDiscreteEnv(**kwargs)`, built quietly."""
  from ble_latex import quiet  # pylint: disable=g-import-not-at-top
  gym_env = _gym_env()
  with quiet.third_party_noise():
    return gym_env.LatexBalloonDiscreteEnv(**kwargs)


def register_env() -> None:
  """Registers the latex balloon envs with gym (idempotent)."""
  import ble_latex  # pylint: disable=g-import-not-at-top,unused-import
  from gym.envs import registration  # pylint: disable=g-import-not-at-top
  for env_id, entry_point in ENV_IDS.items():
    if env_id in registration.registry:
      continue
    with contextlib.ExitStack() as stack:
      if hasattr(registration, 'namespace'):
        stack.enter_context(registration.namespace(None))
      registration.register(id=env_id, entry_point=entry_point)


def check_env_name(name: str) -> None:
  """Raises errors.UsageError (exit 2) unless gym knows the env `name`."""
  import gym  # pylint: disable=g-import-not-at-top
  from ble_latex import errors  # pylint: disable=g-import-not-at-top
  valid = [k for k in gym.envs.registry if 'Balloon' in k]
  if name not in gym.envs.registry:
    raise errors.UsageError(errors.unknown('env', name, valid))
