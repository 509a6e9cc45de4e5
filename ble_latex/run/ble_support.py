# coding=utf-8
"""What BLE's own train and eval commands need to fly the latex envs and agents.

BLE 1.0.1's `python -m balloon_learning_environment.train` (and
`eval.eval`, and both through `ble-latex-ble`) call
`run_helpers.bind_gin_variables(agent, agent_gin_file, gin_bindings)` before
`gym.make`, then `run_helpers.create_agent(agent, env.action_space.n,
observation_shape=...)`. `install(run_helpers)`, which ble_latex's import
hook runs right after BLE's `run_helpers` module executes (`compat`, hook
`ble_commands`), wraps the first:

- ble_latex's agents join BLE's registry (`agents.register`) and the latex
  gin configurables are declared (`compat.GIN_CONFIGURABLE_MODULES`) before
  BLE parses the agent's gin file and the bindings, so `--agent=sac` and
  `--gin_bindings='latex_episode.episode_steps = 30'` work as BLE's own
  names do; `create_agent` then builds a Box agent with BLE's arguments
  (`LatexBalloon-v0`'s Box has BLE's `n`: `ble.gym_env.LatexActionBox`);
- where BLE's command is the program (`ble_command()`), a latex-side mistake
  (an unknown agent, a Box agent on a Discrete(3) env or the reverse, an
  agent that only acts reading the env's core state, a gin binding or file
  gin refuses) is one line on stderr and exit status 2, not a traceback.
  Called from other code, BLE's function behaves as BLE's.

BLE's `ConsoleCollector` counts discrete actions; `BoxConsoleCollector`
(BLE's `--collectors=console`, installed by `install_collectors`, hook
`ble_console_collector`) reports a Box action's episode mean instead and is
BLE's own for integer actions.
"""

import functools
import importlib
import sys
from typing import Any, NoReturn, Optional, Sequence

import numpy as np

# BLE's command modules, as `python -m` or `ble-latex-ble` runs them.
BLE_TRAIN = 'balloon_learning_environment.train'
BLE_EVAL = 'balloon_learning_environment.eval.eval'
BLE_COMMANDS = (BLE_TRAIN, BLE_EVAL)
# BLE's eval builds this env whatever the flags say.
BLE_ENV = 'BalloonLearningEnvironment-v0'
PROJECT_COMMANDS = ('ble-latex-train', 'ble-latex-eval',
                    'ble-latex-ble eval --env_name=...')


def ble_command() -> Optional[str]:
  """The BLE command module running as the program (`__main__`), else None."""
  spec = getattr(sys.modules.get('__main__'), '__spec__', None)
  name = getattr(spec, 'name', None)
  return name if name in BLE_COMMANDS else None


def usage_exit(message: str, prog: Optional[str] = None) -> NoReturn:
  """One line on stderr, exit status 2 (BLE's commands, a usage mistake)."""
  prog = prog or ble_command() or 'ble_latex'
  print(f'{prog}: {message}', file=sys.stderr)
  raise SystemExit(2)


def _env_name() -> str:
  """The env BLE's running command builds (its --env_name; eval: BLE's)."""
  from absl import flags  # pylint: disable=g-import-not-at-top
  if ble_command() == BLE_TRAIN and 'env_name' in flags.FLAGS:
    return flags.FLAGS.env_name
  return BLE_ENV


def _declare_latex_names() -> None:
  """ble_latex's agents in BLE's registry; the latex gin names declared."""
  # pylint: disable=g-import-not-at-top
  import gin
  from ble_latex import agents
  from ble_latex import compat
  from ble_latex import quiet
  # pylint: enable=g-import-not-at-top
  with quiet.third_party_noise(), quiet.dopamine_parameters_at_debug(), (
      gin.unlock_config()):
    agents.register()
    for name in compat.GIN_CONFIGURABLE_MODULES:
      importlib.import_module(name)


def unknown_agent_message(name: str) -> str:
  """One line: the agent is unknown; the choices; the project's commands."""
  from balloon_learning_environment.agents import agent_registry  # pylint: disable=g-import-not-at-top
  return (f'unknown agent {name!r}; choices: '
          f'{", ".join(sorted(agent_registry.REGISTRY))} (the project\'s '
          f'own commands: {", ".join(PROJECT_COMMANDS)})')


def check_agent_fits(name: str, env_name: str, command: str) -> None:
  """Raises errors.ConfigError where agent `name` cannot fly `env_name`.

  Args:
    name: A registered agent.
    env_name: The gym id BLE's command builds.
    command: BLE's command module (`BLE_TRAIN` or `BLE_EVAL`).
  """
  # pylint: disable=g-import-not-at-top
  from ble_latex import agents
  from ble_latex import errors
  from ble_latex.ble import gym_registration
  # pylint: enable=g-import-not-at-top
  box_env = env_name in gym_registration.BOX_ENV_IDS
  latex_eval = 'ble-latex-ble eval --env_name=LatexBalloon-v0 (or ble-latex-eval)'
  if name in agents.BOX_AGENTS and not box_env:
    where = ("BLE's eval flies only BalloonLearningEnvironment-v0; use "
             f'{latex_eval}' if command == BLE_EVAL else
             '--env_name=LatexBalloon-v0')
    raise errors.ConfigError(
        f'agent {name!r} acts in the (a0, a1, a2) Box, not in {env_name}\'s '
        f'Discrete(3): {where}')
  if name not in agents.BOX_AGENTS and box_env:
    raise errors.ConfigError(
        f'agent {name!r} acts in BLE\'s Discrete(3): use '
        f'--env_name=LatexBalloonDiscrete-v0, or a Box agent with '
        f'{env_name} ({", ".join(sorted(agents.BOX_AGENTS))})')
  if name in agents.EVAL_ONLY_AGENTS:
    raise errors.ConfigError(
        f'agent {name!r} only acts and reads the env\'s core state, which '
        f"BLE's {command.rsplit('.', 1)[-1]} does not give an agent: fly it "
        f'with {latex_eval}')


def _bind_gin_variables(original, agent: str, agent_gin_file=None,
                        gin_bindings: Sequence[str] = (),
                        additional_gin_files: Sequence[str] = ()) -> None:
  """BLE's `bind_gin_variables`, the latex names declared first."""
  _declare_latex_names()
  command = ble_command()
  if command is None:
    original(agent, agent_gin_file, gin_bindings, additional_gin_files)
    return
  # BLE's command is the program: its mistakes are one line, not a traceback.
  from balloon_learning_environment.agents import agent_registry  # pylint: disable=g-import-not-at-top
  from ble_latex import errors  # pylint: disable=g-import-not-at-top
  if agent not in agent_registry.REGISTRY:
    usage_exit(unknown_agent_message(agent))
  try:
    check_agent_fits(agent, _env_name(), command)
  except errors.ConfigError as e:
    usage_exit(str(e))
  try:
    original(agent, agent_gin_file, gin_bindings, additional_gin_files)
  except ValueError as e:  # gin's unknown name or parameter, a bad value.
    usage_exit(f'gin: {str(e).splitlines()[0]}')
  except OSError as e:
    usage_exit(f'gin file: {e}')


def install(run_helpers: Any) -> None:
  """Wraps BLE's `run_helpers.bind_gin_variables` (idempotent)."""
  original = run_helpers.bind_gin_variables
  if getattr(original, '_ble_latex_wrapped', False):
    return
  wrapped = functools.wraps(original)(
      functools.partial(_bind_gin_variables, original))
  wrapped._ble_latex_wrapped = True  # pylint: disable=protected-access
  run_helpers.bind_gin_variables = wrapped


def _is_box_action(action: Any) -> bool:
  return np.ndim(action) > 0


def box_console_collector(console_collector: Any) -> type:
  """BLE's ConsoleCollector, reporting a Box action's episode mean."""

  class BoxConsoleCollector(console_collector.ConsoleCollector):
    """BLE's console collector; a Box action is averaged, not counted."""

    def begin_episode(self) -> None:
      super().begin_episode()
      self._action_sum = None
      self._action_steps = 0

    def _add(self, statistics: Any) -> None:
      """Adds a Box transition's reward and action to the episode's."""
      self._current_episode_reward += statistics.reward
      a = np.asarray(statistics.action, np.float64)
      self._action_sum = a if self._action_sum is None else (
          self._action_sum + a)
      self._action_steps += 1

    def step(self, statistics: Any) -> None:
      if _is_box_action(statistics.action):
        self._add(statistics)
      else:
        super().step(statistics)

    def end_episode(self, statistics: Any) -> None:
      if not _is_box_action(statistics.action):
        super().end_episode(statistics)
        return
      from absl import logging  # pylint: disable=g-import-not-at-top
      self._add(statistics)
      mean = np.round(self._action_sum / self._action_steps, 3).tolist()
      text = (f'Episode {self.current_episode}: '
              f'reward: {self._current_episode_reward:07.2f}, '
              f'episode length: {statistics.step}, mean action: {mean}')
      logging.info(text)
      if self._log_file is not None:
        self._log_file_writer.write(text + '\n')
      self.current_episode += 1

  return BoxConsoleCollector


def install_collectors(collector_dispatcher: Any) -> None:
  """BLE's `console` collector becomes `BoxConsoleCollector` (idempotent)."""
  from balloon_learning_environment.metrics import console_collector  # pylint: disable=g-import-not-at-top
  collectors = collector_dispatcher.AVAILABLE_COLLECTORS
  if collectors.get('console') is console_collector.ConsoleCollector:
    collectors['console'] = box_console_collector(console_collector)
