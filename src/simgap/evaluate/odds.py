"""Odds, not anecdotes: how likely an outcome is over repeats of one scenario with other seeds.

A physical run near a limit goes one way or the other with the sensing noise's seed (and, with
``measured`` latency, the machine's load). Over N repeats: the goal rate and the failure rate
with Wilson's 95 % score interval (exact enough at small N, never outside [0, 1], unlike the
normal approximation), and quantiles of the largest lateral offset ``max |d|`` with a bootstrap
percentile interval (seeded: the same repeats give the same interval).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

Z_95 = 1.959963984540054        # the standard normal's 97.5th percentile
BOOTSTRAP_RESAMPLES = 2000


@dataclass(frozen=True)
class Rate:
    """``k`` of ``n`` trials, with its Wilson 95 % interval [low, high]."""

    k: int
    n: int
    low: float
    high: float

    @property
    def value(self) -> float:
        return self.k / self.n if self.n else math.nan

    def __str__(self) -> str:
        return f"{self.k}/{self.n} ({100 * self.low:.0f}-{100 * self.high:.0f} %)"


def wilson(k: int, n: int, z: float = Z_95) -> Rate:
    """Wilson's score interval of a binomial rate ``k``/``n`` (n = 0: [0, 1])."""
    if not 0 <= k <= n:
        raise ValueError(f"{k} successes of {n} trials")
    if n == 0:
        return Rate(0, 0, 0.0, 1.0)
    p, z2 = k / n, z * z
    centre = (p + z2 / (2 * n)) / (1 + z2 / n)
    half = z * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / (1 + z2 / n)
    return Rate(k, n, max(0.0, centre - half), min(1.0, centre + half))


@dataclass(frozen=True)
class Quantile:
    """The ``q`` quantile of ``n`` values, with a bootstrap percentile interval [low, high]."""

    q: float
    value: float
    low: float
    high: float
    n: int

    def __str__(self) -> str:
        return f"{self.value:.3f} ({self.low:.3f}-{self.high:.3f})" if self.n else "—"


def bootstrap_quantile(values: Sequence[float], q: float = 0.5, level: float = 0.95,
                       resamples: int = BOOTSTRAP_RESAMPLES, seed: int = 0) -> Quantile:
    """The ``q`` quantile of the finite ``values`` and its bootstrap percentile interval at ``level``."""
    x = np.asarray([v for v in values if v is not None and math.isfinite(v)], dtype=float)
    if not len(x):
        return Quantile(q, math.nan, math.nan, math.nan, 0)
    rng = np.random.default_rng(seed)
    estimates = np.quantile(x[rng.integers(0, len(x), size=(resamples, len(x)))], q, axis=1)
    tail = (1.0 - level) / 2.0
    return Quantile(q, float(np.quantile(x, q)), float(np.quantile(estimates, tail)),
                    float(np.quantile(estimates, 1.0 - tail)), len(x))


@dataclass(frozen=True)
class Odds:
    """A scenario's runs in one fidelity with one planner, over their repeats (seeds)."""

    scenario: str
    fidelity: str
    planner: str
    goal: Rate                       # runs whose every agent reached its goal
    failure: Rate                    # runs that ended otherwise (or failed as a run)
    max_d_median: Quantile           # the median, over runs, of the largest |d| from the lane's centre [m]
    max_d_p90: Quantile

    @property
    def runs(self) -> int:
        return self.goal.n


def odds(scenario: str, fidelity: str, planner: str, goals: Sequence[bool], max_d: Sequence[float]) -> Odds:
    """The odds of one group of repeats: whether each run reached its goals, and its max |d|."""
    n, k = len(goals), sum(bool(g) for g in goals)
    return Odds(scenario, fidelity, planner, wilson(k, n), wilson(n - k, n), bootstrap_quantile(max_d, 0.5),
                bootstrap_quantile(max_d, 0.9))
