# coding=utf-8
"""Search methods over a launch grid, at equal rollout budgets (issue 46).

The dense grid, scored batched (`scoring.score`), is the ground truth on the
grid: its best expected TW50 is the optimum every method is measured
against. A method proposes one launch at a time; each proposal is snapped to
the nearest grid node and costs one evaluation (K rollouts, one per noise
draw), the grid's score of that node (so every method sees the same noisy
K-draw estimate, and a repeated proposal costs again). After b evaluations
a method recommends the best it has seen; its regret is

  regret(b) = max_grid score - score(best seen in the first b)  (>= 0).

Methods:
- `random_proposals`: uniform in the box (Saunders et al.'s baseline);
- `bayes_proposals`: Bayesian optimisation (`bayes_opt` 3.4.0, the
  `bayesian-optimization` package: a Gaussian process with a Matern 5/2
  kernel over the box scaled to [0, 1]^d, its length scales refit at every
  proposal, upper-confidence-bound acquisition, the library's defaults
  otherwise; each suggestion snapped to the nearest node not yet
  evaluated), after `init_points` uniform proposals, as the follow-up
  paper's spatio-temporal GP searches launch site and time;
- the grid itself, in a random order (`grid_proposals`): what exhaustive
  search has found after b evaluations if it is stopped there.
"""

import dataclasses
import warnings
from typing import Dict, List, Sequence

import numpy as np

from ble_latex import errors
from ble_latex.launch import scoring

METHODS = ('grid', 'random', 'bayes')


@dataclasses.dataclass(frozen=True)
class GridTable:
  """A scored dense grid (`scoring.grid` order) as the searches' objective.

  Attributes:
    axes: Per dimension (`SearchSpace.names` order) its grid points.
    score: [N] expected TW50 of each node (`Scores.mean`). # [.]
  """
  axes: Sequence[np.ndarray]
  score: np.ndarray

  @classmethod
  def from_scores(cls, space: scoring.SearchSpace, shape: Sequence[int],
                  scores: scoring.Scores) -> 'GridTable':
    """The table of `scoring.grid(space, *shape)`'s scores."""
    expected = scoring.grid(space, *shape).array()
    if expected.shape != scores.launches.array().shape or not np.allclose(
        expected, scores.launches.array()):
      raise errors.ConfigError(
          f'scores of {len(scores.launches)} launches are not the grid '
          f'{tuple(shape)} of {space}')
    axes = [np.unique(values) for values in expected.T]
    return cls(axes=axes, score=np.asarray(scores.mean, np.float64))

  @property
  def active(self) -> List[int]:
    """The dimensions with more than one grid point."""
    return [d for d, a in enumerate(self.axes) if len(a) > 1]

  @property
  def optimum(self) -> float:
    """The grid's best score."""
    return float(self.score.max())

  def index(self, unit: np.ndarray) -> int:
    """The grid node nearest a point of the active box scaled to [0, 1]^d."""
    strides = np.cumprod([1] + [len(a) for a in self.axes[:-1]])
    index = 0
    for u, d in zip(np.clip(unit, 0.0, 1.0), self.active):
      n = len(self.axes[d])
      index += int(np.rint(u * (n - 1))) * int(strides[d])
    return index

  def unit(self, index: int) -> np.ndarray:
    """The node's coordinates in the active box scaled to [0, 1]^d."""
    out, strides = [], np.cumprod([1] + [len(a) for a in self.axes[:-1]])
    for d in self.active:
      n = len(self.axes[d])
      out.append((index // int(strides[d])) % n / (n - 1))
    return np.array(out)


def _check_budget(budget: int) -> None:
  if not isinstance(budget, (int, np.integer)) or budget < 1:
    raise errors.ConfigError(f'search budget must be an integer >= 1, got '
                             f'{budget!r}')


def grid_proposals(table: GridTable, budget: int, seed: int) -> np.ndarray:
  """The grid's nodes in a random order (exhaustive search, stopped)."""
  _check_budget(budget)
  order = np.random.default_rng(seed).permutation(len(table.score))
  return order[:budget]


def random_proposals(table: GridTable, budget: int, seed: int) -> np.ndarray:
  """`budget` uniform proposals in the box, snapped to the grid."""
  _check_budget(budget)
  rng = np.random.default_rng(seed)
  return np.array([table.index(u) for u in
                   rng.uniform(size=(budget, len(table.active)))])


def bayes_proposals(table: GridTable, budget: int, seed: int,
                    init_points: int = 5) -> np.ndarray:
  """Bayesian optimisation's `budget` proposals, snapped to the grid.

  Args:
    table: The scored grid.
    budget: Evaluations.
    seed: Seeds the initial proposals and the optimiser.
    init_points: Uniform proposals before the Gaussian process leads.

  Returns:
    [budget] grid indices, in the order proposed.
  """
  import bayes_opt  # pylint: disable=g-import-not-at-top
  _check_budget(budget)
  names = [f'x{d}' for d in table.active]
  optimizer = bayes_opt.BayesianOptimization(
      f=None, pbounds={n: (0.0, 1.0) for n in names}, random_state=seed,
      verbose=0, allow_duplicate_points=True)
  first = list(dict.fromkeys(  # Distinct, in the order drawn.
      random_proposals(table, min(init_points, budget), seed).tolist()))
  # The scores are K-draw means: a little observation noise for the GP.
  # One fit of the kernel's length scales per proposal, from the last ones
  # (no random restarts: 10x faster, ~0.2 s a proposal on 2 busy cores).
  optimizer.set_gp_params(alpha=1e-4, n_restarts_optimizer=0)
  proposals = list(first)
  for index in first:
    optimizer.register(params=dict(zip(names, table.unit(index))),
                       target=float(table.score[index]))
  nodes = np.array([table.unit(i) for i in range(len(table.score))])
  seen = np.zeros(len(nodes), bool)
  seen[first] = True
  while len(proposals) < budget:
    with warnings.catch_warnings():  # sklearn's kernel-bound notes.
      warnings.simplefilter('ignore')
      point = optimizer.suggest()
    # The nearest node not yet evaluated (a suggestion next to a node seen
    # would otherwise stall the search on it; the grid is finite).
    distance = np.sum((nodes - np.array([point[n] for n in names]))**2, axis=1)
    index = int(np.argmin(np.where(seen, np.inf, distance)))
    if seen.all():
      index = table.index(np.array([point[n] for n in names]))
    seen[index] = True
    proposals.append(index)
    optimizer.register(params=dict(zip(names, table.unit(index))),
                       target=float(table.score[index]))
  return np.array(proposals)


PROPOSERS = {'grid': grid_proposals, 'random': random_proposals,
             'bayes': bayes_proposals}


def regret_curve(table: GridTable, proposals: np.ndarray,
                 budgets: Sequence[int]) -> List[float]:
  """Regret of the best seen after each budget's first proposals."""
  seen = np.maximum.accumulate(table.score[proposals])
  return [table.optimum - float(seen[min(b, len(seen)) - 1]) for b in budgets]


def compare(table: GridTable, budgets: Sequence[int], seeds: Sequence[int],
            methods: Sequence[str] = METHODS) -> Dict[str, List[List[float]]]:
  """Each method's regret at each budget, per seed.

  Returns:
    {method: [seed][budget] regret}.
  """
  for method in methods:
    if method not in PROPOSERS:
      raise errors.ConfigError(f'unknown search method {method!r}; valid: '
                               f'{", ".join(METHODS)}')
  top = max(budgets)
  return {m: [regret_curve(table, PROPOSERS[m](table, top, int(s)), budgets)
              for s in seeds] for m in methods}
