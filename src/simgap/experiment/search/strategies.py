"""Search strategies: what to run next, given what has been seen.

Every strategy proposes *candidates* — a point of the search space: scenario parameters, reality
knobs, a vehicle — and says in which fidelity of the ladder each starts. The search loop
(`simgap.experiment.search`) runs them, checks every high-fidelity failure in the ideal world,
and tells the strategy each result.

* ``grid``: ``grid_levels`` values per dimension, every combination, visited in a seeded random
  order so that a budget ending before the grid does still covers the whole space evenly.
* ``random``: uniform, seeded per candidate.
* ``lhs``: a Latin hypercube design of ``lhs_samples`` points, in its order.
* ``bo``: Bayesian optimisation in the high fidelity alone: optuna's TPE (multivariate, with a
  constant liar for runs in flight) maximising the objective.
* ``multi_fidelity`` (`simgap.experiment.search.multi_fidelity`): the cheap fidelities screen, the
  expensive one confirms. Each candidate
  runs first in the screening fidelity; one whose *risk* reaches the promotion threshold goes up
  a rung, ending in the high fidelity. Risk is the largest of: 2 if the screen run already fails,
  the peak grip use (combined acceleration over what the road's friction allows — a single-track
  screen can ask for more than the road gives without failing), and the objective over
  ``risk_scale``. A candidate within the distinct radius of a confirmed failure is never
  promoted: it would find nothing new.

  Candidates come from three kinds of move: *global* (uniform over the space), *knobs* (a
  confirmed failure's road, start and vehicle under reality knobs one to one and a half distinct
  radii away — the ideal world takes no knob, so its verdict on that scenario is already known
  and is not paid for again) and *scenario* (the same distance away in the road and start alone,
  under the knobs that made the failure, and a distinct radius from every failing scenario: a
  new situation, not a variation of one). The allocation adapts as evidence comes in, at two levels: Thompson sampling
  on each move's failures per CPU second picks the move (one candidate in ten is global
  regardless), and on each failure's share of failing neighbours per CPU second a try around it
  costs (its own failing run and its neighbours' runs, averaged: a failure that shows at once is
  cheaper to vary than one that shows at the end of the road) picks whose neighbourhood to
  search. Both weigh the n-th failure within a distinct radius of one road and start (and vehicle)
  by ``1/n^scenario_spread`` (a spec field, default 1: on a planted landscape with five failure
  regions, 120 runs, 4 seeds, 0 / 1 / 1.2 found 38 / 61 / 75 failing scenarios a distinct radius
  apart and 178 / 124 / 137 distinct violations; `curve-gaps` uses 1.0), so that new scenarios
  keep being sought. A neighbourhood whose
  neighbours fail at least half the time skips the screen: there a failing high-fidelity run,
  which ends early, costs about what the screen would. The promotion threshold is learned
  from the high-fidelity verdicts on screened candidates: the risk that best separates those that
  failed from those that passed (fewest passing candidates at or above it plus failing ones below
  it). One candidate in ten is promoted whatever its risk, so that there are verdicts below the
  threshold too and a screen that misses failures lowers it. (A threshold that widened while most
  promotions failed drifted to the lowest risk on the real `curve-gaps`, where the screen's risk
  separates well: it promoted 66 of 77 screened candidates, 24 of which passed in MuJoCo, each
  run to its end.)
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from scipy.stats import qmc

from simgap.experiment.search.multi_fidelity import MultiFidelityStrategy
from simgap.experiment.search.space import Candidate, SearchSpace, Strategy, uniform_candidate
from simgap.experiment.search.spec import SearchSpec


class GridStrategy(Strategy):
    name = "grid"

    def __init__(self, space: SearchSpace, seed: int, levels: int):
        super().__init__(space, seed)
        axes = [np.linspace(0.0, 1.0, levels) for _ in space.dims]
        points = [(u, v, p) for p in space.planners for v in space.vehicles for u in itertools.product(*axes)]
        order = np.random.default_rng(seed).permutation(len(points))
        self.points = [points[i] for i in order]

    def propose(self, index: int) -> Candidate | None:
        if index >= len(self.points):
            return None
        unit, vehicle, planner = self.points[index]
        return self.space.candidate(index, unit, vehicle, planner=planner)


class RandomStrategy(Strategy):
    name = "random"

    def propose(self, index: int) -> Candidate | None:
        return uniform_candidate(self.space, index, np.random.default_rng([self.seed, index]))


class LatinHypercubeStrategy(Strategy):
    name = "lhs"

    def __init__(self, space: SearchSpace, seed: int, samples: int):
        super().__init__(space, seed)
        d = len(space.dims) + (1 if len(space.vehicles) > 1 else 0) + (1 if len(space.planners) > 1 else 0)
        self.design = qmc.LatinHypercube(d=max(d, 1), seed=seed).random(samples)

    def propose(self, index: int) -> Candidate | None:
        if index >= len(self.design):
            return None
        row = self.design[index]
        n = len(self.space.dims)
        vehicles, planners = self.space.vehicles, self.space.planners
        vehicle = vehicles[min(int(row[n] * len(vehicles)), len(vehicles) - 1)] if len(vehicles) > 1 else vehicles[0]
        n += len(vehicles) > 1
        planner = planners[min(int(row[n] * len(planners)), len(planners) - 1)] if len(planners) > 1 else None
        return self.space.candidate(index, row[:len(self.space.dims)], vehicle, planner=planner)


class BayesianStrategy(Strategy):
    """A TPE study over the space, maximising the objective in the high fidelity."""

    name = "bo"

    def __init__(self, space: SearchSpace, seed: int, objective: str):
        import optuna

        super().__init__(space, seed)
        self.objective = objective
        optuna.logging.set_verbosity(optuna.logging.WARNING)
        sampler = optuna.samplers.TPESampler(seed=seed, multivariate=True, constant_liar=True,
                                             n_startup_trials=10)
        self.study = optuna.create_study(direction="maximize", sampler=sampler)
        self.distributions = space.distributions()

    def propose(self, index: int) -> Candidate | None:
        trial = self.study.ask(self.distributions)
        return self.space.from_trial(index, trial.params, trial)

    def tell(self, candidate: Candidate, score: float | None) -> None:
        import optuna

        state = optuna.trial.TrialState.FAIL if score is None or not math.isfinite(score) else None
        if candidate.trial is not None:
            if state is None:
                self.study.tell(candidate.trial, score)
            else:
                self.study.tell(candidate.trial, state=state)
            candidate.trial = None
        elif state is None:            # a result from an earlier invocation
            self.study.add_trial(optuna.trial.create_trial(
                params=self.space.trial_params(candidate), distributions=self.distributions, value=score))

    def observe(self, candidate, rung, row, failed):
        if rung == self.high:
            self.tell(candidate, row.value(self.objective) if row.status == "ok" else None)
        return []


def make_strategy(name: str, space: SearchSpace, spec: SearchSpec) -> Strategy:
    if name == "grid":
        return GridStrategy(space, spec.seed, spec.grid_levels)
    if name == "random":
        return RandomStrategy(space, spec.seed)
    if name == "lhs":
        return LatinHypercubeStrategy(space, spec.seed, spec.lhs_samples)
    if name == "bo":
        return BayesianStrategy(space, spec.seed, spec.objective)
    if name == "multi_fidelity":
        return MultiFidelityStrategy(space, spec.seed, spec.objective, spec.risk_scale, spec.distinct_radius,
                                     spec.scenario_spread)
    raise ValueError(name)
