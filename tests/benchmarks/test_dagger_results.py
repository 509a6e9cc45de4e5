"""benchmarks/dagger_results.py: DAgger runs into the docs' record."""

import json

from tests import helpers

ROOT = helpers.ROOT


def _summary_round(r, tw50, oor=0.0):
  return {'round': r, 'beta': 0.5 ** r, 'teacher_fraction': 0.5 ** r,
          'labelled': 100, 'dataset_size': 100 * (r + 1),
          'train_tw50_window_mean': 0.5, 'fit_loss': 0.2,
          'validation': {'episodes': 4, 'tw50_window_mean': tw50,
                         'tw50_mean': tw50, 'out_of_resources_pct': oor},
          'fly_s': 2.0, 'fit_s': 1.0, 'validate_s': 0.5, 'loadavg': [0, 0, 0]}


def _eval(seeds, tw50):
  return [{'seed': s, 'reward': 1.0, 'tw50': t, 'tw50_window': t,
           'helium_vented_mols': 1.0, 'sand_dropped_kg': 0.1,
           'terminal_reason': 'time_limit'} for s, t in zip(seeds, tw50)]


def test_the_log_lines_dagger_train_writes_are_read_back(tmp_path):
  """`dagger.records_from_log` (`--from_logs`) reads the lines
  `dagger.round_line` writes."""
  from ble_latex.run import dagger  # pylint: disable=g-import-not-at-top
  rounds = [_summary_round(0, 0.125), _summary_round(1, 0.353, oor=2.0)]
  log = tmp_path / 'seed_0.log'
  log.write_text('compiling...\n' + ''.join(
      dagger.round_line(r) + '\n' for r in rounds) + 'validation TW50 ...\n')
  read = [dagger.flat_round(r) for r in dagger.records_from_log(str(log))]
  assert [(r['round'], r['validation_tw50_window'],
           r['validation_out_of_resources_pct'], r['labelled'])
          for r in read] == [(0, 0.125, 0.0, 100), (1, 0.353, 2.0, 100)]


def test_a_group_is_written_with_held_out_pairs(tmp_path, capsys,
                                                benchmark_script):
  runs = tmp_path / 'runs'
  for seed, curve in ((0, (0.1, 0.3, 0.2)), (1, (0.4, 0.6))):
    (runs / f'seed_{seed}').mkdir(parents=True)
    rounds = [_summary_round(r, t) for r, t in enumerate(curve)]
    if seed == 1:  # The best TW50, but out of resources: not chosen.
      rounds[1]['validation']['out_of_resources_pct'] = 10.0
    (runs / f'seed_{seed}' / 'summary.json').write_text(
        json.dumps({'rounds': rounds}))
    (tmp_path / f'held_{seed}.json').write_text(
        json.dumps(_eval([3, 1, 2], [0.2, 0.4, 0.6])))
  (tmp_path / 'ref.json').write_text(json.dumps(_eval([1, 2, 3],
                                                      [0.5, 0.5, 0.5])))
  out = tmp_path / 'results.json'
  script = benchmark_script('dagger_results.py')
  rc = script.main([f'--name=g', f'--runs={runs}',
                    f'--heldout={tmp_path}/held_{{seed}}.json',
                    f'--reference=latex_mpc={tmp_path}/ref.json',
                    f'--json={out}'])
  assert rc == 0, capsys.readouterr().err
  group = json.loads(out.read_text())['groups']['g']
  assert group['seeds']['0']['best_round'] == 1
  assert group['seeds']['1']['best_round'] == 0
  held = group['seeds']['0']['heldout']
  assert held['seeds'] == [1, 2, 3] and held['tw50_window'] == [0.4, 0.6, 0.2]
  assert group['references']['latex_mpc']['seeds'] == [1, 2, 3]


def test_a_missing_reference_is_one_line_and_writes_nothing(tmp_path, capsys,
                                                            benchmark_script):
  runs = tmp_path / 'runs' / 'seed_0'
  runs.mkdir(parents=True)
  (runs / 'summary.json').write_text(json.dumps(
      {'rounds': [_summary_round(0, 0.1)]}))
  out = tmp_path / 'results.json'
  script = benchmark_script('dagger_results.py')
  rc = script.main([f'--name=g', f'--runs={tmp_path / "runs"}',
                    f'--reference=x={tmp_path}/absent.json',
                    f'--json={out}'])
  err = capsys.readouterr().err.strip().splitlines()
  assert rc == 1 and len(err) == 1 and 'absent.json' in err[0], err
  assert not out.exists()
