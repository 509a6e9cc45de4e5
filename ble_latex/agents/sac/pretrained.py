# coding=utf-8
r"""The SAC policy shipped with ble_latex, registered as agent `sac_pretrained`.

`export_policy` strips a training checkpoint (replay buffer, optimiser states,
PRNG key, target networks) down to what acting needs: the config, the network
parameters and the temperature. Policies are msgpack data files
(`ble_latex.safe_io`; reading one cannot run code). Two are shipped as package
data: `policies/sac_latex.msgpack`, trained on the paper's physics, and
`policies/sac_latex_realistic.msgpack`, trained on the calibrated realistic
latex physics (gin_configs/latex_realistic.gin; seed 2 of
benchmarks/sac_jax/realistic_calibrated, chosen on validation). `sac.SACPretrainedAgent` (the BLE agent)
loads the one of the physics gin binds (`shipped_policy`), or the file its
`policy_path` names:

  ble-latex-eval --agent=sac_pretrained --suite=latex_small
  ble-latex-eval --agent=sac_pretrained --suite=latex_small \
      --gin_file=gin_configs/latex_realistic.gin

  ble-latex-export-policy \
      --checkpoint=RUN/checkpoints/checkpoint_00049.msgpack \
      --output=ble_latex/agents/policies/sac_latex.msgpack

Pickled policies and checkpoints of ble_latex <= 0.1 (`*.pkl`) are read only
with `trust_legacy_pickle=True` (`ble-latex-export-policy
--trust_legacy_pickle`, `SACPretrainedAgent.trust_legacy_pickle`); converting
one once gives a data-only file.
"""

import os
from typing import Any, Dict, Mapping

from ble_latex import errors
from ble_latex import safe_io
from ble_latex.agents.sac import core as sac_core

POLICY_FORMAT = 'ble_latex-sac-policy-v2'  # msgpack (`safe_io`).
LEGACY_POLICY_FORMAT = 'ble_latex-sac-policy-v1'  # Pickles of ble_latex <= 0.1.
POLICY_SUFFIX = '.msgpack'
# The shipped policies (package data of `ble_latex.agents`).
POLICY_DIR = os.path.join(os.path.dirname(os.path.dirname(__file__)),
                          'policies')
DEFAULT_POLICY = os.path.join(POLICY_DIR, 'sac_latex' + POLICY_SUFFIX)
REALISTIC_POLICY = os.path.join(POLICY_DIR,
                                'sac_latex_realistic' + POLICY_SUFFIX)
# `ensemble.SACEnsembleAgent`'s default members (agent `sac_ensemble`),
# each seed's policy chosen on latex_validation: the SAC seeds trained on
# the drifted wind column (gin_configs/latex_wind_lookahead.gin;
# benchmarks/sac_jax/wind_lookahead12), on the column corrected by the
# measured winds (gin_configs/latex_wind_memory.gin; .../wind_memory16) and
# on both (gin_configs/latex_wind_memory_lookahead.gin;
# .../memory_lookahead), each member on its own view. This set validated
# best among the declared candidates (benchmarks/ensemble/results.json
# `shipped`).
SHIPPED_ENSEMBLE = tuple(
    os.path.join(POLICY_DIR, f'sac_latex_{name}' + POLICY_SUFFIX)
    for name in [f'drifts_{k}' for k in range(6)] +
    [f'memory_{k}' for k in range(5)] + ['both_0'])
_KEPT = ('config', 'iteration', 'training_steps', 'network_params',
         'log_alpha')
_TEXT = ('source', 'note')


def shipped_policy(realistic: bool) -> str:
  """The shipped policy trained on the paper's or the realistic physics.

  Args:
    realistic: The env flies realistic latex physics
      (`flight.params.FlightParams.realistic`).

  Returns:
    `REALISTIC_POLICY` or `DEFAULT_POLICY`.
  """
  return REALISTIC_POLICY if realistic else DEFAULT_POLICY


def shipped_ensemble(realistic: bool) -> tuple:
  """The shipped ensemble's member files (paper physics only).

  Raises:
    errors.ConfigError: Under realistic physics (none is shipped).
  """
  if realistic:
    raise errors.ConfigError(
        'no SAC ensemble is shipped for realistic physics; give '
        'SACEnsembleAgent.policy_paths')
  return SHIPPED_ENSEMBLE


def _is_pickle_path(path: str) -> bool:
  return path.endswith('.pkl')


def read_checkpoint(path: str, trust_legacy_pickle: bool = False
                   ) -> Mapping[str, Any]:
  """A SAC checkpoint file's bundle (`.msgpack`, or a trusted legacy `.pkl`)."""
  if _is_pickle_path(path):
    return safe_io.read_legacy_pickle(path, trust=trust_legacy_pickle,
                                      what='SAC checkpoint')
  return safe_io.read_tree(path, file_format=sac_core.CHECKPOINT_FORMAT,
                           what='SAC checkpoint')


def export_policy(checkpoint_file: str, output_file: str, note: str = '',
                  trust_legacy_pickle: bool = False) -> Dict[str, Any]:
  """Writes the acting part of a SAC checkpoint to `output_file`.

  Args:
    checkpoint_file: A `checkpoint_NNNNN.msgpack` (or, trusted, `.pkl`).
    output_file: The policy file to write (`.msgpack`).
    note: Free text recorded in the policy.
    trust_legacy_pickle: Allow reading a legacy pickle checkpoint.

  Returns:
    The policy dict written.

  Raises:
    errors.BadFileError: The checkpoint is unreadable or refused (named).
  """
  bundle = read_checkpoint(checkpoint_file, trust_legacy_pickle)
  with safe_io.checking():
    policy = policy_from_bundle(bundle, os.path.basename(checkpoint_file),
                                note, what=checkpoint_file)
  write_policy(policy, output_file)
  return policy


def policy_from_bundle(bundle: Mapping[str, Any], source: str, note: str = '',
                       what: str = 'bundle') -> Dict[str, Any]:
  """The acting part of a SAC checkpoint bundle (or `SACAgent.acting_bundle`).

  Args:
    bundle: A `SACAgent.bundle_and_checkpoint` or `acting_bundle` dict (or a
      legacy checkpoint's).
    source: Checkpoint file name recorded in the policy.
    note: Free text recorded in the policy.
    what: How to name the bundle in the error message.

  Returns:
    The policy dict (`POLICY_FORMAT`).

  Raises:
    ValueError: If `bundle` is not a ble_latex SAC checkpoint bundle.
  """
  if not isinstance(bundle, Mapping) or bundle.get('format') not in (
      sac_core.CHECKPOINT_FORMAT, sac_core.LEGACY_CHECKPOINT_FORMAT):
    raise ValueError(f'{what} is not a ble_latex SAC checkpoint')
  missing = [k for k in _KEPT if k not in bundle]
  if missing:
    raise ValueError(f'{what} misses {missing}')
  policy = {k: bundle[k] for k in _KEPT}
  policy.update(format=POLICY_FORMAT, source=source, note=note)
  return check_policy(policy, what)


def check_policy(policy: Dict[str, Any], what: str) -> Dict[str, Any]:
  """Checks a policy's values before anything is built from them.

  The config (`sac_core.file_config`: types, sizes within
  `sac_core.MAX_NUM_LAYERS` / `sac_core.MAX_HIDDEN_UNITS`, ...), then the
  network parameters against the shapes that config implies (computed
  abstractly, nothing allocated): real floating point and finite, leaf by
  leaf; `log_alpha` a finite float of shape (1,); `iteration` and
  `training_steps` integers >= 0.

  Args:
    policy: A policy dict (`POLICY_FORMAT`).
    what: The file (or bundle), for the message.

  Returns:
    The policy with its config normalised and its arrays as NumPy arrays.

  Raises:
    ValueError: Naming `what` and the entry or leaf.
  """
  policy = dict(policy)
  policy['config'] = sac_core.file_config(policy['config'], what)
  policy['network_params'] = sac_core.check_like(
      sac_core.network_shapes(policy['config']), policy['network_params'],
      f'{what}: network_params')
  policy['log_alpha'] = safe_io.checked_array(
      policy['log_alpha'], f'{what}: log_alpha', shape=(1,))
  for key in ('iteration', 'training_steps'):
    policy[key] = safe_io.checked_count(policy[key], f'{what}: {key}')
  return policy


def write_policy(policy: Dict[str, Any], output_file: str) -> None:
  """Writes a policy dict (from `export_policy`/`load_policy`) atomically."""
  if policy.get('format') != POLICY_FORMAT:
    raise ValueError(f'not a {POLICY_FORMAT} policy')
  if _is_pickle_path(output_file):  # A usage error: one line, exit 2.
    raise errors.ConfigError(f'{output_file}: policies are msgpack files; '
                             f'use a {POLICY_SUFFIX} name')
  safe_io.write_tree(output_file, policy, file_format=POLICY_FORMAT)


def load_policy(path: str, trust_legacy_pickle: bool = False
               ) -> Dict[str, Any]:
  """Reads and checks a policy file.

  Args:
    path: A `.msgpack` policy, or (with `trust_legacy_pickle`) a legacy
      `.pkl` one.
    trust_legacy_pickle: Allow a legacy pickle (it can run code).

  Returns:
    The policy dict, converted to `POLICY_FORMAT`.

  Raises:
    FileNotFoundError: If `path` does not exist.
    safe_io.UntrustedFileError: For a pickle without the opt-in.
    errors.BadFileError: If the file is truncated, corrupt or not a policy;
      the message names `path`.
  """
  if _is_pickle_path(path):
    policy = safe_io.read_legacy_pickle(path, trust=trust_legacy_pickle,
                                        what='SAC policy')
    if not isinstance(policy, dict) or policy.get(
        'format') != LEGACY_POLICY_FORMAT:
      raise errors.BadFileError(f'{path} is not a ble_latex SAC policy '
                                f'({LEGACY_POLICY_FORMAT})')
    policy = dict(policy, format=POLICY_FORMAT)
  else:
    policy = safe_io.read_tree(path, file_format=POLICY_FORMAT,
                               what='SAC policy',
                               max_bytes=safe_io.MAX_POLICY_BYTES)
  missing = [k for k in (*_KEPT, *_TEXT) if k not in policy]
  if missing:
    raise errors.BadFileError(f'SAC policy {path} misses {missing}')
  with safe_io.checking():
    return check_policy(policy, f'SAC policy {path}')
