"""What the tests share that is not a fixture: the folders they read, and
the one-line refusal check (tests/conftest.py holds the fixtures).

Test files sit in folders mirroring the package (docs/layout.md, "Tests");
their paths come from here, never from their own `__file__`."""

import pathlib

TESTS = pathlib.Path(__file__).resolve().parent
ROOT = TESTS.parent  # The repository.
DATA = TESTS / 'data'
REAL_WINDS = DATA / 'realwinds'  # Real wind files (data/realwinds/PROVENANCE.md).


def one_line(capsys, prog):
  """The command's stderr: one line starting `prog: `; returns it."""
  err = capsys.readouterr().err.strip().splitlines()
  assert len(err) == 1, err
  assert err[0].startswith(f'{prog}: '), err
  return err[0]
