# coding=utf-8
"""DAgger distillation (agents/dagger.py, its driver run/dagger.py): tiny
rounds on the batched core."""

import json
import os

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from ble_latex import errors
from ble_latex.agents import dagger as algorithm
from ble_latex.agents.planning import config as plan_config
from ble_latex.agents.sac import pretrained
from ble_latex.run import dagger

# DAgger rounds fly planners and fit networks (~150 s loaded): make test-slow.
pytestmark = pytest.mark.slow

# A teacher small enough to compile and fly in seconds (the real one is
# `latex_mpc`'s beam search; the algorithm is the same).
TEACHER = plan_config.PlannerConfig(
    mode=plan_config.FORECAST, search=plan_config.CEM, num_samples=8,
    iterations=1, horizon=4, num_segments=2, replan_every=2, grid_levels=2)
TINY = dict(num_balloons=2, episode_steps=4, num_layers=1, hidden_units=16,
            batch_size=8, fit_steps=5, dataset_capacity=64,
            validation_seeds=2, beta0=0.5)
_TIMES = ('fly_s', 'fit_s', 'validate_s', 'loadavg')


def _train(base_dir, num_rounds, **overrides):
  config = dagger.DaggerConfig(**{**TINY, **overrides})
  return dagger.train(base_dir=str(base_dir), num_rounds=num_rounds,
                      config=config, teacher=TEACHER, log=lambda _: None)


def _untimed(records):
  return [{k: v for k, v in r.items() if k not in _TIMES} for r in records]


@pytest.fixture(scope='module')
def runs(tmp_path_factory):
  """A run of 1 round resumed to 2, and a run of 2 rounds straight."""
  root = tmp_path_factory.mktemp('dagger')
  first = _train(root / 'resumed', 1)
  resumed = _train(root / 'resumed', 2)
  straight = _train(root / 'straight', 2)
  return root, first, resumed, straight


def test_a_round_runs_and_records(runs):
  root, first, _, _ = runs
  (record,) = first['rounds']
  assert record['round'] == 0 and record['labelled'] == 2 * 4
  assert 0.0 <= record['validation']['tw50_window_mean'] <= 1.0
  assert np.isfinite(record['fit_loss'])
  summary = json.loads((root / 'resumed' / dagger.SUMMARY).read_text())
  assert summary['settings']['trainer'] == 'dagger'
  # Only the newest checkpoint is kept.
  assert sorted(os.listdir(root / 'resumed' / 'checkpoints')) == [
      'dagger_00001.msgpack']


def test_the_aggregate_grows(runs):
  _, _, resumed, _ = runs
  sizes = [r['dataset_size'] for r in resumed['rounds']]
  labelled = [r['labelled'] for r in resumed['rounds']]
  assert sizes == [labelled[0], labelled[0] + labelled[1]]
  assert sizes[1] > sizes[0]


def test_resume_continues_as_a_straight_run(runs):
  _, first, resumed, straight = runs
  assert _untimed(resumed['rounds'][:1]) == _untimed(first['rounds'])
  assert _untimed(resumed['rounds']) == _untimed(straight['rounds'])


def test_resume_refuses_other_settings(runs):
  root = runs[0]
  with pytest.raises(errors.ResumeError, match='fit_steps'):
    _train(root / 'resumed', 3, fit_steps=6)


def test_the_best_student_is_a_sac_policy(runs):
  root, _, resumed, _ = runs
  policy = pretrained.load_policy(str(root / 'resumed' / dagger.BEST_POLICY))
  assert policy['config']['hidden_units'] == 16
  assert resumed['best']['round'] in (0, 1)
  assert policy['iteration'] == resumed['best']['round']


def test_the_fit_lowers_the_imitation_loss_on_a_fixed_batch():
  student = algorithm.student_for(1, 16, 1e-2)
  params = algorithm.init_params(student, jax.random.PRNGKey(0))
  keys = jax.random.split(jax.random.PRNGKey(1), 2)
  obs = jax.random.uniform(keys[0], (32, 71), minval=-1.0, maxval=1.0)
  labels = jax.random.uniform(keys[1], (32, 3), minval=-0.9, maxval=0.9)
  before = algorithm.imitation_loss(student, params, obs, labels)
  fitted, _, _ = algorithm.fit(student, params, student.optimizer.init(params),
                               obs, labels, jnp.int32(32), 50, 32,
                               jax.random.PRNGKey(2))
  after = algorithm.imitation_loss(student, fitted, obs, labels)
  assert float(after) < 0.5 * float(before)


def test_the_aggregate_is_a_ring():
  data = algorithm.empty_aggregate(5)
  obs = np.arange(4 * 71, dtype=np.float32).reshape(4, 71)
  labels = np.arange(4 * 3, dtype=np.float32).reshape(4, 3)
  data = algorithm.aggregate(data, obs, labels)
  assert (data.size, data.cursor) == (4, 4)
  data = algorithm.aggregate(data, obs[:3] + 1000, labels[:3])
  assert (data.size, data.cursor) == (5, 2)
  np.testing.assert_array_equal(data.obs[0], obs[1] + 1000)
  np.testing.assert_array_equal(data.obs[3], obs[3])
  # More rows than fit at once: the newest are kept, in ring order.
  data = algorithm.aggregate(data, np.tile(obs, (2, 1)) + 5000,
                          np.tile(labels, (2, 1)))
  assert (data.size, data.cursor) == (5, 0)
  np.testing.assert_array_equal(data.obs[1:5], obs[[0, 1, 2, 3]] + 5000)
  np.testing.assert_array_equal(data.obs[0], obs[3] + 5000)


def test_from_box_inverts_to_box():
  from ble_latex.envs import jax_env  # pylint: disable=g-import-not-at-top
  u = jnp.array([[-1.0, -0.5, 1.0], [0.3, 0.0, -1.0]])
  np.testing.assert_allclose(algorithm.from_box(jax_env.to_box(u)), u,
                             atol=1e-6)


@pytest.mark.parametrize('overrides, name', [
    ({'num_balloons': 0}, 'dagger_config.num_balloons'),
    ({'teacher': 'nope'}, 'dagger_config.teacher'),
    ({'teacher': ['latex_mpc']}, 'dagger_config.teacher'),  # Was a TypeError.
    ({'beta0': 1.5}, 'dagger_config.beta0'),
    ({'learning_rate': float('nan')}, 'dagger_config.learning_rate'),
    ({'seed': -1}, 'dagger_config.seed'),
    ({'episode_steps': 217}, 'dagger_config.episode_steps'),
])
def test_bad_config_is_one_line(overrides, name):
  with pytest.raises(errors.ConfigError) as e:
    dagger.DaggerConfig(**{**TINY, **overrides})
  # One line; gin appends where it was called (commands drop that).
  assert name in str(e.value).split('\n')[0]


def test_episode_steps_must_fit_the_teachers_blocks(tmp_path):
  with pytest.raises(errors.ConfigError, match='replan_every') as e:
    _train(tmp_path / 'odd', 1, episode_steps=3)
  assert '\n' not in str(e.value)
  assert not (tmp_path / 'odd').exists()
