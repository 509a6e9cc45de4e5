# coding=utf-8
"""ble_latex.run.wind_file: a wind file's gin bindings, written once."""

import os

import gin
import pytest

from ble_latex import errors
from ble_latex import gin_aliases
from ble_latex.run import gin_binding
from ble_latex.run import wind_file

from tests import helpers

DATA = str(helpers.REAL_WINDS)
HILO = os.path.join(DATA, 'PHTO-Hilo_2023-11-01T00Z_uwyo.csv')


def test_the_bindings_text():
  assert wind_file.file_bindings('/w/x.nc') == [
      'latex_episode.wind_field_factory = @GriddedWindField',
      "GriddedWindField.path = '/w/x.nc'"]
  assert wind_file.start_dates('eval') == (
      "GriddedWindField.start_dates = 'eval'")
  assert wind_file.start_dates(None) == 'GriddedWindField.start_dates = None'
  assert wind_file.fixed_station(19.72, -155) == [
      "GriddedWindField.stations = 'fixed'", 'GriddedWindField.center_lat = 19.72',
      'GriddedWindField.center_lon = -155.0']
  assert wind_file.PER_SEED == "GriddedWindField.stations = 'per_seed'"


def test_a_cells_bindings():
  center = {'suite': 'latex_small', 'station_mode': 'center',
            'station_lat_lon': [19.72, -155.07]}
  assert wind_file.cell_bindings(center, 'rel/x.csv') == [
      *wind_file.file_bindings(os.path.abspath('rel/x.csv')),
      "GriddedWindField.start_dates = 'eval'",
      'GriddedWindField.center_lat = 19.72', 'GriddedWindField.center_lon = -155.07']
  per_seed = {'suite': 'latex_small', **wind_file.station_settings(
      'gfs_namerica', '/not/read', 'per_seed',
      ['GriddedWindField.station_margin_km = 400'])}
  assert per_seed['station_bindings'] == [
      wind_file.PER_SEED, 'GriddedWindField.station_margin_km = 400']
  assert wind_file.cell_bindings(per_seed, '/w/x.nc')[-2:] == (
      per_seed['station_bindings'])
  assert wind_file.station_settings('hilo', '/not/read', 'center') == {
      'station_mode': 'center', 'station_lat_lon': [19.72, -155.07]}


def test_the_commands_bindings_come_from_here():
  """--wind_file and --station_lat/--station_lon (`wind_file.era5_bindings`, `station_bindings`)."""
  gin.clear_config()
  try:
    gin_binding.bind_gin(None, None, [], [])
    assert wind_file.station_bindings(1.5, 2.0) == wind_file.fixed_station(1.5, 2.0)
    bindings = wind_file.era5_bindings(HILO, None, 'eval')
    assert bindings[:2] == wind_file.file_bindings(os.path.abspath(HILO))
    # A sounding's named site (`stations.file_defaults`), no start range.
    assert all(b.startswith('GriddedWindField.') for b in bindings[2:])
    with pytest.raises(errors.UsageError, match='needs ERA5 winds'):
      wind_file.era5_bindings(None, 'train', 'eval')
  finally:
    gin.clear_config()


def test_a_cell_recorded_under_an_old_gin_name_is_the_same_cell():
  """`canonical`: a record's per-seed station written before the rename
  (`Era5WindField.stations`, also module-qualified) equals today's; another
  value does not."""
  today = wind_file.station_settings('boise', '/not/read', 'per_seed')
  for old_name in ('Era5WindField', 'ble_latex.wind.era5.Era5WindField'):
    recorded = {**today, 'station_bindings': [
        f"{old_name}.stations = 'per_seed'"]}
    assert recorded != today
    assert wind_file.canonical(recorded) == wind_file.canonical(today)
    assert not wind_file.differing(recorded, today)
  other = {**today, 'station_bindings': ["Era5WindField.stations = 'fixed'"]}
  assert wind_file.canonical(other) != wind_file.canonical(today)
  assert wind_file.differing(other, today) == ['station_bindings']
  assert gin_aliases.current('x.y = 1') == 'x.y = 1'
