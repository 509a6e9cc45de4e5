"""A training run directory (ble_latex/run/run_dir.py): the resume check."""

import json
import os

import ble_latex  # noqa: F401  pylint: disable=unused-import
import pytest

from ble_latex import errors
from ble_latex.run import episode_log
from ble_latex.run import run_dir


def _write_log(path, n):
  with open(path, 'w') as f:
    for i in range(n):
      f.write(json.dumps({'episode': i}) + '\n')


@pytest.mark.parametrize('logged,start_iteration,ok', [
    (0, 0, True), (1, 0, True), (2, 0, True),  # Killed in iteration 0.
    (4, 2, True), (5, 2, True), (6, 2, True),  # Up to one iteration past it.
    (7, 2, False),  # Checkpoints missing: would drop 3 logged episodes.
    (9, 0, False),  # No checkpoint at all but several iterations logged.
    (2, 2, False),  # Log shorter than the checkpoint: a gap.
])
def test_check_resume_protects_the_episode_log(tmp_path, logged,
                                               start_iteration, ok):
  log_path = tmp_path / episode_log.EPISODE_LOG
  _write_log(log_path, logged)
  snapshot = log_path.read_bytes()
  info = {'agent': 'sac', 'episodes_per_iteration': 2}
  check = lambda: run_dir.check_resume(  # pylint: disable=g-long-lambda
      str(tmp_path), info, start_iteration=start_iteration,
      episodes_per_iteration=2)
  if ok:
    check()
  else:
    with pytest.raises(errors.ResumeError, match='Nothing was changed'):
      check()
  assert log_path.read_bytes() == snapshot


def test_check_resume_without_a_bound_on_unsaved_iterations(tmp_path):
  """A trainer that checkpoints every few rounds: any number may be logged
  past the newest checkpoint; a gap is still refused; no log, no check."""
  _write_log(tmp_path / episode_log.EPISODE_LOG, 9)

  def check(start):
    run_dir.check_resume(str(tmp_path), {}, start_iteration=start,
                         episodes_per_iteration=2, unsaved_iterations=None)
  check(0)
  check(4)
  with pytest.raises(errors.ResumeError, match='episodes 9..9 would be'):
    check(5)
  run_dir.check_resume(str(tmp_path), {}, start_iteration=5,
                       episodes_per_iteration=2, log_episodes=False)


def test_check_resume_refuses_other_settings(tmp_path):
  (tmp_path / run_dir.RUN_INFO).write_text(
      json.dumps({'agent': 'sac', 'episodes_per_iteration': 10}))
  with pytest.raises(errors.ResumeError,
                     match='episodes_per_iteration=10.*episodes_per_iteration=5'):
    run_dir.check_resume(str(tmp_path), {'agent': 'sac',
                                         'episodes_per_iteration': 5},
                         start_iteration=0, episodes_per_iteration=5,
                         log_episodes=False)
  (tmp_path / run_dir.RUN_INFO).write_text('{torn')
  with pytest.raises(errors.ResumeError, match='unreadable'):
    run_dir.check_resume(str(tmp_path), {'agent': 'sac'}, start_iteration=0,
                         episodes_per_iteration=1, log_episodes=False)
  (tmp_path / run_dir.RUN_INFO).write_text('[1]')
  with pytest.raises(errors.ResumeError, match='not a JSON object'):
    run_dir.check_resume(str(tmp_path), {'agent': 'sac'}, start_iteration=0,
                         episodes_per_iteration=1, log_episodes=False)


def test_settings_added_since_a_run_started_count_with_their_defaults(
    tmp_path):
  run_dir.write_run_info(str(tmp_path), {'config': {'a': 1}})
  resume = lambda config: run_dir.check_resume(  # pylint: disable=g-long-lambda
      str(tmp_path), {'config': config}, start_iteration=0,
      episodes_per_iteration=1, log_episodes=False,
      defaults={'config': {'b': 'old'}})
  resume({'a': 1, 'b': 'old'})
  with pytest.raises(errors.ResumeError, match="'b': 'new'"):
    resume({'a': 1, 'b': 'new'})


@pytest.mark.parametrize('seed', [2**32, -1, 10**20, True])
def test_both_trainers_refuse_seeds_beyond_2_32(seed, tmp_path):
  from ble_latex.run import jax_train  # pylint: disable=g-import-not-at-top
  from ble_latex.run import train_lib  # pylint: disable=g-import-not-at-top
  with pytest.raises(errors.ConfigError, match='training seed'):
    train_lib.train(agent_name='sac', env_name='LatexBalloon-v0',
                    base_dir=str(tmp_path / 'a'), num_iterations=1,
                    episodes_per_iteration=1, max_episode_length=1,
                    collectors=[], seed=seed)
  with pytest.raises(errors.ConfigError, match='training seed'):
    jax_train.train_seeds(runs=[(seed, str(tmp_path / 'b'))],
                          num_iterations=1)
  assert not os.listdir(tmp_path)
