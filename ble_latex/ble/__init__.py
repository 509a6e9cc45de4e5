# coding=utf-8
"""Everything that exists only for BLE: gym 0.25 envs, arena, BLE objects.

The gym ids `LatexBalloon-v0` / `LatexBalloonDiscrete-v0` and their
`BalloonEnv` subclasses (`gym_env`), BLE's arena interface over the flight
core (`arena`), the `LatexBalloonState` view (`balloon`), BLE's feature
constructors (`features`, `discrete_features`), the reward on BLE's
`SimulatorState` (`reward`), the BLE `WindField` adapters (`wind`) and the
discrete Gymnasium env over BLE's Perciatelli features
(`gymnasium_discrete`). The functional env, the Gymnasium envs and the
trainer import none of this (nor TensorFlow).
"""
