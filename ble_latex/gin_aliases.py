# coding=utf-8
"""Gin configurables renamed, their old names kept as aliases for one release.

Gin registers a configurable under one name and has no alias of it. `renamed`
registers a function under its new name and, beside it, a stand-in under the
old name (and the old module string) taking the same keywords, so that gin
files, commands and recorded operative configs that spell the old name still
parse. The returned function reads both:

- a keyword bound under the old name only is used as if bound under the new
  one (a `FutureWarning` names the new binding);
- bound under both names to the same value: that value; to two different
  values: `errors.ConfigError` naming both (one value, one home);
- a keyword the caller passes wins over both, as gin's own.

The operative config (`gin.operative_config_str`) then lists each value once,
under the name that bound it, so a recorded config parses back to the same
values. `ALIASES` lists the old names (docs/commands.md, "Gin names"); they go in the
release after the one that renamed them (`REMOVAL`).

Light on purpose: only gin and the standard library.
"""

import functools
import inspect
from typing import Any, Callable, Dict
import warnings

import gin

from ble_latex import errors

# Old gin name -> new gin name, for every alias `renamed` registered.
ALIASES: Dict[str, str] = {}
# When the aliases go.
REMOVAL = 'the next release'


def current(binding: str) -> str:
  """Gin binding text 'NAME.key = value' under today's name of NAME.

  A NAME (maybe module-qualified) that `ALIASES` lists as renamed becomes
  its new name, unqualified; any other text is returned as it is. For
  comparing a binding recorded before a rename with one written today
  (the modules that rename must be imported first: they fill `ALIASES`).
  """
  target, equals, value = binding.partition('=')
  parts = target.strip().split('.')
  if not equals or len(parts) < 2 or parts[-2] not in ALIASES:
    return binding
  return f'{ALIASES[parts[-2]]}.{parts[-1]} ={value}'


def _unbound(value: Any) -> Any:
  """A bound value as comparable text (references are not evaluated)."""
  return repr(value)


def renamed(name: str, *, module: str, old_name: str,
            old_module: str) -> Callable[[Callable[..., Any]], Any]:
  """Makes a keyword-only function gin configurable `name`, alias `old_name`.

  Args:
    name: The gin name (e.g. 'latex_episode').
    module: Its gin module string (the module that declares it).
    old_name: The name it had (e.g. 'LatexBalloonEnv'), registered as an
      alias until `REMOVAL`.
    old_module: The module string the old name was registered under, so that
      module-qualified old bindings parse too.

  Returns:
    A decorator returning the function to call: gin's configurable with the
    old name's bindings merged in (the module docstring).
  """
  def decorate(function: Callable[..., Any]) -> Callable[..., Any]:
    configurable = gin.configurable(name, module=module)(function)
    keywords = [p.replace(default=inspect.Parameter.empty)
                for p in inspect.signature(function).parameters.values()]

    def alias(**values: Any) -> Dict[str, Any]:
      return values  # Only what was bound under the old name (no defaults).
    alias.__name__ = alias.__qualname__ = old_name
    alias.__module__ = function.__module__
    alias.__doc__ = f'Deprecated gin name of `{name}` (until {REMOVAL}).'
    alias.__signature__ = inspect.Signature(keywords)
    alias = gin.configurable(old_name, module=old_module)(alias)
    ALIASES[old_name] = name

    @functools.wraps(function)
    def merged(**given: Any) -> Any:
      old = gin.get_bindings(alias, resolve_references=False)
      if not old:
        return configurable(**given)
      new = gin.get_bindings(configurable, resolve_references=False)
      for key in sorted(set(old) & set(new) - set(given)):
        if _unbound(old[key]) != _unbound(new[key]):
          raise errors.ConfigError(
              f'gin bindings {old_name}.{key} = {old[key]!r} and '
              f'{name}.{key} = {new[key]!r} differ: {old_name} is the old '
              f'name of {name} (an alias until {REMOVAL}); bind '
              f'{name}.{key} only')
      warnings.warn(
          f'gin name {old_name}.* is deprecated (removed in {REMOVAL}): bind '
          f'{name}.{", ".join(sorted(old))} instead', FutureWarning,
          stacklevel=2)
      values = {k: v for k, v in alias().items()  # Gin injects, and logs.
                if k not in new and k not in given}
      return configurable(**values, **given)
    merged.gin_name = name
    merged.gin_alias = old_name
    return merged
  return decorate
