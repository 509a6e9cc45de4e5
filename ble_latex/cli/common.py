# coding=utf-8
"""The command-line convention of every `ble-latex-*` command.

Every command is an absl program, as BLE's are: its flags are absl flags,
defined on the command's own `flags.FlagValues` (`FLAGS` in its module), and
its entry point is `main(argv=None) -> int`, which hands its absl main to
`run_absl`. Own flag registries (not absl's process-global `flags.FLAGS`)
let commands whose flags share names (`--output_dir`, `--gin_bindings`, ...)
run in one process: the demo calls `ble-latex-plot`, tests and notebooks call
any of them. `run_absl` gives every command the same contract:

- `--help` / `-h` / `--helpfull` lists the command's flags and exits 0;
- a usage error (unknown flag, bad or missing value, unknown agent, suite, env,
  gin file or gin configurable) is one line on stderr,
  `PROG: what is wrong; valid: a, b, c`, and exit status 2;
- a directory (or output file) another writer holds (`safe_io.InUseError`)
  is one line on stderr, `PROG: ... is in use by pid P on host H ...`, and
  exit status 1;
- otherwise the absl main runs inside absl's `app.run` (absl logging, init
  callbacks) and its return value is the exit status (None: 0);
- refused input found while running is one line too (`run_absl`): a refused
  configuration (`errors.ConfigError`, a gin binding that does not parse, a
  gin-bound value a configurable refuses) exits 2; a failure of the file
  system (`OSError`: an output path that is a file or read-only, a missing
  input, a full disk), an unusable input file (`errors.BadFileError`) or a
  `CommandFailure` exits 1. Any other exception is a bug: a traceback.
"""

import difflib
import importlib
import os
import sys
import types
from typing import (Any, Callable, Iterable, List, NoReturn, Optional,
                    Sequence)

from absl import app
from absl import flags
import gin

from ble_latex import configs
from ble_latex import errors
from ble_latex import gin_aliases
from ble_latex import gin_values
from ble_latex import safe_io

HELP_FLAGS = ('-h', '--help', '-help', '--helpshort', '--helpfull',
              '-helpfull')
EXIT_USAGE = 2
EXIT_FAILURE = 1
# gin's note on an exception raised inside a configurable's call.
_GIN_CALL_NOTE = 'In call to configurable '


class LazyModule(types.ModuleType):
  """A module imported (inside `quiet.third_party_noise`) on first use.

  Commands name their heavy modules (TensorFlow through BLE's agents and
  Dopamine, the VAE, matplotlib) with `lazy_module`, so `--help` and usage
  errors answer before anything heavy is imported.
  """

  def __init__(self, name: str):
    super().__init__(name)
    self.__dict__['_lazy_target'] = None

  def _load(self) -> types.ModuleType:
    target = self.__dict__['_lazy_target']
    if target is None:
      from ble_latex import quiet  # pylint: disable=g-import-not-at-top
      with quiet.third_party_noise():
        target = importlib.import_module(self.__name__)
      self.__dict__['_lazy_target'] = target
    return target

  def __getattr__(self, attr: str) -> Any:
    return getattr(self._load(), attr)

  def __setattr__(self, attr: str, value: Any) -> None:
    setattr(self._load(), attr, value)

  def __delattr__(self, attr: str) -> None:
    delattr(self._load(), attr)


def lazy_module(name: str) -> Any:
  """The module `name` (dotted), imported quietly on first attribute use."""
  module = sys.modules.get(name)
  return module if module is not None else LazyModule(name)


class CommandUsageError(Exception):
  """A usage error found while running: one line, exit status 2."""


class CommandFailure(Exception):
  """A failure found while running: one line, exit status 1."""


def usage(prog: str, message: str) -> int:
  """Prints the one-line usage error `PROG: message`; returns exit status 2."""
  print(f'{prog}: {message}', file=sys.stderr)
  return EXIT_USAGE


def usage_error(prog: str, message: str) -> NoReturn:
  """`usage`, then exits with its status."""
  sys.exit(usage(prog, message))


def unknown(what: str, name: str, valid: Iterable[str],
            label: str = 'valid') -> str:
  """"unknown agent 'x'; valid: a, b" (with a guess when one is close)."""
  valid = sorted(set(valid))
  close = difflib.get_close_matches(name, valid, n=1)
  guess = f' (did you mean {close[0]!r}?)' if close else ''
  return f'unknown {what} {name!r}{guess}; {label}: {", ".join(valid)}'


def help_text(prog: str, doc: Optional[str],
              flag_values: flags.FlagValues) -> str:
  """'usage: PROG [flags]', the command's doc, then its flags."""
  parts = [f'usage: {prog} [flags]']
  if doc:
    parts.append(doc.strip())
  parts.append('flags:')
  parts.append(flag_values.get_help())
  return '\n\n'.join(parts)


def _exit_status(code: Any) -> int:
  """`SystemExit.code` as an exit status (None: 0; a message: 1)."""
  if code is None:
    return 0
  return code if isinstance(code, int) else 1


def run_absl(main: Callable[[Sequence[str]], Optional[int]], prog: str,
             flag_values: flags.FlagValues,
             argv: Optional[Sequence[str]] = None, doc: Optional[str] = None,
             check: Optional[Callable[[], None]] = None,
             positional: bool = False) -> int:
  """Parses the command's flags, runs `check`, then `main` in absl's app.run.

  Args:
    main: The absl main; gets [prog, *positional args].
    prog: Command name for messages.
    flag_values: The command's own flags.
    argv: Arguments without the program name (default sys.argv[1:]).
    doc: Text shown above the flags by --help.
    check: Validates flag values before the work starts; raises
      CommandUsageError with a one-line message.
    positional: The command takes positional arguments (else they are a
      usage error).

  Returns:
    The exit status: 0 (or what `main` returns), 2 for a usage error.
  """
  argv = list(sys.argv[1:] if argv is None else argv)
  if {a.split('=', 1)[0] for a in argv} & set(HELP_FLAGS):
    print(help_text(prog, doc, flag_values))
    return 0
  for name in flag_values:  # Defaults again (a command may run twice).
    flag_values[name].unparse()
  try:
    args = flag_values([prog, *argv])
  except flags.Error as e:
    return usage(prog, f'{e} (try --help)')
  if not positional and len(args) > 1:
    return usage(prog, f'unexpected arguments: {args[1:]}')
  message = number_flags_message(flag_values)
  if message is not None:
    return usage(prog, message)
  gin.clear_config()  # A command run twice in one process binds afresh.

  def checked_main(unused_argv: Sequence[str]) -> Optional[int]:
    try:
      if check is not None:
        check()
      return main(args)
    except (app.UsageError, CommandUsageError) as e:
      usage_error(prog, str(e))
    except (OSError, errors.BadFileError, CommandFailure, safe_io.InUseError,
            FloatingPointError) as e:  # FloatingPointError: a diverged run.
      print(f'{prog}: {one_line(e)}', file=sys.stderr)
      sys.exit(EXIT_FAILURE)
    except ValueError as e:
      message = refused_config_message(e)
      if message is None:
        raise
      usage_error(prog, message)

  quiet_init_callbacks()
  from ble_latex import quiet  # pylint: disable=g-import-not-at-top
  try:
    with quiet.command_logs():
      app.run(checked_main, argv=[prog])
  except SystemExit as e:
    return _exit_status(e.code)
  return 0


def number_flags_message(flag_values: flags.FlagValues) -> Optional[str]:
  """The usage message of a number flag the core cannot hold, else None.

  absl parses `--x=nan`, `--x=inf` and `--x=1e39` as floats and any integer
  as a Python int; every float flag of every command must be finite in
  float32 (`gin_values.is_number`: the core's float), every integer flag
  within int64.

  Args:
    flag_values: The command's parsed flags.

  Returns:
    'NAME must be ..., got VALUE' for the first bad flag, or None.
  """
  for name in flag_values:
    flag = flag_values[name]
    value = flag.value
    if value is None or isinstance(value, bool):
      continue
    if isinstance(flag.parser, flags.FloatParser):
      values = value if isinstance(value, list) else [value]
      if not all(gin_values.is_number(v) for v in values):
        return (f'--{name} must be a finite number (in float32: |x| <= '
                f'3.4e38), got {flag.value!r}')
    elif isinstance(flag.parser, flags.IntegerParser):
      values = value if isinstance(value, list) else [value]
      if not all(-2**63 <= v < 2**63 for v in values):
        return f'--{name} must be an integer within int64, got {value!r}'
  return None


def quiet_init_callbacks() -> None:
  """Runs absl's after-init callbacks inside `quiet.third_party_noise`.

  TensorFlow registers one (`distribute/combinations.py`) that probes for
  GPUs and logs a native "failed call to cuInit" error on machines without
  CUDA.
  """
  from ble_latex import quiet  # pylint: disable=g-import-not-at-top
  callbacks = getattr(app, '_init_callbacks', None)
  if not callbacks:
    return

  def quietly(callback):
    def run():
      with quiet.third_party_noise():
        callback()
    return run

  pending = [quietly(c) for c in callbacks]
  callbacks.clear()
  callbacks.extend(pending)


def output_name(name: str, flag: str) -> str:
  """A name of output files kept inside the output folder.

  Args:
    name: The name (e.g. --name_override's), used as `<folder>/<name>.json`.
    flag: The flag that gave it, for the message.

  Returns:
    `name`.

  Raises:
    CommandUsageError: An empty name, '.' or '..', or one holding a path
      separator or NUL (an absolute or `../` name would write outside the
      folder).
  """
  seps = {os.sep, os.altsep} - {None}
  if (not name or name in ('.', '..') or '\0' in name or
      any(sep in name for sep in seps)):
    raise CommandUsageError(
        f'{flag} must be a plain file name (no {"/".join(sorted(seps))}, not '
        f'"." or ".."), kept inside the output folder, got {name!r}')
  return name


def prepare_output_dir(path: str, flag: str) -> None:
  """Creates the output folder `path` before the work starts.

  Args:
    path: The folder (made with its parents if missing).
    flag: The flag that named it (e.g. '--output_dir'), for the message.

  Raises:
    CommandFailure: `path` (or a parent) is a file, or the folder cannot be
      created or written (one line, exit status 1).
  """
  if os.path.exists(path) and not os.path.isdir(path):
    raise CommandFailure(f'{flag}: {path} is a file, not a folder')
  try:
    os.makedirs(path, exist_ok=True)
  except OSError as e:
    raise CommandFailure(f'{flag}: cannot create the folder {path} '
                         f'({e.strerror or e})') from e
  if not os.access(path, os.W_OK | os.X_OK):
    raise CommandFailure(f'{flag}: the folder {path} is not writable')


def check_env_config() -> None:
  """The bound env and physics values (`env_params.params_from_gin`), now.

  Call after binding gin, before the work starts.

  Raises:
    errors.ConfigError: a value the env's checks refuse, naming its gin
      binding (`run_absl`: one line, exit 2).
  """
  from ble_latex.envs import env_params  # pylint: disable=g-import-not-at-top
  env_params.params_from_gin()


# -- Wind files: --wind_file (alias --era5_path) / --era5_dates. -------------
WIND_FILE_HELP = ('Wind file (the reader chosen by content: ERA5 or another '
                  'CF NetCDF analysis, GRIB2, a University of Wyoming '
                  'sounding; one time step flies time-invariant) or glob '
                  'pattern: every env flies it (binds '
                  'latex_episode.wind_field_factory = @GriddedWindField and '
                  'GriddedWindField.path; the same as '
                  'gin_configs/paper_era5.gin with that path). --era5_path is an alias.')
ERA5_DATES_HELP = ("Date range ERA5 flights start in: a split (train, "
                   "validation, eval; ble_latex.wind.gridded.DATE_SPLITS), "
                   "'all' (anywhere in the file) or FIRST,END (ISO dates, "
                   "END excluded). Default: {default}. Needs ERA5 winds "
                   "(--era5_path or a gin file binding @GriddedWindField).")


GIN_FILE_HELP = 'Extra gin files.'
GIN_BINDINGS_HELP = 'Gin bindings to override default values.'


def define_gin_flags(flag_values: Any, *,
                     files_help: Optional[str] = GIN_FILE_HELP,
                     bindings_help: Optional[str] = GIN_BINDINGS_HELP,
                     files_alias: bool = False) -> None:
  """--gin_file and --gin_bindings (repeatable), the one home of both.

  Every command and script that takes gin files or bindings defines them
  here, with its own help; a help of None leaves that flag out.
  `files_alias` also accepts --gin_files, ble_latex 0.1's name.
  """
  if files_help is not None:
    flags.DEFINE_multi_string('gin_file', [], files_help,
                              flag_values=flag_values)
    if files_alias:
      flags.DEFINE_alias('gin_files', 'gin_file', flag_values=flag_values)
  if bindings_help is not None:
    flags.DEFINE_multi_string('gin_bindings', [], bindings_help,
                              flag_values=flag_values)


STATION_HELP = ('Wind file: the station-keeping target {what} (with '
                '--station_{other}; every flight keeps station there; '
                'default: per-seed stations on a gridded snapshot, a '
                "sounding's site).")


def define_station_flags(flag_values: Any) -> None:
  """--station_lat / --station_lon of eval and train (`station_bindings`)."""
  for name, what, other in (('station_lat', '[deg N]', 'lon'),
                            ('station_lon', '[deg E]', 'lat')):
    flags.DEFINE_float(name, None, STATION_HELP.format(what=what, other=other),
                       flag_values=flag_values)


def station_bindings(lat: Optional[float], lon: Optional[float]
                     ) -> List[str]:
  """The gin bindings of --station_lat / --station_lon (a fixed station).

  Raises:
    CommandUsageError: one without the other, or a value out of range.
  """
  if lat is None and lon is None:
    return []
  if lat is None or lon is None:
    raise CommandUsageError('--station_lat and --station_lon go together')
  if not (-90.0 <= lat <= 90.0 and -360.0 <= lon <= 360.0):
    raise CommandUsageError(
        f'--station_lat={lat:g} --station_lon={lon:g}: expected a latitude '
        'in [-90, 90] and a longitude in [-360, 360] [deg]')
  from ble_latex.run import wind_file  # pylint: disable=g-import-not-at-top
  return wind_file.fixed_station(lat, lon)


def era5_bindings(path: Optional[str], dates: Optional[str],
                  default_dates: str, station: Sequence[str] = ()
                  ) -> List[str]:
  """The gin bindings of --wind_file / --era5_dates (after `bind_gin`).

  Call after the user's gin is bound: ERA5 is on with `path`, or when gin
  binds `latex_episode.wind_field_factory = @GriddedWindField`. The start
  range is `dates`, else a `GriddedWindField.start_dates` the user bound,
  else `default_dates` (the command's split).

  Args:
    path: --wind_file (--era5_path), or None.
    dates: --era5_dates, or None.
    default_dates: The command's split (train: 'train'; eval: the suite's).
    station: `station_bindings` of --station_lat/--station_lon (they
      replace `wind_file_defaults`).

  Returns:
    Bindings to add after the user's (empty without ERA5).

  Raises:
    CommandUsageError: --era5_dates or a station without ERA5, or a bad
      range.
  """
  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import env_params
  from ble_latex.envs import winds
  from ble_latex.run import wind_file
  # pylint: enable=g-import-not-at-top
  bindings = []
  if path is not None:
    if not path.strip():
      raise CommandUsageError('--wind_file is empty')
    if dates is not None:  # A usage error before the file is read.
      era5_dates_value(dates)
    # Absolute (the Ray workers' working directory may differ).
    path = os.path.abspath(os.path.expandvars(os.path.expanduser(path)))
    bindings += wind_file.file_bindings(path) + (
        list(station) or wind_file_defaults(path))
  elif not winds.is_era5(env_params.episode()['wind_field_factory']):
    for flag, given in (('--era5_dates', dates is not None),
                        ('--station_lat/--station_lon', bool(station))):
      if given:
        raise CommandUsageError(
            f'{flag} needs ERA5 winds: --wind_file, or a gin file binding '
            'latex_episode.wind_field_factory = @GriddedWindField')
    return []
  else:
    bindings += list(station)
  if dates is None:
    if 'start_dates' in winds.bound_settings():
      return bindings  # The user's gin chose the range.
    if not _is_era5_file(path):
      return bindings  # Another source: flights start anywhere in it.
    dates = default_dates
  value = era5_dates_value(dates)
  return bindings + [wind_file.start_dates(value)]


def _is_era5_file(path: Optional[str]) -> bool:
  """Whether the wind file (`path`, else gin's `GriddedWindField.path`) is
  ERA5, whose dates the commands' default splits (`gridded.DATE_SPLITS`) are;
  a GFS series, forecast or sounding is not split by them. Unreadable: True
  (the reader reports it when the env starts)."""
  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import winds
  from ble_latex.wind import gridded
  # pylint: enable=g-import-not-at-top
  try:
    path = path or winds.bound_settings()['path']
    return gridded.load(path).source == gridded.ERA5.label
  except (KeyError, OSError, ValueError):  # A BadFileError is a ValueError.
    return True


def wind_file_defaults(path: str) -> List[str]:
  """The station bindings --wind_file implies, where the user bound none.

  `stations.file_defaults` (per-seed stations on a gridded snapshot other
  than ERA5: eval seed s flies station s; a sounding's named site), unless
  `GriddedWindField.stations`, `center_lat` or `center_lon` is bound.

  Raises:
    FileNotFoundError, errors.BadFileError: as `gridded.load`.
  """
  # pylint: disable=g-import-not-at-top
  from ble_latex.envs import winds
  from ble_latex.run import wind_file
  from ble_latex.wind import gridded
  from ble_latex.wind import stations
  # pylint: enable=g-import-not-at-top
  if {'stations', 'center_lat', 'center_lon'} & set(winds.bound_settings()):
    return []
  defaults = stations.file_defaults(gridded.load(path))
  return wind_file.settings(defaults)


def era5_dates_value(dates: str) -> Any:
  """`GriddedWindField.start_dates` of an --era5_dates value (checked)."""
  from ble_latex.wind import gridded  # pylint: disable=g-import-not-at-top
  if dates == 'all':
    return None
  value = dates if dates in gridded.DATE_SPLITS else tuple(
      d.strip() for d in dates.split(','))
  try:
    gridded.start_dates_range(value, '--era5_dates')
  except errors.ConfigError as e:
    raise CommandUsageError(str(e)) from e
  return value


# -- Checks shared by train and eval. ----------------------------------------
def training_seeds(values: Sequence[str], flag: str = '--seeds'
                   ) -> List[int]:
  """A --seeds list of training seeds: distinct ints in [0, 2**32).

  Raises:
    CommandUsageError: One line naming the flag and the bad value.
  """
  try:
    seeds = [int(s) for s in values]
  except ValueError as e:
    raise CommandUsageError(f'{flag} takes integers, got {values}') from e
  if not seeds or len(set(seeds)) != len(seeds):
    raise CommandUsageError(f'{flag} takes distinct integers >= 0, got '
                            f'{values}')
  for seed in seeds:
    training_seed(seed, flag)
  return seeds


def training_seed(seed: int, flag: str = '--seed') -> int:
  """A training seed (`run_dir.check_training_seed`) or a usage error."""
  from ble_latex.run import run_dir  # pylint: disable=g-import-not-at-top
  try:
    return run_dir.check_training_seed(seed, flag)
  except errors.ConfigError as e:
    raise CommandUsageError(str(e)) from e



def check_ray_flags(address: Optional[str], num_cpus: Optional[int]) -> None:
  """--ray_address / --ray_num_cpus: Ray installed, address well formed."""
  from ble_latex.run import distributed  # pylint: disable=g-import-not-at-top
  if address is None:
    if num_cpus is not None:
      raise CommandUsageError('--ray_num_cpus needs --ray_address=local')
    return
  try:
    distributed.check_address(address)
    distributed.require_ray()
  except (ValueError, distributed.RayUnavailableError) as e:
    raise CommandUsageError(str(e)) from e
  if num_cpus is not None and address != 'local':
    raise CommandUsageError(
        '--ray_num_cpus is only for --ray_address=local; a cluster\'s nodes '
        'declare their CPUs (ray start --num-cpus)')


def check_agent(name: str) -> None:
  from ble_latex import quiet  # pylint: disable=g-import-not-at-top
  with quiet.third_party_noise():  # Imports dopamine's SAC, TF's GPU probe.
    # pylint: disable=g-import-not-at-top
    from balloon_learning_environment.agents import agent_registry
    from ble_latex import agents
    # pylint: enable=g-import-not-at-top
    agents.register()
  if name not in agent_registry.REGISTRY:
    raise CommandUsageError(unknown('agent', name, agent_registry.REGISTRY))


def check_suite(name: str) -> None:
  from ble_latex.run import suites  # pylint: disable=g-import-not-at-top
  if name not in suites.available_suites():
    raise CommandUsageError(unknown('suite', name, suites.available_suites()))


def check_env_name(name: str) -> None:
  import gym  # pylint: disable=g-import-not-at-top
  valid = [k for k in gym.envs.registry if 'Balloon' in k]
  if name not in gym.envs.registry:
    raise CommandUsageError(unknown('env', name, valid))


def check_gin_files(paths: Iterable[Optional[str]]) -> None:
  """Each gin file exists as given or under BLE's folder (as gin finds it)."""
  from ble_latex import quiet  # pylint: disable=g-import-not-at-top
  with quiet.third_party_noise():  # BLE's package import registers gym envs.
    import balloon_learning_environment  # pylint: disable=g-import-not-at-top
  ble_parent = os.path.dirname(
      os.path.dirname(balloon_learning_environment.__file__))
  shipped = [p.name for p in configs.gin_dir().glob('*.gin')]
  for path in paths:
    if path is None or os.path.isfile(path) or os.path.isfile(
        os.path.join(ble_parent, path)):
      continue
    hint = (f' (shipped: {configs.gin_file(os.path.basename(path))})'
            if os.path.basename(path) in shipped else '')
    raise CommandUsageError(
        f'{unknown("gin file", path, shipped)}{hint}; shipped files live in '
        f'{configs.gin_dir()}')


def one_line(error: BaseException) -> str:
  """An exception's message as one line (gin's call notes become a suffix).

  Args:
    error: The exception; gin appends '  In call to configurable X (...)'
      lines to exceptions raised inside a configurable.

  Returns:
    Its first line, with ' (in gin configurable X)' for the innermost
    configurable gin noted.
  """
  text = str(error) or type(error).__name__
  first, *rest = text.split('\n')
  notes = [line.strip()[len(_GIN_CALL_NOTE):].split(' ', 1)[0].strip("'")
           for line in rest if line.strip().startswith(_GIN_CALL_NOTE)]
  if notes:
    first += f' (in gin configurable {notes[0]})'
  return first


def refused_config_message(error: ValueError) -> Optional[str]:
  """The one-line usage message of a refused configuration, else None.

  Refused: gin's unknown configurable/parameter (`gin_usage_message`), an
  `errors.ConfigError` (e.g. a gin binding that does not parse, an agent that
  does not fit the env), and a ValueError raised inside a gin configurable's
  call (gin notes it): a bound value the configurable's checks refuse.

  Args:
    error: The ValueError.

  Returns:
    The message, or None for an `errors.BadFileError` (a failure, not a
    usage error) and any other ValueError (a bug: re-raise it).
  """
  if isinstance(error, errors.BadFileError):
    return None
  message = gin_usage_message(error)
  if message is not None:
    return message
  if isinstance(error, errors.ConfigError) or _GIN_CALL_NOTE in str(error):
    return one_line(error)
  return None


def gin_usage_message(error: ValueError) -> Optional[str]:
  """One line for gin's unknown-configurable/parameter errors, else None."""
  first = str(error).split('\n', 1)[0]
  if first.startswith('No configurable matching '):
    name = first[len('No configurable matching '):].strip(" .'")
    return unknown('gin configurable', name, _latex_configurables(),
                   label="ble_latex's (BLE's work too)")
  if "doesn't have a parameter named" in first:
    return f'gin binding: {first}'
  return None


def _latex_configurables() -> list:
  from gin import config  # pylint: disable=g-import-not-at-top
  registry = config._REGISTRY  # pylint: disable=protected-access
  return sorted({c.name for _, c in registry.items()
                 if c.module.startswith('ble_latex') and
                 c.name not in gin_aliases.ALIASES})  # Not the old names.
