# coding=utf-8
"""BLE's eval on the latex envs and suites (`ble-latex-ble eval --env_name=...`).

BLE 1.0.1's `balloon_learning_environment.eval.eval` always builds
`BalloonLearningEnvironment-v0` and accepts only the suites registered when it
is imported, and its flags cannot be extended from outside. This is its
`main` with the env chosen by `--env_name`, as BLE's docs suggest for a
package (a thin entry point over BLE's `eval_lib` and `suites`):

- BLE's flags, defined by importing BLE's module (after the latex suites
  joined BLE's registry, so `--suite=latex_micro` etc. are choices), plus
  `--env_name`;
- BLE's `--wind_field=generative` (its default) flies BLE's generative field
  in the flight core (the latex envs' default, `ble.wind.CoreGenerativeWindField`,
  as `ble-latex-eval` flies it); `simple` BLE's static field;
- the agent built for the env (`runner.create_agent`: Box agents, planners
  and `sac_ensemble` attached to the env), its checkpoint loaded;
- BLE's `eval_lib.eval_agent` flies the suite and BLE's `write_result`
  writes OUTPUT_DIR/SUITE/NAME.json in BLE's format (seed,
  cumulative_reward, time_within_radius, final_timestep, flight_path, ...).

Per seed the record is the flight `ble-latex-eval` records for the same agent
(`tests/cli/test_ble_commands.py`): cumulative_reward = reward, final_timestep =
steps, time_within_radius = tw50.
"""

import dataclasses
import sys
from typing import Optional, Sequence

from ble_latex import quiet

ENV_FLAG = 'env_name'
BLE_EVAL_MODULE = 'balloon_learning_environment.eval.eval'
HELP = ('-h', '--help', '-help', '--helpshort', '--helpfull')


def _define_flags() -> None:
  """BLE's eval flags (its module imported) plus --env_name; idempotent."""
  from absl import flags  # pylint: disable=g-import-not-at-top
  from ble_latex.run import suites  # pylint: disable=g-import-not-at-top
  suites.register()  # Before BLE's module defines --suite's choices.
  with quiet.third_party_noise():
    from balloon_learning_environment.eval import eval as ble_eval  # pylint: disable=g-import-not-at-top,redefined-builtin,unused-import
  if ENV_FLAG not in flags.FLAGS:
    flags.DEFINE_string(
        ENV_FLAG, 'LatexBalloon-v0',
        'The env to evaluate on (ble_latex: any registered Balloon id; BLE\'s '
        'own eval builds only BalloonLearningEnvironment-v0).')


def _check(prog: str) -> None:
  """Unknown agent or env, an agent that cannot fly the env: one line, 2."""
  # pylint: disable=g-import-not-at-top
  from absl import flags
  from balloon_learning_environment.agents import agent_registry
  import gym
  from ble_latex import agents
  from ble_latex.ble import gym_registration
  from ble_latex.run import ble_support
  # pylint: enable=g-import-not-at-top
  f = flags.FLAGS
  with quiet.third_party_noise(), quiet.dopamine_parameters_at_debug():
    agents.register()
  if f.agent not in agent_registry.REGISTRY:
    ble_support.usage_exit(ble_support.unknown_agent_message(f.agent), prog)
  valid = sorted(k for k in gym.envs.registry if 'Balloon' in k)
  if f.env_name not in valid:
    ble_support.usage_exit(
        f'unknown env {f.env_name!r}; choices: {", ".join(valid)}', prog)
  box_env = f.env_name in gym_registration.BOX_ENV_IDS
  if (f.agent in agents.BOX_AGENTS) != box_env:
    kind = 'the (a0, a1, a2) Box' if box_env else 'Discrete(3)'
    ble_support.usage_exit(
        f'agent {f.agent!r} cannot fly {f.env_name} (actions in {kind}); '
        'Box agents fly LatexBalloon-v0, BLE\'s agents '
        'LatexBalloonDiscrete-v0', prog)


def _main(argv: Sequence[str]) -> None:
  """BLE's eval `main`, on `--env_name`'s env."""
  # pylint: disable=g-import-not-at-top
  from absl import app
  from absl import flags
  from balloon_learning_environment.env import wind_field
  from balloon_learning_environment.eval import eval as ble_eval  # pylint: disable=redefined-builtin
  from balloon_learning_environment.eval import eval_lib
  from balloon_learning_environment.utils import run_helpers
  import gym
  from ble_latex.run import runner
  from ble_latex.run import suites
  # pylint: enable=g-import-not-at-top
  f = flags.FLAGS
  if len(argv) > 1:
    raise app.UsageError('Too many command-line arguments.')
  run_helpers.bind_gin_variables(f.agent, f.agent_gin_file, f.gin_bindings)
  kwargs = {}
  if f.renderer is not None:
    kwargs['renderer'] = ble_eval._RENDERERS[f.renderer]()  # pylint: disable=protected-access
  if f.wind_field == 'simple':
    kwargs['wind_field_factory'] = wind_field.SimpleStaticWindField
  with quiet.third_party_noise():
    env = gym.make(f.env_name, **kwargs).unwrapped
  agent = runner.create_agent(f.agent, env)
  if f.checkpoint_dir is not None and f.checkpoint_idx is not None:
    agent.load_checkpoint(f.checkpoint_dir, f.checkpoint_idx)
  suite = suites.get_eval_suite(f.suite)
  seeds = list(suite.seeds)
  if f.num_shards > 1:
    start = int(len(seeds) * f.shard_idx / f.num_shards)
    end = int(len(seeds) * (f.shard_idx + 1) / f.num_shards)
    seeds = seeds[start:end]
  suite = dataclasses.replace(suite, seeds=seeds)  # BLE's registry unchanged.
  result = eval_lib.eval_agent(agent, env, suite,
                               render_period=f.render_period)
  ble_eval.write_result(result)


def main(argv: Optional[Sequence[str]] = None,
         prog: str = 'ble-latex-ble eval') -> int:
  """Runs BLE's eval on `--env_name` with argv (argv[0], then BLE's flags).

  Returns:
    The exit status: 0, or 2 for a usage mistake (one line on stderr).
  """
  from absl import flags  # pylint: disable=g-import-not-at-top
  argv = list(sys.argv if argv is None else argv)
  _define_flags()
  if set(argv[1:]) & set(HELP):
    f = flags.FLAGS
    print(f'usage: {prog} --env_name=ENV [BLE eval flags...]\n\n'
          f'{f.module_help(BLE_EVAL_MODULE)}\n{f.module_help(__name__)}')
    return 0
  try:
    rest = flags.FLAGS(argv)
  except flags.Error as e:
    print(f'{prog}: {e}', file=sys.stderr)
    return 2
  try:
    _check(prog)
    _main(rest)
  except SystemExit as e:
    return int(e.code or 0) if not isinstance(e.code, str) else 1
  return 0
