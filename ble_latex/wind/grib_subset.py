# coding=utf-8
"""The GRIB2 messages that may hold winds on pressure levels, found fast.

A GFS forecast file holds ~350 messages, of which ~50 are u and v on
isobaric levels. cfgrib builds its index by creating an eccodes handle and
reading ~20 keys for every message, once per `xr.open_dataset`; on 13 such
files `gridded.load` spent ~40 of its ~55 s there
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
frame is read whole, so cfgrib still sees and reports it. The kept
messages are decoded by cfgrib and checked as before.
"""

import os
import struct

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


def wind_messages(path: str, out: str) -> bool:
  """Writes to `out` the messages of a GRIB file that may hold u/v on
  pressure levels, one message in memory at a time.

  Args:
    path: A GRIB file (its magic checked by the caller).
    out: The file to write the kept messages to, in file order.

  Returns:
    Whether `out` holds the winds to read: False when the file cannot be
    framed (truncated, junk between messages), no message is dropped or
    none is kept, so the caller reads `path` itself.
  """
  size = os.path.getsize(path)
  kept = dropped = False
  with open(path, 'rb') as stream, open(out, 'wb') as sink:
    position = 0
    while position < size:
      head = stream.read(16)
      if len(head) < 16 or head[:4] != _MAGIC:
        return False
      if head[7] == 2:
        total = struct.unpack('>Q', head[8:16])[0]
      elif head[7] == 1:
        total = int.from_bytes(head[4:7], 'big')
      else:
        return False
      if total < 20 or position + total > size:
        return False
      message = head + stream.read(total - 16)
      if len(message) < total or message[-4:] != _END:
        return False
      if _may_be_wind(message):
        sink.write(message)
        kept = True
      else:
        dropped = True
      position += total
  return kept and dropped
