"""The space a search explores and the interface of its strategies.

A *candidate* is a point of the space: the continuous dimensions (scenario parameters, then
reality knobs, normalised to [0, 1]), a vehicle and a planner. A `Strategy` proposes candidates by
index and is told, typed, how each of their runs went (`simgap.experiment.run_row.RunRow`, with
whether the spec's failure rule calls it a failure); it answers with the rungs of the ladder to run
the candidate in next, and hears the high-fidelity verdict on each candidate. The search loop
(`simgap.experiment.search`) does the rest.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from simgap.experiment.run_row import RunRow
from simgap.experiment.search.spec import DimensionKind, SearchSpec
from simgap.planning.registry import DEFAULT_PLANNER
from simgap.scenario.logical import LogicalScenario


@dataclass
class Candidate:
    index: int
    unit: tuple[float, ...]            # the continuous dimensions, normalised to [0, 1]
    vehicle: str
    params: dict[str, float]           # every scenario parameter (defaults filled in)
    knobs: dict[str, float]
    trial: Any = None                  # the optuna trial that proposed it, if any
    start_rung: int | None = None      # the rung it runs in first, if not the strategy's usual one
    planner: str = DEFAULT_PLANNER     # the name of the planner of every agent

    @property
    def driver(self) -> tuple[str, str]:
        """Who drives: the vehicle and the planner (failures of different drivers are distinct)."""
        return (self.vehicle, self.planner)

    def distance(self, other: Candidate) -> float:
        if self.driver != other.driver:
            return math.inf
        return float(np.linalg.norm(np.subtract(self.unit, other.unit)))


class SearchSpace:
    """The continuous dimensions of a spec (scenario parameters, then knobs), its vehicles and its
    planners (by name)."""

    def __init__(self, spec: SearchSpec, logical: LogicalScenario, vehicles: list[str] | None = None,
                 planners: list[str] | None = None):
        self.spec, self.logical = spec, logical
        self.dims = spec.dimensions
        self.vehicles = list(vehicles or spec.vehicles)      # as runs load them (data files resolved)
        self.planners = list(planners or [DEFAULT_PLANNER])

    def candidate(self, index: int, unit: Any, vehicle: str, trial: Any = None, planner: str | None = None
                  ) -> Candidate:
        unit = tuple(float(min(max(u, 0.0), 1.0)) for u in unit)
        params = {n: p.coerce(p.default) for n, p in self.logical.parameters.items()}
        knobs = {}
        for d, u in zip(self.dims, unit):
            value = round(d.low + u * (d.high - d.low), 6)
            if d.kind is DimensionKind.PARAMETER:
                params[d.name] = self.logical.parameters[d.name].coerce(value)
            else:
                knobs[d.name] = value
        return Candidate(index, unit, vehicle, params, knobs, trial, planner=planner or self.planners[0])

    def distributions(self) -> dict[str, Any]:
        import optuna

        out: dict[str, Any] = {f"u{i}": optuna.distributions.FloatDistribution(0.0, 1.0) for i in range(len(self.dims))}
        if len(self.vehicles) > 1:
            out["vehicle"] = optuna.distributions.CategoricalDistribution(self.vehicles)
        if len(self.planners) > 1:
            out["planner"] = optuna.distributions.CategoricalDistribution(self.planners)
        return out

    def trial_params(self, c: Candidate) -> dict[str, Any]:
        out: dict[str, Any] = {f"u{i}": u for i, u in enumerate(c.unit)}
        if len(self.vehicles) > 1:
            out["vehicle"] = c.vehicle
        if len(self.planners) > 1:
            out["planner"] = c.planner
        return out

    def from_trial(self, index: int, params: dict[str, Any], trial: Any = None) -> Candidate:
        unit = [params[f"u{i}"] for i in range(len(self.dims))]
        return self.candidate(index, unit, params.get("vehicle", self.vehicles[0]), trial, params.get("planner"))


class Strategy:
    """Base: propose candidates by index (deterministic strategies) and ignore results."""

    name = ""
    first_rung = -1          # the high fidelity

    def __init__(self, space: SearchSpace, seed: int):
        self.space, self.seed = space, seed
        self.high = len(space.spec.ladder) - 1

    def propose(self, index: int) -> Candidate | None:
        raise NotImplementedError

    def observe(self, candidate: Candidate, rung: int, row: RunRow, failed: bool) -> list[int]:
        """Record a finished run of ``candidate`` in ``rung`` (``failed``: by the spec's failure
        rule); return the rungs to run it in next."""
        return []

    def restore(self, candidate: Candidate, rung: int, row: RunRow, failed: bool) -> None:
        """Replay a result stored by an earlier invocation (resume)."""
        self.observe(candidate, rung, row, failed)

    def confirmed(self, candidate: Candidate, failed: bool) -> None:
        """The high-fidelity verdict on ``candidate`` (for strategies that learn from it)."""


def uniform_candidate(space: SearchSpace, index: int, rng: np.random.Generator) -> Candidate:
    unit = rng.random(len(space.dims))
    vehicle = space.vehicles[rng.integers(len(space.vehicles))]
    planner = space.planners[rng.integers(len(space.planners))] if len(space.planners) > 1 else None
    return space.candidate(index, unit, vehicle, planner=planner)
