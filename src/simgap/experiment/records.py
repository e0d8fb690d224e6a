"""What an experiment or a search runs and what it records: a run's identity (`JobId`), the run to
execute (`Job`) and its row in the results store (`RunRow`), whose columns and Parquet schema come
from this one definition.

A job's key — ``scenario/fidelity`` (``/PLANNER`` unless the planner is the default ``frenet``,
``/rN`` when the experiment repeats runs; a search names its ladder's rungs instead of fidelities:
``c00012/high``) — is printed only by `JobId.key`; code that needs the parts of a job holds its
`JobId`, never a key taken apart.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any, Literal

import pyarrow as pa

from simgap.cosim import CosimSettings, Fidelity, Outcome
from simgap.errors import validated
from simgap.planning.registry import DEFAULT_PLANNER, PlannerChoice

Status = Literal["ok", "failed"]
PLANNER_VEHICLE = "sedan"           # the vehicle the planner assumes it drives, unless a spec says another


@dataclass(frozen=True)
class JobId:
    """Which run: a scenario in a fidelity (backend, vehicle, controller), with a planner, a
    repeat and a seed."""

    scenario: str
    fidelity: Fidelity
    repeat: int | None = None        # None: the only run of its scenario and fidelity
    seed: int = 0
    planner: str = DEFAULT_PLANNER
    stage: str | None = None         # what the key names instead of the fidelity (a search's rung)

    @property
    def key(self) -> str:
        """Unique and stable within an experiment; names the run's row in the store."""
        parts = [self.scenario, self.stage or self.fidelity.label]
        parts += [self.planner] if self.planner != DEFAULT_PLANNER else []
        return "/".join(parts + ([f"r{self.repeat}"] if self.repeat is not None else []))

    @property
    def folder(self) -> str:
        """The run directory's path under ``runs/``: ``scenario/fidelity[@planner][/rN]``."""
        name = self.fidelity.label.replace("/", "-") + (f"@{self.planner}" if self.planner != DEFAULT_PLANNER else "")
        return "/".join([self.scenario, name] + ([f"r{self.repeat}"] if self.repeat is not None else []))

    def __str__(self) -> str:
        return self.key

    def columns(self) -> dict[str, Any]:
        """The identity columns of a store row."""
        return {"key": self.key, "scenario": self.scenario, "fidelity": self.fidelity.label,
                "backend": self.fidelity.backend, "vehicle": self.fidelity.vehicle,
                "controller": self.fidelity.controller or "", "planner": self.planner,
                "repeat": self.repeat or 0, "seed": self.seed}


@dataclass(frozen=True)
class Job:
    """One run to execute: its identity, the concrete scenario, and every setting it runs with."""

    id: JobId
    parameters: dict[str, float]                    # the scenario's parameters
    vehicle: str                                    # catalogue name or data file the vehicle is loaded from
    backend_settings: dict[str, Any] = field(default_factory=dict)
    cosim: dict[str, Any] = field(default_factory=dict)      # over the experiment's cosim settings
    scenario_path: str | None = None                          # else the context's scenarios[scenario]
    planner: PlannerChoice = field(default_factory=PlannerChoice)   # of every agent; its name is id.planner

    @property
    def key(self) -> str:
        return self.id.key

    @property
    def scenario(self) -> str:
        return self.id.scenario

    @property
    def backend(self) -> str:
        return self.id.fidelity.backend

    @property
    def controller(self) -> str | None:
        return self.id.fidelity.controller

    @property
    def fidelity(self) -> str:
        return self.id.fidelity.label

    @property
    def repeat(self) -> int:
        return self.id.repeat or 0

    @property
    def seed(self) -> int:
        return self.id.seed


@dataclass(frozen=True)
class RunRow:
    """One row of the results store: a finished run, ok or failed (then only ``failure`` says
    more). Scalars are summed or taken worst over the run's agents."""

    id: JobId
    parameters: dict[str, float]
    vehicle: str                                 # as the job named it (catalogue name or data file)
    status: Status
    failure: str = ""
    outcome: Outcome | None = None               # the first agent outcome that is not reaching the goal
    agents: int | None = None
    goals_reached: int | None = None
    time_to_goal_max_s: float | None = None      # NaN unless every agent reached its goal
    distance_m: float | None = None
    max_road_excursion_m: float | None = None
    planner_failures: int | None = None
    planner_exceptions: int | None = None        # planning cycles in which the planner raised
    planning_mean_s: float | None = None         # wall time per planning call (the slowest agent's)
    planning_p95_s: float | None = None
    planning_max_s: float | None = None
    planning_over_budget: int | None = None      # calls over the loop's planning_budget_s
    min_distance_m: float | None = None          # the smallest gap to any other road user
    peak_lateral_acceleration: float | None = None
    peak_jerk: float | None = None
    wall_time_s: float | None = None
    fingerprint: str | None = None
    run_dir: str | None = None                   # relative to the experiment directory
    job_time_s: float | None = None              # the worker's time for the whole job
    score: float | None = None                   # the worst agent's closed-loop score
    solution_valid: bool | None = None           # every agent's solution valid (None: not checked)
    solution_reason: str = ""                    # the first invalid agent's first reason
    solution_cost: float | None = None           # the solution's cost: the sum over its agents (as CommonRoad's)
    metrics: dict[str, float] = field(default_factory=dict)     # simgap.evaluate.run_metrics.RUN_METRICS
    score_components: dict[str, float] = field(default_factory=dict)   # the worst agent's -> score_<component>
    timings: dict[str, float] = field(default_factory=dict)     # seconds per phase -> time_<phase>_s
    versions: dict[str, str] = field(default_factory=dict)      # package -> version_<package>
    extra: dict[str, Any] = field(default_factory=dict)         # columns a caller adds (a search's)

    @classmethod
    def failed(cls, job: Job, reason: str) -> "RunRow":
        return cls(job.id, job.parameters, job.vehicle, "failed", reason)

    def with_columns(self, **extra: Any) -> "RunRow":
        return replace(self, extra=self.extra | extra)

    def columns(self) -> dict[str, Any]:
        """The row as the store writes it (one flat mapping of column to value)."""
        cols = self.id.columns() | {"vehicle": self.vehicle}
        cols |= {f"param_{k}": float(v) for k, v in self.parameters.items()}
        for f in fields(self):
            if f.name in _SCALARS:
                value = getattr(self, f.name)
                cols[f.name] = value.value if isinstance(value, Outcome) else value
        cols |= dict(self.metrics)
        cols |= {f"score_{name}": float(v) for name, v in self.score_components.items()}
        cols |= {f"time_{phase}_s": float(v) for phase, v in self.timings.items()}
        cols |= {f"version_{name}": v for name, v in self.versions.items()}
        return cols | self.extra

    def schema(self) -> pa.Schema:
        """The Parquet schema of `columns`: the scalars' types from this class, floats for the
        parameters, metrics and timings, strings for versions; the caller's columns inferred."""
        cols = self.columns()
        types = {"key": pa.string(), "scenario": pa.string(), "fidelity": pa.string(), "backend": pa.string(),
                 "vehicle": pa.string(), "controller": pa.string(), "planner": pa.string(),
                 "repeat": pa.int64(), "seed": pa.int64()} | _SCALARS
        types |= {k: pa.float64() for k in cols if k.startswith(("param_", "time_", "score_")) or k in self.metrics}
        types |= {k: pa.string() for k in cols if k.startswith("version_")}
        inferred = pa.Table.from_pylist([{k: self.extra[k] for k in self.extra}]).schema if self.extra else None
        return pa.schema([pa.field(k, types[k]) if k in types else inferred.field(k) for k in cols])


def _arrow_type(annotation: str) -> pa.DataType:
    """The Arrow type of a `RunRow` scalar annotation (``float | None``, ``Status``, ...)."""
    base = annotation.replace(" | None", "")
    return {"float": pa.float64(), "int": pa.int64(), "str": pa.string(), "Status": pa.string(),
            "Outcome": pa.string(), "bool": pa.bool_()}[base]


_SCALARS: dict[str, pa.DataType] = {
    f.name: _arrow_type(str(f.type)) for f in fields(RunRow)
    if f.name not in ("id", "parameters", "vehicle", "metrics", "score_components", "timings", "versions", "extra")}


@dataclass(frozen=True)
class JobContext:
    """What every job of an experiment or a search shares: where it writes, the scenario file of
    each scenario, and the loop settings (validated once, where the spec was read)."""

    root: Path
    cosim: CosimSettings
    scenarios: dict[str, str] | None = None       # scenario name -> file (else each job names its file)
    planner_vehicle: str = PLANNER_VEHICLE        # catalogue name or data file
    validate: bool = True                         # check each run's solution (slow; --no-validate skips it)

    def cosim_of(self, job: Job) -> CosimSettings:
        """The loop settings of ``job``: the shared ones, a section the job sets replaced by its own."""
        return validated(CosimSettings, self.cosim.model_dump() | job.cosim, prefix="cosim")
