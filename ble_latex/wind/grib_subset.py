# coding=utf-8
"""The GRIB2 messages that may hold winds on pressure levels, found fast.

A GFS forecast file holds ~350 messages, of which ~50 are u and v on
isobaric levels. cfgrib builds its index by creating an eccodes handle and
reading ~20 keys for every message, once per `xr.open_dataset`; on 13 such
files `era5.load` spent ~40 of its ~55 s there
(`benchmarks/grib_load_speed.py`).
`wind_messages` frames the file's messages from their fixed headers (WMO
Manual on Codes, FM 92 GRIB edition 2: section 0 is 16 octets with the
discipline in octet 7 and the total length in octets 9-16; every other
section starts with its 4-octet length and 1-octet number; product
definition templates 4.0-4.15 keep the parameter category, number and the
type of the first fixed surface in octets 10, 11 and 23) and keeps every
message that may be a wind on an isobaric surface: discipline 0,
category 2 (momentum), number 2 (u) or 3 (v), surface type 100 (isobaric).
It only drops what is certainly something else: a message of another
edition, another template, or odd framing is kept, and a file it cannot
frame is read whole (None), so cfgrib still sees and reports it. The kept
messages are decoded by cfgrib and checked as before.
"""

import struct
from typing import List, Optional

_MAGIC = b'GRIB'
_END = b'7777'
# (discipline, parameter category, parameter number) of u and v (WMO Code
# tables 0.0, 4.1 and 4.2), and the isobaric surface (Code table 4.5).
WIND_PARAMETERS = frozenset({(0, 2, 2), (0, 2, 3)})
ISOBARIC_SURFACE = 100
# Product definition templates with the octets above at these places.
_TEMPLATES = range(0, 16)


def _may_be_wind(message: bytes) -> bool:
  """Whether a GRIB message may hold u or v on an isobaric surface."""
  if message[7] != 2:  # Not edition 2: kept for cfgrib to read.
    return True
  discipline = message[6]
  position, end = 16, len(message) - 4
  fields = 0
  while position + 5 <= end:
    length = struct.unpack('>I', message[position:position + 4])[0]
    number = message[position + 4]
    if length < 5 or position + length > end:
      return True  # Odd framing: let cfgrib judge.
    if number == 4:
      fields += 1
      section = message[position:position + length]
      if len(section) < 23:
        return True
      template = struct.unpack('>H', section[7:9])[0]
      if template not in _TEMPLATES:
        return True
      if ((discipline, section[9], section[10]) in WIND_PARAMETERS and
          section[22] == ISOBARIC_SURFACE):
        return True
    position += length
  return fields == 0  # No product definition found: kept.


def wind_messages(path: str) -> Optional[bytes]:
  """The messages of a GRIB2 file that may hold u/v on pressure levels.

  Args:
    path: A GRIB file (its magic checked by the caller).

  Returns:
    The kept messages' bytes, in file order; None when the file cannot be
    framed (truncated, junk between messages) or every message is kept, so
    the caller reads the file itself.
  """
  with open(path, 'rb') as stream:
    data = stream.read()
  kept: List[bytes] = []
  position, dropped = 0, False
  while position < len(data):
    if data[position:position + 4] != _MAGIC or position + 16 > len(data):
      return None
    if data[position + 7] == 2:
      total = struct.unpack('>Q', data[position + 8:position + 16])[0]
    elif data[position + 7] == 1:
      total = int.from_bytes(data[position + 4:position + 7], 'big')
    else:
      return None
    message = data[position:position + total]
    if total < 20 or len(message) < total or message[-4:] != _END:
      return None
    if _may_be_wind(message):
      kept.append(message)
    else:
      dropped = True
    position += total
  return b''.join(kept) if dropped and kept else None
