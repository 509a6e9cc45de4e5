# coding=utf-8
"""Choosing on validation: the best record within an out-of-resources cap.

The one home of the project's selection rule (issue 66): among validation
results, keep those with at most `max_oor_pct` % of flights out of
resources, and take the highest TW50 over the window
(`tw50_window_mean`), ties broken by `tie` (larger wins; e.g. the earlier
round with `tie=lambda r: -r['iteration']`). Every chooser uses it: a
training seed's snapshot (`choose_snapshot`: `benchmarks/sac_seeds.py`,
`benchmarks/reward_shape.py`; `sweep_lib`), a candidate policy
(`best_named`: `benchmarks/train_sac.py`; `run.seed_runs.best_snapshots`:
`benchmarks/policy_select.py`), a DAgger round (`run.dagger.best_round`)
and the docs' best-validated seed (`docs/hooks/learned.py`).

Only validation results go in: nothing here looks at a held-out suite.
"""

from typing import (Any, Callable, Dict, Iterable, List, Mapping, Optional,
                    TypeVar)

T = TypeVar('T')

SCORE = 'tw50_window_mean'  # the metric, maximised
OUT_OF_RESOURCES = 'out_of_resources_pct'  # the cap's field [%]


def _identity(row: Any) -> Any:
  return row


def _no_tie(row: Any) -> int:
  del row
  return 0


def ranked(rows: Iterable[T], *, max_oor_pct: Optional[float] = None,
           result: Callable[[T], Any] = _identity,
           tie: Callable[[T], Any] = _no_tie) -> List[T]:
  """`rows` within the cap, best first.

  Args:
    rows: Anything that holds a validation result (`result(row)` is a
      mapping with `SCORE` and `OUT_OF_RESOURCES`).
    max_oor_pct: Most % of validation flights out of resources; None = no
      cap.
    result: Where a row keeps its validation result (the row itself by
      default).
    tie: A key that breaks equal scores, larger first.

  Returns:
    The rows within the cap, highest `SCORE` first (then highest `tie`);
    rows of equal keys keep their order.
  """
  fit = [r for r in rows if max_oor_pct is None or
         result(r)[OUT_OF_RESOURCES] <= max_oor_pct]
  return sorted(fit, key=lambda r: (result(r)[SCORE], tie(r)), reverse=True)


def best(rows: Iterable[T], *, max_oor_pct: Optional[float] = None,
         result: Callable[[T], Any] = _identity,
         tie: Callable[[T], Any] = _no_tie) -> Optional[T]:
  """The best row of `ranked` (the first of equal keys), or None."""
  order = ranked(rows, max_oor_pct=max_oor_pct, result=result, tie=tie)
  return order[0] if order else None


def choose_snapshot(validation: List[Dict[str, Any]], max_oor_pct: float,
                    max_minutes: Optional[float] = None,
                    max_iteration: Optional[int] = None
                    ) -> Optional[Dict[str, Any]]:
  """The validated snapshot with the best TW50 (window) within the caps.

  Ties go to the earlier round.

  Args:
    validation: validation.jsonl records.
    max_oor_pct: Most % of validation episodes out of resources.
    max_minutes: Only snapshots taken within this much training time [min].
    max_iteration: Only snapshots of rounds up to this one (0-based).
  """
  capped = [r for r in validation if
            (max_minutes is None or r['elapsed_s'] <= 60.0 * max_minutes) and
            (max_iteration is None or r['iteration'] <= max_iteration)]
  return best(capped, max_oor_pct=max_oor_pct, tie=lambda r: -r['iteration'])


def best_named(results: Mapping[str, Dict[str, Any]],
               max_oor_pct: float) -> Optional[str]:
  """The name of the best result within the cap (ties: higher
  `reward_mean`), or None: a candidate policy among named validations."""
  chosen = best(results.items(), max_oor_pct=max_oor_pct,
                result=lambda item: item[1],
                tie=lambda item: item[1]['reward_mean'])
  return chosen[0] if chosen else None
