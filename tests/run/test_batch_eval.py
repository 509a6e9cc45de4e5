"""Agents that fly the JAX core fly batched in `ble-latex-eval` and Ray eval
(`ble_latex.run.batch_eval`, issue 48 item 24): the same records per seed as
one balloon at a time, routed there by `eval_lib.evaluate`, the command's
sharding and its lock kept."""

import json

import pytest

from ble_latex.cli import eval as eval_command
from ble_latex.run import batch_eval
from ble_latex.run import eval_lib
from ble_latex import safe_io

TINY = list(range(1_000_000, 1_000_010))  # latex_tiny's held-out seeds.
STRIDES = 6
# A latex_mpc small enough to compile in seconds; its wind memory and warm
# starts carry over replans (every 2 strides) as the default's do.
SMALL_MPC = ('LatexMpcAgent.num_samples = 8', 'LatexMpcAgent.horizon = 4',
             'LatexMpcAgent.num_segments = 2', 'LatexMpcAgent.replan_every = 2',
             'LatexMpcAgent.grid_levels = 2', 'LatexMpcAgent.beam_width = 4',
             'LatexMpcAgent.wind_memory = 2')
# The stated tolerances of one core against another (tests/ble/test_golden.py,
# issue 11): altitude 0.5 m, position 5 m, resources 1e-6 of the launch
# inventory (here relative to the value), reward 1e-3 per stride. Today the
# batched records equal the others bit for bit on this machine; XLA's
# batched kernels may sum in another order elsewhere.
ALTITUDE_TOL_M = 0.5  # [m]
POSITION_TOL_KM = 0.005  # [km]
RESOURCE_RTOL = 1e-6
REWARD_ATOL = 1e-3  # Per stride.


def _assert_records_match(batched, serial):
  assert [r['seed'] for r in batched] == [r['seed'] for r in serial]
  for b, s in zip(batched, serial):
    assert b.keys() == s.keys()
    for key in ('seed', 'steps', 'window_steps', 'terminal_reason', 'tw50',
                'tw50_window'):
      assert b[key] == s[key], (s['seed'], key)
    assert b['reward'] == pytest.approx(s['reward'],
                                        abs=REWARD_ATOL * s['steps'])
    for key in ('helium_vented_mols', 'sand_dropped_kg'):
      assert b[key] == pytest.approx(s[key], rel=RESOURCE_RTOL, abs=1e-9)
    assert b['final_distance_km'] == pytest.approx(s['final_distance_km'],
                                                   abs=POSITION_TOL_KM)
    assert len(b['flight_path']) == len(s['flight_path'])
    for p, q in zip(b['flight_path'], s['flight_path']):
      assert p.keys() == q.keys()
      assert (p['t_s'], p['decision']) == (q['t_s'], q['decision'])
      assert p['altitude_m'] == pytest.approx(q['altitude_m'],
                                              abs=ALTITUDE_TOL_M)
      for key in ('x_km', 'y_km'):
        assert p[key] == pytest.approx(q[key], abs=POSITION_TOL_KM)
      for key in ('helium_mols', 'sand_kg'):
        assert p[key] == pytest.approx(q[key], rel=RESOURCE_RTOL)


# Batches of at most 2 (and 1) balloons: the shapes every test here shares,
# so the batched step compiles twice in the module.
@pytest.mark.slow  # Flies each agent both ways (latex_mpc ~75 s).
@pytest.mark.parametrize('agent, bindings, seeds, batches', [
    ('sac_pretrained', (), TINY[:3], [TINY[:2], TINY[2:3]]),
    ('latex_mpc', SMALL_MPC, TINY[:2], [TINY[:2]]),
    ('latex_station_seeker', (), TINY[:3], [TINY[:2], TINY[2:3]]),
])
def test_batched_records_equal_one_balloon_at_a_time(agent, bindings, seeds,
                                                     batches, monkeypatch):
  agent_, env = eval_lib.build(eval_lib.EvalSpec(agent=agent,
                                                 gin_bindings=bindings))
  serial = eval_lib.evaluate(agent_, env, seeds, STRIDES, batched=False)
  flown = []
  fly_batch = batch_eval.fly_batch
  monkeypatch.setattr(batch_eval, 'fly_batch', lambda policy, env, seeds, n: (
      flown.append(list(seeds)) or fly_batch(policy, env, seeds, n)))
  monkeypatch.setattr(batch_eval, 'BATCH_SIZE', 2)
  batched = eval_lib.evaluate(agent_, env, seeds, STRIDES)
  assert flown == batches  # `eval_lib.evaluate` flew them batched, in order.
  _assert_records_match(batched, serial)
  # The one-at-a-time records after a batch are unchanged (the env and the
  # agent were left as they were).
  assert eval_lib.evaluate(agent_, env, seeds[:1], STRIDES,
                           batched=False) == serial[:1]


def test_an_ended_flight_stops_its_record_the_others_fly_on(monkeypatch):
  """A balloon whose flight ends (here: the episode's time limit at 4
  strides for every balloon, and a cap of 6) keeps the record the
  one-at-a-time loop writes: its steps, terminal reason and path end there."""
  agent, env = eval_lib.build(eval_lib.EvalSpec(
      agent='latex_station_seeker',
      gin_bindings=('latex_episode.episode_steps = 4',)))
  seeds = TINY[3:5]
  serial = eval_lib.evaluate(agent, env, seeds, STRIDES, batched=False)
  batched = batch_eval.evaluate(agent, env, seeds, STRIDES)
  assert [r['steps'] for r in batched] == [4, 4]
  assert {r['terminal_reason'] for r in batched} == {'time_limit'}
  _assert_records_match(batched, serial)


def test_batched_resets_compile_no_single_step_ahead(monkeypatch):
  """The batched path steps its own program: the gym env's resets compile
  `start` ahead but not the one-balloon `step` (a ~10 s compile that only
  the background thread would have run); the env's setting is restored."""
  from ble_latex.envs import gymnasium_compile  # pylint: disable=g-import-not-at-top
  asked = []
  ahead = gymnasium_compile.Compiled.ahead

  def recording(self, keys, params, normalized, step=True):
    asked.append(step)
    return ahead(self, keys, params, normalized, step)

  monkeypatch.setattr(gymnasium_compile.Compiled, 'ahead', recording)
  agent, env = eval_lib.build(eval_lib.EvalSpec(
      agent='latex_station_seeker',
      gin_bindings=('latex_episode.episode_steps = 2',)))
  asked.clear()  # The build's own reset.
  batch_eval.evaluate(agent, env, TINY[5:6], 2)
  assert asked == [False]
  assert env.unwrapped.arena.driver.compile_step_ahead
  env.reset(seed=0)  # One balloon at a time again: its step ahead.
  assert asked == [False, True]


@pytest.mark.parametrize('agent, env_name, bindings, batched', [
    ('sac_pretrained', 'LatexBalloon-v0', (), True),
    ('latex_mpc', 'LatexBalloon-v0', SMALL_MPC, True),
    ('latex_station_seeker', 'LatexBalloon-v0', (), True),
    # Its one random stream runs through the seeds in order.
    ('latex_random', 'LatexBalloon-v0', (), False),
    # BLE's agents on the discrete env.
    ('station_seeker', 'LatexBalloonDiscrete-v0', (), False),
])
def test_which_agents_fly_batched(agent, env_name, bindings, batched):
  agent_, env = eval_lib.build(eval_lib.EvalSpec(
      agent=agent, env_name=env_name, gin_bindings=bindings))
  assert batch_eval.flies_batched(agent_, env) is batched


def test_envs_the_core_cannot_fly_alone_keep_one_balloon_at_a_time():
  """A BLE reward function (over BLE's objects) or a BLE wind field flown
  through host callbacks: the batched core would fly another episode."""
  from balloon_learning_environment.env import wind_field  # pylint: disable=g-import-not-at-top
  from ble_latex.ble import gym_env  # pylint: disable=g-import-not-at-top
  from ble_latex.ble import reward  # pylint: disable=g-import-not-at-top
  agent, env = eval_lib.build(eval_lib.EvalSpec(
      agent='latex_station_seeker'))
  assert batch_eval.flies_batched(agent, env)
  for other in (gym_env.LatexBalloonEnv(reward_function=reward.latex_reward),
                gym_env.LatexBalloonEnv(
                    wind_field_factory=wind_field.SimpleStaticWindField)):
    assert batch_eval.core_env(other) is None
    assert not batch_eval.flies_batched(agent, other)


def test_eval_command_shards_and_locks_the_batched_path(tmp_path, capsys):
  argv = ['--agent=sac_pretrained', '--suite=latex_tiny', '--num_shards=5',
          '--shard_idx=3', f'--max_episode_length={STRIDES}',
          f'--output_dir={tmp_path}']
  path = eval_lib.output_path(str(tmp_path), 'latex_tiny', 'sac_pretrained',
                              5, 3)
  with safe_io.locked_file(path, what='eval output'):
    assert eval_command.main(argv) == 1  # Another writer holds the file.
  capsys.readouterr()
  assert eval_command.main(argv) == 0, capsys.readouterr().err[-2000:]
  with open(path) as f:
    written = json.load(f)
  assert [r['seed'] for r in written] == TINY[6:8]
  serial = eval_lib.evaluate(
      *eval_lib.build(eval_lib.EvalSpec(agent='sac_pretrained')), TINY[6:8],
      STRIDES, batched=False)
  # The command's records also name their winds (`wind_source`), station and
  # start, and each point its place and time (`tracks.locate`).
  assert all(r.pop('wind_source') for r in written)
  for record in written:
    for key in ('station_lat', 'station_lon', 'station_source', 'start_utc'):
      record.pop(key)
    for point in record['flight_path']:
      for key in ('lat', 'lon', 'utc'):
        point.pop(key)
  _assert_records_match(written, serial)


@pytest.mark.slow  # A local Ray whose two workers each compile (~1 min).
@pytest.mark.ci
def test_ray_flies_batches_and_names_each_seed_of_a_failed_one():
  ray = pytest.importorskip('ray')
  del ray
  from ble_latex.run import distributed  # pylint: disable=g-import-not-at-top
  spec = eval_lib.EvalSpec(agent='sac_pretrained')
  seeds = TINY[:5]
  distributed.connect('local', num_cpus=2)
  try:
    remote = distributed.evaluate(spec, seeds, STRIDES,
                                  batch_size=batch_eval.BATCH_SIZE)
    with pytest.raises(distributed.SeedsFailedError) as raised:
      distributed.evaluate(spec, [TINY[0], TINY[1], -7, TINY[2]], 3,
                           batch_size=batch_eval.BATCH_SIZE)
  finally:
    distributed.shutdown()
  serial = eval_lib.evaluate(*eval_lib.build(spec), seeds, STRIDES,
                             batched=False)
  _assert_records_match(remote, serial)
  # Two tasks of two seeds on 2 CPUs: the second, with seed -7, failed.
  assert sorted(raised.value.failures) == [-7, TINY[2]]
  assert [r['seed'] for r in raised.value.completed] == TINY[:2]
