"""The jitted SAC trainer (ble_latex/agents/sac/trainer.py): its settings and
replay ring."""

from hypothesis import given
from hypothesis import settings
from hypothesis import strategies as st
import jax.numpy as jnp
import numpy as np
import pytest

import ble_latex  # noqa: F401  pylint: disable=unused-import
from ble_latex import errors
from ble_latex.agents.sac import core as sac_core
from ble_latex.agents.sac import trainer as sac_trainer


@pytest.mark.parametrize('name,value', [('num_envs', 0),
                                        ('updates_per_step', 1.5),
                                        ('batch_size', 0), ('gamma', 2.0),
                                        ('actor_learning_rate', float('nan'))])
def test_bad_settings_name_the_gin_binding(name, value):
  with pytest.raises(ValueError, match=f'sac_trainer_config.{name} must'):
    sac_trainer.TrainerConfig(**{name: value})


@settings(max_examples=30, deadline=None)
@given(st.lists(st.lists(st.booleans(), min_size=4, max_size=4), min_size=1,
                max_size=6))
def test_replay_ring_keeps_the_valid_rows_in_order(masks):
  capacity = 7
  replay = sac_trainer.Replay(
      obs=jnp.zeros((capacity, 2)), action=jnp.zeros((capacity, 3)),
      reward=jnp.zeros((capacity,)), next_obs=jnp.zeros((capacity, 2)),
      terminal=jnp.zeros((capacity,)), size=jnp.int32(0),
      cursor=jnp.int32(0))
  expected, counter = [], 0
  for mask in masks:
    rewards = jnp.arange(counter, counter + 4, dtype=jnp.float32)
    counter += 4
    replay = sac_trainer._add(  # pylint: disable=protected-access
        replay, jnp.zeros((4, 2)), jnp.zeros((4, 3)), rewards,
        jnp.zeros((4, 2)), jnp.zeros(4), jnp.asarray(mask))
    expected += [float(r) for r, m in zip(rewards, mask) if m]
  kept = expected[-capacity:]
  assert int(replay.size) == len(kept)
  assert int(replay.cursor) == len(expected) % capacity
  ring = np.asarray(replay.reward)
  stored = [ring[(len(expected) - len(kept) + i) % capacity]
            for i in range(len(kept))]
  assert stored == kept


# -- Sizes that drive memory, and integers beyond int64 (issue 48 item 13). ---
@pytest.mark.parametrize('name, value', [
    ('hidden_units', 2**70), ('hidden_units', 10**400),
    ('hidden_units', sac_core.MAX_HIDDEN_UNITS + 1),
    ('replay_capacity', sac_core.MAX_REPLAY_CAPACITY + 1),
    ('batch_size', 2**63), ('num_envs', sac_core.MAX_NUM_ENVS + 1),
    ('min_replay_history', 2**31), ('updates_per_step', 2**64)])
def test_sizes_beyond_their_bounds_are_one_line_config_errors(name, value):
  with pytest.raises(errors.ConfigError,
                     match=f'sac_trainer_config.{name} must be an integer'
                     ) as refused:
    sac_trainer.TrainerConfig(**{name: value})
  # One line; gin appends where it was called (commands drop that).
  assert str(refused.value).split('\n')[0].endswith(f'got {value!r}')


def test_train_command_refuses_hidden_units_beyond_int64(tmp_path, capsys):
  import gin  # pylint: disable=g-import-not-at-top
  from ble_latex.cli import train  # pylint: disable=g-import-not-at-top
  try:
    status = train.main([
        f'--base_dir={tmp_path}/run', '--trainer=jax', '--num_iterations=1',
        '--gin_bindings=sac_trainer_config.hidden_units = '
        '99999999999999999999999'])
  finally:
    gin.clear_config()
  err = capsys.readouterr().err
  assert status == 2, err
  assert err.startswith(
      'ble-latex-train: sac_trainer_config.hidden_units must be an integer '
      '>= 1 and <= 4096, got 99999999999999999999999') and (
          err.count('\n') == 1), err
  assert not (tmp_path / 'run').exists()  # Refused before anything starts.
