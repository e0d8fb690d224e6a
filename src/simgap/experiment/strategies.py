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
* ``multi_fidelity``: the cheap fidelities screen, the expensive one confirms. A TPE study over
  the screen's *risk* proposes candidates; each runs in the first screening fidelity; one whose
  risk reaches the promotion threshold goes up a rung, ending in the high fidelity. Risk is the
  largest of: 2 if the screen run already fails, the peak grip use (combined acceleration over
  what the road's friction allows — a single-track screen can ask for more than the road gives
  without failing), and the objective over ``risk_scale``. It is discounted near failures that
  are already confirmed, so proposals move on to new regions instead of re-finding one. The
  allocation adapts as evidence comes in: the threshold falls when most promoted candidates fail
  in high fidelity (the screen is trustworthy: cast a wider net) and rises when few do; one
  candidate in ten is promoted whatever its risk, and if such a candidate fails in high
  fidelity the threshold drops to its risk (the screen missed it).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.stats import qmc

from simgap.experiment.knobs import KNOBS
from simgap.experiment.search_spec import SearchSpec
from simgap.scenario.logical import LogicalScenario

EXPLORE_EVERY = 10          # multi_fidelity: one candidate in this many is promoted whatever its risk


@dataclass
class Candidate:
    index: int
    unit: tuple[float, ...]            # the continuous dimensions, normalised to [0, 1]
    vehicle: str
    params: dict[str, float]           # every scenario parameter (defaults filled in)
    knobs: dict[str, float]
    trial: Any = None                  # the optuna trial that proposed it, if any

    def distance(self, other: "Candidate") -> float:
        if self.vehicle != other.vehicle:
            return math.inf
        return float(np.linalg.norm(np.subtract(self.unit, other.unit)))


class SearchSpace:
    """The continuous dimensions of a spec (scenario parameters, then knobs) and its vehicles."""

    def __init__(self, spec: SearchSpec, logical: LogicalScenario):
        self.spec, self.logical = spec, logical
        self.dims = spec.dimensions
        self.vehicles = list(spec.vehicles)

    def candidate(self, index: int, unit: Any, vehicle: str, trial: Any = None) -> Candidate:
        unit = tuple(float(min(max(u, 0.0), 1.0)) for u in unit)
        params = {n: p.coerce(p.default) for n, p in self.logical.parameters.items()}
        knobs = {}
        for (kind, name, lo, hi), u in zip(self.dims, unit):
            value = round(lo + u * (hi - lo), 6)
            if kind == "param":
                params[name] = self.logical.parameters[name].coerce(value)
            else:
                knobs[name] = value
        return Candidate(index, unit, vehicle, params, knobs, trial)

    def distributions(self) -> dict[str, Any]:
        import optuna

        out: dict[str, Any] = {f"u{i}": optuna.distributions.FloatDistribution(0.0, 1.0) for i in range(len(self.dims))}
        if len(self.vehicles) > 1:
            out["vehicle"] = optuna.distributions.CategoricalDistribution(self.vehicles)
        return out

    def trial_params(self, c: Candidate) -> dict[str, Any]:
        out: dict[str, Any] = {f"u{i}": u for i, u in enumerate(c.unit)}
        if len(self.vehicles) > 1:
            out["vehicle"] = c.vehicle
        return out

    def from_trial(self, index: int, params: dict[str, Any], trial: Any = None) -> Candidate:
        unit = [params[f"u{i}"] for i in range(len(self.dims))]
        return self.candidate(index, unit, params.get("vehicle", self.vehicles[0]), trial)


class Strategy:
    """Base: propose candidates by index (deterministic strategies) and ignore results."""

    name = ""
    first_rung = -1          # the high fidelity

    def __init__(self, space: SearchSpace, seed: int):
        self.space, self.seed = space, seed
        self.high = len(space.spec.ladder) - 1

    def propose(self, index: int) -> Candidate | None:
        raise NotImplementedError

    def observe(self, candidate: Candidate, rung: int, row: dict[str, Any], failed: bool) -> list[int]:
        """Record a finished run of ``candidate`` in ``rung``; return the rungs to run it in next."""
        return []

    def restore(self, candidate: Candidate, rung: int, row: dict[str, Any], failed: bool) -> None:
        """Replay a result stored by an earlier invocation (resume)."""
        self.observe(candidate, rung, row, failed)

    def confirmed(self, candidate: Candidate, failed: bool) -> None:
        """The high-fidelity verdict on ``candidate`` (for strategies that learn from it)."""


class GridStrategy(Strategy):
    name = "grid"

    def __init__(self, space: SearchSpace, seed: int, levels: int):
        super().__init__(space, seed)
        axes = [np.linspace(0.0, 1.0, levels) for _ in space.dims]
        points = [(u, v) for v in space.vehicles for u in itertools.product(*axes)]
        order = np.random.default_rng(seed).permutation(len(points))
        self.points = [points[i] for i in order]

    def propose(self, index: int) -> Candidate | None:
        if index >= len(self.points):
            return None
        unit, vehicle = self.points[index]
        return self.space.candidate(index, unit, vehicle)


class RandomStrategy(Strategy):
    name = "random"

    def propose(self, index: int) -> Candidate | None:
        rng = np.random.default_rng([self.seed, index])
        unit = rng.random(len(self.space.dims))
        return self.space.candidate(index, unit, self.space.vehicles[rng.integers(len(self.space.vehicles))])


class LatinHypercubeStrategy(Strategy):
    name = "lhs"

    def __init__(self, space: SearchSpace, seed: int, samples: int):
        super().__init__(space, seed)
        d = len(space.dims) + (1 if len(space.vehicles) > 1 else 0)
        self.design = qmc.LatinHypercube(d=max(d, 1), seed=seed).random(samples)

    def propose(self, index: int) -> Candidate | None:
        if index >= len(self.design):
            return None
        row = self.design[index]
        n = len(self.space.dims)
        vehicles = self.space.vehicles
        vehicle = vehicles[min(int(row[n] * len(vehicles)), len(vehicles) - 1)] if len(vehicles) > 1 else vehicles[0]
        return self.space.candidate(index, row[:n], vehicle)


class _Optimiser(Strategy):
    """A TPE study over the space, maximising a score told per candidate."""

    def __init__(self, space: SearchSpace, seed: int):
        import optuna

        super().__init__(space, seed)
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


class BayesianStrategy(_Optimiser):
    name = "bo"

    def __init__(self, space: SearchSpace, seed: int, objective: str):
        super().__init__(space, seed)
        self.objective = objective

    def observe(self, candidate, rung, row, failed):
        if rung == self.high:
            self.tell(candidate, _value(row, self.objective) if row.get("status") == "ok" else None)
        return []


SCREEN_FAILURE_RISK = 2.0     # the risk of a candidate that already fails in the screen


@dataclass
class _Evidence:
    promoted: list[tuple[float, bool]] = field(default_factory=list)   # (risk, failed in high)


class MultiFidelityStrategy(_Optimiser):
    name = "multi_fidelity"
    first_rung = 1

    def __init__(self, space: SearchSpace, seed: int, objective: str, risk_scale: float,
                 distinct_radius: float):
        super().__init__(space, seed)
        self.objective, self.risk_scale, self.radius = objective, risk_scale, distinct_radius
        self.threshold = 1.0
        self.evidence = _Evidence()
        self.failures: list[Candidate] = []
        self.risk: dict[int, float] = {}
        self.explored: set[int] = set()

    def risk_of(self, row: dict[str, Any], failed: bool) -> float | None:
        if row.get("status") != "ok":
            return None
        parts = [SCREEN_FAILURE_RISK if failed else 0.0, _value(row, "peak_grip_use"),
                 _value(row, self.objective) / self.risk_scale]
        return max(p for p in parts if math.isfinite(p))

    def _novelty(self, c: Candidate) -> float:
        nearest = min((c.distance(f) for f in self.failures), default=math.inf)
        return min(1.0, nearest / self.radius)

    def observe(self, candidate, rung, row, failed):
        if not 0 < rung < self.high:
            return []
        risk = self.risk_of(row, failed)
        novelty = self._novelty(candidate)
        if rung == self.first_rung:
            self.tell(candidate, None if risk is None else risk * novelty)
        if risk is None:
            return []
        self.risk[candidate.index] = risk
        explore = candidate.index % EXPLORE_EVERY == EXPLORE_EVERY - 1
        if novelty < 1.0:           # a failure is already confirmed this close: nothing new to find
            return []
        if risk >= self.threshold or explore:
            if risk < self.threshold:
                self.explored.add(candidate.index)
            return [rung + 1]
        return []

    def restore(self, candidate, rung, row, failed):
        if rung == self.first_rung and rung < self.high:
            risk = self.risk_of(row, failed)
            self.tell(candidate, None if risk is None else risk * self._novelty(candidate))
            if risk is not None:
                self.risk[candidate.index] = risk

    def confirmed(self, candidate: Candidate, failed: bool) -> None:
        risk = self.risk.get(candidate.index)
        if failed:
            self.failures.append(candidate)
        if risk is None:
            return
        if candidate.index in self.explored:
            if failed:
                self.threshold = min(self.threshold, risk)      # the screen missed this one
            return                                              # not the screen's judgement: no evidence on it
        self.evidence.promoted.append((risk, failed))
        recent = self.evidence.promoted[-10:]
        if len(recent) >= 4:
            precision = sum(f for _, f in recent) / len(recent)
            if precision > 0.6:
                self.threshold *= 0.9
            elif precision < 0.3:
                self.threshold *= 1.1
            # never above a screen failure's risk: what fails in the screen always goes up
            self.threshold = min(max(self.threshold, 0.2), SCREEN_FAILURE_RISK)


def _value(row: dict[str, Any], name: str) -> float:
    v = row.get(name)
    return float(v) if v is not None and not (isinstance(v, float) and math.isnan(v)) else math.nan


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
        return MultiFidelityStrategy(space, spec.seed, spec.objective, spec.risk_scale, spec.distinct_radius)
    raise ValueError(name)
