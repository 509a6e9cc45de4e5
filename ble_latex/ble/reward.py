# coding=utf-8
"""Station-keeping reward for the latex balloon (paper Eq. reward_function).

The paper's reward is BLE's Perciatelli reward without its power term:
1 within radius rho, else c * 2^(-(d - rho) / tau). BLE's
`perciatelli_reward_function` computes exactly that for a latex balloon: its
power penalty only applies to BLE's air-pump DOWN command, which a latex
balloon state never records (`last_command` stays STAY). Its constants are
the env's, handed to BLE's function explicitly: the one station radius
(`latex_episode.station_keeping_radius_km`, 50 km), cliff and half-life
(`latex_reward.reward_dropoff = 0.4`, `latex_reward.reward_halflife_km =
100.0`); BLE's own `perciatelli_reward_function.*` names may only repeat them
(`env_params.check_ble_repeat`).

This module adds only the optional resource penalty (default off, as in the
paper; gin `latex_reward.*`, the core's `env_params.reward_settings`) and,
with `latex_reward.reward_tanh_scale_km` > 0, the follow-up paper's tanh
shape inside the circle (`jax_features.tanh_inside`, as the core's reward).
"""

import math
from typing import Optional

from balloon_learning_environment.env import balloon_env
from balloon_learning_environment.env import simulator_data
from balloon_learning_environment.env.balloon import control

from ble_latex import gin_values
from ble_latex.envs import env_params
from ble_latex.envs import jax_features


def latex_reward(simulator_state: simulator_data.SimulatorState,
                 helium_vented_mols: float = 0.0,
                 sand_dropped_kg: float = 0.0,
                 *,
                 helium_penalty_per_mol: Optional[float] = None,
                 sand_penalty_per_kg: Optional[float] = None,
                 station_keeping_radius_km: Optional[float] = None) -> float:
  """Implements Eq. reward_function plus an optional resource penalty.

  Args:
    simulator_state: The simulator state after the step.
    helium_vented_mols: Helium vented during this step. # [mol]
    sand_dropped_kg: Sand dropped during this step. # [kg]
    helium_penalty_per_mol: Penalty per mol of helium vented; None: gin's
      `latex_reward.helium_penalty_per_mol`. # [1/mol]
    sand_penalty_per_kg: Penalty per kg of sand dropped; None: gin's. # [1/kg]
    station_keeping_radius_km: rho; None: the env's one radius (gin's
      `latex_episode.station_keeping_radius_km`), handed to BLE's reward
      explicitly. # [km]

  Returns:
    The step reward.
  """
  if simulator_state.balloon_state.last_command == (
      control.AltitudeControlCommand.DOWN):
    raise ValueError('A latex balloon state must not record the air-pump DOWN '
                     "command: BLE's reward would apply its power penalty.")
  bound = env_params.reward_settings()
  if helium_penalty_per_mol is None:
    helium_penalty_per_mol = bound['helium_penalty_per_mol']
  if sand_penalty_per_kg is None:
    sand_penalty_per_kg = bound['sand_penalty_per_kg']
  gin_values.check_penalties(helium_penalty_per_mol=helium_penalty_per_mol,
                             sand_penalty_per_kg=sand_penalty_per_kg)
  if station_keeping_radius_km is None:
    station_keeping_radius_km = env_params.episode()[
        'station_keeping_radius_km']
  reward = balloon_env.perciatelli_reward_function(
      simulator_state, station_keeping_radius_km=station_keeping_radius_km,
      reward_dropoff=bound['reward_dropoff'],
      reward_halflife=bound['reward_halflife_km'])
  scale = bound['reward_tanh_scale_km']
  distance_km = math.hypot(simulator_state.balloon_state.x.km,
                           simulator_state.balloon_state.y.km)
  if scale > 0 and distance_km <= station_keeping_radius_km:
    reward = float(jax_features.tanh_inside(  # The follow-up's tanh shape.
        distance_km, station_keeping_radius_km, bound['reward_dropoff'],
        scale))
  return (reward - helium_penalty_per_mol * helium_vented_mols -
          sand_penalty_per_kg * sand_dropped_kg)

