"""The search spec: which space to search (scenario parameters and reality knobs), in which
ladder of fidelities, what a failure is, what to maximise, and which strategies to compare.

Example (the built-in ``curve-gaps``, abridged)::

    name: curve-gaps
    logical: curve
    parameters:                        # the scenario's dimensions: ranges to search
      radius: {min: 10, max: 100}
      initial_speed: {min: 0, max: 25}
    knobs:                             # reality knobs (see simgap.experiment.knobs)
      road_friction: {min: 0.2, max: 1.0}
      steer_delay: {min: 0, max: 0.25}
    vehicles: [sedan, suv, city]       # more than one: a dimension of the search
    planners: [frenet]                 # likewise (default [frenet]; entries as in experiment specs)
    ladder:                            # cheapest first: ideal, optional screens, the high fidelity
      - {backend: ideal}
      - {backend: dynamic, cosim: {replan_every: 5}}
      - {backend: mujoco}
    failure:                           # any one of these makes a run a failure
      goal_missed: true
      above: {max_lane_excursion_m: 0.0}
    objective: max_lateral_offset_m    # maximised by the optimising strategies
    strategies: [grid, random, lhs, bo, multi_fidelity]

A "violated assumption" is a candidate that passes in the ideal fidelity and fails in the high
one. A wrong key, type or range is an `InputError` naming the file, the field and what is allowed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum
from importlib import resources
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from simgap.control import DEFAULT_CONTROLLER
from simgap.cosim import REFERENCE, CosimSettings, Outcome
from simgap.errors import InputError, validated
from simgap.evaluate.closed_loop_score import COMPONENTS
from simgap.evaluate.run_metrics import RUN_METRICS
from simgap.experiment.knobs import check_knob
from simgap.experiment.spec import (
    BatchSpec,
    builtin_or_file,
    check_backend,
    check_controller,
    check_parameter,
    check_tilt,
    check_vehicles,
    logical_of,
    planner_choices,
    read_spec,
    results_hash,
    results_relevant,
    settings_of,
    vehicle_ref,
)
from simgap.planning.registry import PlannerChoice
from simgap.scenario.logical import LogicalScenario
from simgap.scenario.relief import RoadTilt, road_tilt
from simgap.vehicles import DEFAULT_VEHICLE

SCORE_DROP = "score_drop"
STRATEGIES = ("grid", "random", "lhs", "bo", "multi_fidelity")
#: metrics a failure rule or an objective may name: the per-run metrics, the store's scalars, the
#: scores (score_drop: the ideal run's score minus this run's; a search that names it runs each
#: candidate's ideal run first)
METRICS = tuple(RUN_METRICS) + ("max_road_excursion_m", "peak_lateral_acceleration", "peak_jerk",
                                "min_distance_m", "planner_failures", "score", SCORE_DROP, "solution_cost") \
    + tuple(f"score_{name}" for name in COMPONENTS)


class DimensionKind(StrEnum):
    """What a search dimension moves; the values are the words written to disk (probe plans,
    violation records)."""

    PARAMETER = "param"        # a parameter of the logical scenario
    KNOB = "knob"              # a reality knob of the high fidelity (`simgap.experiment.knobs`)


@dataclass(frozen=True)
class Dimension:
    """A continuous dimension of the search space: ``kind``, ``name`` and its range [low, high]."""

    kind: DimensionKind
    name: str
    low: float
    high: float


class Range(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    min: float
    max: float

    @model_validator(mode="after")
    def _ordered(self) -> Range:
        if self.min > self.max:
            raise ValueError("min must not exceed max")
        return self


class Rung(BaseModel):
    """One fidelity of the ladder."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    backend: str
    settings: dict[str, Any] = Field(default_factory=dict, description="backend settings")
    cosim: dict[str, Any] = Field(default_factory=dict, description="loop settings for this fidelity")


class FailureRule(BaseModel):
    """What makes a run a failure: any one condition."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    goal_missed: bool = Field(True, description="any outcome but reaching the goal (collision, off road, ...)")
    collision: bool = Field(True, description="a collision")
    solution_invalid: bool = Field(False, description="the driven trajectory is not a valid CommonRoad solution "
                                   "for the planner's vehicle model (commonroad-drivability-checker)")
    above: dict[str, float] = Field(default_factory=dict, description="metric -> bound it must not exceed")
    below: dict[str, float] = Field(default_factory=dict, description="metric -> bound it must not fall under")

    def failed(self, row: dict[str, Any]) -> str | None:
        """Why ``row`` (a finished run) is a failure, or None."""
        outcome = row.get("outcome")
        if self.collision and outcome == Outcome.COLLISION:
            return "collision"
        if self.goal_missed and outcome not in (None, Outcome.GOAL_REACHED):
            return f"goal missed ({outcome})"
        if self.solution_invalid and row.get("solution_valid") is False:
            return f"invalid solution ({row.get('solution_reason') or 'no reason given'})"
        for name, bound in self.above.items():
            v = row.get(name)
            if v is not None and not math.isnan(v) and v > bound:
                return f"{name} {v:.3g} > {bound:g}"
        for name, bound in self.below.items():
            v = row.get(name)
            if v is not None and not math.isnan(v) and v < bound:
                return f"{name} {v:.3g} < {bound:g}"
        return None


class SearchSpec(BatchSpec):
    parameters: dict[str, Range] = Field(default_factory=dict)
    knobs: dict[str, Range] = Field(default_factory=dict)
    vehicles: list[str] = Field(default_factory=lambda: [DEFAULT_VEHICLE], min_length=1)
    controller: str = DEFAULT_CONTROLLER
    ladder: list[Rung] = Field(min_length=2)
    failure: FailureRule = Field(default_factory=FailureRule)
    objective: str = "max_lateral_offset_m"
    risk_scale: float = Field(1.0, gt=0, description="objective value the screen counts as risky as a failure")
    distinct_radius: float = Field(0.1, gt=0, le=1, description="failures closer than this (normalised) are one")
    scenario_spread: float = Field(1.0, ge=0, le=3, description="multi_fidelity: the n-th failure within "
                                   "distinct_radius of one road and start (and vehicle) counts 1/n^spread when it "
                                   "weighs where to search (0: every distinct failure alike; 1 and more: new "
                                   "scenarios first)")
    strategies: list[Literal["grid", "random", "lhs", "bo", "multi_fidelity"]] = \
        Field(default_factory=lambda: list(STRATEGIES), min_length=1)
    grid_levels: int = Field(3, ge=2, le=20, description="values per dimension of the grid")
    lhs_samples: int = Field(500, ge=2, le=100_000, description="size of the Latin hypercube design")

    @field_validator("strategies")
    @classmethod
    def _each_strategy_once(cls, strategies: list[str]) -> list[str]:
        twice = next((s for i, s in enumerate(strategies) if s in strategies[:i]), None)
        if twice is not None:
            raise ValueError(f"'{twice}' is listed twice (allowed: each strategy once)")
        return strategies

    def results_hash(self) -> str:
        return results_hash(results_relevant(self, {"name", "description", "run_timeout_s", "strategies"}))

    @property
    def needs_ideal_first(self) -> bool:
        """Whether a run is judged by its score drop: then every candidate's ideal run comes first."""
        return SCORE_DROP in (self.objective, *self.failure.above, *self.failure.below)

    @property
    def dimensions(self) -> list[Dimension]:
        """Every continuous dimension, in a fixed order: the scenario parameters, then the knobs."""
        return ([Dimension(DimensionKind.PARAMETER, n, r.min, r.max) for n, r in self.parameters.items()]
                + [Dimension(DimensionKind.KNOB, n, r.min, r.max) for n, r in self.knobs.items()])



def _builtin_dir() -> Path:
    return Path(str(resources.files("simgap.experiment") / "builtin" / "search"))


@dataclass(frozen=True)
class RungSettings:
    """One rung of the ladder as its runs take it: its backend, the backend's settings (the
    controller included; None for an optional backend that is not installed) and the loop's
    (the spec's, a section the rung sets replaced by the rung's), each validated once."""

    backend: str
    settings: BaseModel | None
    cosim: CosimSettings

    @property
    def controller(self) -> str | None:
        return getattr(self.settings, "controller", None)


@dataclass(frozen=True)
class Search:
    """A search spec as read and checked where it was read: the spec as the file says it (its
    results hash), its logical scenario and file, and what its runs take — every rung's settings,
    the planners (loaded, their settings validated, by name), the vehicles as runs load them and
    the planner's vehicle."""

    spec: SearchSpec
    logical: LogicalScenario
    file: Path
    rungs: list[RungSettings]
    planners: dict[str, PlannerChoice]
    vehicles: list[str]
    planner_vehicle: str


def load_search_spec(name_or_path: str | Path) -> Search:
    """The search a spec file (or a built-in name) describes; every problem is an `InputError`
    naming the file and the field."""
    path = builtin_or_file(name_or_path, _builtin_dir(), "search")
    spec = read_spec(path, SearchSpec, "search spec", "name, logical, ladder, ...")
    return checked_search(spec, logical_of(spec, path), path)


def checked_search(spec: SearchSpec, logical: LogicalScenario, path: Path | None = None) -> Search:
    """``spec`` checked against ``logical`` and the registries, every setting validated into its
    model; errors name ``path`` and the field (a spec made in code: ``search.yaml``, and files it
    names are relative to the working directory)."""
    path = path if path is not None else Path("search.yaml")
    for name, rng in spec.parameters.items():
        check_parameter(logical, name, rng.min, rng.max, path)
    for name, rng in spec.knobs.items():
        check_knob(name, rng.min, rng.max, file=path, where=f"knobs.{name}")
        check_tilt(logical, name in RoadTilt.model_fields, path, f"knobs.{name}")
    if not spec.parameters and not spec.knobs and len(spec.vehicles) < 2 and len(spec.planners) < 2:
        raise InputError("nothing to search: no parameter, knob, vehicle or planner varies", file=path,
                         field="parameters", allowed=", ".join(logical.parameters))
    planners = {c.name: c for c in planner_choices(spec, path)}
    check_vehicles(spec.vehicles, path, "vehicles")
    check_vehicles([spec.planner_vehicle], path, "planner_vehicle")
    check_controller(spec.controller, path, "controller")
    cosim = validated(CosimSettings, spec.cosim, file=path, prefix="cosim")
    rungs = []
    for i, rung in enumerate(spec.ladder):
        check_backend(rung.backend, path, f"ladder.{i}")
        values = dict(rung.settings) if rung.backend == REFERENCE else {"controller": spec.controller} | rung.settings
        settings = settings_of(rung.backend, values, path, f"ladder.{i}.settings")
        check_tilt(logical, not road_tilt(settings).is_level, path, f"ladder.{i}.settings")
        rungs.append(RungSettings(rung.backend, settings, validated(CosimSettings, cosim.model_dump() | rung.cosim,
                                                                    file=path, prefix=f"ladder.{i}.cosim")))
    if spec.ladder[0].backend != REFERENCE:
        raise InputError("the ladder starts with the ideal fidelity (the world of the planner's assumptions)",
                         file=path, field="ladder.0.backend", allowed=REFERENCE)
    if any(r.backend == REFERENCE for r in spec.ladder[1:]):
        raise InputError("only the first rung is ideal", file=path, field="ladder", allowed="dynamic, mujoco")
    for where, names in (("objective", [spec.objective]), ("failure.above", list(spec.failure.above)),
                         ("failure.below", list(spec.failure.below))):
        for n in names:
            if n not in METRICS:
                raise InputError(f"unknown metric '{n}'", file=path, field=where, allowed=", ".join(METRICS))
    if "multi_fidelity" in spec.strategies and len(spec.ladder) < 3:
        raise InputError("multi_fidelity needs a screening fidelity between ideal and the high one", file=path,
                         field="ladder", allowed="ideal, dynamic, mujoco")
    return Search(spec, logical, path, rungs, planners, [vehicle_ref(v, path) for v in spec.vehicles],
                  vehicle_ref(spec.planner_vehicle, path))
