# coding=utf-8
"""The station-keeping task: what counts as keeping station (paper, "Method").

One home for the radius that TW50, `tw50_window`, the reward's rho and the
figures' circle use. BLE's gym reward reads its own gin binding
`perciatelli_reward_function.station_keeping_radius_km`, whose default is the
same 50 km (checked in tests).
"""

STATION_RADIUS_KM = 50.0  # [km] rho: within it the balloon keeps station.
