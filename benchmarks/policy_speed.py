"""Seconds per decision of a SAC policy file, one balloon at a time (issue 47).

  python benchmarks/policy_speed.py --json=benchmarks/records/policy_speed.json \\
      --policy=shipped --policy=dagger_seed_1=benchmarks/records/dagger/gpu_h200/seed_1/best_policy.msgpack

Issue 47 asks for a controller that decides in <= 10 ms per balloon on 2 CPU
cores. Each `--policy NAME=PATH` (or `shipped`: the shipped policy) is
loaded as BLE's `sac_pretrained` agent in eval mode (its mean action);
`NAME=PATH,PATH,...` (or `shipped_ensemble`: its shipped members) as
`sac_ensemble` (the members' critics choose among their actions); and
`agent.step(reward, observation)` is timed on `--steps` observations of real
flights (the core's, drawn from `latex_small`'s first seed and its strides
under random actions), one call per decision, after `--warmup`
calls that compile. All policies run in the same process, side by side;
the record holds each one's median and 90th percentile, the load average
and the machine's cores. A policy trained on another wind column
(`latex_observation.wind_memory` = K > 0, `wind_lookahead` = N > 0, recorded
in its file) is loaded under those bindings; its observation costs more to
compute (a Gaussian-process fit and 25 posterior means; 25 drifts of N
strides), so the env's observation of one balloon (`jax_env.observation`,
jitted) is timed too, under the paper's observation and under each policy's:
a controller's decision is its observation plus its step.
`--lookahead=1,3_follow` also times each ensemble with its proposals flown
ahead (`SACEnsembleAgent.lookahead_strides`, `lookahead_follow`). An ensemble
whose members observe otherwise than the env (`ensemble.observe`) computes
their views from the env's state inside its step: that is timed with it.
"""

import json
import os
import platform
import sys
import time
from typing import Dict, Optional, Sequence, Tuple

from absl import flags
import numpy as np

import ble_latex  # pylint: disable=unused-import  # Fixes first.
from ble_latex import safe_io
from ble_latex.cli import common as cli
from ble_latex.run import gin_binding

FLAGS = flags.FlagValues()
flags.DEFINE_multi_string('policy', ['shipped'], 'NAME=PATH of a SAC policy '
                          'file, NAME=PATH,PATH,... of a `sac_ensemble`, '
                          '`shipped` or `shipped_ensemble`.',
                          flag_values=FLAGS)
flags.DEFINE_integer('steps', 2000, 'Decisions timed per policy.',
                     lower_bound=10, flag_values=FLAGS)
flags.DEFINE_integer('warmup', 20, 'Decisions before timing (compiles).',
                     lower_bound=1, flag_values=FLAGS)
flags.DEFINE_string('json', None, 'Write the record here.',
                    flag_values=FLAGS)
flags.DEFINE_list('lookahead', [], 'Also time each ensemble with these '
                  'lookaheads: H (`SACEnsembleAgent.lookahead_strides`) or '
                  'H_follow (and `lookahead_follow`).', flag_values=FLAGS)


class _Core:
  """What `ensemble.SACEnsembleAgent.attach_env` reads: a core's state."""

  def __init__(self, params):
    self.params = params
    self.state = None


def _observations(count: int, observation: Dict[str, int]):
  """`count` observations and states of one `latex_small` flight (random
  actions), observed under the `latex_observation.*` settings given, and
  the env parameters."""
  import jax  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import env_params  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import jax_env  # pylint: disable=g-import-not-at-top
  from ble_latex.run import suites  # pylint: disable=g-import-not-at-top
  env = jax_env.LatexBalloonJaxEnv()
  params = env_params.check_params(
      env_params.params_from_gin().replace(**observation))
  seed = list(suites.get_eval_suite('latex_small').seeds)[0]
  obs, state = env.reset(jax.random.PRNGKey(seed), params)
  step = jax.jit(env.step)
  rng = np.random.default_rng(0)
  out, states = [], []
  key = jax.random.PRNGKey(0)
  for _ in range(count):
    out.append(np.asarray(obs))
    states.append(state)
    key, step_key = jax.random.split(key)
    action = rng.uniform(-1.0, 1.0, size=3).astype(np.float32)
    obs, state, _, _, _, _ = step(step_key, state, action, params)
  return np.stack(out), states, params


def _observation_cost(observation: Dict[str, int], steps: int) -> dict:
  """Seconds of the env's observation of one balloon (jitted) under the
  `latex_observation.*` settings `observation` (all 0: the paper's)."""
  import jax  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import env_params  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import jax_env  # pylint: disable=g-import-not-at-top
  env = jax_env.LatexBalloonJaxEnv()
  params = env_params.check_params(
      env_params.params_from_gin().replace(**observation))
  _, state = env.reset(jax.random.PRNGKey(0), params)
  step = jax.jit(env.step_env)
  for _ in range(max(params.wind_memory, 1)):  # A full memory.
    _, state, *_ = step(None, state, np.zeros(3, np.float32), params)
  observe = jax.jit(jax_env.observation)
  for _ in range(FLAGS.warmup):
    observe(state, params).block_until_ready()
  seconds = []
  for _ in range(steps):
    t0 = time.perf_counter()
    observe(state, params).block_until_ready()
    seconds.append(time.perf_counter() - t0)
  seconds = np.asarray(seconds)
  return {'observation': dict(observation), 'calls': len(seconds),
          'median_s': float(np.median(seconds)),
          'p90_s': float(np.percentile(seconds, 90))}


def _observation_of(path: Optional[str]) -> Dict[str, int]:
  """The `latex_observation.*` settings a policy file (None: the shipped
  one) records."""
  from ble_latex.agents.sac import pretrained  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import env_params  # pylint: disable=g-import-not-at-top
  config = (pretrained.load_policy(path)['config'] if path else {})
  return {k: int(config.get(k, 0)) for k in env_params.OBSERVATION_FIELDS}


def _time(name: str, path: Optional[str], steps: int,
          lookahead: Tuple[int, bool] = (0, False)) -> dict:
  """Times one policy (or ensemble) on `steps` decisions (see module)."""
  import gin  # pylint: disable=g-import-not-at-top
  from ble_latex import quiet  # pylint: disable=g-import-not-at-top
  paths = path.split(',') if path else []
  with quiet.third_party_noise():
    from ble_latex.agents.sac import ensemble  # pylint: disable=g-import-not-at-top
  # The env observes as the member that remembers the most winds (an
  # ensemble's other members read their views of its state).
  observation = dict(ensemble.env_view_for(
      [ensemble.view_of(_observation_of(p)) for p in paths or [None]]))
  observations, states, params = _observations(steps, observation)
  with gin.unlock_config():  # The observation the policy was trained on.
    for key, value in observation.items():
      gin.bind_parameter(f'latex_observation.{key}', value)
  with quiet.third_party_noise():
    from ble_latex.agents.sac import agent as sac  # pylint: disable=g-import-not-at-top
    if len(paths) > 1 or lookahead[0]:
      agent = ensemble.SACEnsembleAgent(
          3, (observations.shape[1],), policy_paths=paths,
          lookahead_strides=lookahead[0], lookahead_follow=lookahead[1])
    else:
      agent = sac.SACPretrainedAgent(3, (observations.shape[1],),
                                     policy_path=path)
  agent.set_mode('eval')
  core = _Core(params)
  if getattr(agent, 'needs_env', False):
    agent.attach_env(core)
  core.state = states[0]
  agent.begin_episode(observations[0])
  for obs, state in zip(observations[:FLAGS.warmup], states):
    core.state = state
    agent.step(0.0, obs)
  seconds = []
  for obs, state in zip(observations, states):
    core.state = state
    t0 = time.perf_counter()
    agent.step(0.0, obs)
    seconds.append(time.perf_counter() - t0)
  seconds = np.asarray(seconds)
  return {'name': name, 'path': path or 'shipped', 'observation': observation,
          'views': [dict(v) for v in getattr(agent, 'views', ())],
          'lookahead': getattr(agent, 'lookahead', ensemble.NO_LOOKAHEAD
                               )._asdict(),
          'decisions': len(seconds),
          'median_s': float(np.median(seconds)),
          'p90_s': float(np.percentile(seconds, 90)),
          'mean_s': float(seconds.mean())}


def _main(argv: Sequence[str]) -> int:
  del argv
  policies = []
  for item in FLAGS.policy:
    if item == 'shipped':
      policies.append(('shipped', None))
      continue
    if item == 'shipped_ensemble':
      from ble_latex.agents.sac import pretrained  # pylint: disable=g-import-not-at-top
      policies.append((item, ','.join(pretrained.SHIPPED_ENSEMBLE)))
      continue
    name, sep, path = item.partition('=')
    if not sep or not name or not path:
      raise cli.CommandUsageError(f'--policy {item!r}: want NAME=PATH or '
                                  'shipped')
    missing = [p for p in path.split(',') if not os.path.isfile(p)]
    if missing:
      raise cli.CommandFailure(f'--policy {name}: no file {missing[0]}')
    policies.append((name, path))
  lookaheads = []
  for item in FLAGS.lookahead:
    strides, _, follow = item.partition('_')
    if not strides.isdigit() or follow not in ('', 'follow'):
      raise cli.CommandUsageError(f'--lookahead {item!r}: want H or H_follow')
    lookaheads.append((item, (int(strides), bool(follow))))
  timed = [(name, path, (0, False)) for name, path in policies]
  timed += [(f'{name}_lookahead{item}', path, h) for name, path in policies
            if path and ',' in path for item, h in lookaheads]
  load_before = list(os.getloadavg())
  rows = []
  for name, path, h in timed:
    try:
      rows.append(_time(name, path, FLAGS.steps, h))
    except ValueError as error:  # errors.ConfigError is one.
      raise cli.CommandFailure(
          f'--policy {name}: {gin_binding.one_line(error)}')
    print(f"{name}: median {1e3 * rows[-1]['median_s']:.3f} ms, p90 "
          f"{1e3 * rows[-1]['p90_s']:.3f} ms per decision")
  observing = []
  settings = [_observation_of(None)] + [
      r['observation'] for r in rows]
  for observation in settings:
    if any(o['observation'] == observation for o in observing):
      continue
    observing.append(_observation_cost(observation, FLAGS.steps))
    print(f"observation {observation}: median "
          f"{1e3 * observing[-1]['median_s']:.3f} ms")
  record = {'what': 'SAC policy files as BLE agents (sac_pretrained, or '
                    'sac_ensemble for several files; eval mode), one '
                    'decision per agent.step call',
            'date': time.strftime('%Y-%m-%dT%H:%M', time.gmtime()),
            'host': platform.node(), 'cpus': os.cpu_count(),
            'loadavg_before': load_before,
            'loadavg_after': list(os.getloadavg()),
            'command': ' '.join(sys.argv), 'policies': rows,
            'observations': observing}
  if FLAGS.json:
    safe_io.atomic_write(FLAGS.json, json.dumps(record, indent=1) + '\n')
  return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
  return cli.run_absl(_main, 'benchmarks/policy_speed.py', FLAGS, argv,
                      doc=__doc__)


if __name__ == '__main__':
  sys.exit(main())
