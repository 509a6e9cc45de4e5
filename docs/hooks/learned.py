"""Issue 47's tables (learned controllers), registered by `tables.py` beside
this file (`TABLES`).

DAgger students (`benchmarks/records/dagger/results.json`), SAC on different
observations (`benchmarks/records/sac_jax/observation_results.json`) and README's
learned controllers, with seconds per decision (`benchmarks/records/policy_speed*.json`).
What a cell holds is `ble_latex.run.tables`'s; the best-validated training
seed is `ble_latex.run.selection`'s rule.
"""

import re
from typing import Dict, Tuple

from ble_latex.run import episode_log
from ble_latex.run import selection
from ble_latex.run import tables as tables_lib

RECORDS = episode_log.RECORDS_DIR
DAGGER = RECORDS / 'dagger' / 'results.json'
OBSERVATION = RECORDS / 'sac_jax' / 'observation_results.json'


DAGGER_REFERENCES = (('sac_pretrained', '`sac_pretrained`'),
                     ('latex_mpc', '`latex_mpc`'),
                     ('latex_mpc_oracle', 'the oracle'))


def dagger() -> str:
  """Per DAgger group and training seed: validation, held out, paired."""
  record = tables_lib.load(DAGGER)
  lines = ['| run | training seed | rounds (labels) | best round: validation '
           '| `latex_small` TW50 window | out of resources | ' + ' | '.join(
               f'student − {label} per seed' for _, label in DAGGER_REFERENCES)
           + ' |', '|---' * (6 + len(DAGGER_REFERENCES)) + '|']
  for name, group in record['groups'].items():
    held_means = []
    for seed, entry in sorted(group['seeds'].items(), key=lambda x: int(x[0])):
      held = entry.get('heldout')
      cells = ['—'] * (2 + len(DAGGER_REFERENCES))
      if held:
        held_means.append(held['tw50_window_mean'])
        cells = [
            tables_lib.pct(held['tw50_window_mean'], held['tw50_window_std']),
            f"{held['out_of_resources_pct']:.0f} %"] + [
                tables_lib.paired_cell(group['references'][ref], held, DAGGER)
                if ref in group['references'] else '—'
                for ref, _ in DAGGER_REFERENCES]
      lines.append(
          f"| {name} | {seed} | {len(entry['rounds'])} ({entry['labels']:,}) "
          f"| {entry['best_round']}: "
          f"{100 * entry['best_validation_tw50_window']:.1f} % | "
          + ' | '.join(cells) + ' |')
    if len(held_means) > 1:
      mean, std = tables_lib.mean_std(held_means)
      lines.append(f'| {name} | mean ± std over seeds | | | '
                   f'{100 * mean:.1f} % ± {100 * std:.1f} |' + ' |' * (
                       1 + len(DAGGER_REFERENCES)))
  return '\n'.join(lines)


def observation() -> str:
  """Per observation and training seed: chosen on validation, held out,
  paired with the references seed by seed."""
  record = tables_lib.load(OBSERVATION)
  lines = ['| observation | training seed | chosen round: validation | '
           '`latex_small` TW50 window | out of resources | ' + ' | '.join(
               f'− {label} per seed' for _, label in DAGGER_REFERENCES)
           + ' |', '|---' * (5 + len(DAGGER_REFERENCES)) + '|']
  for name, run in record['runs'].items():
    held_means = []
    for seed, entry in sorted(run['seeds'].items(), key=lambda x: int(x[0])):
      held_means.append(entry['heldout_tw50_window_mean'])
      held = entry['heldout']
      paired = [
          tables_lib.paired_cell(record['references'][ref], held, OBSERVATION)
          if held and ref in record['references'] else '—'
          for ref, _ in DAGGER_REFERENCES]
      lines.append(
          f"| {name} ({_settings(entry['observation'])}) | {seed} | "
          f"{entry['chosen_round']}: "
          f"{100 * entry['chosen_validation_tw50_window']:.1f} % | "
          f"{100 * entry['heldout_tw50_window_mean']:.1f} % | "
          f"{entry['heldout_oor_pct']:.0f} % | " + ' | '.join(paired) + ' |')
    mean, std = tables_lib.mean_std(held_means)
    lines.append(f'| {name} | mean ± std over {len(held_means)} seeds | | '
                 f'{100 * mean:.1f} % ± {100 * std:.1f} |' + ' |' * (
                     1 + len(DAGGER_REFERENCES)))
  return '\n'.join(lines)


def _settings(observation: Dict[str, int]) -> str:
  """`latex_observation.*` settings as `key` value pairs (the paper's: 0)."""
  return ', '.join(f'`{k}` {v}' for k, v in observation.items() if v) or (
      'the paper\'s')


def _label(observation: Dict[str, int]) -> str:
  """README's name of a SAC run's observation."""
  parts = []
  if observation.get('wind_memory'):
    parts.append(f'corrected by {observation["wind_memory"]} measured winds')
  if observation.get('wind_lookahead'):
    hours = observation['wind_lookahead'] / 3
    parts.append(f'as {hours:g}-hour drifts')
  return ('SAC, the paper\'s observation' if not parts else
          'SAC, wind column ' + ' and '.join(parts))


POLICY_SPEED = RECORDS / 'policy_speed.json'
POLICY_SPEED_OBSERVATION = RECORDS / 'policy_speed_observation.json'


def _key(observation: Dict[str, int]) -> Tuple[Tuple[str, int], ...]:
  """An observation's settings without its zeros (the paper's: ())."""
  return tuple(sorted((k, v) for k, v in observation.items() if v))


def _best_validated(seeds: Dict[str, dict], score) -> Tuple[str, dict]:
  """The training seed whose chosen policy validated best (`score`; ties:
  the lower seed), by `selection.best` (no out-of-resources cap)."""
  return selection.best(
      seeds.items(), result=lambda item: {selection.SCORE: score(item[1])},
      tie=lambda item: -int(item[0]))


def learned_short() -> str:
  """README's learned controllers: held out over training seeds, the
  best-validated seed paired with `latex_mpc`, seconds per decision."""
  observation_record = tables_lib.load(OBSERVATION)
  dagger_record = tables_lib.load(DAGGER)
  speed = {p['name']: p for p in tables_lib.load(POLICY_SPEED)['policies']}
  observed = tables_lib.load(POLICY_SPEED_OBSERVATION)
  observed_speed = {p['name']: p for p in observed['policies']}
  observe_ms = {_key(o['observation']): 1e3 * o['median_s']
                for o in observed['observations']}
  paper = _key({})
  mpc = observation_record['references']['latex_mpc']
  lines = ['| controller | training seeds | `latex_small` TW50 window (over '
           'training seeds) | out of resources | best-validated seed − '
           '`latex_mpc` per seed | ms / decision |', '|---|---|---|---|---|---|']

  def row(label, means, oor, paired, ms, seeds=None, tw50=None):
    mean, std = tables_lib.mean_std(means)
    tw50 = tw50 or f'{100 * mean:.1f} % ± {100 * std:.1f}'
    lines.append(f'| {label} | {seeds or len(means)} | {tw50} | '
                 f'{oor:.1f} % | {paired} | {ms} |')

  for name, run in observation_record['runs'].items():
    seeds = run['seeds']
    observation = next(iter(seeds.values()))['observation']
    seed, best = _best_validated(
        seeds, lambda e: e['chosen_validation_tw50_window'])
    held = best['heldout'] or (
        observation_record['references'].get('sac_pretrained')
        if _key(observation) == paper else None)
    step = observed_speed.get(name, observed_speed['shipped'])
    observe = observe_ms[_key(observation)]
    ms = (f'{observe + 1e3 * step["median_s"]:.2f} (observation '
          f'{observe:.2f})')
    row(f'{_label(observation)} (seed {seed} best validated)',
        [e['heldout_tw50_window_mean'] for e in seeds.values()],
        sum(e['heldout_oor_pct'] for e in seeds.values()) / len(seeds),
        tables_lib.paired_cell(mpc, held, OBSERVATION) if held else '—', ms)
  sweep = tables_lib.load(ENSEMBLE)
  flown = tables_lib.flights_summary(ENSEMBLE_EVAL)
  chosen = sweep['runs'][sweep['lookahead_chosen']]['latex_validation']
  step = observed_speed[_lookahead_speed_name(chosen)]
  observe = observe_ms[_key(step['observation'])]
  shipped = sweep['shipped']['policies']
  alone = _alone(sweep['runs'], 'latex_small')
  spread = tables_lib.mean_std([alone[p]['tw50_window_mean'] for p in shipped])
  row(f'`sac_ensemble`: {_members_label(shipped)}; their critics choose '
      f'among their actions, each flown {_lookahead_words(chosen)}',
      [flown['tw50_window'][0]], flown['out_of_resources_pct'],
      tables_lib.paired_cell(mpc, flown['per_seed'], ENSEMBLE_EVAL),
      f'{observe + 1e3 * step["median_s"]:.2f} (observation {observe:.2f})',
      seeds=f'{len(shipped)} (one ensemble)',
      tw50=f'{100 * flown["tw50_window"][0]:.1f} % (its members alone: '
      f'{100 * spread[0]:.1f} % ± {100 * spread[1]:.1f})')
  group = dagger_record['groups']['gpu_h200']
  seed, best = _best_validated(
      group['seeds'], lambda e: e['best_validation_tw50_window'])
  ms = [1e3 * p['median_s'] for n, p in speed.items()
        if n.startswith('dagger_seed_')]
  row(f'DAgger student of `latex_mpc` (H200, seed {seed} best validated)',
      [e['heldout']['tw50_window_mean'] for e in group['seeds'].values()],
      sum(e['heldout']['out_of_resources_pct']
          for e in group['seeds'].values()) / len(group['seeds']),
      tables_lib.paired_cell(group['references']['latex_mpc'],
                             best['heldout'], DAGGER),
      f'{observe_ms[paper] + min(ms):.2f}–{observe_ms[paper] + max(ms):.2f} '
      f'(observation {observe_ms[paper]:.2f})')
  return '\n'.join(lines)


# Rounds (0-based) at which the validation curves are compared.
OBSERVATION_ROUNDS = (49, 99, 149, 199, 229)


def observation_curve() -> str:
  """Validation TW50 at equal rounds: mean ± std over seeds, each run."""
  record = tables_lib.load(OBSERVATION)
  lines = ['| observation | seeds | ' + ' | '.join(
      f'round {r}' for r in OBSERVATION_ROUNDS) + ' |',
           '|---' * (2 + len(OBSERVATION_ROUNDS)) + '|']
  for name, run in record['runs'].items():
    cells = []
    for r in OBSERVATION_ROUNDS:
      values = [dict((i, v) for i, v, _ in e['validation']).get(r)
                for e in run['seeds'].values()]
      values = [v for v in values if v is not None]
      if not values:
        cells.append('—')
        continue
      mean, std = tables_lib.mean_std(values)
      cells.append(f'{100 * mean:.1f} % ± {100 * std:.1f} ({len(values)})')
    lines.append(f'| {name} | {len(run["seeds"])} | ' + ' | '.join(cells)
                 + ' |')
  return '\n'.join(lines)


# The learned value beyond the planner's horizon (issue 47 item 2), flown on
# the first 40 `latex_validation` seeds: (record under benchmarks/records/planners/,
# label). The first row is the reference of the paired column.
PLANNER_VALUE_ROWS = (
    ('latex_validation/latex_mpc', '`latex_mpc` (its defaults)'),
    ('latex_validation/latex_mpc_value1',
     '`latex_mpc`, value of the shipped SAC policy, `value_weight` 1'),
    ('latex_validation/latex_mpc_value03',
     '`latex_mpc`, value of the shipped SAC policy, `value_weight` 0.3'),
)


def planner_value() -> str:
  """`latex_mpc` with and without the learned value, paired per seed."""
  lines = ['| planner | seeds | TW50 window (mean ± std) | out of resources | '
           'sand dropped [kg] | s / decision | − `latex_mpc` per seed |',
           '|---|---|---|---|---|---|---|']
  reference = tables_lib.planner_per_seed(PLANNER_VALUE_ROWS[0][0])
  for i, (path, label) in enumerate(PLANNER_VALUE_ROWS):
    s = tables_lib.planner_summary(path)
    paired = tables_lib.paired_cell(
        reference, s['per_seed'], tables_lib.planner_record(path)) if i else '—'
    lines.append(f'| {label} | {s["seeds"]} | '
                 f'{tables_lib.pct(*s["tw50_window"])} | '
                 f'{s["out_of_resources_pct"]:.0f} % | {s["sand"]:.2f} | '
                 f'{s["s_per_decision"]:.3g} | {paired} |')
  return '\n'.join(lines)


ENSEMBLE = RECORDS / 'ensemble' / 'results.json'
# `ble-latex-eval --agent=sac_ensemble` on latex_small (flight paths removed).
ENSEMBLE_EVAL = (RECORDS / 'ensemble' / 'latex_small' /
                 'sac_ensemble.json')
# (sweep run name prefix or name, label) of the `ensemble` table's rows, in
# order; `drifts_critic_` + three seeds is summarised over every triple.
ENSEMBLE_VARIANTS = (
    ('drifts_average_012', 'mean of the three actions (no critic)'),
    ('drifts_critic8_012', 'critics choose among the three actions and 8 '
     'draws of each actor'),
    ('drifts_critic_min_012', 'critics choose, the members\' values '
     'combined by their minimum'),
)


# The sweep's training runs (benchmarks/records/sac_jax/RUN) by what they observe.
_RUN_LABELS = {'wind_lookahead12': 'drift', 'wind_memory16': 'corrected-column',
               'memory_lookahead': 'both-corrections'}


def _members_label(policies) -> str:
  """'drift seeds 0, 1 + corrected-column seeds 0, 2' of policy paths."""
  runs: Dict[str, list] = {}
  for path in policies:
    found = re.search(r'sac_jax/([^/]+)/seed_(\d+)', path)
    runs.setdefault(found.group(1), []).append(found.group(2))
  return ' + '.join(f"SAC {_RUN_LABELS[r]} seeds {', '.join(s)}"
                    for r, s in runs.items())


def _alone(runs: dict, suite: str) -> dict:
  """Policy path -> its flight alone (a `mean` run) on `suite`."""
  return {r[suite]['policies'][0]: r[suite] for r in runs.values()
          if r.get(suite) and r[suite]['mode'] == 'mean'}


def _members_mean(runs: dict, policies, suite: str) -> dict:
  """Per seed, the mean TW50 of an ensemble's members flown alone."""
  alone = _alone(runs, suite)
  return tables_lib.per_seed_mean([alone[p] for p in policies])


def _cell(run: dict, suite: str) -> str:
  r = run.get(suite)
  return f"{100 * r['tw50_window_mean']:.1f} %" if r else '—'


def _result_cell(r: dict) -> str:
  """'TW50 window % (out of resources %)' of one sweep flight."""
  return (f"{100 * r['tw50_window_mean']:.1f} % "
          f"({r['out_of_resources_pct']:.0f} %)")


def _validation_cell(run: dict) -> str:
  return _result_cell(run['latex_validation'])


def ensemble() -> str:
  """SAC policies alone and as critic-chosen ensembles, validation and
  held out, paired with their members and with `latex_mpc` per seed."""
  sweep = tables_lib.load(ENSEMBLE)
  runs = sweep['runs']
  mpc = tables_lib.planner_per_seed('latex_small/latex_mpc')
  lines = ['| controller | `latex_validation` TW50 window (out of '
           'resources) | `latex_small` '
           'TW50 window | out of resources (`latex_small`) | − its members '
           'alone per seed (`latex_small`) | − `latex_mpc` per seed |',
           '|---|---|---|---|---|---|']

  def row(label, run):
    held = run.get('latex_small')
    members = (tables_lib.paired_cell(
        _members_mean(runs, held['policies'], 'latex_small'), held, ENSEMBLE)
               if held and held['mode'] in ('critic', 'mixed') else '—')
    lines.append(
        f"| {label} | {_validation_cell(run)} | "
        f"{_cell(run, 'latex_small')} | "
        + (f"{held['out_of_resources_pct']:.0f} %" if held else '—')
        + f" | {members} | "
        + (tables_lib.paired_cell(mpc, held, ENSEMBLE) if held else '—') + ' |')

  for prefix, what, whose in (('drifts', 'drifts', 'drift'),
                              ('memory', 'corrected column',
                               'corrected-column')):
    alone = sorted(n for n in runs if n.startswith(f'{prefix}_seed_'))
    for name in alone:
      row(f"SAC ({what}), seed {name.rsplit('_', 1)[1]} alone", runs[name])
    triples = sorted(n for n in runs if n.startswith(f'{prefix}_critic_')
                     and n[len(prefix) + 8:].isdigit())
    shown = set(sweep.get('shipped', {}).get('candidates', ()))
    for name in [n for n in triples if n in shown or len(triples) <= 2]:
      row(f"ensemble of the {whose} seeds {', '.join(name[len(prefix) + 8:])}"
          ', critics choose', runs[name])
    if len(triples) > 2:
      held = [runs[n]['latex_small']['tw50_window_mean'] for n in triples]
      valid = [runs[n]['latex_validation']['tw50_window_mean']
               for n in triples]
      (hm, hs), (vm, vs) = tables_lib.mean_std(held), tables_lib.mean_std(valid)
      gains = []
      for n in triples:
        r = runs[n]['latex_small']
        base = _members_mean(runs, r['policies'], 'latex_small')
        gains.append(r['tw50_window_mean'] -
                     tables_lib.mean_std(base['tw50_window'])[0])
      gm, gs = tables_lib.mean_std(gains)
      lines.append(
          f'| every 3 of the {len(alone)} seeds ({len(triples)} ensembles, '
          f'mean ± std over them) | {100 * vm:.1f} % ± {100 * vs:.1f} | '
          f'{100 * hm:.1f} % ± {100 * hs:.1f} ({100 * min(held):.1f}–'
          f'{100 * max(held):.1f}) | — | {100 * gm:+.1f} ± {100 * gs:.1f} '
          '(over ensembles) | — |')
    if f'{prefix}_critic_all' in runs:
      row(f'ensemble of all {len(alone)} seeds, critics choose',
          runs[f'{prefix}_critic_all'])
  for name in sorted(n for n in runs if n.startswith('both_seed_')):
    row(f"SAC (both corrections), seed {name.rsplit('_', 1)[1]} alone",
        runs[name])
  for name in sorted((n for n in runs if n.startswith('mixed_')),
                     key=lambda n: len(runs[n]['latex_validation']['policies'])):
    row(f"{_members_label(runs[name]['latex_validation']['policies'])}, "
        'each on its own view, critics choose', runs[name])
  for name, label in ENSEMBLE_VARIANTS:
    if name in runs:
      row(f'seeds 0, 1, 2: {label}', runs[name])
  if 'drifts_critic_all_snapshots' in runs:
    run = runs['drifts_critic_all_snapshots']
    count = len(run['latex_validation']['policies'])
    row(f'all {count // 2} seeds and each seed\'s next-best validated snapshot '
        f'({count} members), critics choose', run)
  for name in sorted(n for n in runs if n.startswith('drifts_snapshots_')):
    row(f"seed {name.rsplit('_', 1)[1]}'s three best-validated snapshots, "
        'critics choose', runs[name])
  return '\n'.join(lines)


def _lookahead_words(run: dict) -> str:
  """'3 strides ahead in the forecast (then its member's actions)'."""
  return (f"{run['horizon']} stride{'s' if run['horizon'] > 1 else ''} "
          'ahead in the forecast' +
          (' (then its member\'s actions)' if run['follow'] else ' (held)'))


def _lookahead_speed_name(run: dict) -> str:
  """`benchmarks/policy_speed.py --lookahead`'s name of a lookahead run."""
  return (f"shipped_ensemble_lookahead{run['horizon']}"
          + ('_follow' if run['follow'] else ''))


def ensemble_lookahead() -> str:
  """The shipped members with their proposals flown ahead: validation,
  held out (the best validated only), paired with the same members without
  a lookahead, and milliseconds per decision."""
  sweep = tables_lib.load(ENSEMBLE)
  runs = sweep['runs']
  base = runs[sweep['shipped']['name']]
  speed = {p['name']: p for p in
           tables_lib.load(POLICY_SPEED_OBSERVATION)['policies']}
  mpc = tables_lib.planner_per_seed('latex_small/latex_mpc')
  lines = ['| each proposal flown | `latex_validation` TW50 window (out of '
           'resources) | − no lookahead per seed (validation) | '
           '`latex_small` TW50 window (out of resources) | − no lookahead '
           'per seed (`latex_small`) | − `latex_mpc` per seed | ms / '
           'decision (step) |', '|---|---|---|---|---|---|---|']
  names = [n for n in runs if n.startswith('shipped_lookahead_')]
  for name in sorted(names, key=lambda n: (
      runs[n]['latex_validation']['horizon'],
      runs[n]['latex_validation']['follow'])):
    run = runs[name]
    valid = run['latex_validation']
    held = run.get('latex_small')
    step = speed.get(_lookahead_speed_name(valid))
    held_cells = (
        f'{_result_cell(held)} | '
        f"{tables_lib.paired_cell(base['latex_small'], held, ENSEMBLE)} | "
        f'{tables_lib.paired_cell(mpc, held, ENSEMBLE)}' if held else
        '— | — | —')
    ms = f"{1e3 * step['median_s']:.2f}" if step else '—'
    lines.append(
        f'| {_lookahead_words(valid)} | {_validation_cell(run)} | '
        f"{tables_lib.paired_cell(base['latex_validation'], valid, ENSEMBLE)} | "
        f'{held_cells} | {ms} |')
  lines.append(
      f"| not flown ahead (the shipped members' critics score where the "
      f"balloon is) | {_validation_cell(base)} | — | "
      f"{_result_cell(base['latex_small'])} | — | "
      f"{tables_lib.paired_cell(mpc, base['latex_small'], ENSEMBLE)} | "
      f"{1e3 * speed['shipped_ensemble']['median_s']:.2f} |")
  return '\n'.join(lines)


def ensemble_replicates() -> str:
  """The recipe replicated on disjoint training seeds (`REPLICATES` of
  benchmarks/policy_select.py): without and with the chosen lookahead."""
  sweep = tables_lib.load(ENSEMBLE)
  runs = sweep['runs']
  mpc = tables_lib.planner_per_seed('latex_small/latex_mpc')
  lines = ['| members (4 training seeds each) | `latex_validation`: without '
           '/ with the lookahead | `latex_small`: without / with (out of '
           'resources with) | with − without per seed (`latex_small`) | '
           'with − `latex_mpc` per seed |', '|---|---|---|---|---|']
  held = []
  names = sorted(n for n in runs
                 if re.fullmatch(r'replicate_\d+', n) and
                 'latex_small' in runs.get(f'{n}_lookahead', {}))
  for name in names:
    without, with_ = runs[name], runs[f'{name}_lookahead']
    small = with_['latex_small']
    held.append(small['tw50_window_mean'])
    lines.append(
        f"| {_members_label(small['policies'])} | "
        f"{_cell(without, 'latex_validation')} / "
        f"{_cell(with_, 'latex_validation')} | "
        f"{_cell(without, 'latex_small')} / {_cell(with_, 'latex_small')} "
        f"({small['out_of_resources_pct']:.0f} %) | "
        f"{tables_lib.paired_cell(without['latex_small'], small, ENSEMBLE)} | "
        f'{tables_lib.paired_cell(mpc, small, ENSEMBLE)} |')
  if held:
    mean, std = tables_lib.mean_std(held)
    lines.append(f'| mean ± std over the {len(held)} replicates | | '
                 f'with: {100 * mean:.1f} % ± {100 * std:.1f} | | |')
  return '\n'.join(lines)


# `sac_ensemble` under gin_configs/latex_realistic.gin (ble-latex-eval
# records, flight paths removed; docs/ensemble.md says how they were flown).
ENSEMBLE_REALISTIC = RECORDS / 'ensemble' / 'realistic'


def ensemble_realistic() -> str:
  """Realistic physics: the ensemble of three realistic SAC seeds, without
  and with the lookahead on validation, the chosen one held out, paired
  with the shipped realistic `sac_pretrained` on the same flights."""
  def summary(suite, name):
    return tables_lib.flights_summary(
        ENSEMBLE_REALISTIC / suite / f'{name}.json')

  def cell(s):
    return (f"{100 * s['tw50_window'][0]:.1f} % "
            f"({s['out_of_resources_pct']:.0f} %)")

  valid = {False: summary('latex_validation', 'sac_ensemble_no_lookahead'),
           True: summary('latex_validation', 'sac_ensemble')}
  held = summary('latex_small', 'sac_ensemble')
  single = summary('latex_small', 'sac_pretrained')
  where = ENSEMBLE_REALISTIC / 'latex_small'
  return '\n'.join([
      '| controller (realistic physics) | `latex_validation` TW50 window (out '
      'of resources) | `latex_small` TW50 window (out of resources) | − '
      '`sac_pretrained` (realistic policy) per seed |', '|---|---|---|---|',
      f'| `sac_ensemble` of 3 realistic SAC seeds, no lookahead | '
      f'{cell(valid[False])} | — | — |',
      f'| `sac_ensemble` of 3 realistic SAC seeds, 3 strides ahead '
      f'(then its member\'s actions) | {cell(valid[True])} | {cell(held)} | '
      f"{tables_lib.paired_cell(single['per_seed'], held['per_seed'], where)}"
      ' |',
      f'| `sac_pretrained`, the shipped realistic policy | — | {cell(single)} '
      '| — |'])


# This file's tables by block name (`tables.TABLES` holds them too).
TABLES = {
    'dagger': dagger,
    'observation': observation,
    'observation-curve': observation_curve,
    'learned-short': learned_short,
    'planner-value': planner_value,
    'ensemble': ensemble,
    'ensemble-lookahead': ensemble_lookahead,
    'ensemble-replicates': ensemble_replicates,
    'ensemble-realistic': ensemble_realistic,
}
