# coding=utf-8
"""Deprecated name of `ble_latex.wind.gridded`, kept until the next release.

The one reader of wind files reads ERA5, GFS (NetCDF, GRIB2) and soundings
alike, so issue 66 named it for what it reads: `ble_latex.wind.gridded` (the
ERA5 downloads keep their names: `era5_requests`, `era5_arco`). For one
release (`gin_aliases.REMOVAL`) the old name still works: gin files
(`import ble_latex.wind.era5`), code (`from ble_latex.wind import era5`) and
pickles of its classes get the `gridded` module itself, with a
`FutureWarning`. Gin's old configurable name `Era5WindField` (and
`ble_latex.wind.era5.Era5WindField`) is the alias `gridded` registers
(`gin_aliases.renamed`).
"""

import sys
import warnings

from ble_latex.wind import gridded

warnings.warn('ble_latex.wind.era5 is deprecated (removed in the next '
              'release): import ble_latex.wind.gridded', FutureWarning,
              stacklevel=2)
sys.modules[__name__] = gridded
