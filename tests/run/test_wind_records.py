# coding=utf-8
"""Eval, train and launch records name a time series' source, run and lead
times (`wind_source`; issue 64, item 3). The series is one GRIB2 file of
the committed GFS slice at +72, +75, +78 h (`tests/wind/test_steps._write_steps`);
eval and train fly it with their default dates (the ERA5 split is for ERA5
files only).
"""

import json

import gin
import pytest

from tests.wind.test_steps import _write_steps  # pylint: disable=g-bad-import-order

HOURS = (72, 75, 78)
RUN = 'GRIB2 run 2011-10-08T00Z +72..+78 h'


@pytest.fixture(name='series')
def _series(tmp_path):
  gin.clear_config()
  yield _write_steps(tmp_path / 'steps.grib2', HOURS)
  gin.clear_config()


def test_the_bound_series_names_its_run_and_lead_times(series):
  """What eval's records and train's run.json write (`env_params.
  wind_source`), as the commands bind --wind_file."""
  from ble_latex.envs import env_params  # pylint: disable=g-import-not-at-top
  from ble_latex.run import gin_binding  # pylint: disable=g-import-not-at-top
  from ble_latex.run import wind_file  # pylint: disable=g-import-not-at-top
  gin_binding.bind_gin(None, None, [], [])
  bindings = wind_file.era5_bindings(series, None, 'eval')
  gin_binding.bind_gin(None, None, [], bindings)
  assert env_params.wind_source() == f"{RUN}: ['{series}']"


@pytest.mark.slow
def test_eval_records_name_the_run_and_lead_times(series, tmp_path, capsys):
  from ble_latex.cli import eval as eval_cli  # pylint: disable=g-import-not-at-top
  out = tmp_path / 'out'
  code = eval_cli.main([
      f'--output_dir={out}', '--agent=latex_station_seeker',
      '--suite=latex_micro', '--max_episode_length=2',
      '--gin_bindings=GriddedWindField.episode_hours=1.0',
      f'--wind_file={series}'])
  assert code == 0, capsys.readouterr().err
  records = json.loads((out / 'latex_micro' / 'latex_station_seeker.json'
                        ).read_text())
  assert records and all(r['wind_source'] == f"{RUN}: ['{series}']"
                         for r in records)


@pytest.mark.slow
def test_train_run_json_names_the_run_and_lead_times(series, tmp_path,
                                                      capsys):
  from ble_latex.cli import train  # pylint: disable=g-import-not-at-top
  run = tmp_path / 'run'
  code = train.main([
      f'--base_dir={run}', '--num_iterations=1', '--collectors=episodes',
      '--gin_bindings=ble_latex.agents.sac.SACAgent.min_replay_history=30',
      '--gin_bindings=ble_latex.agents.sac.SACAgent.batch_size=16',
      '--gin_bindings=ble_latex.agents.sac.SACAgent.hidden_units=16',
      '--max_episode_length=2', '--episodes_per_iteration=1',
      '--gin_bindings=GriddedWindField.episode_hours=1.0',
      f'--wind_file={series}'])
  assert code == 0, capsys.readouterr().err
  info = json.loads((run / 'run.json').read_text())
  assert info['wind_source'] == f"{RUN}: ['{series}']"


@pytest.mark.slow
def test_launch_world_names_the_run_and_lead_times(series):
  from ble_latex.launch import scoring  # pylint: disable=g-import-not-at-top
  world = scoring.era5_world(series, max_hours=1.0, steps=2)
  assert world.describe['wind_source'] == f"{RUN}: ['{series}']"
  assert world.describe['winds_vary_in_time']


# A planner small enough to compile in seconds (tests/agents/planning/test_planners.py's).
_SMALL_MPC = [f'--gin_bindings=LatexMpcAgent.{b}' for b in (
    'num_samples=8', 'iterations=1', 'horizon=4', 'num_segments=2',
    'replan_every=2', 'grid_levels=2')]


@pytest.mark.slow
def test_the_planner_flies_the_series_through_eval(series, tmp_path, capsys):
  """`ble-latex-eval --agent=latex_mpc` on the series (issue 64: the
  planners on a time series)."""
  from ble_latex.cli import eval as eval_cli  # pylint: disable=g-import-not-at-top
  out = tmp_path / 'out'
  code = eval_cli.main([
      f'--output_dir={out}', '--agent=latex_mpc', '--suite=latex_micro',
      '--max_episode_length=3', '--gin_bindings=GriddedWindField.episode_hours=1.0',
      *_SMALL_MPC, f'--wind_file={series}'])
  assert code == 0, capsys.readouterr().err
  records = json.loads((out / 'latex_micro' / 'latex_mpc.json').read_text())
  assert records and all(r['wind_source'] == f"{RUN}: ['{series}']"
                         and r['steps'] == 3 for r in records)


@pytest.mark.slow
def test_the_planner_benchmark_flies_the_series(series, tmp_path,
                                                 benchmark_script):
  """benchmarks/planners.py --wind_file on the series: its records and
  timing name the run and lead times."""
  rc = benchmark_script('planners.py').main([
      '--agent=latex_mpc', '--suite=latex_small', '--num_seeds=2',
      '--max_episode_length=3', f'--output_dir={tmp_path}',
      '--gin_bindings=GriddedWindField.episode_hours=1.0', *_SMALL_MPC,
      f'--wind_file={series}'])
  assert rc == 0
  folder = tmp_path / 'latex_small'
  records = json.loads((folder / 'latex_mpc.json').read_text())
  timing = json.loads((folder / 'timing' / 'latex_mpc.json').read_text())
  assert len(records) == 2
  assert {r['wind_source'] for r in records} == {f"{RUN}: ['{series}']"}
  assert timing['wind_source'] == f"{RUN}: ['{series}']"


@pytest.mark.slow
def test_the_launch_command_flies_the_series(series, tmp_path):
  """`ble-latex-launch --wind_file` on the series: a tiny grid flies, and
  launches.json names the run and lead times."""
  from ble_latex.cli import launch  # pylint: disable=g-import-not-at-top
  out = tmp_path / 'out'
  assert launch.main([
      f'--output_dir={out}', f'--wind_file={series}', '--station_lat=10',
      '--station_lon=10', '--east_km=-30,30', '--north_km=-30,30',
      '--hours=0,1', '--grid=2,2,1', '--draws=1', '--max_steps=2',
      '--top=2', '--paths=0']) == 0
  record = json.loads((out / 'launches.json').read_text())
  assert record['world']['wind_source'] == f"{RUN}: ['{series}']"
  assert record['world']['winds_vary_in_time']
  assert len(record['grid_tw50_mean']) == 4
