# coding=utf-8
"""The commands (`ble-latex-*`), all absl-flag programs."""
