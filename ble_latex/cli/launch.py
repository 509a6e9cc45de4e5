# coding=utf-8
r"""Where and when to launch: ranks a grid of launches by expected TW50.

  ble-latex-launch --output_dir=launch_out [--agent=latex_station_seeker] \
      [--seed=0 | --wind_file=F [--station_lat=1 --station_lon=-113] \
       [--date=2022-11-05T00:00]] [--east_km=-150,150 --north_km=-150,150 \
      --hours=0,21 [--altitude_m=15000,20000]] [--grid=41,41,8[,N_ALT]] \
      [--draws=4] [--max_steps=216] [--top=100] [--paths=3]

Every candidate (an offset east and north of the station, a delay after the
world's start and a start altitude) is flown by the agent for the episode
under --draws draws of BLE's forecast-error noise, all in one batched JAX
program per chunk (`ble_latex.launch.scoring`), in the world of BLE's
generative forecast of env seed --seed, or of a wind file (--wind_file,
alias --era5_path: ERA5, a GFS analysis in NetCDF or GRIB2, a sounding; the
reader chosen by content) with the station at --station_lat/--station_lon
(default: the centre of the file's domain, or the site a sounding's file
names) and the world's start at --date (default: the file's first time; a
snapshot flies its own time). A bad wind file is one line, exit 1. Writes
OUTPUT_DIR/launches.json (the ranked launches with their mean, std and
standard error of TW50 over the draws; the whole grid's means) and
OUTPUT_DIR/launch_map.png (expected TW50 over the launch box, the station,
the best launches' flight paths). docs/launch.md.
"""

import datetime as dt
import json
import os
import socket
import sys
import time
from typing import List, Optional, Sequence

from absl import flags

from ble_latex import agents
from ble_latex import safe_io
from ble_latex.cli import common as cli

# Imported on first use, after the flags are parsed (`--help` stays fast).
jax = cli.lazy_module('jax')
controllers = cli.lazy_module('ble_latex.launch.controllers')
env_params = cli.lazy_module('ble_latex.envs.env_params')
launch_map = cli.lazy_module('ble_latex.launch.launch_map')
scoring = cli.lazy_module('ble_latex.launch.scoring')
ascent_lib = cli.lazy_module('ble_latex.launch.ascent')
gin_binding = cli.lazy_module('ble_latex.run.gin_binding')
sites = cli.lazy_module('ble_latex.launch.sites')
gridded = cli.lazy_module('ble_latex.wind.gridded')
tracks = cli.lazy_module('ble_latex.run.tracks')

PROG = 'ble-latex-launch'
FLAGS = flags.FlagValues()
flags.DEFINE_string('output_dir', None, 'Folder of launches.json and '
                    'launch_map.png.', flag_values=FLAGS)
flags.DEFINE_string('agent', 'latex_station_seeker', 'The agent that flies '
                    'the launches: latex_station_seeker, sac, sac_pretrained '
                    'or a latex_mpc planner.', flag_values=FLAGS)
flags.DEFINE_string('agent_gin_file', None, "Replaces the agent's gin file.",
                    flag_values=FLAGS)
cli.define_gin_flags(FLAGS, files_help='Gin files (after the env defaults).',
                     bindings_help='Gin bindings, last.')
flags.DEFINE_integer('seed', 0, 'The world: env seed of the generative '
                     'forecast (with --wind_file: the noise seed).',
                     flag_values=FLAGS)
flags.DEFINE_string('wind_file', None, 'Wind file(s): fly its winds (ERA5, '
                    'GFS NetCDF/GRIB2, a UWyo sounding; by content).',
                    flag_values=FLAGS)
flags.DEFINE_alias('era5_path', 'wind_file', flag_values=FLAGS)
flags.DEFINE_float('station_lat', None, 'Wind file: the station [deg N] '
                   "(default: the domain's centre).", flag_values=FLAGS)
flags.DEFINE_float('station_lon', None, 'Wind file: the station [deg E] '
                   "(default: the domain's centre).", flag_values=FLAGS)
flags.DEFINE_float('min_hull_margin_mps', None, 'Wind file: skip a station '
                   'whose column holds zero inside the hull of the reachable '
                   'winds by less than this [m/s] (0: zero outside; '
                   'ble_latex.wind.feasibility); nothing is flown.',
                   flag_values=FLAGS)
flags.DEFINE_string('date', None, "Wind file: the world's start (launch delay "
                    "0), ISO date-time, UTC (default: the file's first time).",
                    flag_values=FLAGS)
flags.DEFINE_list('east_km', ['-150', '150'], 'Launch box east of the '
                  'station: low,high [km].', flag_values=FLAGS)
flags.DEFINE_list('north_km', ['-150', '150'], 'Launch box north of the '
                  'station: low,high [km].', flag_values=FLAGS)
flags.DEFINE_list('hours', ['0', '21'], "Launch delay after the world's "
                  'start: low,high [h].', flag_values=FLAGS)
flags.DEFINE_list('altitude_m', None, 'Start altitude band low,high [m] '
                  "(default: the middle of the env's start band).",
                  flag_values=FLAGS)
flags.DEFINE_list('grid', ['41', '41', '8'], 'Grid points: east,north,'
                  'hours[,altitudes].', flag_values=FLAGS)
flags.DEFINE_integer('draws', 4, 'Noise draws per launch (K).',
                     flag_values=FLAGS)
flags.DEFINE_integer('max_steps', None, 'Strides per flight (default: the '
                     "env's episode, 216).", flag_values=FLAGS)
flags.DEFINE_integer('top', 100, 'Ranked launches written in full.',
                     flag_values=FLAGS)
flags.DEFINE_integer('paths', 3, 'Best launches whose flight paths are '
                     'drawn.', flag_values=FLAGS)
flags.DEFINE_boolean('from_ground', False, 'Launch from the ground: each '
                     "launch's offset and delay are its site and time on the "
                     'ground, its altitude where it is stopped to float; the '
                     'realistic ascent (ASTRA\'s drag and burst) with its '
                     'drift comes first (ble_latex.launch.ascent).',
                     flag_values=FLAGS)
flags.DEFINE_float('ascent_rate_mps', None, '--from_ground: the steady ascent '
                   'rate on the ground the balloon is filled for [m/s] '
                   '(default 5).', flag_values=FLAGS)
flags.DEFINE_float('descent_rate_mps', None, '--from_ground: the parachute\'s '
                   'descent rate at sea level after a burst [m/s] (default '
                   '5).', flag_values=FLAGS)
flags.mark_flags_as_required(['output_dir'], flag_values=FLAGS)


def _pair(name: str) -> Optional[List[float]]:
  values = FLAGS[name].value
  if values is None:
    return None
  try:
    pair = [float(v) for v in values]
  except ValueError:
    pair = []
  if len(pair) != 2:
    raise cli.CommandUsageError(f'--{name} must be two numbers low,high, got '
                                f'{",".join(values)!r}')
  return pair


def _grid() -> List[int]:
  try:
    shape = [int(v) for v in FLAGS.grid]
  except ValueError:
    shape = []
  if not 3 <= len(shape) <= 4 or min(shape) < 1:
    raise cli.CommandUsageError(
        '--grid must be 3 or 4 positive integers east,north,hours[,altitudes]'
        f', got {",".join(FLAGS.grid)!r}')
  n = 1
  for points in shape:
    n *= points
  if n * max(FLAGS.draws, 1) > scoring.MAX_BALLOONS:  # Before any allocation.
    raise cli.CommandUsageError(
        f'--grid={",".join(map(str, shape))} x --draws={FLAGS.draws} = '
        f'{n * max(FLAGS.draws, 1)} balloons, more than '
        f'{scoring.MAX_BALLOONS}; use a coarser grid or fewer draws')
  return shape


def _ascent() -> Optional[object]:
  """--from_ground's `ascent.Ascent`, or None; bad rates are usage errors."""
  rates = {name: FLAGS[name].value for name in ('ascent_rate_mps',
                                                'descent_rate_mps')
           if FLAGS[name].value is not None}
  if not FLAGS.from_ground:
    if rates:
      raise cli.CommandUsageError(f'--{next(iter(rates))} needs --from_ground')
    return None
  try:
    return ascent_lib.Ascent(**rates)
  except ValueError as error:
    raise cli.CommandUsageError(f'--from_ground: {error}') from error


def _check() -> None:
  for name in ('east_km', 'north_km', 'hours', 'altitude_m'):
    _pair(name)
  _ascent()
  _grid()
  era5_flags = [FLAGS.station_lat, FLAGS.station_lon, FLAGS.date,
                FLAGS.min_hull_margin_mps]
  if FLAGS.wind_file is None and any(v is not None for v in era5_flags):
    raise cli.CommandUsageError('--station_lat, --station_lon, --date and '
                                '--min_hull_margin_mps need --wind_file '
                                '(--era5_path)')
  if (FLAGS.station_lat is None) != (FLAGS.station_lon is None):
    raise cli.CommandUsageError('--station_lat and --station_lon go '
                                "together (neither: the domain's centre)")
  if FLAGS.wind_file is not None and not FLAGS.wind_file.strip():
    raise cli.CommandUsageError('--wind_file is empty')
  for name, minimum in (('draws', 1), ('top', 1), ('paths', 0),
                        ('max_steps', 1), ('seed', 0)):
    value = FLAGS[name].value
    if value is not None and value < minimum:
      raise cli.CommandUsageError(f'--{name} must be >= {minimum}, got '
                                  f'{value}')
  agents.check_agent(FLAGS.agent)
  cli.prepare_output_dir(FLAGS.output_dir, '--output_dir')


def _progress(done: int, n: int, start: float) -> None:
  """'  2048/13448 launches, 70 s, ETA 6 min 29 s' (the rate so far; the
  first chunk includes the compile, so the first ETA is pessimistic)."""
  elapsed = time.monotonic() - start
  left = elapsed / max(done, 1) * (n - done)
  eta = (f', ETA {int(left // 60)} min {int(left % 60)} s' if done < n
         else '')
  print(f'  {done}/{n} launches, {elapsed:.0f} s{eta}', flush=True)


def _hopeless() -> bool:
  """--min_hull_margin_mps: True (and says so) when the station is skipped."""
  if FLAGS.min_hull_margin_mps is None:
    return False
  station = (FLAGS.station_lat, FLAGS.station_lon)
  if station[0] is None:  # The launch's default station (`era5_world`).
    station = scoring.domain_centre(gridded.load(FLAGS.wind_file))
  site, = sites.feasible_stations(FLAGS.wind_file, [station],
                                  FLAGS.min_hull_margin_mps)
  if site['keep']:
    return False
  print(f'{PROG}: station {tracks.lat_lon_text(site["lat"], site["lon"])} '
        'skipped: zero lies '
        f'{"inside" if site["margin_mps"] >= 0 else "outside"} the hull of '
        f'the reachable winds by {abs(site["margin_mps"]):.2f} m/s, less '
        f'than --min_hull_margin_mps={FLAGS.min_hull_margin_mps:g}; nothing '
        'flown')
  return True


def _main(argv: Sequence[str]) -> None:
  del argv
  # One writer per output folder: a second run on it is refused, not raced.
  with safe_io.locked_dir(FLAGS.output_dir, what='launch output folder'):
    _plan()


def _plan() -> None:
  gin_binding.bind_gin(FLAGS.agent, FLAGS.agent_gin_file, FLAGS.gin_file,
                       FLAGS.gin_bindings)
  if FLAGS.wind_file is not None and _hopeless():
    return
  hours = _pair('hours')
  altitude = _pair('altitude_m')
  space = scoring.SearchSpace(
      east_km=tuple(_pair('east_km')), north_km=tuple(_pair('north_km')),
      hours=tuple(hours),
      altitude_m=None if altitude is None else tuple(altitude),
  ).checked(env_params.params_from_gin())
  if FLAGS.wind_file is None:
    world = scoring.generative_world(FLAGS.seed, steps=FLAGS.max_steps)
  else:
    world = scoring.era5_world(
        FLAGS.wind_file, center_lat=FLAGS.station_lat,
        center_lon=FLAGS.station_lon, date=FLAGS.date, max_hours=hours[1],
        seed=FLAGS.seed, steps=FLAGS.max_steps)
  shape = _grid()
  launches = scoring.grid(space, *shape)
  controller = controllers.controller_named(FLAGS.agent)
  n = len(launches)
  print(f'{PROG}: {n} launches x {FLAGS.draws} draws x '
        f'{world.params.episode_steps} strides, {FLAGS.agent}, '
        f'{world.describe["source"]} world', flush=True)
  load_before = os.getloadavg()
  start = time.monotonic()
  ascent = _ascent()
  scores = scoring.score(world, controller, launches, draws=FLAGS.draws,
                         progress=lambda done: _progress(done, n, start),
                         ascent=ascent)
  wall_s = time.monotonic() - start
  table = scoring.ranked(scores, world, FLAGS.top)
  if ascent is not None and table:
    table = scoring.with_ascent(table, scoring.ascent_legs(
        world, launches.take([r['index'] for r in table]), ascent), world)
  best = table[:FLAGS.paths]
  paths = None
  if best:
    paths = scoring.flight_paths(world, controller, launches.take(
        [r['index'] for r in best]), ascent=ascent)[0]
  radius = world.params.radius_km
  inside = [r for r in scoring.ranked(scores, world) if r['inside_radius']]
  record = {
      'flags': {name: FLAGS[name].value for name in (
          'agent', 'seed', 'wind_file', 'station_lat', 'station_lon', 'date',
          'east_km', 'north_km', 'hours', 'altitude_m', 'grid', 'draws',
          'max_steps', 'gin_file', 'gin_bindings', 'from_ground',
          'ascent_rate_mps', 'descent_rate_mps')},
      'ascent': None if ascent is None else dict(vars(ascent)),
      'agent': FLAGS.agent, 'world': world.describe,
      'space': {k: list(v) for k, v in zip(space.names, space.bounds())},
      'grid': shape, 'draws': FLAGS.draws,
      'steps': int(world.params.episode_steps),
      'radius_km': radius,
      'timing': {'score_wall_s': wall_s, 'launches': n,
                 'balloon_strides': n * FLAGS.draws *
                                    int(world.params.episode_steps),
                 'load_avg_before': list(load_before),
                 'load_avg_after': list(os.getloadavg()),
                 'device': str(jax.devices()[0]), 'host': socket.gethostname(),
                 'date': dt.datetime.now(dt.timezone.utc).isoformat()},
      'best_inside_radius': inside[0] if inside else None,
      'top_outside_radius_fraction': (
          sum(not r['inside_radius'] for r in table[:10]) /
          max(len(table[:10]), 1)),
      'ranked': table,
      'grid_tw50_mean': [round(float(v), 5) for v in scores.mean],
      'grid_tw50_stderr': [round(float(v), 5) for v in scores.stderr],
  }
  json_path = os.path.join(FLAGS.output_dir, 'launches.json')
  safe_io.atomic_write(json_path, json.dumps(record, indent=1))
  fig = launch_map.launch_map(
      scores, shape, radius, best, paths,
      delay_panel=world.describe['winds_vary_in_time'],
      title=(f'{FLAGS.agent}, {world.describe["source"]} world '
             f'{world.describe.get("date", world.describe["seed"])}: '
             f'{n} launches x {FLAGS.draws} draws'))
  png_path = os.path.join(FLAGS.output_dir, 'launch_map.png')
  fig.savefig(png_path, dpi=110)
  top = table[0]
  print(f'best launch: {tracks.lat_lon_text(top["lat"], top["lon"])} '
        f'({top["east_km"]:g} km east, {top["north_km"]:g} km north), '
        f'{top["launch_utc"] or "undated"} (+{top["hours"]:g} h), '
        f'{top["altitude_m"]:g} m: TW50 {top["tw50_mean"]:.3f} +- '
        f'{top["tw50_stderr"]:.3f} ({top["distance_km"]:.0f} km from the '
        'station)')
  if ascent is not None:
    print(f'  {_ascent_text(top["ascent"], top["altitude_m"], ascent)}')
  print(f'scored in {wall_s:.1f} s (load {load_before[0]:.1f}); wrote '
        f'{json_path} and {png_path}')


def _ascent_text(leg: dict, altitude_m: float, ascent: object) -> str:
  """The console's line on a launch's way up (`scoring.with_ascent`)."""
  def where(name):
    lat, lon = leg[f'{name}_lat'], leg[f'{name}_lon']
    place = ('(outside its descent bound)' if lat is None else
             tracks.lat_lon_text(lat, lon))
    return f'{place}{", " + leg[name + "_utc"] if leg[name + "_utc"] else ""}'

  if leg['floats']:
    return (f'from the ground at {ascent.ascent_rate_mps:g} m/s: reaches '
            f'float ({altitude_m:g} m) at {where("float")} after '
            f'{leg["ascent_min"]:.0f} min, {leg["ascent_drift_km"]:.1f} km '
            'from the launch site')
  if 'burst_altitude_m' in leg:
    return (f'from the ground at {ascent.ascent_rate_mps:g} m/s: bursts at '
            f'{leg["burst_altitude_m"] / 1000:.1f} km, below its float '
            f'({altitude_m:g} m), at {where("burst")}; lands at '
            f'{where("landing")}')
  return (f'from the ground: reaches neither float nor burst within '
          f'{ascent.max_hours:g} h')


def main(argv: Optional[Sequence[str]] = None) -> int:
  """The command (`cli.run_absl`); returns the exit status."""
  return cli.run_absl(_main, PROG, FLAGS, argv, doc=__doc__, check=_check)


if __name__ == '__main__':
  sys.exit(main())
