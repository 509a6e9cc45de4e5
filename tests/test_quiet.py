"""Third-party start-up noise dropped, our own output kept (`quiet.py`)."""

import os
import sys
import warnings

from ble_latex import quiet


def test_quiet_passes_other_output_through(capfd):
  with quiet.third_party_noise():
    warnings.warn('ours', UserWarning)
    warnings.warn('Please import `interp1d` from the `scipy.interpolate` '
                  'namespace', DeprecationWarning)
    sys.stderr.write('an error of ours\n')
    os.write(2, b'I0000 00:00:1795331363.160793   18478 cudart_stub.cc:31] '
             b'Could not find cuda drivers on your machine, GPU will not be '
             b'used.\nE0000 native error\n')
  err = capfd.readouterr().err
  assert 'ours' in err and 'an error of ours' in err
  assert 'E0000 native error' in err
  assert 'interp1d' not in err and 'cuda drivers' not in err
