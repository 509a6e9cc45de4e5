# coding=utf-8
"""The station-keeping task: what counts as keeping station (paper, "Method").

The default of the station radius rho (the paper's 50 km). The radius a run
flies is `EnvParams.radius_km`, bound as `latex_episode.station_keeping_
radius_km`: the reward, TW50 (trainers, metrics, BLE's view) and the drawn
circle read it; BLE's `perciatelli_reward_function.station_keeping_radius_km`
may only repeat it (`env_params.check_one_radius`).
"""

STATION_RADIUS_KM = 50.0  # [km] rho: within it the balloon keeps station.
# Strides per episode: 3 days of 20-minute actions (the paper's). The env's
# `EnvParams.episode_steps` default, the Gymnasium ids' time limit, the suites'
# episodes and the metrics' window all read it.
EPISODE_STEPS = 216
