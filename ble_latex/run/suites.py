# coding=utf-8
"""Held-out evaluation suites for the latex balloon, in BLE's suite registry.

Training episode i uses env seed TRAIN_SEED_OFFSET + i (< EVAL_SEED_OFFSET);
evaluation suites use seeds from EVAL_SEED_OFFSET up, so they never overlap.
`latex_validation` (seeds from VALIDATION_SEED_OFFSET) is for choosing among
checkpoints (`benchmarks/train_sac.py select`); it overlaps neither training
nor the held-out suites that results are reported on.
On ERA5 winds the split is by dates too (`era5_dates`): training flights
start inside `wind.gridded.DATE_SPLITS['train']`, `latex_validation` inside
'validation' and every other suite inside 'eval', three disjoint date
ranges a 3-day episode apart, so a policy is never evaluated (or chosen) on
winds it trained on.
Registration is explicit and happens in one place, `register()`: nothing is
added to BLE's registry at import. `get_eval_suite` and `available_suites`
(BLE's, with the latex suites registered first) are what ble_latex's commands
use; code that calls BLE's registry itself calls `register()` first.
"""

from typing import List

from balloon_learning_environment.eval import suites

from ble_latex import errors
from ble_latex.envs import task

TRAIN_SEED_OFFSET = 0
EVAL_SEED_OFFSET = 1_000_000
VALIDATION_SEED_OFFSET = 2_000_000
EPISODE_STEPS = task.EPISODE_STEPS  # 3 days of 20-minute actions.

SUITE_SIZES = {
    'latex_micro': 1,
    'latex_tiny': 10,
    'latex_small': 100,
    'latex_medium': 1000,
}


# The ERA5 date split (`wind.gridded.DATE_SPLITS`) each use flies.
TRAIN_DATES = 'train'
SUITE_DATES = {'latex_validation': 'validation'}
EVAL_DATES = 'eval'  # Every other suite.


def era5_dates(suite: str) -> str:
  """The `DATE_SPLITS` name ERA5 flights of `suite` start in."""
  return SUITE_DATES.get(suite, EVAL_DATES)


def register() -> None:
  """Adds the latex suites to BLE's registry (idempotent).

  BLE 1.0.1 has no public registration function: its registry is the
  module's `_eval_suites` dict, which `suites.get_eval_suite` reads.
  """
  for name, size in SUITE_SIZES.items():
    suites._eval_suites[name] = suites.EvaluationSuite(  # pylint: disable=protected-access
        list(range(EVAL_SEED_OFFSET, EVAL_SEED_OFFSET + size)), EPISODE_STEPS)
  suites._eval_suites['latex_validation'] = suites.EvaluationSuite(  # pylint: disable=protected-access
      list(range(VALIDATION_SEED_OFFSET, VALIDATION_SEED_OFFSET + 100)),
      EPISODE_STEPS)


def get_eval_suite(name: str) -> suites.EvaluationSuite:
  """BLE's `suites.get_eval_suite(name)`, the latex suites included."""
  register()
  return suites.get_eval_suite(name)


def available_suites() -> List[str]:
  """BLE's `suites.available_suites()`, the latex suites included."""
  register()
  return suites.available_suites()


def check_suite(name: str) -> None:
  """Raises errors.UsageError (exit 2) unless `name` is a suite."""
  if name not in available_suites():
    raise errors.UsageError(errors.unknown('suite', name, available_suites()))


def train_seed(episode: int) -> int:
  """Env seed of training episode `episode`."""
  seed = TRAIN_SEED_OFFSET + episode
  if seed >= EVAL_SEED_OFFSET:
    raise ValueError(f'training episode {episode} would use seed {seed}, '
                     f'inside the held-out eval seeds (>= {EVAL_SEED_OFFSET})')
  return seed
