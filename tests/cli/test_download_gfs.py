# coding=utf-8
"""`ble-latex-download-gfs` against a local stand-in of NOMADS' GRIB filter.

No network: a `http.server` on 127.0.0.1 in a thread answers the filter's
requests from the committed GRIB2 slice (a GFS run's +72 h u/v, 2.5 deg,
tests/data/realwinds/PROVENANCE.md) as the filter would: only the asked
variables and levels, cut to the asked box, stamped with the asked run and
forecast hour (eccodes). The downloads must load with `gridded.load`, the
loader `--wind_file` uses.
"""

import datetime as dt
import http.server
import os
import re
import threading
import urllib.parse

import eccodes
import numpy as np
import pytest

from ble_latex.cli import download_gfs
from ble_latex.wind import gfs_requests as gfs
from ble_latex.wind import gridded

from tests import helpers

SLICE = os.path.join(helpers.REAL_WINDS, 'gfs_2011-10-11T00Z_uv_10-250hPa_2p5deg.grib2')
RUN = dt.datetime(2026, 12, 5, 0)
SCRIPT = '/cgi-bin/filter_gfs_0p25.pl'
_SHORT = {'UGRD': 'u', 'VGRD': 'v'}


def _slice_fields():
  """(shortName, level, lat (descending), lon, values) of each field."""
  fields = []
  with open(SLICE, 'rb') as f:
    eccodes.codes_grib_multi_support_on()
    try:
      while (h := eccodes.codes_grib_new_from_file(f)) is not None:
        try:
          ni, nj = eccodes.codes_get(h, 'Ni'), eccodes.codes_get(h, 'Nj')
          lat = np.linspace(eccodes.codes_get(h, 'latitudeOfFirstGridPointInDegrees'),
                            eccodes.codes_get(h, 'latitudeOfLastGridPointInDegrees'), nj)
          lon = np.linspace(eccodes.codes_get(h, 'longitudeOfFirstGridPointInDegrees'),
                            eccodes.codes_get(h, 'longitudeOfLastGridPointInDegrees'), ni)
          fields.append((eccodes.codes_get(h, 'shortName'),
                         eccodes.codes_get(h, 'level'), lat, lon,
                         eccodes.codes_get_values(h).reshape(nj, ni),
                         eccodes.codes_get_message(h)))
        finally:
          eccodes.codes_release(h)
    finally:
      eccodes.codes_grib_multi_support_off()
  return fields


def _cut(query, run, hour, fields):
  """The filter's answer: the asked fields in the box, stamped run + hour."""
  shorts = {_SHORT[k[4:]] for k in query if k.startswith('var_')}
  levels = {float(k[4:-3]) for k in query if re.fullmatch(r'lev_.*_mb', k)}
  west, east = float(query['leftlon']) % 360, float(query['rightlon']) % 360
  south, north = float(query['bottomlat']), float(query['toplat'])
  out = b''
  for short, level, lat, lon, values, message in fields:
    if short not in shorts or level not in levels:
      continue
    rows = np.nonzero((lat >= south) & (lat <= north))[0]
    cols = np.nonzero((lon >= west) & (lon <= east))[0]
    handle = eccodes.codes_new_from_message(message)
    try:
      for key, value in (
          ('Ni', cols.size), ('Nj', rows.size),
          ('latitudeOfFirstGridPointInDegrees', float(lat[rows[0]])),
          ('latitudeOfLastGridPointInDegrees', float(lat[rows[-1]])),
          ('longitudeOfFirstGridPointInDegrees', float(lon[cols[0]])),
          ('longitudeOfLastGridPointInDegrees', float(lon[cols[-1]])),
          ('dataDate', int(f'{run:%Y%m%d}')), ('dataTime', run.hour * 100),
          ('forecastTime', hour)):
        eccodes.codes_set(handle, key, value)
      eccodes.codes_set_values(
          handle, values[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1].ravel())
      out += eccodes.codes_get_message(handle)
    finally:
      eccodes.codes_release(handle)
  return out


class _StandIn(http.server.ThreadingHTTPServer):
  """The stand-in filter: `hours` it has, `requests` it got, a `cut` mode."""

  def __init__(self):
    super().__init__(('127.0.0.1', 0), _Handler)
    self.fields = _slice_fields()
    self.hours = {0, 3, 6}
    self.requests = []
    self.cut = False
    self.url = f'http://127.0.0.1:{self.server_address[1]}{SCRIPT}'


class _Handler(http.server.BaseHTTPRequestHandler):

  def log_message(self, *args):  # Quiet.
    pass

  def _reply(self, code, body, length=None):
    self.send_response(code)
    self.send_header('Content-Length', str(length or len(body)))
    self.end_headers()
    self.wfile.write(body)

  def do_GET(self):  # pylint: disable=invalid-name
    server = self.server
    url = urllib.parse.urlsplit(self.path)
    query = dict(urllib.parse.parse_qsl(url.query, keep_blank_values=True))
    server.requests.append(query)
    match_dir = re.fullmatch(r'/gfs\.(\d{8})/(\d{2})/atmos', query.get('dir', ''))
    match_file = re.fullmatch(r'gfs\.t(\d{2})z\.pgrb2\.0p25\.f(\d{3})',
                              query.get('file', ''))
    if url.path != SCRIPT or not match_dir or not match_file or (
        match_dir.group(2) != match_file.group(1)) or 'subregion' not in query:
      return self._reply(400, b'<html><body>bad request</body></html>')
    run = dt.datetime.strptime(''.join(match_dir.groups()), '%Y%m%d%H')
    hour = int(match_file.group(2))
    if hour not in server.hours:
      return self._reply(
          404, b'<html><body><h1>data file is not present</h1></body></html>')
    body = _cut(query, run, hour, server.fields)
    if server.cut:  # Announce it all, send half, close.
      return self._reply(200, body[:len(body) // 2], length=len(body))
    return self._reply(200, body)


@pytest.fixture(name='standin', scope='module')
def _standin():
  server = _StandIn()
  thread = threading.Thread(target=server.serve_forever, daemon=True)
  thread.start()
  yield server
  server.shutdown()
  server.server_close()


@pytest.fixture(autouse=True)
def _reset(standin):
  standin.requests.clear()
  standin.cut = False


def _files(standin, hours=(0, 3)):
  south, north, west, east = gfs.box(40.0, -100.0, 10.0)
  return gfs.build_files(run=RUN, hours=hours, south=south, north=north,
                         west=west, east=east, base_url=standin.url)


def test_request_is_the_grib_filter_url():
  south, north, west, east = gfs.box(40.0, -100.0, 5.0)
  (one,) = gfs.build_files(run=dt.datetime(2026, 12, 5, 6), hours=[3],
                           south=south, north=north, west=west, east=east,
                           min_pressure_hpa=50, max_pressure_hpa=100)
  assert one.url == (
      'https://nomads.ncep.noaa.gov/cgi-bin/filter_gfs_0p25.pl?'
      'dir=%2Fgfs.20261205%2F06%2Fatmos&file=gfs.t06z.pgrb2.0p25.f003&'
      'var_UGRD=on&var_VGRD=on&lev_50_mb=on&lev_70_mb=on&lev_100_mb=on&'
      'subregion=&leftlon=-105&rightlon=-95&toplat=45&bottomlat=35')
  assert one.name == 'gfs_20261205T06Z_f003.grib2'
  assert one.valid == dt.datetime(2026, 12, 5, 9)
  assert gfs.box(0.0, 178.0, 5.0)[2:] == (173.0, 183.0)  # Across 180.


def test_run_and_hours_are_parsed_or_refused_in_one_line():
  assert gfs.parse_run('2026-12-05T18Z') == dt.datetime(2026, 12, 5, 18)
  assert gfs.parse_run('2026120506') == dt.datetime(2026, 12, 5, 6)
  assert gfs.parse_hours('0-6/3,12,126-132/3') == [0, 3, 6, 12, 126, 129, 132]
  for bad, match in (('2026-12-05T03Z', '00Z, 06Z'), ('2026-13-05T00Z',
                                                     'not a date'),
                     ('yesterday', 'YYYY-MM-DDTHHZ')):
    with pytest.raises(ValueError, match=match):
      gfs.parse_run(bad)
  for bad, match in (('121', 'no forecast hour 121'), ('6-0', 'LAST >= '),
                     ('0-x', 'expected hours'), ('390', '384')):
    with pytest.raises(ValueError, match=match):
      gfs.parse_hours(bad)
  with pytest.raises(ValueError, match='at least 2'):
    gfs.levels_hpa(11, 14)


def test_download_loads_and_resumes(standin, tmp_path):
  stale = tmp_path / '.tmp-gfs_20261205T00Z_f000.grib2-1-dead'
  stale.write_bytes(b'GRIB half')  # A killed run's temporary file.
  paths = gfs.download(_files(standin), str(tmp_path), pause_s=0)
  assert [os.path.basename(p) for p in paths] == [
      'gfs_20261205T00Z_f000.grib2', 'gfs_20261205T00Z_f003.grib2']
  assert len(standin.requests) == 2 and not stale.exists()
  # Every requested level from 10 to 1000 hPa; the slice holds 10-250.
  assert {k for k in standin.requests[0] if k.startswith('lev_')} == {
      f'lev_{p}_mb' for p in gfs.GFS_LEVELS_HPA if 10 <= p <= 1000}
  data = gridded.load(paths)  # What --wind_file loads.
  assert data.source == 'GRIB2' and not data.time_invariant
  assert data.description == 'GRIB2 run 2026-12-05T00Z +0..+3 h'
  assert [str(t)[:16] for t in data.times] == ['2026-12-05T00:00',
                                               '2026-12-05T03:00']
  np.testing.assert_array_equal(data.latitude, np.arange(30.0, 50.1, 2.5))
  np.testing.assert_array_equal(data.longitude, np.arange(250.0, 270.1, 2.5))
  np.testing.assert_array_equal(data.pressure / 100, [10, 20, 30, 50, 70, 100,
                                                      150, 200, 250])
  # The winds are the slice's: u at 50 hPa, 40 N, 100 W (260 E).
  (u50,) = [f for f in standin.fields if f[0] == 'u' and f[1] == 50]
  expected = u50[4][np.argmin(abs(u50[2] - 40)), np.argmin(abs(u50[3] - 260))]
  assert data.uv[1, 3, 4, 4, 0] == pytest.approx(expected, abs=1e-3)
  # Resumed: complete files are not asked for again; a missing one is.
  standin.requests.clear()
  os.remove(paths[1])
  again = gfs.download(_files(standin), str(tmp_path), pause_s=0)
  assert again == paths and len(standin.requests) == 1
  assert standin.requests[0]['file'] == 'gfs.t00z.pgrb2.0p25.f003'


def test_a_cut_reply_leaves_no_file(standin, tmp_path):
  standin.cut = True
  with pytest.raises(gfs.DownloadError, match='f000.grib2: the reply was cut '
                     'short'):
    gfs.download(_files(standin, [0]), str(tmp_path), pause_s=0)
  assert os.listdir(tmp_path) == []
  standin.cut = False
  (path,) = gfs.download(_files(standin, [0]), str(tmp_path), pause_s=0)
  assert gfs.is_complete(path) and os.listdir(tmp_path) == [
      os.path.basename(path)]


def test_reply_too_large_or_not_grib(standin, tmp_path):
  with pytest.raises(gfs.DownloadError, match='over 0.001 MB'):
    gfs.download(_files(standin, [0]), str(tmp_path), max_bytes=1000)
  with pytest.raises(gfs.DownloadError,
                     match='f012.grib2: HTTP 404 .*data file is not present'):
    gfs.download(_files(standin, [12]), str(tmp_path))
  assert os.listdir(tmp_path) == []


def _command(capsys, *args):
  code = download_gfs.main(list(args))
  out, err = capsys.readouterr()
  return code, out, err


def test_command(standin, tmp_path, capsys):
  common = ['--run=2026-12-05T00Z', '--center_lat=40', '--center_lon=-100',
            '--half_width_deg=10', f'--base_url={standin.url}']
  code, out, err = _command(capsys, *common, '--hours=0-6/3', '--dry_run')
  assert code == 0 and not err and not standin.requests
  assert [l.split('&file=')[1][:24] for l in out.splitlines()] == [
      f'gfs.t00z.pgrb2.0p25.f00{h}' for h in (0, 3, 6)]
  out_dir = tmp_path / 'gfs'
  code, out, err = _command(capsys, *common, '--hours=0,3', '--pause_s=0',
                            f'--output_dir={out_dir}')
  assert code == 0, err
  assert 'wrote 2 file(s): GRIB2 run 2026-12-05T00Z +0..+3 h' in out
  assert f"--wind_file='{out_dir}/gfs_20261205T00Z_f*.grib2'" in out
  assert gridded.load(f'{out_dir}/gfs_20261205T00Z_f*.grib2').times.size == 2
  # Usage errors (exit 2) and failures (exit 1): one line each.
  for args, status, message in (
      ([], 2, '--run is required'),
      (['--run=2026-12-05T00Z', '--center_lat=40'], 2,
       '--center_lon is required'),
      ([*common, '--hours=121'], 2, '--hours: GFS 0.25 deg has no forecast'),
      ([*common, '--hours=0-120', '--max_files=10'], 2, 'over --max_files=10'),
      ([*common, '--min_pressure_hpa=11', '--max_pressure_hpa=14'], 2,
       'at least 2'),
      ([*common, '--run=2026-12-05T02Z'], 2, '--run: GFS runs start at'),
      ([*common, '--base_url=ftp://x'], 2, 'http(s) URL'),
      ([*common, '--hours=12', f'--output_dir={out_dir}'], 1,
       'HTTP 404 Not Found: data file is not present')):
    code, _, err = _command(capsys, *args)
    assert code == status and err.count('\n') == 1, (args, err)
    assert err.startswith('ble-latex-download-gfs: ') and message in err, err
