# coding=utf-8
"""Gymnasium registration of the ble_latex envs (`ble_latex/...-v0` ids).

Gymnasium 1.x has no plugin entry points, so the ids are registered by
`import ble_latex` itself, without importing gymnasium (~0.2 s) or anything
heavy: `ble_latex.compat`'s import hook calls `register_envs()` right after
gymnasium is imported, or at once if gymnasium already is. So both orders work:

  import ble_latex, gymnasium             # or: import gymnasium, ble_latex
  gymnasium.register_envs(ble_latex)      # optional; keeps linters quiet
  env = gymnasium.make('ble_latex/LatexBalloon-v0')

String entry points: the env modules load on `make` (JAX and the flight core;
BLE's env modules and TensorFlow only for the discrete id). `make_vec` of the
continuous id is one batched env (`gymnasium_env.LatexBalloonVectorEnv`),
of the discrete id a `SyncVectorEnv`.
"""

NAMESPACE = 'ble_latex'
_MODULE = 'ble_latex.envs.gymnasium_env'
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
    f'{NAMESPACE}/LatexBalloon-v0': f'{_MODULE}:make_vector_latex_balloon',
    f'{NAMESPACE}/LatexBalloonDiscrete-v0':
        f'{_DISCRETE}:make_vector_latex_balloon_discrete',
}


def register_envs() -> None:
  """Registers the ids with gymnasium (idempotent)."""
  from gymnasium.envs import registration  # pylint: disable=g-import-not-at-top
  for env_id, entry_point in ENV_IDS.items():
    if env_id not in registration.registry:
      # The envs end their episodes themselves (216 steps, the inner env's
      # gin-bound `episode_steps`): no TimeLimit unless make() asks for one
      # (`max_episode_steps=...`).
      registration.register(
          id=env_id, entry_point=entry_point,
          vector_entry_point=VECTOR_ENTRY_POINTS[env_id])
