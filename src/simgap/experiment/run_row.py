"""A run's row in the results store (`RunRow`): its identity (`simgap.experiment.job.JobId`), the
scenario's parameters, the scalars of the finished run (summed or taken worst over its agents; its
scores among them), its metrics, the worst agent's score components (``score_<component>``),
timings and versions, and the columns a caller adds. Its columns and Parquet schema
come from this one definition (adding a column is adding a field), and a stored row reads back
into one (`RunRow.from_columns`).

The ``vehicle`` column is the vehicle's name (the fidelity's); where a run loaded its vehicle from
a data file, ``vehicle_file`` holds that file.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields, replace
from typing import Any, Literal

import pyarrow as pa

from simgap.cosim import Outcome
from simgap.evaluate.closed_loop_score import COMPONENTS
from simgap.evaluate.run_evaluation import worst_scores
from simgap.evaluate.run_metrics import RUN_METRICS
from simgap.experiment.job import Job, JobId
from simgap.record import FORMAT_VERSION, RunRecord
from simgap.vehicles import is_vehicle_file

Status = Literal["ok", "failed"]


@dataclass(frozen=True)
class RunRow:
    """One row of the results store: a finished run, ok or failed (then only ``failure`` says
    more). Scalars are summed or taken worst over the run's agents."""

    id: JobId
    parameters: dict[str, float]
    vehicle_ref: str                             # what the job loaded the vehicle by: a catalogue name or a data file
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
    fingerprint: str | None = None               # the run's identity on any machine (History.fingerprint)
    machine_fingerprint: str | None = None       # ... bit for bit, on the machine that ran it
    run_dir: str | None = None                   # relative to the experiment directory
    reproduce: str | None = None                 # the command that runs it again (`simgap replay ...`)
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
    def of(cls, job: Job, record: RunRecord, run_dir: str, job_time_s: float) -> RunRow:
        """The row of a finished run: a projection of its record (scalars summed or taken worst
        over its agents) under the job's identity; ``run_dir`` relative to the experiment's folder."""
        history, evaluation = record.history, record.evaluation
        outcomes = [a.outcome for a in history.agents]
        agents = evaluation.agents
        times = [a.time_to_goal_s for a in agents if a.time_to_goal_s is not None]
        gaps = [a.min_distance_to_traffic_m for a in agents if a.min_distance_to_traffic_m is not None]
        peaks = [a.tracking.comfort for a in agents if a.tracking is not None]     # the evaluation's
        return cls(
            job.id, job.parameters, job.vehicle, "failed" if history.failure else "ok", history.failure or "",
            outcome=Outcome.worst(outcomes), agents=len(agents),
            goals_reached=outcomes.count(Outcome.GOAL_REACHED),
            time_to_goal_max_s=max(times) if len(times) == len(outcomes) and times else math.nan,
            distance_m=sum(a.distance_m for a in agents),
            max_road_excursion_m=max((a.max_road_excursion_m for a in agents), default=0.0),
            planner_failures=sum(a.planner_failures for a in history.agents),
            planner_exceptions=sum(a.planner_exceptions for a in history.agents),
            planning_mean_s=_slowest(a.planning_mean_s for a in agents),
            planning_p95_s=_slowest(a.planning_p95_s for a in agents),
            planning_max_s=_slowest(a.planning_max_s for a in agents),
            planning_over_budget=sum(a.planning_over_budget for a in agents),
            min_distance_m=min(gaps) if gaps else math.nan,
            peak_lateral_acceleration=max((p.peak_lateral_acceleration for p in peaks), default=math.nan),
            peak_jerk=max((p.peak_jerk for p in peaks), default=math.nan),
            wall_time_s=history.wall_time_s, fingerprint=record.fingerprint,
            machine_fingerprint=record.machine_fingerprint, run_dir=run_dir,
            job_time_s=job_time_s, metrics=dict(evaluation.metrics), timings=record.all_timings,
            versions=dict(record.settings.versions), **asdict(worst_scores(evaluation)))

    @classmethod
    def failed(cls, job: Job, reason: str) -> RunRow:
        return cls(job.id, job.parameters, job.vehicle, "failed", reason)

    @property
    def vehicle_file(self) -> str:
        """The data file the vehicle was loaded from ("" for a catalogue vehicle)."""
        return self.vehicle_ref if is_vehicle_file(self.vehicle_ref) else ""

    def with_columns(self, **extra: Any) -> RunRow:
        return replace(self, extra=self.extra | extra)

    def value(self, name: str) -> float:
        """A scalar, a run metric or a score component (``score_<component>``) by name (what failure
        rules and objectives name); NaN when the run has none."""
        if name in self.metrics:
            v: float | None = self.metrics[name]
        elif name.startswith("score_") and name[len("score_"):] in self.score_components:
            v = self.score_components[name[len("score_"):]]
        else:
            v = getattr(self, name) if name in _SCALARS else self.extra.get(name)
        return math.nan if v is None else float(v)

    @classmethod
    def from_columns(cls, cols: Mapping[str, Any]) -> RunRow:
        """A row as the store holds it, typed again (the inverse of `columns`): identity, the
        parameters, the scalars, metrics, timings and versions; every other column in ``extra``."""
        rest = {k: v for k, v in cols.items() if k not in _ID_COLUMNS and k != "format_version"}
        parameters = {k[len("param_"):]: rest.pop(k) for k in list(rest) if k.startswith("param_")}
        metrics = {k: rest.pop(k) for k in list(rest) if k in RUN_METRICS}
        components = {name: rest.pop(f"score_{name}") for name in COMPONENTS if f"score_{name}" in rest}
        timings = {k[len("time_"):-len("_s")]: rest.pop(k) for k in list(rest)
                   if k.startswith("time_") and k.endswith("_s")}
        versions = {k[len("version_"):]: rest.pop(k) for k in list(rest) if k.startswith("version_")}
        scalars = {k: rest.pop(k) for k in list(rest) if k in _SCALARS}
        if scalars.get("outcome"):
            scalars["outcome"] = Outcome(scalars["outcome"])
        return cls(JobId.from_columns(cols), parameters, cols.get("vehicle_file") or cols["vehicle"], metrics=metrics,
                   score_components=components, timings=timings, versions=versions, extra=rest, **scalars)

    def columns(self) -> dict[str, Any]:
        """The row as the store writes it (one flat mapping of column to value)."""
        cols = self.id.columns() | {"vehicle_file": self.vehicle_file, "format_version": FORMAT_VERSION}
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
                 "repeat": pa.int64(), "seed": pa.int64(), "stage": pa.string(), "vehicle_file": pa.string(),
                 "format_version": pa.int64()} | _SCALARS
        types |= {k: pa.float64() for k in cols if k.startswith(("param_", "time_")) or k in self.metrics}
        types |= {f"score_{name}": pa.float64() for name in self.score_components}
        types |= {k: pa.string() for k in cols if k.startswith("version_")}
        inferred = pa.Table.from_pylist([{k: self.extra[k] for k in self.extra}]).schema if self.extra \
            else pa.schema([])
        return pa.schema([pa.field(k, types[k]) if k in types else inferred.field(k) for k in cols])


def _slowest(values) -> float:
    """The largest of the agents' planning-time figures (NaN when no agent planned)."""
    known = [v for v in values if v is not None]
    return max(known) if known else math.nan


def _arrow_type(annotation: str) -> pa.DataType:
    """The Arrow type of a `RunRow` scalar annotation (``float | None``, ``Status``, ...)."""
    base = annotation.replace(" | None", "")
    return {"float": pa.float64(), "int": pa.int64(), "str": pa.string(), "Status": pa.string(),
            "Outcome": pa.string(), "bool": pa.bool_()}[base]


_SCALARS: dict[str, pa.DataType] = {
    f.name: _arrow_type(str(f.type)) for f in fields(RunRow)
    if f.name not in ("id", "parameters", "vehicle_ref", "metrics", "score_components", "timings", "versions", "extra")}
_ID_COLUMNS = ("key", "scenario", "fidelity", "backend", "vehicle", "controller", "planner", "repeat", "seed", "stage",
               "vehicle_file")
