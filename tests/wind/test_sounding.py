"""wind/sounding.py: University of Wyoming soundings on real bytes."""

import math
import os

from hypothesis import given
from hypothesis import settings
from hypothesis import strategies as st
import numpy as np
import pytest

from ble_latex import errors
from ble_latex.wind import sounding

from tests import helpers

DATA = helpers.REAL_WINDS
BOISE = DATA / 'BOI-Boise_2010-12-09T12Z_uwyo.txt'
HILO = DATA / 'PHTO-Hilo_2023-11-01T00Z_uwyo.csv'


def test_boise_text_reads_its_levels():
  column = sounding.read(str(BOISE))
  # 134 rows; 5 lack wind or pressure, 2 repeat a pressure (115, 20 hPa).
  assert len(column.pressure_pa) == 129
  assert column.height_m[0] == 874.0 and column.height_m[-1] == 32309.0
  assert np.all(np.diff(column.pressure_pa) < 0)
  assert np.all(np.diff(column.height_m) > 0)
  # The file's row "52.7 20117 ... 310 21": 21 knots from 310 deg.
  i = int(np.flatnonzero(column.height_m == 20117.0)[0])
  speed = 21 * 1852.0 / 3600.0
  assert column.pressure_pa[i] == pytest.approx(5270.0)
  assert column.u_mps[i] == pytest.approx(-speed * math.sin(math.radians(310)))
  assert column.v_mps[i] == pytest.approx(-speed * math.cos(math.radians(310)))
  assert column.u_mps[i] > 0 and column.v_mps[i] < 0  # From the north-west.
  # The duplicated 115 hPa level keeps its first listed height.
  assert 15240.0 in column.height_m and 15237.0 not in column.height_m


def test_hilo_csv_reads_its_levels():
  column = sounding.read(str(HILO))
  assert len(column.pressure_pa) == 162
  assert column.pressure_pa[0] == pytest.approx(100_900.0)
  assert column.height_m[-1] == 34405.0
  # Its top row "6,34405,...,220,19".
  speed = 19 * 1852.0 / 3600.0
  assert np.hypot(column.u_mps[-1], column.v_mps[-1]) == pytest.approx(speed)


@settings(max_examples=50, deadline=None)
@given(st.floats(0, 360), st.floats(0, 100))
def test_components_keep_speed_and_point_downwind(direction, speed):
  u, v = sounding.wind_components(np.array(direction), np.array(speed))
  assert math.hypot(u, v) == pytest.approx(speed, abs=1e-9)
  if speed > 1e-6:
    # The wind blows towards direction + 180 deg.
    towards = math.degrees(math.atan2(u, v)) % 360
    delta = (towards - (direction + 180)) % 360
    assert min(delta, 360 - delta) < 1e-6


def _write(tmp_path, text, name='s.txt'):
  path = tmp_path / name
  path.write_text(text, encoding='utf-8')
  return str(path)


@pytest.mark.parametrize('text, match', [
    ('hello world\n', 'no header row'),
    ('a,b,c\n1,2,3\n', 'no column'),
    ('PRES,HGHT,DRCT,SKNT\n100,16000,10,5\n', '1 level'),
    ('PRES,HGHT,DRCT,SKNT\n100,16000,10,5\n50,15000,10,5\n',
     'heights do not grow'),
    ('PRES,HGHT,DRCT,SKNT\n100,16000,10,5\n50,20000,10,5\n',
     'winds cover 16000-20000 m'),
    ('PRES,HGHT,DRCT,SKNT\n100,14000,10,5\n50,26000,400,5\n', '0-360'),
    ('PRES,HGHT,DRCT,SKNT\n100,14000,10,5\n50,26000,x,5\n', 'not a number'),
    # 9999 knots (5 km/s) flew: the grids' wind bound held for no sounding.
    ('PRES,HGHT,DRCT,SKNT\n100,14000,10,9999\n50,26000,10,5\n',
     'a wind of 9999 knots at 100 hPa is above 200 m/s'),
])
def test_bad_files_are_one_line_errors(tmp_path, text, match):
  path = _write(tmp_path, text, 's.csv' if ',' in text else 's.txt')
  with pytest.raises(errors.BadFileError, match=match) as info:
    sounding.read(path)
  assert '\n' not in str(info.value) and path in str(info.value)


def test_truncated_and_binary_and_missing_files(tmp_path):
  text = BOISE.read_text(encoding='utf-8')
  cut = _write(tmp_path, text[:len(text) // 3])  # Levels end below 15 km.
  with pytest.raises(errors.BadFileError, match='winds cover'):
    sounding.read(cut)
  binary = tmp_path / 'b.txt'
  binary.write_bytes(b'\xff\xfe\x00' * 10)
  with pytest.raises(errors.BadFileError, match='not a text file'):
    sounding.read(str(binary))
  with pytest.raises(errors.BadFileError, match='cannot read'):
    sounding.read(str(tmp_path / 'none.txt'))
  big = tmp_path / 'big.txt'
  big.write_bytes(b' ' * (sounding.MAX_FILE_BYTES + 1))
  with pytest.raises(errors.BadFileError, match='no sounding'):
    sounding.read(str(big))


def test_a_sounding_csv_with_a_byte_order_mark_reads(tmp_path):
  from ble_latex.wind import sounding  # pylint: disable=g-import-not-at-top
  hilo = os.path.join(helpers.REAL_WINDS, 'PHTO-Hilo_2023-11-01T00Z_uwyo.csv')
  with open(hilo, 'rb') as f:
    raw = f.read()
  path = tmp_path / 'bom.csv'
  path.write_bytes(b'\xef\xbb\xbf' + raw)
  plain, bom = sounding.read(hilo), sounding.read(str(path))
  assert len(bom.pressure_pa) == len(plain.pressure_pa) > 10


# -- Item 3: a sounding's pressures are checked against their heights. ------
def _hilo_scaled(tmp_path, factor):
  hilo = os.path.join(helpers.REAL_WINDS, 'PHTO-Hilo_2023-11-01T00Z_uwyo.csv')
  with open(hilo, encoding='utf-8') as f:
    lines = f.read().splitlines()
  rows = [lines[0]] + [
      ','.join([repr(float(l.split(',')[0]) * factor), *l.split(',')[1:]])
      for l in lines[1:] if l.strip()]
  path = tmp_path / f'PHTO-Hilo_x{factor:g}_uwyo.csv'
  path.write_text('\n'.join(rows) + '\n')
  return str(path)


@pytest.mark.parametrize('factor', [100.0, 0.1, 1e34])
def test_a_sounding_in_other_pressure_units_is_refused(factor, tmp_path):
  from ble_latex.wind import sounding  # pylint: disable=g-import-not-at-top
  with pytest.raises(errors.BadFileError, match='PRES must be in hPa'):
    sounding.read(_hilo_scaled(tmp_path, factor))
  assert len(sounding.read(_hilo_scaled(tmp_path, 1.0)).pressure_pa) == 162
