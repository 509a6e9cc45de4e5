"""The planner benchmark scripts' own checks (benchmarks/planners.py --seeds,
the batch's size; without TensorFlow: tests/test_no_tensorflow.py)."""

import subprocess
import sys

import pytest

from tests import helpers

ROOT = helpers.ROOT


@pytest.mark.parametrize('seeds, message', [
    ('5', '--seeds: [5] not among the 100 seeds of latex_small'),
    ('1000000,x', "--seeds: integers, got ['1000000', 'x']"),
])
def test_planners_seeds_outside_the_suite_are_one_line(tmp_path, capsys,
                                                       seeds, message,
                                                       benchmark_script):
  planners = benchmark_script('planners.py')
  rc = planners.main(['--suite=latex_small', f'--seeds={seeds}',
                      f'--output_dir={tmp_path}'])
  err = capsys.readouterr().err.strip().splitlines()
  assert rc == 2
  assert err == [f'benchmarks/planners.py: {message}']
  assert not list(tmp_path.rglob('*.json'))  # Nothing written.


def test_planners_refuse_a_batch_too_big_for_one_call(tmp_path, capsys,
                                                      benchmark_script):
  """Issue 48 item 15: a batched call that would fly more plan strides at
  once than `plan_config.MAX_PLAN_STRIDES` is refused in one line naming the
  binding and --batch, before anything is compiled or written."""
  planners = benchmark_script('planners.py')
  rc = planners.main(['--agent=latex_mpc_oracle', '--suite=latex_small',
                      '--batch=100', f'--output_dir={tmp_path}',
                      '--gin_bindings=LatexMpcOracleAgent.beam_width=8192'])
  err = capsys.readouterr().err.strip().splitlines()
  assert rc == 2 and len(err) == 1, err
  assert err[0].startswith('benchmarks/planners.py: gin binding '
                           'LatexMpcOracleAgent.beam_width = 8192')
  assert 'with --batch = 100 would fly' in err[0]
  assert not list(tmp_path.rglob('*.json'))  # Nothing written.


@pytest.mark.slow
def test_planners_times_a_planner_that_plans_once(tmp_path, benchmark_script):
  """One plan per episode (the oracle's way): the batches after the first
  compiled one still give seconds per decision, and the first is left out."""
  import json  # pylint: disable=g-import-not-at-top
  planners = benchmark_script('planners.py')
  bindings = [f'--gin_bindings=LatexMpcOracleAgent.{b}' for b in (
      'horizon=12', 'num_segments=4', 'replan_every=12', 'beam_width=2',
      'grid_levels=2', 'beam_cell_km=0')]
  rc = planners.main(['--agent=latex_mpc_oracle', '--suite=latex_small',
                      '--short', '--batch=1', f'--output_dir={tmp_path}',
                      *bindings])
  assert rc == 0
  timing = json.loads(
      (tmp_path / 'latex_small' / 'timing' / 'latex_mpc_oracle.json')
      .read_text())
  first, second = timing['batches']
  assert first['plan_calls'] == second['plan_calls'] == 1
  assert first['plan_s_warm'] == [] and len(second['plan_s_warm']) == 1
  assert timing['summary']['s_per_decision_per_balloon'] == pytest.approx(
      second['plan_s_warm'][0])


_CHEAP_ORACLE = [f'--gin_bindings=LatexMpcOracleAgent.{b}' for b in (
    'horizon=12', 'num_segments=4', 'replan_every=12', 'beam_width=2',
    'grid_levels=2', 'beam_cell_km=0')]


@pytest.mark.slow
def test_planners_never_drop_seeds_and_refuse_other_settings(tmp_path, capsys,
                                                             benchmark_script):
  """Issue 48 items 1, 2, 14: a re-flight of chosen seeds merges into the
  finished record (never fewer seeds); a partial file flown with other
  settings is refused naming them; a truncated or crafted partial is one
  line; so is an unknown suite."""
  import json  # pylint: disable=g-import-not-at-top
  planners = benchmark_script('planners.py')
  base = ['--agent=latex_mpc_oracle', '--suite=latex_small', '--short',
          '--max_episode_length=2', f'--output_dir={tmp_path}',
          *_CHEAP_ORACLE]
  folder = tmp_path / 'latex_small'
  record = folder / 'latex_mpc_oracle.json'
  partial = folder / 'latex_mpc_oracle.partial.json'
  assert planners.main(base) == 0
  first = json.loads(record.read_text())
  assert len(first) == 2 and not partial.exists()
  capsys.readouterr()
  # The documented diagnostic: re-fly one seed; the other stays.
  assert planners.main([*base, f'--seeds={first[1]["seed"]}']) == 0
  again = json.loads(record.read_text())
  assert [r['seed'] for r in again] == [r['seed'] for r in first]
  assert again[0] == first[0]  # Kept as flown.
  timing = json.loads((folder / 'timing' / 'latex_mpc_oracle.json')
                      .read_text())
  assert timing['summary']['seeds'] == 2
  capsys.readouterr()
  # With other settings, the re-flight would mix records: refused.
  rc = planners.main([*base, f'--seeds={first[1]["seed"]}',
                      '--max_episode_length=5'])
  err = capsys.readouterr().err.strip().splitlines()
  assert rc == 2 and len(err) == 1
  assert 'max_steps: 2 there, 5 here' in err[0]
  assert json.loads(record.read_text()) == again
  # A partial file of other settings (a killed run) is not resumed.
  config = dict(timing['run_config'], max_steps=5,
                gin_bindings=['LatexMpcOracleAgent.horizon=5'])
  partial.write_text(json.dumps({'run_config': config,
                                 'records': first[:1]}))
  rc = planners.main(base)
  err = capsys.readouterr().err.strip().splitlines()
  assert rc == 2 and len(err) == 1
  assert 'other settings (max_steps: 5 there, 2 here; gin_bindings:' in err[0]
  for text in ('[{"seed": 1', json.dumps(first[:1]),
               json.dumps({'run_config': timing['run_config'],
                           'records': [{'seed': 'x'}]})):
    partial.write_text(text)
    rc = planners.main(base)
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 1 and len(err) == 1, err
    assert str(partial) in err[0]
  assert json.loads(record.read_text()) == again
  rc = planners.main([*base, '--suite=nosuch'])
  err = capsys.readouterr().err.strip().splitlines()
  assert rc == 2 and err[0].startswith(
      "benchmarks/planners.py: unknown suite 'nosuch'") and len(err) == 1


def test_policy_speed_refuses_bad_policies_in_one_line(tmp_path, capsys,
                                                       benchmark_script):
  """benchmarks/policy_speed.py: a --policy that is not NAME=PATH is a usage
  error (2), a missing file a failure (1), before anything is flown."""
  speed = benchmark_script('policy_speed.py')
  out = tmp_path / 'speed.json'
  rc = speed.main(['--policy=nonsense', f'--json={out}'])
  err = capsys.readouterr().err.strip().splitlines()
  assert rc == 2 and len(err) == 1 and 'want NAME=PATH' in err[0], err
  rc = speed.main([f'--policy=a={tmp_path}/absent.msgpack', f'--json={out}'])
  err = capsys.readouterr().err.strip().splitlines()
  assert rc == 1 and len(err) == 1 and 'absent.msgpack' in err[0], err
  # An ensemble's members are each checked (`sac_ensemble`).
  from ble_latex.agents.sac import pretrained  # pylint: disable=g-import-not-at-top
  rc = speed.main([f'--policy=e={pretrained.SHIPPED_ENSEMBLE[0]},'
                   f'{tmp_path}/gone.msgpack', f'--json={out}'])
  err = capsys.readouterr().err.strip().splitlines()
  assert rc == 1 and len(err) == 1 and 'gone.msgpack' in err[0], err
  rc = speed.main(['--policy=shipped', '--lookahead=3_ahead', f'--json={out}'])
  err = capsys.readouterr().err.strip().splitlines()
  assert rc == 2 and len(err) == 1 and 'H_follow' in err[0], err
  assert not out.exists()


def test_policy_select_refuses_bad_input_in_one_line(tmp_path, capsys,
                                                     benchmark_script):
  """benchmarks/policy_select.py: a bad flag or a policy of another
  observation is a usage error (2), a missing file a failure (1); nothing
  is written."""
  script = benchmark_script('policy_select.py')
  out = tmp_path / 'record.json'
  for argv, rc_want, text in (
      (['--mode=bogus'], 2, 'mode'),
      ([], 2, '--policy'),
      ([f'--policy={tmp_path}/none.msgpack'], 1, 'none.msgpack'),
      (['--policy=shipped',
        f"--gin_file={ROOT / 'gin_configs' / 'latex_wind_lookahead.gin'}"],
       2, 'wind_lookahead'),
      (['--policy=shipped', '--mode=lookahead', '--horizon=0'], 2,
       '--horizon')):
    rc = script.main(['policy_select.py', *argv, f'--output={out}'])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == rc_want and len(err) == 1 and text in err[0], (argv, err)
  assert not out.exists()


def test_observation_results_refuses_bad_runs_in_one_line(tmp_path, capsys,
                                                          benchmark_script):
  """benchmarks/observation_results.py: a --run that is not NAME=BASE_DIR is
  a usage error (2), a run without its report a failure (1); nothing is
  written either way."""
  script = benchmark_script('observation_results.py')
  out = tmp_path / 'record.json'
  rc = script.main(['--run=nonsense', f'--json={out}'])
  err = capsys.readouterr().err.strip().splitlines()
  assert rc == 2 and len(err) == 1 and 'want NAME=PATH' in err[0], err
  rc = script.main([f'--run=a={tmp_path}', f'--json={out}'])
  err = capsys.readouterr().err.strip().splitlines()
  assert rc == 1 and len(err) == 1 and 'report.json' in err[0], err
  assert not out.exists()


@pytest.mark.parametrize('name', ['../../x', '/tmp/abs'])
def test_planners_name_override_stays_inside_output_dir(
    name, tmp_path, capsys, benchmark_script):
  script = benchmark_script('planners.py')
  out = tmp_path / 'a' / 'out'
  assert script.main([f'--output_dir={out}', f'--name_override={name}',
                      '--suite=latex_small', '--seeds=0']) == 2
  assert '--name_override must be a plain file name' in helpers.one_line(
      capsys, 'benchmarks/planners.py')
  assert not list(tmp_path.rglob('*.json'))
