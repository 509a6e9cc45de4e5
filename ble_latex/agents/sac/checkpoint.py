# coding=utf-8
"""The SAC agent's checkpoints: Dopamine's bundle API over msgpack files.

`SACCheckpoints` is the part of `sac.SACAgent` that writes and reads its
training state: one msgpack file per iteration (`checkpoint_NNNNN.msgpack`,
`ble_latex.safe_io`: data only, reading one cannot run code) holding
network, target and optimizer states, temperature and its optimizer state,
the PRNG key, the train-step counter and the filled part of the replay
buffer, written atomically (temporary file, fsync, rename). Dopamine pickles
the bundle and writes the replay buffer as a dozen separate, non-atomic
files and does not save the PRNG key. Pickled checkpoints of older ble_latex
versions are read only with `trust_legacy_pickle=True`.

Everything read is checked before the agent changes (`unbundle`): shapes,
dtypes and finiteness of every array (`sac_core.restore_like`), the config
(`sac_core.file_config`), and the replay buffer's counters against its
arrays and capacity (`restore_replay`).
"""

import os
from typing import Any, Dict, Mapping, Optional, Sequence

from absl import logging
from dopamine.replay_memory import circular_replay_buffer
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import run_files
from ble_latex import safe_io
from ble_latex.agents.sac import core as sac_core

_STORE_PREFIX = circular_replay_buffer.STORE_FILENAME_PREFIX


class SACCheckpoints:
  """Checkpoint I/O of `sac.SACAgent` (a mixin: it reads the agent's state).

  Uses the agent's `network_params`, `target_params`, `optimizer_state`,
  `log_alpha`, `alpha_optimizer_state`, `_rng`, `state`, `training_steps`,
  `_replay` (built by `_build_replay_buffer`), `_config()` and
  `_checkpoint_duration`, `_trust_legacy_pickle`.
  """

  def _replay_bundle(self) -> Dict[str, Any]:
    """The replay buffer's state; stored arrays cut to their filled part."""
    filled = min(int(self._replay.add_count), self._replay_capacity)
    bundle = {}
    for name, value in self._replay._return_checkpointable_elements().items():  # pylint: disable=protected-access
      if name.startswith(_STORE_PREFIX):
        bundle[name] = np.array(value[:filled])
      elif name == 'episode_end_indices':
        bundle[name] = np.array(sorted(value), dtype=np.int64)
      elif isinstance(value, np.ndarray):
        bundle[name] = np.array(value)
      else:
        raise TypeError(f'unexpected replay buffer member {name!r} '
                        f'({type(value).__name__})')
    bundle['_next_experience_is_episode_start'] = bool(
        self._replay._next_experience_is_episode_start)  # pylint: disable=protected-access
    return bundle

  def _restore_replay(self, bundle: Mapping[str, Any]) -> None:
    """Replaces the replay buffer by a fresh one filled from `bundle`.

    Raises before anything of the agent changes (`restore_replay`).
    """
    self._replay = restore_replay(self._build_replay_buffer(), bundle)

  def bundle_and_checkpoint(self, checkpoint_dir: str,
                            iteration_number: int) -> Dict[str, Any]:
    """The agent's full training state as a data-only dict (Dopamine API).

    Args:
      checkpoint_dir: Unused (everything is in the returned dict).
      iteration_number: Iteration the bundle belongs to.

    Returns:
      Dict with the format tag, config, train-step counter, PRNG key, online
      and target parameters, optimizer states (as lists of arrays), log(alpha)
      and the replay; only dicts, lists, numbers, strings and NumPy arrays
      (`safe_io.write_tree`).
    """
    del checkpoint_dir
    bundle = self.acting_bundle(iteration_number)
    self._check_finite(target_params=self.target_params,
                       optimizer_state=self.optimizer_state,
                       alpha_optimizer_state=self.alpha_optimizer_state)
    leaves = jax.tree_util.tree_leaves
    bundle.update(
        rng=np.asarray(self._rng),
        state=np.array(self.state),
        target_params=sac_core.to_numpy(self.target_params),
        optimizer_state=[np.asarray(x) for x in leaves(sac_core.to_numpy(
            self.optimizer_state))],
        alpha_optimizer_state=[np.asarray(x) for x in leaves(sac_core.to_numpy(
            self.alpha_optimizer_state))],
        replay=self._replay_bundle())
    return bundle

  def acting_bundle(self, iteration_number: int) -> Dict[str, Any]:
    """The part of `bundle_and_checkpoint` that acting needs.

    Format tag, iteration, config, train-step counter, online network
    parameters and log(alpha); no replay buffer, optimizer or target states.

    Args:
      iteration_number: Iteration the bundle belongs to.

    Returns:
      A dict with those entries, as in a checkpoint.

    Raises:
      sac_core.TrainingDiverged: If the parameters or log(alpha) hold NaN / inf
        (nothing is written from them).
    """
    self._check_finite(network_params=self.network_params,
                       log_alpha=self.log_alpha)
    return {
        'format': sac_core.CHECKPOINT_FORMAT,
        'iteration': int(iteration_number),
        'config': self._config(),
        'training_steps': int(self.training_steps),
        'network_params': sac_core.to_numpy(self.network_params),
        'log_alpha': np.asarray(self.log_alpha),
    }

  def _check_finite(self, **trees: Any) -> None:
    """Raises TrainingDiverged naming the trees that hold NaN / inf."""
    bad = {name: int(sac_core.nonfinite_count(tree))
           for name, tree in trees.items()}
    bad = {name: n for name, n in bad.items() if n}
    if bad:
      raise sac_core.TrainingDiverged(
          f'training diverged at training step {self.training_steps}: '
          f'non-finite {", ".join(f"{k} ({n} values)" for k, n in bad.items())}'
          '; no checkpoint or policy is written from it (the newest one on '
          'disk is the last good one)')

  def check_config(self, config: Any, what: str,
                   keys: Optional[Sequence[str]] = None) -> None:
    """Raises ValueError unless `config` (from a file) matches this agent's.

    Args:
      config: The `config` entry of a checkpoint or policy (`file_config`
        checks it first).
      what: The file, for the message.
      keys: The entries that must be equal (default: all of this agent's;
        a policy compares `ACTING_CONFIG_KEYS`).
    """
    mine = self._config()
    theirs = sac_core.file_config(config, what)
    keys = list(mine) if keys is None else list(keys)
    differ = [k for k in keys if theirs.get(k) != mine[k]]
    if differ:
      raise ValueError(
          f'{what}: its config has '
          f'{", ".join(f"{k}={theirs.get(k)!r}" for k in differ)}; this '
          f'agent has {", ".join(f"{k}={mine[k]!r}" for k in differ)}')

  def restore_network(self, network_params: Any, what: str) -> Any:
    """Network parameters from a file, checked against this agent's shapes."""
    return sac_core.restore_like(self.network_params, network_params,
                         f'{what}: network_params')

  def unbundle(self, checkpoint_dir: str, iteration_number: int,
               bundle_dictionary: Mapping[str, Any]) -> bool:
    """Restores the state written by `bundle_and_checkpoint` (Dopamine API).

    Nothing of the agent changes unless the whole bundle is valid.

    Args:
      checkpoint_dir: Unused.
      iteration_number: Unused (the bundle carries its own).
      bundle_dictionary: A dict from `bundle_and_checkpoint` (or a legacy
        pickle's, format `LEGACY_CHECKPOINT_FORMAT`).

    Returns:
      True.

    Raises:
      ValueError: If the bundle is not an ble_latex SAC checkpoint, misses an
        entry, or was written by an agent with a different shape / action box
        / network.
    """
    del checkpoint_dir, iteration_number
    bundle = bundle_dictionary
    what = 'checkpoint'
    if not isinstance(bundle, Mapping) or bundle.get('format') not in (
        sac_core.CHECKPOINT_FORMAT, sac_core.LEGACY_CHECKPOINT_FORMAT):
      raise ValueError('not a ble_latex SAC checkpoint (format '
                       f'{sac_core.CHECKPOINT_FORMAT!r} expected)')
    legacy = bundle['format'] == sac_core.LEGACY_CHECKPOINT_FORMAT
    needed = ('config', 'training_steps', 'rng', 'state', 'network_params',
              'target_params', 'optimizer_state', 'log_alpha',
              'alpha_optimizer_state', 'replay')
    missing = [k for k in needed if k not in bundle]
    if missing:
      raise ValueError(f'{what} misses {missing}')
    self.check_config(bundle['config'], what)
    training_steps = safe_io.checked_count(bundle['training_steps'],
                                           f'{what}: training_steps')
    if 'iteration' in bundle:
      safe_io.checked_count(bundle['iteration'], f'{what}: iteration')

    def opt_leaves(value):
      return jax.tree_util.tree_leaves(value) if legacy else value

    network_params = self.restore_network(bundle['network_params'], what)
    target_params = sac_core.restore_like(
        self.target_params, bundle['target_params'], f'{what}: target_params')
    optimizer_state = sac_core.restore_like(
        self.optimizer_state, opt_leaves(bundle['optimizer_state']),
        f'{what}: optimizer_state')
    alpha_optimizer_state = sac_core.restore_like(
        self.alpha_optimizer_state, opt_leaves(bundle['alpha_optimizer_state']),
        f'{what}: alpha_optimizer_state')
    log_alpha = sac_core.restore_like(self.log_alpha, bundle['log_alpha'],
                              f'{what}: log_alpha')
    rng = safe_io.checked_array(bundle['rng'], f'{what}: rng', kind='int',
                                shape=(2,)).astype(np.uint32)
    state = np.array(safe_io.checked_array(
        bundle['state'], f'{what}: state', shape=np.shape(self.state)))
    self._restore_replay(bundle['replay'])  # Raises before replacing.
    self.training_steps = training_steps
    self._rng = jnp.asarray(rng)
    self.state = state
    self.network_params = network_params
    self.target_params = target_params
    self.optimizer_state = optimizer_state
    self.log_alpha = log_alpha
    self.alpha_optimizer_state = alpha_optimizer_state
    self._episode_started = False
    return True

  def save_checkpoint(self, checkpoint_dir: str, iteration_number: int) -> None:
    """Writes checkpoint_dir/checkpoint_NNNNN.msgpack atomically.

    Call it between episodes (BLE does, after each iteration): the state of
    an unfinished episode is not saved. Numbered checkpoints older than
    `checkpoint_duration` iterations are removed afterwards.

    Args:
      checkpoint_dir: Folder of the checkpoints (created if missing).
      iteration_number: Iteration just completed.
    """
    os.makedirs(checkpoint_dir, exist_ok=True)
    safe_io.remove_stale_temporaries(checkpoint_dir, 'checkpoint_')
    bundle = self.bundle_and_checkpoint(checkpoint_dir, iteration_number)
    safe_io.write_tree(
        run_files.checkpoint_file(checkpoint_dir, iteration_number), bundle,
        file_format=sac_core.CHECKPOINT_FORMAT)
    if self._checkpoint_duration is not None:
      for old in run_files.iterations(checkpoint_dir):
        if old < iteration_number - self._checkpoint_duration:
          os.remove(run_files.checkpoint_file(checkpoint_dir, old))

  def load_checkpoint(self, checkpoint_dir: str, iteration_number: int) -> None:
    """Restores the checkpoint of `iteration_number`.

    Reads `checkpoint_NNNNN.msgpack`; a legacy `checkpoint_NNNNN.pkl` only
    with `trust_legacy_pickle=True`. The agent is unchanged on any error.

    Args:
      checkpoint_dir: Folder of the checkpoints.
      iteration_number: Iteration to restore.

    Raises:
      FileNotFoundError: If there is no such checkpoint.
      safe_io.UntrustedFileError: If only a legacy pickle exists and
        `trust_legacy_pickle` is False.
      ValueError: If the file is truncated, corrupt or not a compatible SAC
        checkpoint (the message names the file).
    """
    path = run_files.checkpoint_file(checkpoint_dir, iteration_number)
    legacy = run_files.legacy_checkpoint_file(checkpoint_dir, iteration_number)
    if not os.path.exists(path) and os.path.exists(legacy):
      path = legacy
      bundle = safe_io.read_legacy_pickle(
          legacy, trust=self._trust_legacy_pickle, what='SAC checkpoint')
    else:
      bundle = safe_io.read_tree(path, file_format=sac_core.CHECKPOINT_FORMAT,
                                 what='SAC checkpoint')
    with safe_io.checking(f'SAC checkpoint {path}: '):
      self.unbundle(checkpoint_dir, iteration_number, bundle)
    logging.info('Restored SAC checkpoint %s (training step %d, replay %d).',
                 path, self.training_steps, self.replay_size)

  def reload_latest_checkpoint(self, checkpoint_dir: str) -> int:
    """Loads the newest numbered checkpoint in `checkpoint_dir`, if any.

    Only `checkpoint_NNNNN.msgpack` files count (legacy `.pkl` ones with
    `trust_legacy_pickle=True`); other files in the folder are ignored.

    Args:
      checkpoint_dir: Folder of the checkpoints.

    Returns:
      The iteration number of the loaded checkpoint (BLE's `Agent` semantics:
      training resumes at that number + 1), or -1 if there is none.

    Raises:
      safe_io.UntrustedFileError: If the folder holds only legacy pickle
        checkpoints and `trust_legacy_pickle` is False.
      ValueError: If the newest checkpoint cannot be read (never falls back
        silently to starting over).
    """
    iterations = run_files.iterations(checkpoint_dir)
    legacy = run_files.iterations(
        checkpoint_dir, run_files.LEGACY_CHECKPOINT_PATTERN)
    if legacy and (not iterations or legacy[-1] > iterations[-1]):
      if not self._trust_legacy_pickle:
        newest = run_files.legacy_checkpoint_file(checkpoint_dir, legacy[-1])
        raise safe_io.UntrustedFileError(
            f'{checkpoint_dir} holds legacy pickle checkpoints (newest '
            f'{os.path.basename(newest)}'
            '); pickles can run code. If you made them, resume with '
            "--gin_bindings='ble_latex.agents.sac.SACAgent.trust_legacy_pickle = True' "
            '(docs/trusted-files.md).')
      iterations = legacy
    if not iterations:
      return -1
    self.load_checkpoint(checkpoint_dir, iterations[-1])
    return iterations[-1]


def restore_replay(replay: circular_replay_buffer.OutOfGraphReplayBuffer,
                   bundle: Mapping[str, Any]
                   ) -> circular_replay_buffer.OutOfGraphReplayBuffer:
  """Fills a fresh, empty Dopamine buffer from a checkpoint's replay entry.

  Checked first, so that no transition is made up or lost: `add_count`
  transitions were added, so every stored array holds exactly
  min(add_count, capacity) rows of the buffer's row shape (the cursor,
  add_count mod capacity, is where the next one goes; a count beyond the
  rows would have zero rows sampled and real ones overwritten);
  `invalid_range` is Dopamine's for that cursor; episode ends are filled
  rows.

  Args:
    replay: A new buffer of this agent's capacity and shapes (filled here).
    bundle: The checkpoint's `replay` entry (`SACCheckpoints._replay_bundle`).

  Returns:
    `replay`, filled.

  Raises:
    ValueError: Naming the entry (`replay <name>`) that is missing, of
      another shape or kind, or inconsistent with the counters.
  """
  expected = set(replay._return_checkpointable_elements()) | {
      '_next_experience_is_episode_start'}
  if not isinstance(bundle, Mapping) or set(bundle) != expected:
    found = sorted(bundle) if isinstance(bundle, Mapping) else bundle
    raise ValueError(f'replay buffer entries differ: expected '
                     f'{sorted(expected)}, found {found!r}')
  capacity = replay._replay_capacity
  add_count = safe_io.checked_count(bundle['add_count'], 'replay add_count',
                                    high=np.iinfo(np.int64).max)
  filled = min(add_count, capacity)
  for name, value in bundle.items():
    if name.startswith(_STORE_PREFIX):
      array = replay._store[name[len(_STORE_PREFIX):]]
      value = safe_io.checked_array(
          value, f'replay {name}',
          kind='float' if array.dtype.kind == 'f' else 'int')
      if value.shape != (filled,) + array.shape[1:]:
        raise ValueError(
            f'replay {name} has shape {value.shape}; add_count {add_count} '
            f'in a buffer of capacity {capacity} needs '
            f'{(filled,) + array.shape[1:]}')
      array[:filled] = value
  cursor = add_count % capacity
  expected_invalid = np.asarray(
      replay.invalid_range if add_count == 0 else
      circular_replay_buffer.invalid_range(
          cursor, capacity, replay._stack_size,
          replay._update_horizon))
  invalid = np.asarray(bundle['invalid_range'])
  if (invalid.dtype.kind not in 'iuf' or
      invalid.shape != expected_invalid.shape or
      not np.array_equal(invalid, expected_invalid)):
    raise ValueError(f'replay invalid_range is {invalid.tolist()!r}; '
                     f'add_count {add_count} (cursor {cursor}) gives '
                     f'{expected_invalid.tolist()}')
  ends = bundle['episode_end_indices']
  if isinstance(ends, (set, frozenset)):  # Legacy pickles hold a set.
    ends = sorted(ends)
  ends = np.asarray(ends).reshape(-1)
  if ends.size:
    ends = safe_io.checked_array(ends, 'replay episode_end_indices',
                                 kind='int')
    if ends.min() < 0 or ends.max() >= filled:
      raise ValueError(f'replay episode_end_indices must be rows of the '
                       f'{filled} filled, got {ends.min()}..{ends.max()}')
  replay.episode_end_indices = {int(i) for i in ends}
  replay.add_count = np.array(add_count)
  replay.invalid_range = expected_invalid
  replay._next_experience_is_episode_start = bool(
      bundle['_next_experience_is_episode_start'])
  return replay
