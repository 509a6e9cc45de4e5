# coding=utf-8
"""The latex balloon's flight core in JAX: pure, jittable, vmappable.

The one implementation of the latex balloon's physics and controller (it
replaced a NumPy model, now kept only as a test oracle in tests/reference),
in the style of gymnax: parameters and state are `flax.struct` pytrees and every
transition is a pure function, so a batch of balloons (and atmospheres) can
be stepped with `jax.vmap` inside one `jax.jit`.

Modules (import them directly; this package imports nothing):

  params      `FlightParams`: every flight-system constant (payload, sand,
              helium, c_d, burst volume, n_min, m_s_min, band, valve/ballast
              rates, step structure); `flight_params_from_gin` reads the
              existing gin bindings (`latex_launch.*`, `latex_controller.*`,
              `latex_flight.*`) in one place.
  state       `FlightState` (position, altitude, ascent rate, helium, sand,
              settled free lift, pending and cumulative releases, time, status,
              last action/decision) and `initial_state` (neutral start as
              `balloon.create_state`); `FlightStatus`, `DecisionCode`.
  atmosphere  BLE's standard atmosphere with its per-reset lapse-rate blend:
              `reset(key)`, `at_height`, `at_pressure`.
  physics     The paper's equations (Eq. fullN2L, its closed-form `relax`, the
              vertical integrator, Eq. vent, Eq. ballast, Eq. float).
  controller  Eq. fullcontroller (`decide`), Eq. float (`float_actuation`),
              the altitude-band guard as an action filter (`band_guard`) and
              its in-stride test (`heading_out_of_band`).
  envelope    The helium's temperature and pressure, free lift, c_d(Re) and
              burst volume under the realistic-physics switches (issue 28;
              off: the paper's model), shared by the integrator and the
              controller (`controller.decide_realistic`).
  solar       The sun's elevation (NOAA, as BLE's solar.py) for the
              helium's day/night temperature.
  thermal     The helium-air temperature difference: the sun's forcing at
              the balloon's position, a first-order thermal lag (issue 44).
  gas         The helium's own temperature as a state (issue 68): adiabatic
              compression, thermal relaxation, the bounded heating
              disturbance.
  disturbance The free-lift disturbance: random walk or Ornstein-Uhlenbeck.
  launch      `neutral_launch`: the launch fill neutral in the bound gas.
  reference   The validation flight, a fine RK4 reference, and the
              reference checks of both modes (`reference_table`,
              `run_day_at_float`, `compare_modes`).
  calibration The realistic float measured against its sources (plant
              constant, calm probability, sunset loss, band cost, days aloft;
              benchmarks/float_calibration.py prints the table).
  dynamics    `step`: one controller action and the physics of one stride
              (sub-steps, wind callback, releases, in-stride guard, envelope
              and resource statuses); `make_step` jits it.

Everything works in JAX's default float32 and, inside a caller's
`jax.enable_x64(True)` scope, in float64; nothing here changes JAX's
process-wide configuration.
"""
