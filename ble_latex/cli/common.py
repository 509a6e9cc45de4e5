# coding=utf-8
"""Shared command-line behaviour of the absl-based commands.

`ble-latex-train`, `ble-latex-eval` and `ble-latex-export-policy` use BLE's
absl flags. absl's own handling prints only "USAGE: ... [flags]" for --help
and exits 1, and prints its whole usage (or a traceback) for a bad name.
`run_absl` gives every command the same contract instead:

- `--help` / `-h` lists the command's flags (`--helpfull`: all flags, absl's
  included) and exits 0;
- a usage error (unknown flag, bad or missing value, unknown agent, suite, env,
  gin file or gin configurable) is one line on stderr,
  `PROG: what is wrong; valid: a, b, c`, and exit status 2.
"""

import difflib
import os
import sys
from typing import Callable, Iterable, NoReturn, Optional, Sequence

from absl import app
from absl import flags

from ble_latex import configs

HELP_FLAGS = ('-h', '--help', '-help', '--helpshort')
EXIT_USAGE = 2


class CommandUsageError(Exception):
  """A usage error found while running: one line, exit status 2."""


def usage_error(prog: str, message: str) -> NoReturn:
  print(f'{prog}: {message}', file=sys.stderr)
  sys.exit(EXIT_USAGE)


def unknown(what: str, name: str, valid: Iterable[str],
            label: str = 'valid') -> str:
  """"unknown agent 'x'; valid: a, b" (with a guess when one is close)."""
  valid = sorted(set(valid))
  close = difflib.get_close_matches(name, valid, n=1)
  guess = f' (did you mean {close[0]!r}?)' if close else ''
  return f'unknown {what} {name!r}{guess}; {label}: {", ".join(valid)}'


def help_text(prog: str, doc: Optional[str], module: str,
              full: bool = False) -> str:
  fv = flags.FLAGS
  listing = fv.get_help() if full else fv.module_help(module)
  parts = [f'usage: {prog} [flags]']
  if doc:
    parts.append(doc.strip())
  parts.append('flags:' if full else f'flags (all flags: {prog} --helpfull):')
  parts.append(listing)
  return '\n\n'.join(parts)


def run_absl(main: Callable[[Sequence[str]], Optional[int]], prog: str,
             argv: Optional[Sequence[str]] = None, doc: Optional[str] = None,
             check: Optional[Callable[[], None]] = None) -> None:
  """Parses flags, runs `check` (raising CommandUsageError) then absl's main.

  Args:
    main: absl main (gets [prog, *positional args]).
    prog: Command name for messages.
    argv: Arguments without the program name (default sys.argv[1:]).
    doc: Text shown above the flags by --help.
    check: Validates flag values before the work starts; raises
      CommandUsageError with a one-line message.
  """
  argv = list(sys.argv[1:] if argv is None else argv)
  names = {a.split('=', 1)[0] for a in argv}
  if names & {'--helpfull', '-helpfull'}:
    print(help_text(prog, doc, main.__module__, full=True))
    sys.exit(0)
  if names & set(HELP_FLAGS):
    print(help_text(prog, doc, main.__module__))
    sys.exit(0)
  flags.FLAGS.unparse_flags()
  try:
    flags.FLAGS([prog, *argv])  # Only to report errors in one line.
  except flags.Error as e:
    usage_error(prog, f'{e} (try --help)')
  # app.run parses again; multi-value flags would otherwise double up.
  flags.FLAGS.unparse_flags()

  def checked_main(args: Sequence[str]) -> Optional[int]:
    try:
      if check is not None:
        check()
      return main(args)
    except (app.UsageError, CommandUsageError) as e:
      usage_error(prog, str(e))
    except ValueError as e:
      gin_message = gin_usage_message(e)
      if gin_message is None:
        raise
      usage_error(prog, gin_message)

  quiet_init_callbacks()
  app.run(checked_main, argv=[prog, *argv])


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


# -- Checks shared by train and eval. ----------------------------------------
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
  from balloon_learning_environment.agents import agent_registry  # pylint: disable=g-import-not-at-top
  from ble_latex import agents  # pylint: disable=g-import-not-at-top
  from ble_latex import quiet  # pylint: disable=g-import-not-at-top
  with quiet.third_party_noise():  # Imports dopamine's SAC, TF's GPU probe.
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
                 if c.module.startswith('ble_latex')})
