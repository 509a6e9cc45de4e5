# coding=utf-8
"""ble_latex.run.speed: what the speed benchmarks share (issue 66)."""

import json

import jax.numpy as jnp
import numpy as np

from ble_latex.flight import params as params_lib
from ble_latex.run import speed


def test_the_header_names_the_command_machine_batch_and_load():
  header = speed.record_header('gas_step_speed.py', ['--batch=4'], 4)
  assert header['command'] == 'python benchmarks/gas_step_speed.py --batch=4'
  assert header['batch'] == 4
  assert set(header) == {'command', 'date', 'machine', 'batch',
                         'load_before'}
  assert 'CPUs' in header['machine']


def test_write_results_adds_the_machine_and_writes_json(tmp_path, capsys):
  path = tmp_path / 'r.json'
  results = {'x': 1}
  speed.write_results(results, (1.0, 2.0, 3.0), str(path), note='n; ')
  written = json.loads(path.read_text())
  assert written['x'] == 1
  assert written['machine']['loadavg_before'] == [1.0, 2.0, 3.0]
  assert {'cpus', 'platform', 'loadavg_after', 'command'} <= set(
      written['machine'])
  assert capsys.readouterr().out.startswith('n; load average before/after')


def test_time_compiled_reports_compile_size_and_best_call():
  r = speed.time_compiled(lambda x: x * 2.0, (jnp.ones(3),), 2)
  assert len(r['all_s']) == 2 and r['best_s'] == min(r['all_s'])
  assert r['stablehlo_lines'] > 0 and r['hlo_lines'] > 0
  assert r['compile_s'] >= 0.0 and r['lower_s'] >= 0.0


def test_the_timed_stride_flies_its_balloons_at_16_to_18_km():
  calm, flights = speed.stride_setup()
  u, v = calm(jnp.ones(2), 0.0, 0.0, 0.0)
  assert float(jnp.abs(u).sum() + jnp.abs(v).sum()) == 0.0
  _, states, actions, keys = flights(params_lib.make_flight_params(), 3)
  assert actions.shape == (3, 3) and keys.shape[0] == 3
  np.testing.assert_allclose(actions[0], [17500.0, 1.0, -1.0])
  assert states.pressure_pa.shape == (3,)

