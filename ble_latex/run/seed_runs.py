# coding=utf-8
"""Several training seeds of one setting: train, keep the chosen, fly it.

The machinery of `benchmarks/sac_seeds.py` and `benchmarks/reward_shape.py`
(issue 66: scripts parse flags and call the package):
- `train_seeds`: runs (or resumes) `ble-latex-train --trainer=jax` for
  several seeds, in one or several processes at once;
- `write_chosen_policy`: copies the snapshot chosen on validation
  (`selection.choose_snapshot`) to the seed's `chosen_policy.msgpack`, with
  why it was chosen in its note;
- `validation_rows`: runs of different settings side by side on
  validation only (the chosen snapshot, the mean of the last five), and
  `comparison_table`, their Markdown table (the settings that differ shown);
- `best_snapshots`: a run's best-validated snapshots (an ensemble's
  members beside the chosen one);
- `fly_held_out`: flies a pretrained policy on a held-out suite in the gym
  env (`ble-latex-eval`'s code) and writes its records;
- `reward_bindings`: the gin bindings that train with one of `REWARDS`, and
  `reward_summary`: a reward's seeds spread (mean, std) on the held-out
  suite and each real source (`benchmarks/reward_shape.py`).
"""

import json
import os
import statistics
import subprocess
import sys
from typing import Any, Dict, List, Mapping, Optional, Sequence

from ble_latex import run_files


def train_seeds(base_dir: str, seeds: List[int], num_iterations: int,
                snapshot_period: int, checkpoint_period: int,
                gin_bindings: List[str], parallel: int = 1,
                vmap_seeds: bool = False, gin_files: Sequence[str] = (),
                extra_flags: Sequence[str] = ()) -> None:
  """Runs (or resumes) `ble-latex-train --trainer=jax --seeds=...`.

  With `parallel` > 1 the seeds are dealt round-robin to that many
  `ble-latex-train` processes running at once (each trains its share one
  after another, or vmapped together with `vmap_seeds`). `extra_flags` go
  to each command (e.g. `--validation_episodes=20`).

  Raises:
    RuntimeError: A training process failed (its command named).
  """
  groups = [seeds[i::parallel] for i in range(parallel)]
  commands = [
      [sys.executable, '-m', 'ble_latex.cli.train', '--trainer=jax',
       f'--base_dir={base_dir}',
       f'--seeds={",".join(str(s) for s in group)}',
       f'--num_iterations={num_iterations}',
       f'--policy_snapshot_period={snapshot_period}',
       f'--checkpoint_period={checkpoint_period}',
       '--collectors=progress', '--collectors=episodes',
       '--collectors=tensorboard',
       *(['--vmap_seeds'] if vmap_seeds and len(group) > 1 else []),
       *[f'--gin_file={f}' for f in gin_files],
       *[f'--gin_bindings={b}' for b in gin_bindings], *extra_flags]
      for group in groups if group]
  processes = []
  for command in commands:
    print(' '.join(command), flush=True)
    processes.append(subprocess.Popen(command))
  failed = [p.args for p in processes if p.wait() != 0]
  if failed:
    raise RuntimeError(f'training failed: {failed}')


def fly_held_out(suite_name: str, policy_path: str, output: str,
                 gin_files: Sequence[str] = (),
                 num_seeds: Optional[int] = None) -> Dict[str, float]:
  """Flies a policy on the held-out suite (its first `num_seeds` seeds,
  default all) in the gym env, writes the records to `output`; their
  summary (`metrics.summarize`)."""
  # pylint: disable=g-import-not-at-top
  import gym
  from ble_latex.agents.sac import agent as sac
  from ble_latex.run import eval_lib
  from ble_latex.run import gin_binding
  from ble_latex.run import metrics
  from ble_latex.run import suites
  # pylint: enable=g-import-not-at-top
  gin_binding.bind_gin('sac_pretrained', None, list(gin_files), [])
  suite = suites.get_eval_suite(suite_name)
  env = gym.make('LatexBalloon-v0').unwrapped
  space = env.action_space
  agent = sac.SACPretrainedAgent(
      space.shape[0], env.observation_space.shape, action_low=space.low,
      action_high=space.high, policy_path=policy_path)
  records = eval_lib.evaluate(agent, env, list(suite.seeds)[:num_seeds],
                              suite.max_episode_length,
                              description=f'held-out {policy_path}')
  eval_lib.write_results(output, records)
  return metrics.summarize(records)


def write_chosen_policy(run: str, seed: int, chosen: Dict[str, Any],
                        validation: List[Dict[str, Any]],
                        max_oor_pct: float) -> str:
  """Writes run/chosen_policy.msgpack from the chosen snapshot; its path.

  Snapshots are not committed (see .gitignore): in a fresh checkout an
  earlier report's chosen policy is kept when it is that same round.

  Raises:
    FileNotFoundError: The snapshot is missing and no chosen policy of that
      round is kept.
  """
  # pylint: disable=g-import-not-at-top
  from ble_latex.agents.sac import pretrained
  # pylint: enable=g-import-not-at-top
  source = run_files.policy_snapshot_path(run, chosen['iteration'])
  policy_path = run_files.chosen_policy_path(run)
  if not os.path.exists(source):
    if os.path.exists(policy_path):
      kept = pretrained.load_policy(policy_path)
      if kept.get('iteration') == chosen['iteration']:
        print(f'seed {seed}: snapshot {source} absent; keeping '
              f'{policy_path} (same round {chosen["iteration"]})')
        return policy_path
    raise FileNotFoundError(
        f'seed {seed}: the chosen snapshot {source} is missing (and no '
        f'chosen policy of round {chosen["iteration"]} in {run})')
  policy = pretrained.load_policy(source)
  policy['note'] += (
      f'; chosen among {len(validation)} snapshots by TW50 (window) on '
      f'latex_validation seeds {chosen["seeds"][0]}..{chosen["seeds"][1]} '
      f'({100 * chosen["tw50_window_mean"]:.1f} %, <= {max_oor_pct:g} % '
      'out of resources)')
  pretrained.write_policy(policy, policy_path)
  return policy_path


def best_snapshots(run: str, count: int, max_oor_pct: float) -> List[str]:
  """The snapshot paths of a run's `count` best-validated rounds.

  Ranked by `selection.ranked` on the run's validation.jsonl (within
  `max_oor_pct` % out of resources, the earlier round first among equal
  scores), best first.
  """
  # pylint: disable=g-import-not-at-top
  from ble_latex.run import episode_log
  from ble_latex.run import records
  from ble_latex.run import selection
  # pylint: enable=g-import-not-at-top
  rows = records.load_validation(os.path.join(run, episode_log.VALIDATION_LOG))
  rows = selection.ranked(rows, max_oor_pct=max_oor_pct,
                          tie=lambda r: -r['iteration'])
  return [run_files.policy_snapshot_path(run, r['iteration'])
          for r in rows[:count]]


def validation_rows(run_dirs: Sequence[str], max_oor_pct: float,
                    max_iteration: Optional[int], max_minutes: Optional[float]
                    ) -> List[Dict[str, Any]]:
  """Per run directory: its recorded config, last validated round, the
  snapshot `selection.choose_snapshot` picks within the caps, and the mean
  TW50 (window) and out-of-resources % [%] of its last five validations
  (rounds up to `max_iteration`)."""
  # pylint: disable=g-import-not-at-top
  from ble_latex.run import episode_log
  from ble_latex.run import jax_train
  from ble_latex.run import records
  from ble_latex.run import run_dir
  from ble_latex.run import selection
  # pylint: enable=g-import-not-at-top
  rows = []
  for run in run_dirs:
    with open(os.path.join(run, run_dir.RUN_INFO), encoding='utf-8') as f:
      info = json.load(f)
    validation = [r for r in records.load_validation(
        os.path.join(run, episode_log.VALIDATION_LOG))
                  if max_iteration is None or r['iteration'] <= max_iteration]
    chosen = selection.choose_snapshot(validation, max_oor_pct, max_minutes,
                                       max_iteration)
    last = validation[-5:]
    rows.append({
        'run': run, 'config': jax_train.recorded_config(info['config']),
        'validated_rounds': [r['iteration'] for r in validation][-1:],
        'chosen': chosen,
        'last5_tw50_window_mean': (statistics.mean(
            r['tw50_window_mean'] for r in last) if last else None),
        'last5_oor_pct': (statistics.mean(
            r['out_of_resources_pct'] for r in last) if last else None)})
  return rows


def comparison_table(rows: Sequence[Dict[str, Any]]) -> str:
  """`validation_rows`' rows as a Markdown table (no trailing newline): per
  run the recorded settings that differ between the runs, the last validated
  round, the chosen snapshot's round, TW50 (window) [%] and out-of-resources
  % [%], and the mean of the last five validations ('—' where missing)."""
  configs = [r['config'] for r in rows]
  differ = sorted({k for c in configs for k in c
                   if any(d.get(k) != c.get(k) for d in configs)})
  pct = lambda x: '—' if x is None else f'{100 * x:.1f} %'
  lines = [f'| run | {" | ".join(differ)} | last round | chosen round | '
           'validation TW50 window (chosen) | OOR % (chosen) | mean of last 5 '
           '| OOR % (last 5) |',
           '|---' * (len(differ) + 7) + '|']
  for r in rows:
    c = r['chosen'] or {}
    last5_oor = r['last5_oor_pct']
    lines.append(
        f'| {r["run"]} | '
        + ' | '.join(str(r['config'].get(k, '—')) for k in differ)
        + f' | {(r["validated_rounds"] or ["—"])[0]} | '
        f'{c.get("iteration", "—")} | {pct(c.get("tw50_window_mean"))} | '
        f'{c.get("out_of_resources_pct", "—")} | '
        f'{pct(r["last5_tw50_window_mean"])} | '
        f'{"—" if last5_oor is None else round(last5_oor, 1)} |')
  return '\n'.join(lines)


# The rewards a study can train with: the paper's flat one, or tanh-shaped.
REWARDS = ('perciatelli', 'tanh')


def reward_bindings(reward: str, tanh_scale_km: float) -> List[str]:
  """The gin bindings that select `reward` of `REWARDS` for training
  (tanh: `latex_reward.reward_tanh_scale_km`, [km]).

  Raises:
    ValueError: one line, for a reward not in `REWARDS`.
  """
  if reward == 'perciatelli':
    return []
  if reward == 'tanh':
    return [f'latex_reward.reward_tanh_scale_km = {tanh_scale_km!r}']
  raise ValueError(f'{reward!r} is not one of {", ".join(REWARDS)}')


def reward_summary(rows: Mapping[str, Mapping[str, Any]]) -> Dict[str, Any]:
  """A reward's seeds (seed -> row) spread over the done ones (with a
  `held_out_tw50_window`): 'seeds_done', then `<key>_mean`/`_std` of the
  held-out TW50 window and edge and core fractions, and per real source
  flown `real_<name>_seeds_done` and its `tw50_window`, `edge_fraction`,
  `core_fraction` spread (std 0 for one seed)."""
  done = [r for r in rows.values() if 'held_out_tw50_window' in r]
  out: Dict[str, Any] = {'seeds_done': len(done)}

  def spread(prefix: str, values: List[float]) -> None:
    if values:
      out[f'{prefix}_mean'] = statistics.mean(values)
      out[f'{prefix}_std'] = (statistics.stdev(values) if len(values) > 1
                              else 0.0)

  for key in ('held_out_tw50_window', 'edge_fraction', 'core_fraction'):
    spread(key, [r[key] for r in done])
  names = sorted({n for r in done for n in r.get('real_winds', {})})
  for name in names:
    flown = [r['real_winds'][name] for r in done
             if name in r.get('real_winds', {})]
    out[f'real_{name}_seeds_done'] = len(flown)
    for key in ('tw50_window', 'edge_fraction', 'core_fraction'):
      spread(f'real_{name}_{key}', [f[key] for f in flown])
  return out
