# coding=utf-8
r"""Test-time action selection over SAC policies (issue 47): a measurement.

Flies the first `--num_seeds` seeds of a suite, batched on the functional
env (as `sac_trainer.validate` does), with one of these deciders over the
policy files given (all of the same `latex_observation.*` settings but for
`mixed`):

- `mean`: the first policy's deterministic action tanh(mu(o)) (what
  `sac_pretrained` flies; reproduces the trainer's validation);
- `average`: the mean of the policies' deterministic actions (an ensemble);
- `critic`: candidates = each policy's deterministic action and
  `--samples` draws from each policy's stochastic actor; the candidate with
  the largest mean over the policies of min(Q1, Q2)(o, a) is flown
  (policy improvement by the learned critics at decision time);
- `mixed`: `critic` over policies of different `latex_observation.*`
  settings (`sac_ensemble`'s views, `ensemble.observe`): each proposes and
  scores from its own observation of the balloon; the env observes as the
  one that remembers the most winds;
- `lookahead`: `mixed` with each proposal first flown `--horizon` strides
  ahead in the forecast planners' wind (`--follow`: after the first stride,
  the member's own actions) and scored by the rewards on the way and the
  members' value where it ends (`ensemble.lookahead_choice`).

Writes a JSON record: per seed, the TW50 over the window and the flight's
status; the mean TW50 over the window and % out of resources.

`--sweep=benchmarks/records/ensemble/results.json` flies the committed set
(`sweep_runs`: each drift seed alone, every 3 of them as a critic-chosen
ensemble, all together, the rejected variants on validation only, the
corrected-column seeds, the mixed ensembles of `--memory_seeds` and
`--both_seeds`, the shipped members with a lookahead,
`ensemble.DECLARED_LOOKAHEADS`) on 100
seeds of `latex_validation` and `latex_small` into one record, resuming
it; the docs' `ensemble` table is generated from
it (`docs/hooks/learned.py`).

  python benchmarks/policy_select.py --mode=critic --samples=8 \
      --policy=benchmarks/records/sac_jax/wind_lookahead12/seed_0/chosen_policy.msgpack \
      --gin_file=gin_configs/latex_wind_lookahead.gin --suite=latex_validation \
      --output=/tmp/select.json
"""

import itertools
import json
import os
import platform
import sys
import time
from typing import Any, Dict, List, Optional, Sequence

from absl import flags
import gin
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import quiet
from ble_latex import run_files
from ble_latex import safe_io
from ble_latex.cli import common as cli

with quiet.third_party_noise():  # Dopamine's import-time notices.
  from ble_latex.agents.planning import value as plan_value  # pylint: disable=g-import-not-at-top
  from ble_latex.agents.sac import ensemble  # pylint: disable=g-import-not-at-top
  from ble_latex.agents.sac import pretrained  # pylint: disable=g-import-not-at-top
  from ble_latex.agents.sac import trainer as sac_trainer  # pylint: disable=g-import-not-at-top
from ble_latex.envs import env_params
from ble_latex.envs import jax_env
from ble_latex.run import episode_log
from ble_latex.run import jax_train
from ble_latex.run import metrics
from ble_latex.run import seed_runs
from ble_latex.run import suites

FLAGS = flags.FlagValues()
flags.DEFINE_multi_string('policy', [], 'SAC policy files (or "shipped").',
                          flag_values=FLAGS)
cli.define_gin_flags(FLAGS, files_help='gin files of the env.',
                     bindings_help=None)
flags.DEFINE_enum('mode', 'mean', ['mean', 'average', 'critic', 'mixed',
                                   'lookahead'],
                  'decider.',
                  flag_values=FLAGS)
flags.DEFINE_integer('samples', 0, 'critic: stochastic draws per policy.',
                     flag_values=FLAGS)
flags.DEFINE_enum('score', 'mean', ['mean', 'min'], 'critic: how the '
                  "policies' critics combine.", flag_values=FLAGS)
flags.DEFINE_integer('horizon', 1, 'lookahead: imagined strides.',
                     flag_values=FLAGS)
flags.DEFINE_bool('follow', False, 'lookahead: later strides fly the member\'s '
                  'own action (else the proposal held).', flag_values=FLAGS)
flags.DEFINE_string('suite', 'latex_validation', 'seeds of this suite.',
                    flag_values=FLAGS)
flags.DEFINE_integer('num_seeds', 100, 'first seeds of the suite.',
                     flag_values=FLAGS)
flags.DEFINE_integer('batch', 100, 'balloons per compiled call.',
                     flag_values=FLAGS)
flags.DEFINE_string('output', '', 'JSON record.', flag_values=FLAGS)
flags.DEFINE_string('sweep', '', 'Fly the committed sweep (`sweep_runs`) into '
                    'this record (resumes it).', flag_values=FLAGS)
flags.DEFINE_list('drift_seeds', ['0', '1', '2'], '--sweep: training seeds of '
                  'benchmarks/records/sac_jax/wind_lookahead12 with a chosen policy.',
                  flag_values=FLAGS)
flags.DEFINE_list('memory_seeds', ['0', '1', '2'], '--sweep: those of '
                  'benchmarks/records/sac_jax/wind_memory16 (the first three are '
                  'always flown alone).', flag_values=FLAGS)
flags.DEFINE_list('both_seeds', [], '--sweep: those of '
                  'benchmarks/records/sac_jax/memory_lookahead (both corrections).',
                  flag_values=FLAGS)


# Critic candidates scored in one compiled call: balloons x members x
# (1 + samples); bounded before anything is compiled (1e9 samples asked 4 TB).
MAX_CANDIDATES = 2**20


def check_sizes(batch: int, samples: int, num_seeds: int) -> None:
  """--batch, --samples and --num_seeds bounded before anything compiles.

  Raises:
    Refused: One line naming the flag (exit 2).
  """
  most = jax_env.MAX_ROLLOUT_BALLOONS
  if not 1 <= batch <= most:
    raise Refused(f'--batch must be in [1, {most}] balloons per compiled '
                  f'call, got {batch}')
  if num_seeds < 1:
    raise Refused(f'--num_seeds must be >= 1, got {num_seeds}')
  per_sample = batch * ensemble.MAX_MEMBERS
  if samples < 0 or per_sample * (1 + samples) > MAX_CANDIDATES:
    raise Refused(
        f'--samples must be in [0, {MAX_CANDIDATES // per_sample - 1}] with '
        f'--batch={batch} (--batch x up to {ensemble.MAX_MEMBERS} members x '
        f'(1 + samples) <= {MAX_CANDIDATES} candidates per call), got '
        f'{samples}')


def check_folder(path: str, flag: str) -> None:
  """The record's folder exists and is writable, before anything is flown.

  Raises:
    OSError: One line naming `flag` (exit 1).
  """
  folder = os.path.dirname(os.path.abspath(path))
  if not os.path.isdir(folder) or not os.access(folder, os.W_OK | os.X_OK):
    raise OSError(f'{flag}: the folder {folder} does not exist or is not '
                  'writable')


def decider(mode: str, samples: int, net: Any, members: Any,
            score: str = 'mean'):
  """obs [N, F], key -> normalised actions [N, 3] (`ensemble`'s functions)."""
  combine = jnp.mean if score == 'mean' else jnp.min

  def one(obs, key):
    proposed = ensemble.proposals(net, members, obs)  # [K, 3]
    if mode == 'mean':
      return proposed[0]
    if mode == 'average':
      return jnp.mean(proposed, axis=0)
    draws = jax.vmap(lambda p, k: jax.vmap(lambda kk: net.apply(
        p, obs, kk, method=net.actor).sampled_action)(
            jax.random.split(k, samples)))(
                members, jax.random.split(key, proposed.shape[0]))
    candidates = jnp.concatenate(
        [proposed, draws.reshape(-1, proposed.shape[1])])
    return candidates[jnp.argmax(ensemble.scores(net, members, obs,
                                                 candidates, combine))]

  def decide(obs, key):
    return jax.vmap(one)(obs, jax.random.split(key, obs.shape[0]))

  return decide


def evaluate_mixed(policies: Sequence[str], suite: str, num_seeds: int,
                   batch: int, horizon: int = 0,
                   follow: bool = False) -> Dict[str, Any]:
  """`mixed`: policies of different observation settings (see module);
  with `horizon` > 0 strides, `lookahead`: `ensemble.lookahead_choice` on
  the env's state."""
  lookahead = ensemble.Lookahead(horizon, follow)
  loaded = [plan_value.load(p) for p in policies]
  member_views = [obs for _, _, obs in loaded]
  env_view = ensemble.env_view_for(member_views)
  gin.clear_config()
  gin.parse_config_files_and_bindings(
      [], [f'latex_observation.{k} = {v}' for k, v in env_view])
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  params = env.default_params
  wind = env.wind_for(params)
  views, group = ensemble.views_of(member_views, env_view)
  net, members = loaded[0][0], sac_trainer.stack([w for _, w, _ in loaded])

  def decide(rows, key):
    del key
    if horizon:
      return jax.vmap(lambda s: ensemble.lookahead_choice(
          net, members, group, views, lookahead, wind, params, s))(rows)
    return jax.vmap(lambda r: ensemble.critic_choice(net, members, r,
                                                     group))(rows)

  def observe(state):
    if horizon:
      return state
    return ensemble.observe(state, params, wind, views)

  return {'mode': 'lookahead' if horizon else 'mixed', 'samples': 0,
          'score': 'mean', 'horizon': horizon, 'follow': follow,
          'policies': list(policies), 'gin_files': [],
          **_fly(env, params, decide, suite, num_seeds, batch, observe)}


class Refused(ValueError):
  """A policy that does not fit the env (usage: exit 2)."""


def evaluate(policies: Sequence[str], gin_files: Sequence[str], mode: str,
             samples: int, score: str, suite: str, num_seeds: int,
             batch: int) -> Dict[str, Any]:
  """One decider flown on a suite's first seeds: the record (see module)."""
  gin.clear_config()
  gin.parse_config_files_and_bindings(list(gin_files), [])
  env = jax_env.LatexBalloonJaxEnv(normalize_actions=False)
  params = env.default_params
  mine = env_params.observation_of(params)
  weights = []
  for path in policies:
    net, w, observation = plan_value.load(path)
    if dict(observation) != mine:
      raise Refused(f'{path} observed {dict(observation)}, the env {mine}')
    weights.append(w)
  members = sac_trainer.stack(weights)
  decide = decider(mode, samples, net, members, score)
  return {'mode': mode, 'samples': samples, 'score': score,
          'policies': list(policies), 'gin_files': list(gin_files),
          **_fly(env, params, decide, suite, num_seeds, batch)}


def _fly(env: Any, params: Any, decide: Any, suite: str, num_seeds: int,
         batch: int, observe: Any = None) -> Dict[str, Any]:
  """Flies `decide` on a suite's first seeds: the record's flights."""
  seeds = list(suites.get_eval_suite(suite).seeds)[:num_seeds]
  window = int(params.episode_steps)
  fly = jax.jit(lambda chunk: sac_trainer.fly_policy(
      env, decide, chunk, window, params, observe=observe))  # One program.
  began = time.time()
  parts = [jax.device_get(fly(jnp.asarray(seeds[i:i + batch], jnp.int32)))
           for i in range(0, len(seeds), batch)]
  result = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
  wall = time.time() - began
  tw50 = [metrics.tw50_fractions(int(w), int(s), window)['tw50_window']
          for w, s in zip(result['within_steps'], result['steps'])]
  return {'suite': suite, 'seeds': seeds, 'tw50_window': tw50,
          'status': [int(x) for x in result['status']],
          'wall_s': wall, 'load': os.getloadavg()[0],
          'date': time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime()),
          **jax_train.validation_summary(result, window)}


# --- The committed sweep (`--sweep`) ----------------------------------------

DRIFTS_GIN = 'gin_configs/latex_wind_lookahead.gin'
MEMORY_GIN = 'gin_configs/latex_wind_memory.gin'
BOTH_GIN = 'gin_configs/latex_wind_memory_lookahead.gin'
BOTH = ('latex_validation', 'latex_small')
# The ensembles `sac_ensemble` may ship, declared before seeds 3-5 were
# trained: the first three drift seeds, the next three, all of them.
SHIP_CANDIDATES = ('drifts_critic_012', 'drifts_critic_345',
                   'drifts_critic_all',
                   # Declared 2026-11-29 06:50, before any was flown held
                   # out: every drift seed with the corrected-column seeds
                   # (each member on its own view, `--mode=mixed`), and
                   # with the seeds that observe both corrections: every
                   # run named MIXED_CANDIDATE + its memory (and both) seeds.
                  )
MIXED_CANDIDATE = 'mixed_drifts_all_memory_'
# The shipped members with their proposals flown ahead (`--mode=lookahead`):
# (strides, follow), declared in the package where the ensemble reads them.
LOOKAHEADS = ensemble.DECLARED_LOOKAHEADS


def _seed_run(run: str, seed: int) -> str:
  return os.path.relpath(episode_log.RECORDS_DIR / 'sac_jax' / run /
                         f'seed_{seed}')


def _chosen(run: str, seed: int) -> str:
  return run_files.chosen_policy_path(_seed_run(run, seed))


def _best_snapshots(run: str, seed: int, count: int) -> List[str]:
  """The `count` snapshots of a seed that validated best (<= 5 % out)."""
  return seed_runs.best_snapshots(_seed_run(run, seed), count, 5.0)


def lookahead_name(strides: int, follow: bool) -> str:
  return f'shipped_lookahead_{strides}' + ('_follow' if follow else '')


def sweep_runs(drift_seeds: Sequence[int], memory_seeds: Sequence[int] = (0, 1, 2),
               both_seeds: Sequence[int] = ()) -> Dict[str, Dict[str, Any]]:
  """name -> (policies, gin file, mode, samples, score, suites[, horizon,
  follow])."""
  runs = {}

  def add(name, policies, gin_file, mode='critic', samples=0, score='mean',
          suites_=BOTH, **lookahead):
    runs[name] = {'policies': list(policies), 'gin_files': [gin_file],
                  'mode': mode, 'samples': samples, 'score': score,
                  'suites': list(suites_), **lookahead}

  drifts = {s: _chosen('wind_lookahead12', s) for s in drift_seeds}
  for s in drift_seeds:
    add(f'drifts_seed_{s}', [drifts[s]], DRIFTS_GIN, mode='mean')
  for triple in itertools.combinations(drift_seeds, 3):
    add('drifts_critic_' + ''.join(map(str, triple)),
        [drifts[s] for s in triple], DRIFTS_GIN)
  if len(drift_seeds) > 3:
    add('drifts_critic_all', list(drifts.values()), DRIFTS_GIN)
    # Each seed's chosen snapshot and its next-best validated one.
    add('drifts_critic_all_snapshots', list(drifts.values()) + [
        _best_snapshots('wind_lookahead12', s, 2)[1] for s in drift_seeds],
        DRIFTS_GIN, suites_=BOTH[:1])
  first = [drifts[s] for s in drift_seeds[:3]]
  add('drifts_average_012', first, DRIFTS_GIN, mode='average',
      suites_=BOTH[:1])
  add('drifts_critic8_012', first, DRIFTS_GIN, samples=8, suites_=BOTH[:1])
  add('drifts_critic_min_012', first, DRIFTS_GIN, score='min',
      suites_=BOTH[:1])
  for s in drift_seeds[:3]:
    add(f'drifts_snapshots_seed_{s}', _best_snapshots('wind_lookahead12', s,
                                                      3),
        DRIFTS_GIN, suites_=BOTH[:1])
  memory = [_chosen('wind_memory16', s) for s in range(3)]
  for s in range(3):
    add(f'memory_seed_{s}', [memory[s]], MEMORY_GIN, mode='mean')
  add('memory_critic_012', memory, MEMORY_GIN)
  # Mixed views: each member proposes and scores from its own observation.
  more = {s: _chosen('wind_memory16', s) for s in memory_seeds}
  for s in memory_seeds:
    if f'memory_seed_{s}' not in runs:
      add(f'memory_seed_{s}', [more[s]], MEMORY_GIN, mode='mean')
  for part in ((0, 1, 2), (3, 4, 5)):
    if set(part) <= set(drift_seeds):
      add('mixed_drifts_{}{}{}_memory_012'.format(*part),
          [drifts[s] for s in part] + memory, MEMORY_GIN, mode='mixed')
  seeds_ = lambda seeds: ''.join(map(str, seeds))
  add(MIXED_CANDIDATE + seeds_(memory_seeds),
      list(drifts.values()) + list(more.values()), MEMORY_GIN, mode='mixed')
  if both_seeds:
    both = [_chosen('memory_lookahead', s) for s in both_seeds]
    for s, path in zip(both_seeds, both):
      add(f'both_seed_{s}', [path], BOTH_GIN, mode='mean')
    add(MIXED_CANDIDATE + seeds_(memory_seeds) + '_both_' + seeds_(both_seeds),
        list(drifts.values()) + list(more.values()) + both, MEMORY_GIN,
        mode='mixed')
  for strides, follow in LOOKAHEADS:
    add(lookahead_name(strides, follow),
        [os.path.relpath(p) for p in pretrained.SHIPPED_ENSEMBLE],
        MEMORY_GIN, mode='lookahead', suites_=BOTH[:1], horizon=strides,
        follow=follow)
  return runs


# Replicates of the shipped recipe from disjoint training seeds (the issue
# asks for >= 3 training seeds with their spread): each group of four
# members, without and with the chosen lookahead, on both suites.
# (training run, seed) of each group's members.
REPLICATES = (
    (('wind_lookahead12', 0), ('wind_lookahead12', 1),
     ('wind_memory16', 0), ('wind_memory16', 1)),
    (('wind_lookahead12', 2), ('wind_lookahead12', 3),
     ('wind_memory16', 2), ('wind_memory16', 3)),
    (('wind_lookahead12', 4), ('wind_lookahead12', 5),
     ('wind_memory16', 4), ('memory_lookahead', 0)),
)


def replicate_runs(strides: int, follow: bool) -> Dict[str, Dict[str, Any]]:
  """`REPLICATES` as sweep runs: `replicate_I` and `replicate_I_lookahead`."""
  runs = {}
  for i, members in enumerate(REPLICATES):
    policies = [_chosen(run, seed) for run, seed in members]
    base = {'policies': policies, 'gin_files': [MEMORY_GIN], 'samples': 0,
            'score': 'mean', 'suites': list(BOTH)}
    runs[f'replicate_{i}'] = {**base, 'mode': 'mixed'}
    runs[f'replicate_{i}_lookahead'] = {**base, 'mode': 'lookahead',
                                        'horizon': strides, 'follow': follow}
  return runs


def _fly_run(run: Dict[str, Any], suite: str, batch: int) -> Dict[str, Any]:
  if run['mode'] in ('mixed', 'lookahead'):
    return evaluate_mixed(run['policies'], suite, 100, batch,
                          run.get('horizon', 0), run.get('follow', False))
  return evaluate(run['policies'], run['gin_files'], run['mode'],
                  run['samples'], run['score'], suite, 100, batch)


def _chosen_lookahead(record: Dict[str, Any]) -> Optional[str]:
  """The best validated lookahead run (<= 5 % out of resources)."""
  fit = [(r['latex_validation']['tw50_window_mean'], n)
         for n, r in record['runs'].items()
         if n in {lookahead_name(*x) for x in LOOKAHEADS}
         and 'latex_validation' in r
         and r['latex_validation']['out_of_resources_pct'] <= 5.0]
  return max(fit)[1] if fit else None


def sweep(output: str, drift_seeds: Sequence[int], batch: int,
          memory_seeds: Sequence[int] = (0, 1, 2),
          both_seeds: Sequence[int] = ()) -> int:
  """Flies `sweep_runs` (100 seeds of each suite) into one record."""
  record = {'what': 'benchmarks/policy_select.py --sweep: SAC policies and '
                    'their critic-chosen ensembles, batched on the '
                    'functional env, 100 seeds per suite',
            'command': ' '.join(sys.argv), 'host': platform.node(),
            'cpus': os.cpu_count(), 'runs': {}}
  if os.path.exists(output):  # Resume: runs already flown are kept.
    with open(output, encoding='utf-8') as f:
      record['runs'] = json.load(f)['runs']
  def fly(runs):
    for name, run in runs.items():
      done = record['runs'].setdefault(name, {})
      for suite in run['suites']:
        if suite in done:
          continue
        done[suite] = result = _fly_run(run, suite, batch)
        print(f"{name} {suite}: {100 * result['tw50_window_mean']:.1f} %, "
              f"{result['out_of_resources_pct']:.0f} % out, "
              f"{result['wall_s']:.0f} s, load {result['load']:.1f}",
              flush=True)
        safe_io.atomic_write(output, json.dumps(record) + '\n')

  runs = sweep_runs(drift_seeds, memory_seeds, both_seeds)
  fly(runs)
  chosen = _chosen_lookahead(record)
  record['lookahead_chosen'] = chosen
  if chosen:  # Held out, and the replicates, with the chosen lookahead.
    fly({chosen: {**runs[chosen], 'suites': list(BOTH)},
         **replicate_runs(runs[chosen]['horizon'], runs[chosen]['follow'])})
  # The ensemble `sac_ensemble` ships: the best validated of the declared
  # candidates (at most 5 % out of resources on validation).
  candidates = [(run['latex_validation'], n)
                for n, run in record['runs'].items()
                if n in SHIP_CANDIDATES or n.startswith(MIXED_CANDIDATE)]
  fit = [(r['tw50_window_mean'], n, r['policies']) for r, n in candidates
         if r['out_of_resources_pct'] <= 5.0]
  if fit:
    score, name, policies = max(fit)
    record['shipped'] = {'name': name, 'policies': policies,
                         'validation_tw50_window': score,
                         'candidates': [n for _, n in candidates]}
    safe_io.atomic_write(output, json.dumps(record) + '\n')
    print(f'shipped: {name} (validation {100 * score:.1f} %)')
  return 0


def main(argv: Sequence[str]) -> int:
  for name in FLAGS:  # Each call parses afresh (tests call it twice);
    FLAGS[name].unparse()  # unparse_flags() would log to a stale handler.
  try:
    FLAGS(argv)
  except flags.Error as e:
    print(f'policy_select: {e}', file=sys.stderr)
    return 2
  try:
    if FLAGS.sweep:
      check_sizes(FLAGS.batch, 0, 1)
      check_folder(FLAGS.sweep, '--sweep')
      return sweep(FLAGS.sweep, [int(s) for s in FLAGS.drift_seeds],
                   FLAGS.batch, [int(s) for s in FLAGS.memory_seeds],
                   [int(s) for s in FLAGS.both_seeds])
    if not FLAGS.policy:
      print('policy_select: give at least one --policy', file=sys.stderr)
      return 2
    check_sizes(FLAGS.batch, FLAGS.samples, FLAGS.num_seeds)
    if FLAGS.output:
      check_folder(FLAGS.output, '--output')
    if (FLAGS.mode == 'lookahead' and
        not 1 <= FLAGS.horizon <= ensemble.MAX_LOOKAHEAD):
      print(f'policy_select: --horizon must be 1 to {ensemble.MAX_LOOKAHEAD} '
            f'strides with --mode=lookahead, got {FLAGS.horizon}',
            file=sys.stderr)
      return 2
    if FLAGS.mode in ('mixed', 'lookahead'):
      record = evaluate_mixed(
          FLAGS.policy, FLAGS.suite, FLAGS.num_seeds, FLAGS.batch,
          FLAGS.horizon if FLAGS.mode == 'lookahead' else 0, FLAGS.follow)
    else:
      record = evaluate(FLAGS.policy, FLAGS.gin_file, FLAGS.mode,
                        FLAGS.samples, FLAGS.score, FLAGS.suite,
                        FLAGS.num_seeds, FLAGS.batch)
  except Refused as e:
    print(f'policy_select: {e}', file=sys.stderr)
    return 2
  except (OSError, ValueError) as e:
    print(f'policy_select: {str(e).splitlines()[0]}', file=sys.stderr)
    return 1
  print(json.dumps({k: v for k, v in record.items()
                    if k not in ('seeds', 'tw50_window', 'status')}))
  if FLAGS.output:
    safe_io.atomic_write(FLAGS.output, json.dumps(record) + '\n')
  return 0


if __name__ == '__main__':
  sys.exit(main(sys.argv))
