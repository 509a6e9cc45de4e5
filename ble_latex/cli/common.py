# coding=utf-8
"""The command-line convention of every `ble-latex-*` command.

This module holds the convention only (absl plumbing, usage errors, the flags
and help texts commands and scripts share); what the commands check and build
lives in the package: a wind file's bindings in `run.wind_file`, gin's
one-line messages in `run.gin_binding`, name and seed checks beside their
registries (`agents.check_agent`, `run.suites.check_suite`,
`ble.gym_registration.check_env_name`, `configs.check_gin_files`,
`run.run_dir.training_seeds`, `run.distributed.check_ray_flags`).

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

import importlib
import os
import sys
import types
from typing import Any, Callable, NoReturn, Optional, Sequence

from absl import app
from absl import flags
import gin

from ble_latex import errors
from ble_latex import gin_values
from ble_latex import safe_io
from ble_latex.run import gin_binding

HELP_FLAGS = ('-h', '--help', '-help', '--helpshort', '--helpfull',
              '-helpfull')
EXIT_USAGE = 2
EXIT_FAILURE = 1


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


class CommandUsageError(errors.UsageError):
  """A usage error found while running: one line, exit status 2.

  A command's or script's own check raises it; library code checking a
  command-line value raises its base, `errors.UsageError` (`run_absl`
  reports both alike).
  """


class CommandFailure(Exception):
  """A failure found while running: one line, exit status 1."""


def usage(prog: str, message: str) -> int:
  """Prints the one-line usage error `PROG: message`; returns exit status 2."""
  print(f'{prog}: {message}', file=sys.stderr)
  return EXIT_USAGE


def usage_error(prog: str, message: str) -> NoReturn:
  """`usage`, then exits with its status."""
  sys.exit(usage(prog, message))


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
    except (app.UsageError, errors.UsageError) as e:
      usage_error(prog, str(e))
    except (OSError, errors.BadFileError, CommandFailure, safe_io.InUseError,
            FloatingPointError) as e:  # FloatingPointError: a diverged run.
      print(f'{prog}: {gin_binding.one_line(e)}', file=sys.stderr)
      sys.exit(EXIT_FAILURE)
    except ValueError as e:
      message = gin_binding.refused_config_message(e)
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
  """--station_lat / --station_lon of eval and train
  (`run.wind_file.station_bindings` reads them)."""
  for name, what, other in (('station_lat', '[deg N]', 'lon'),
                            ('station_lon', '[deg E]', 'lat')):
    flags.DEFINE_float(name, None, STATION_HELP.format(what=what, other=other),
                       flag_values=flag_values)
