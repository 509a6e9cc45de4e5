# coding=utf-8
"""Ray: connecting to a cluster, and eval seeds as Ray tasks.

`ble-latex-eval --ray_address=...` and `ble-latex-sweep` run on Ray (the
optional extra `pip install 'ble_latex[ray]'`). Nothing here schedules,
pools or stores anything itself: each eval seed is one Ray task, retried by
Ray when its worker dies (`max_retries`), and results come back through
Ray's object store.

Addresses (`connect`):
- `local`: an embedded Ray on this machine, with `num_cpus` CPUs (default:
  all), shut down when the command ends;
- `auto`: the cluster this machine has joined (`ray start --head` here, or
  `ray start --address=HEAD:6379` on a worker);
- `HOST:PORT`: that cluster's head node (its GCS port, 6379 by default), or
  `ray://HOST:10001` for Ray Client from outside the cluster.

Workers import ble_latex themselves: every node of a cluster needs the
package installed (the same version), and the files a command names (gin
files, checkpoints) at the same absolute paths, e.g. on a shared filesystem.
"""

import json
import socket
from typing import Any, Dict, List, Optional, Sequence, Tuple

from ble_latex import errors

RAY_EXTRA = "pip install 'ble_latex[ray]'"
# A worker that dies (node lost, out of memory) has its task re-run this many
# times by Ray; an exception raised by the task itself is not retried.
MAX_RETRIES = 3

# Agents and envs a worker has built, by spec (`_fly_seed`).
_WORKER_CACHE: Dict[str, Tuple[Any, Any]] = {}


class RayUnavailableError(RuntimeError):
  """Ray is not installed, or the cluster cannot be reached."""


class SeedsFailedError(RuntimeError):
  """Some eval seeds failed on every try.

  Attributes:
    failures: Seed -> the error of its last try.
    completed: The records of the seeds that did not fail, in seed order.
  """

  def __init__(self, failures: Dict[int, str],
               completed: Sequence[Dict[str, Any]] = ()):
    self.failures = dict(failures)
    self.completed = list(completed)
    lines = [f'  seed {s}: {e}' for s, e in sorted(self.failures.items())]
    super().__init__(f'{len(self.failures)} seed(s) failed on Ray:\n' +
                     '\n'.join(lines))


def require_ray():
  """Imports Ray, or says which extra installs it."""
  try:
    import ray  # pylint: disable=g-import-not-at-top
  except ImportError as e:
    raise RayUnavailableError(
        f'Ray is not installed; install the extra: {RAY_EXTRA}') from e
  return ray


def check_ray_flags(address: Optional[str], num_cpus: Optional[int]) -> None:
  """--ray_address / --ray_num_cpus: Ray installed, address well formed.

  Raises:
    errors.UsageError: One line naming the flag (exit 2).
  """
  if address is None:
    if num_cpus is not None:
      raise errors.UsageError('--ray_num_cpus needs --ray_address=local')
    return
  try:
    check_address(address)
    require_ray()
  except (ValueError, RayUnavailableError) as e:
    raise errors.UsageError(str(e)) from e
  if num_cpus is not None and address != 'local':
    raise errors.UsageError(
        '--ray_num_cpus is only for --ray_address=local; a cluster\'s nodes '
        'declare their CPUs (ray start --num-cpus)')


def check_address(address: str) -> None:
  """Raises ValueError unless `address` is local, auto, HOST:PORT or ray://."""
  if address in ('local', 'auto'):
    return
  host, _, port = address.removeprefix('ray://').rpartition(':')
  if not host or not port.isdigit():
    raise ValueError(f'Ray address {address!r}: expected local, auto, '
                     'HOST:PORT or ray://HOST:PORT')


def connect(address: str, num_cpus: Optional[int] = None) -> None:
  """Starts (`local`) or joins (`auto`, `HOST:PORT`, `ray://...`) Ray.

  Args:
    address: `local`, `auto`, `HOST:PORT` or `ray://HOST:PORT`.
    num_cpus: CPUs of a `local` Ray (default: all of this machine's); must be
      None when joining a cluster, whose nodes declare their own.

  Raises:
    RayUnavailableError: Ray is not installed or the cluster is unreachable.
    ValueError: A malformed address.
  """
  ray = require_ray()
  check_address(address)
  if address not in ('local', 'auto'):
    _probe(address)
  if ray.is_initialized():  # Already connected in this process: reuse.
    return
  quiet = dict(include_dashboard=False, log_to_driver=False,
               configure_logging=True, logging_level='WARNING')
  if address == 'local':
    ray.init(num_cpus=num_cpus, **quiet)
    return
  if num_cpus is not None:
    raise ValueError('num_cpus is only for a local Ray; a cluster\'s nodes '
                     'declare their CPUs (ray start --num-cpus)')
  try:
    if address.startswith('ray://'):
      ray.init(address=address, log_to_driver=False)
    else:
      ray.init(address=address, **quiet)
  except (ConnectionError, RuntimeError, TimeoutError) as e:
    raise RayUnavailableError(
        f'cannot reach the Ray cluster at {address!r} ({e}); start one with '
        '`ray start --head` or use --ray_address=local') from e


def _probe(address: str, timeout_s: float = 10.0) -> None:
  """Fails fast if nothing listens at HOST:PORT (ray.init would retry long)."""
  host, _, port = address.removeprefix('ray://').rpartition(':')
  try:
    with socket.create_connection((host.strip('[]'), int(port)),
                                  timeout=timeout_s):
      pass
  except OSError as e:
    raise RayUnavailableError(
        f'cannot reach the Ray cluster at {address!r} ({e}); start one with '
        '`ray start --head` or use --ray_address=local') from e


def shutdown() -> None:
  """Stops this process's Ray connection (or embedded Ray), if one is up."""
  ray = require_ray()
  if ray.is_initialized():
    ray.shutdown()


def _fly_seeds(spec_json: str, seeds: List[int], max_steps: int
               ) -> List[Dict[str, Any]]:
  """Ray task body: the eval records of seeds (agent built once per worker).

  One seed: `eval_lib.fly`; several (agents flown batched): one
  `batch_eval.evaluate` batch.
  """
  # pylint: disable=g-import-not-at-top
  import ble_latex  # pylint: disable=unused-import  # Fixes first.
  from ble_latex.run import eval_lib
  # pylint: enable=g-import-not-at-top
  if spec_json not in _WORKER_CACHE:
    _WORKER_CACHE.clear()  # gin is process-wide: one spec per worker at a time.
    spec = eval_lib.EvalSpec(**json.loads(spec_json))
    _WORKER_CACHE[spec_json] = eval_lib.build(spec)
  agent, env = _WORKER_CACHE[spec_json]
  if len(seeds) == 1:
    return [eval_lib.fly(agent, env, seeds[0], max_steps)]
  from ble_latex.run import batch_eval  # pylint: disable=g-import-not-at-top
  return batch_eval.evaluate(agent, env, seeds, max_steps,
                             batch_size=len(seeds))


def evaluate(spec: Any, seeds: Sequence[int], max_steps: int,
             description: str = 'eval', batch_size: int = 1
             ) -> List[Dict[str, Any]]:
  """Flies the seeds as Ray tasks; the records in seed order.

  A task flies one seed, or with `batch_size` > 1 (an agent flown batched,
  `batch_eval`) up to `batch_size` seeds at once, in no fewer tasks than
  the cluster's CPUs (while there are seeds); a failed task fails each of
  its seeds.

  The records equal `eval_lib.evaluate`'s for agents whose eval episodes do
  not depend on earlier ones (every deterministic policy; not
  `latex_random`, whose one random stream runs through all seeds in a
  single process).

  Args:
    spec: An `eval_lib.EvalSpec`.
    seeds: Env seeds.
    max_steps: Steps per episode.
    description: Progress-bar label.
    batch_size: Seeds per task at most (1: one seed per task).

  Returns:
    One record per seed, in the order of `seeds`.

  Raises:
    SeedsFailedError: Seeds whose task failed on every try (by seed, with the
      error), after all others finished.
  """
  # pylint: disable=g-import-not-at-top
  import dataclasses
  import tqdm
  from ble_latex.run import eval_lib
  # pylint: enable=g-import-not-at-top
  ray = require_ray()
  spec_json = json.dumps(dataclasses.asdict(spec.absolute()))
  task = ray.remote(max_retries=MAX_RETRIES)(_fly_seeds)
  cpus = max(1, int(ray.cluster_resources().get('CPU', 1)))
  size = max(1, min(batch_size, -(-len(seeds) // cpus)))
  chunks = [list(range(i, min(i + size, len(seeds))))
            for i in range(0, len(seeds), size)]
  refs = {task.remote(spec_json, [int(seeds[i]) for i in chunk],
                      max_steps): chunk for chunk in chunks}
  records: List[Optional[Dict[str, Any]]] = [None] * len(seeds)
  failures: Dict[int, str] = {}
  pending = list(refs)
  with tqdm.tqdm(total=len(seeds), desc=f'{description} (ray)',
                 unit='episode', dynamic_ncols=True) as bar:
    while pending:
      ready, pending = ray.wait(pending, num_returns=1)
      chunk = refs[ready[0]]
      try:
        for i, record in zip(chunk, ray.get(ready[0])):
          records[i] = record
      except ray.exceptions.RayError as e:
        failures.update({int(seeds[i]): _error_line(e) for i in chunk})
      bar.update(len(chunk))
      done = [r for r in records if r is not None]
      if done:
        bar.set_postfix(eval_lib.progress_postfix(done))
  if failures:
    raise SeedsFailedError(failures, [r for r in records if r is not None])
  return records


def _error_line(error: Exception) -> str:
  """The failing task's own exception, in one line."""
  cause = getattr(error, 'cause', None)
  if isinstance(cause, BaseException):
    return f'{type(cause).__name__}: {cause}'.splitlines()[0]
  return f'{type(error).__name__}: {error}'.splitlines()[0]
