# coding=utf-8
"""The SAC policy shipped with ble_latex, registered as agent `sac_pretrained`.

`export_policy` strips a training checkpoint (replay buffer, optimiser states,
PRNG key, target networks) down to what acting needs: the config, the network
parameters and the temperature. The result ships as package data
(`ble_latex/agents/policies/sac_latex.pkl`) and `SACPretrainedAgent` loads it:

  ble-latex-eval --agent=sac_pretrained --suite=latex_small

  python -m ble_latex.agents.pretrained RUN/checkpoints/checkpoint_00049.pkl \
      ble_latex/agents/policies/sac_latex.pkl
"""

import os
import pickle
import sys
from typing import Any, Dict, Mapping, Optional, Sequence

import gin
import jax.numpy as jnp

from ble_latex.agents import sac

POLICY_FORMAT = 'ble_latex-sac-policy-v1'
DEFAULT_POLICY = os.path.join(os.path.dirname(__file__), 'policies',
                              'sac_latex.pkl')
_KEPT = ('config', 'iteration', 'training_steps', 'network_params',
         'log_alpha')


def export_policy(checkpoint_file: str, output_file: str,
                  note: str = '') -> Dict[str, Any]:
  """Writes the acting part of a SAC checkpoint to `output_file`."""
  with open(checkpoint_file, 'rb') as f:
    bundle = pickle.load(f)
  policy = policy_from_bundle(bundle, os.path.basename(checkpoint_file), note,
                              what=checkpoint_file)
  write_policy(policy, output_file)
  return policy


def policy_from_bundle(bundle: Mapping[str, Any], source: str, note: str = '',
                       what: str = 'bundle') -> Dict[str, Any]:
  """The acting part of a SAC checkpoint bundle (or `SACAgent.acting_bundle`).

  Args:
    bundle: A `SACAgent.bundle_and_checkpoint` or `acting_bundle` dict.
    source: Checkpoint file name recorded in the policy.
    note: Free text recorded in the policy.
    what: How to name the bundle in the error message.

  Returns:
    The policy dict (`POLICY_FORMAT`).

  Raises:
    ValueError: If `bundle` is not a ble_latex SAC checkpoint bundle.
  """
  if not isinstance(bundle, Mapping) or bundle.get(
      'format') != sac.CHECKPOINT_FORMAT:
    raise ValueError(f'{what} is not a ble_latex SAC checkpoint')
  policy = {k: bundle[k] for k in _KEPT}
  policy.update(format=POLICY_FORMAT, source=source, note=note)
  return policy


def write_policy(policy: Dict[str, Any], output_file: str) -> None:
  """Writes a policy dict (from `export_policy`/`load_policy`) atomically."""
  if policy.get('format') != POLICY_FORMAT:
    raise ValueError(f'not a {POLICY_FORMAT} policy')
  os.makedirs(os.path.dirname(os.path.abspath(output_file)), exist_ok=True)
  tmp = output_file + '.tmp'
  with open(tmp, 'wb') as f:
    pickle.dump(policy, f, protocol=pickle.HIGHEST_PROTOCOL)
  os.replace(tmp, output_file)


def load_policy(path: str) -> Dict[str, Any]:
  if not os.path.isfile(path):
    raise FileNotFoundError(f'No SAC policy file at {path}')
  with open(path, 'rb') as f:
    policy = pickle.load(f)
  if not isinstance(policy, dict) or policy.get('format') != POLICY_FORMAT:
    raise ValueError(f'{path} is not a ble_latex SAC policy ({POLICY_FORMAT})')
  return policy


@gin.configurable(denylist=['num_actions', 'observation_shape', 'action_low',
                            'action_high'])
class SACPretrainedAgent(sac.SACAgent):
  """`sac.SACAgent` with the shipped (or a given) policy loaded."""

  def __init__(self, num_actions: int, observation_shape: Sequence[int], *,
               action_low: Optional[Sequence[float]] = None,
               action_high: Optional[Sequence[float]] = None,
               seed: int = 0, policy_path: str = DEFAULT_POLICY,
               **kwargs: Any):
    policy = load_policy(policy_path)
    config = policy['config']
    kwargs.setdefault('num_layers', config['num_layers'])
    kwargs.setdefault('hidden_units', config['hidden_units'])
    super().__init__(num_actions, observation_shape, action_low=action_low,
                     action_high=action_high, seed=seed, **kwargs)
    mine = self._config()
    for key in ('observation_shape', 'num_actions', 'action_low',
                'action_high', 'num_layers', 'hidden_units'):
      if mine[key] != config[key]:
        raise ValueError(f'policy {policy_path} has {key}={config[key]}, '
                         f'this agent {mine[key]}')
    self.network_params = sac._to_device(policy['network_params'])  # pylint: disable=protected-access
    # Fine-tuning starts with the target networks equal to the online ones.
    self.target_params = self.network_params
    self.log_alpha = jnp.asarray(policy['log_alpha'])
    self.policy_info = {k: policy[k] for k in ('source', 'iteration',
                                               'training_steps', 'note')}

  def get_name(self) -> str:
    return 'sac_pretrained'


def main(argv: Sequence[str]) -> int:
  if len(argv) not in (3, 4):
    print(f'usage: {argv[0]} CHECKPOINT.pkl OUTPUT.pkl [NOTE]', file=sys.stderr)
    return 2
  policy = export_policy(argv[1], argv[2], argv[3] if len(argv) > 3 else '')
  print(f'wrote {argv[2]} ({os.path.getsize(argv[2]) / 1e6:.1f} MB) from '
        f'{policy["source"]}, iteration {policy["iteration"]}')
  return 0


if __name__ == '__main__':
  sys.exit(main(sys.argv))
