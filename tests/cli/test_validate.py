"""`ble-latex-validate` (ble_latex.cli.validate): its flags."""

from tests import helpers


def test_validate_max_error_percent_nan_is_a_usage_error(capsys):
  from ble_latex.cli import validate  # pylint: disable=g-import-not-at-top
  assert validate.main(['--max_error_percent=nan']) == 2
  assert '--max_error_percent' in helpers.one_line(capsys, 'ble-latex-validate')
