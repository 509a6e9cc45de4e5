"""sac_pretrained: exporting a checkpoint's policy and flying it."""

import ble_latex  # noqa: F401
from ble_latex.agents import pretrained
from ble_latex.agents import sac
from ble_latex import safe_io
import numpy as np
import pytest

_LOW = np.array([14000.0, 1.0, -1.0], dtype=np.float32)
_HIGH = np.array([21000.0, 5.0, 1.0], dtype=np.float32)


def _sac(hidden=16, seed=0):
  return sac.SACAgent(3, (71,), action_low=_LOW, action_high=_HIGH,
                      seed=seed, hidden_units=hidden, min_replay_history=8,
                      batch_size=4)


def _train_a_little(agent):
  rng = np.random.default_rng(0)
  agent.begin_episode(rng.uniform(-1, 1, 71).astype(np.float32))
  for _ in range(20):
    agent.step(float(rng.uniform()), rng.uniform(-1, 1, 71).astype(np.float32))
  agent.end_episode(0.5, False)


def test_exported_policy_acts_like_the_checkpoint(tmp_path):
  agent = _sac()
  _train_a_little(agent)
  agent.save_checkpoint(str(tmp_path), 0)
  policy_file = str(tmp_path / 'policy.msgpack')
  pretrained.export_policy(sac.checkpoint_path(str(tmp_path), 0), policy_file,
                           note='test')
  loaded = pretrained.SACPretrainedAgent(
      3, (71,), action_low=_LOW, action_high=_HIGH, seed=7, hidden_units=16,
      policy_path=policy_file)
  assert loaded.policy_info['note'] == 'test'
  agent.set_mode('eval')
  loaded.set_mode('eval')
  for obs in np.random.default_rng(1).uniform(-1, 1, (5, 71)):
    obs = obs.astype(np.float32)
    np.testing.assert_array_equal(agent.begin_episode(obs),
                                  loaded.begin_episode(obs))
  stored = safe_io.read_tree(policy_file, file_format=pretrained.POLICY_FORMAT)
  assert 'replay' not in stored  # Small: no replay buffer.


def test_bad_policy_files(tmp_path):
  with pytest.raises(FileNotFoundError):
    pretrained.load_policy(str(tmp_path / 'missing.msgpack'))
  bad = tmp_path / 'bad.msgpack'
  safe_io.write_tree(str(bad), {}, file_format='something else')
  with pytest.raises(ValueError, match='not a SAC policy'):
    pretrained.load_policy(str(bad))
  with pytest.raises(ValueError, match='not a SAC checkpoint'):
    pretrained.export_policy(str(bad), str(tmp_path / 'out.msgpack'))


def test_policy_for_other_shapes_is_rejected(tmp_path):
  agent = _sac(hidden=16)
  agent.save_checkpoint(str(tmp_path), 0)
  policy_file = str(tmp_path / 'policy.msgpack')
  pretrained.export_policy(sac.checkpoint_path(str(tmp_path), 0), policy_file)
  with pytest.raises(ValueError, match='observation_shape'):
    pretrained.SACPretrainedAgent(3, (70,), action_low=_LOW,
                                  action_high=_HIGH, policy_path=policy_file)


def test_shipped_policy_flies_the_latex_env():
  import gym
  from ble_latex.run import runner
  env = gym.make('LatexBalloon-v0').unwrapped
  agent = runner.create_agent('sac_pretrained', env)
  # The jitted trainer's run it came from (README "Results").
  assert agent.policy_info['source'].startswith('benchmarks/sac_jax/n32/seed_')
  agent.set_mode('eval')
  obs = env.reset(seed=1_000_000)
  first = agent.begin_episode(obs)
  assert env.action_space.contains(first.astype(np.float32))
  for _ in range(5):
    obs, reward, done, _ = env.step(first)
    action = agent.step(reward, obs)
    assert env.action_space.contains(action.astype(np.float32))
  # Deterministic in eval mode: the same observation, the same action.
  np.testing.assert_array_equal(agent.begin_episode(obs),
                                agent.begin_episode(obs))


# How far the shipped policy's row may move between machines: XLA's CPU float
# paths differ (e.g. 61.25 % recorded on the machine of 2026-11-24, 61.16 %
# on that of 2026-11-25, the same file), and 3-day flights are chaotic.
ROW_TOLERANCE = {'tw50_window': 0.015, 'tw50': 0.015, 'reward_rel': 0.03,
                 'out_of_resources_pct': 3.0}


@pytest.mark.slow
def test_shipped_policy_reproduces_its_results_row():
  """README's sac_pretrained row (benchmarks/results.json), all 100 seeds.

  Equal within `ROW_TOLERANCE` (the row is re-made on the machine that
  ships a policy), and the issue's targets hold here too: TW50 over the
  window >= 60 % with <= 5 % of the flights out of resources.
  """
  import json
  import pathlib
  import gym
  from ble_latex.run import eval_lib
  from ble_latex.run import metrics
  from ble_latex.run import runner
  from ble_latex.run import suites
  root = pathlib.Path(__file__).resolve().parent.parent
  rows = json.loads((root / 'benchmarks' / 'results.json').read_text())
  (row,) = [r for r in rows if r['agent'] == 'sac_pretrained']
  env = gym.make('LatexBalloon-v0').unwrapped
  agent = runner.create_agent('sac_pretrained', env)
  suite = suites.get_eval_suite('latex_small')
  s = metrics.summarize(eval_lib.evaluate(agent, env, suite.seeds,
                                          suite.max_episode_length))
  assert s['episodes'] == row['episodes'] == 100
  assert s['tw50_window_mean'] == pytest.approx(
      row['tw50_window'][0], abs=ROW_TOLERANCE['tw50_window'])
  assert s['tw50_mean'] == pytest.approx(row['tw50'][0],
                                         abs=ROW_TOLERANCE['tw50'])
  assert s['reward_mean'] == pytest.approx(row['reward'][0],
                                           rel=ROW_TOLERANCE['reward_rel'])
  assert s['out_of_resources_pct'] == pytest.approx(
      row['out_of_resources_pct'], abs=ROW_TOLERANCE['out_of_resources_pct'])
  assert s['tw50_window_mean'] >= 0.60 and s['out_of_resources_pct'] <= 5.0
