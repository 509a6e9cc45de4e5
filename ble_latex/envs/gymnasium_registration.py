# coding=utf-8
"""Gymnasium registration of the ble_latex envs (`ble_latex/...-v0` ids).

Gymnasium 1.x has no plugin entry points, so the ids are registered by
`import ble_latex` itself, without importing gymnasium (~0.2 s) or anything
heavy: `ble_latex.compat`'s import hook calls `register_envs()` right after
gymnasium is imported, or at once if gymnasium already is. So both orders work:

  import ble_latex, gymnasium             # or: import gymnasium, ble_latex
  gymnasium.register_envs(ble_latex)      # optional; keeps linters quiet
  env = gymnasium.make('ble_latex/LatexBalloon-v0')
  # Without importing ble_latex first (e.g. CleanRL's gym.make(env_id)):
  env = gymnasium.make('ble_latex:ble_latex/LatexBalloon-v0')

Defaults: actions in [-1, 1]^3 (`normalize_actions=False` for the raw Box),
`spec.max_episode_steps` = 216 (the envs' own episode).

String entry points: the env modules load on `make` (JAX and the flight core;
BLE's env modules and TensorFlow only for the discrete id). `make_vec` of the
continuous id is one batched env (`gymnasium_vector.LatexBalloonVectorEnv`),
of the discrete id a `SyncVectorEnv`.
"""

from ble_latex.envs import task  # Plain constants: stays light.

NAMESPACE = 'ble_latex'
_MODULE = 'ble_latex.envs.gymnasium_env'
_VECTOR = 'ble_latex.envs.gymnasium_vector'
_DISCRETE = 'ble_latex.ble.gymnasium_discrete'  # BLE's features: at the edge.
# env id -> entry point.
ENV_IDS = {
    f'{NAMESPACE}/LatexBalloon-v0': f'{_MODULE}:LatexBalloonGymnasiumEnv',
    f'{NAMESPACE}/LatexBalloonDiscrete-v0':
        f'{_DISCRETE}:LatexBalloonDiscreteGymnasiumEnv',
}
# env id -> vector entry point (`gymnasium.make_vec`'s default mode): the
# batched core for the continuous id, a SyncVectorEnv for the discrete one.
VECTOR_ENTRY_POINTS = {
    f'{NAMESPACE}/LatexBalloon-v0': f'{_VECTOR}:make_vector_latex_balloon',
    f'{NAMESPACE}/LatexBalloonDiscrete-v0':
        f'{_DISCRETE}:make_vector_latex_balloon_discrete',
}

# The spec's time limit: the envs' episode (3 days of 20-minute strides).
MAX_EPISODE_STEPS = task.EPISODE_STEPS
# env id -> default constructor kwargs (RL clients' conventions): the Box
# action of the continuous id is [-1, 1]^3; `normalize_actions=False` gives
# the raw (a0 [m], a1, a2) Box.
DEFAULT_KWARGS = {
    f'{NAMESPACE}/LatexBalloon-v0': {'normalize_actions': True},
}


def register_envs() -> None:
  """Registers the ids with gymnasium (idempotent)."""
  from gymnasium.envs import registration  # pylint: disable=g-import-not-at-top
  for env_id, entry_point in ENV_IDS.items():
    if env_id not in registration.registry:
      # `spec.max_episode_steps` is the envs' own 216-stride episode
      # (gin's `latex_episode.episode_steps` default): make()'s TimeLimit
      # truncates at the same step as the env, and make_vec's batched env
      # takes it as the core's limit (min with `episode_steps`), so one
      # episode end is counted once.
      registration.register(
          id=env_id, entry_point=entry_point,
          vector_entry_point=VECTOR_ENTRY_POINTS[env_id],
          max_episode_steps=MAX_EPISODE_STEPS,
          kwargs=dict(DEFAULT_KWARGS.get(env_id, {})))
