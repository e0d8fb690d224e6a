"""The `Run` record: everything needed to evaluate and to reproduce one co-simulation.

On disk a run is a directory:

- ``run.json``            metadata, per-agent outcomes, events, timings, fingerprint
- ``trajectories.parquet`` every agent's driven states and every plan it made (columnar); from a world
                          with a third dimension also each driven state's height, pitch and roll
                          (columns ``z``, ``pitch``, ``roll``: absent from a run without them)
- ``driven.xml``          the driven scenario as CommonRoad XML (agents as dynamic obstacles, their ids
                          offset by `AGENT_ID_OFFSET`)
- ``driven.json``         the scenario's sidecar (`simgap.scenario.read_metadata` reads it beside
                          ``driven.xml``): what CommonRoad XML cannot hold, such as the road's relief
- ``solution.xml``        every agent's driven trajectory as a CommonRoad solution (`simgap.evaluate.solution`)

The directory is built next to its destination and swapped into place (`simgap.files.replace_directory`),
so a reader never sees a half-written run.
"""

from __future__ import annotations

import hashlib
import json
import math
import traceback
from dataclasses import asdict, dataclass, field
from enum import StrEnum
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from simgap.errors import InputError
from simgap.files import atomic_write_text, replace_directory
from simgap.planning.registry import DEFAULT_PLANNER
from simgap.cosim.fidelity import Fidelity
from simgap.sim.protocol import EventKind, Realism
from simgap.trajectory import ATTITUDE_FIELDS, STATE_FIELDS, Attitude, Trajectory
from simgap.vehicles import Vehicle, load_vehicle

AGENT_ID_OFFSET = 100_000       # agent i is obstacle AGENT_ID_OFFSET + i in the driven scenario (driven.xml)

class Outcome(StrEnum):
    """How an agent's run ended (a string enum: it compares and serialises as its value)."""

    GOAL_REACHED = "goal_reached"
    COLLISION = "collision"
    OFF_ROAD = "off_road"
    PLANNER_FAILURE = "planner_failure"      # no feasible plan for too long
    TIMEOUT = "timeout"                      # the goal not reached by its deadline
    DIVERGED = "diverged"                    # the physics blew up

    @classmethod
    def worst(cls, outcomes: "list[Outcome]") -> "Outcome":
        """The first outcome that is not reaching the goal, else reaching it."""
        return next((o for o in outcomes if o != cls.GOAL_REACHED), cls.GOAL_REACHED)


@dataclass(frozen=True)
class Event:
    """Something that happened to an agent at a time and place."""

    t: float
    agent_id: int
    kind: EventKind
    x: float | None = None
    y: float | None = None
    detail: str = ""
    other_id: int | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "kind", EventKind(self.kind))


@dataclass(frozen=True)
class PlannerError:
    """An exception a planner raised: in its constructor (``t`` None) or in a planning cycle."""

    agent_id: int
    t: float | None
    exception: str          # the exception's type
    message: str
    traceback: str

    @classmethod
    def of(cls, exc: BaseException, agent_id: int, t: float | None) -> "PlannerError":
        trace = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
        remote = getattr(exc, "remote_traceback", "")     # a planner in its own process: its own traceback too
        return cls(agent_id, t, type(exc).__name__, str(exc),
                   trace + (f"\nThe planner's process reported:\n{remote}" if remote else ""))


@dataclass(frozen=True)
class PartialCost:
    """One term of a CommonRoad cost function: its value (unweighted) and its weight."""

    cost: float
    weight: float

    @property
    def weighted(self) -> float:
        return self.cost * self.weight


@dataclass
class AgentOutcome:
    id: int
    vehicle: str
    outcome: Outcome
    time_to_goal_s: float | None
    distance_m: float
    min_distance_to_traffic_m: float | None
    max_road_excursion_m: float = 0.0
    planner_failures: int = 0                   # planning cycles without a plan (None or an exception)
    planner: str = ""                           # the planner's name (label)
    planner_exceptions: int = 0                 # ... of them, cycles in which the planner raised
    planning_calls: int = 0
    planning_mean_s: float | None = None        # wall time per planning call
    planning_p95_s: float | None = None
    planning_max_s: float | None = None
    planning_over_budget: int = 0               # calls longer than the loop's planning_budget_s
    plan_latency_mean_s: float | None = None    # how long after its planning time a plan reached the car
    plan_latency_max_s: float | None = None
    recorded_as: int | None = None              # the recorded road user this agent replaces (its own
                                                # recording in the file, left out of the traffic)
    # scores (simgap.evaluate: closed_loop_score, solution); None: not scored (a run recorded before scores)
    score: float | None = None                  # closed-loop score in [0, 1], built like nuPlan's CLS
    score_components: dict[str, float] = field(default_factory=dict)   # its multipliers and weighted terms
    score_measures: dict[str, float | None] = field(default_factory=dict)   # what they were computed from
    solution_benchmark: str = ""                # the solution's benchmark ID: model+type:cost function:scenario
    solution_cost: float | None = None          # the cost function's total
    solution_partial_costs: dict[str, PartialCost] = field(default_factory=dict)   # by CommonRoad's term id
    solution_cost_error: str = ""               # why the cost could not be evaluated
    solution_valid: bool | None = None          # by commonroad-drivability-checker; None: not checked
    solution_reason: str = ""                   # the first reason it is invalid

    def __post_init__(self) -> None:
        self.outcome = Outcome(self.outcome)          # as read back from run.json
        self.solution_partial_costs = {k: v if isinstance(v, PartialCost) else PartialCost(**v)
                                       for k, v in self.solution_partial_costs.items()}


@dataclass
class Run:
    scenario_id: str
    backend: str
    dt: float
    agents: list[AgentOutcome]
    driven: dict[int, Trajectory]
    plans: dict[int, list[Trajectory]]
    events: list[Event] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    wall_time_s: float = 0.0
    settings: dict[str, Any] = field(default_factory=dict)
    scenario_path: str | None = None
    parameters: dict[str, Any] = field(default_factory=dict)
    sections: dict[str, str] = field(default_factory=dict)     # lanelet id -> road section kind
    versions: dict[str, str] = field(default_factory=dict)
    seed: int = 0
    failure: str | None = None
    vehicles: dict[int, Vehicle] = field(default_factory=dict)    # the model each agent drove
    metrics: dict[str, float] = field(default_factory=dict)       # simgap.evaluate.run_metrics, worst over agents
    planner_errors: list[PlannerError] = field(default_factory=list)   # the first few, with tracebacks
    attitudes: dict[int, tuple[Attitude, ...]] = field(default_factory=dict)   # beside each driven state (3D worlds)

    # ------------------------------------------------------------------ derived
    def vehicle_of(self, agent_id: int) -> Vehicle:
        """The vehicle model agent ``agent_id`` drove: as recorded (a run written before runs
        recorded their vehicles: the catalogue's vehicle of that name)."""
        if agent_id in self.vehicles:
            return self.vehicles[agent_id]
        return load_vehicle(next(a.vehicle for a in self.agents if a.id == agent_id))

    @property
    def fidelity(self) -> Fidelity:
        """What produced the run: its backend, its agents' vehicles and its controller."""
        vehicles = "+".join(sorted({a.vehicle for a in self.agents}))
        return Fidelity(self.backend, vehicles, (self.settings.get("backend") or {}).get("controller"), self.realism)

    @property
    def realism(self) -> Realism:
        """How real the car was: a run recorded before realism was a setting drove a perfect machine."""
        return Realism(self.settings.get("realism", Realism.IDEAL.value))

    @property
    def planner(self) -> str:
        """The name of the planner (of every agent; per agent ``1=frenet,2=idm``) that drove it
        (``frenet`` for runs recorded before planners were named)."""
        return (self.settings.get("planner") or {}).get("name") or DEFAULT_PLANNER

    @property
    def fingerprint(self) -> str:
        """SHA-256 over every agent's driven trajectory: equal iff the runs drove identically."""
        h = hashlib.sha256()
        for aid in sorted(self.driven):
            h.update(str(aid).encode())
            traj = self.driven[aid]
            for f in STATE_FIELDS:
                h.update(np.ascontiguousarray(getattr(traj, f), dtype="<f8").tobytes())
        return h.hexdigest()[:16]

    def summary(self) -> dict[str, Any]:
        return {
            "scenario_id": self.scenario_id,
            "backend": self.backend,
            "wall_time_s": round(self.wall_time_s, 4),
            "fingerprint": self.fingerprint,
            "failure": self.failure,
            "agents": [asdict(a) for a in self.agents],
            "timings": {k: round(v, 4) for k, v in self.timings.items()},
        }

    # ------------------------------------------------------------------ writing
    def _record_json(self) -> str:
        """``run.json``: everything but the trajectories."""
        meta = self.summary() | {
            "dt": self.dt,
            "events": [asdict(e) for e in self.events],
            "settings": self.settings,
            "scenario_path": self.scenario_path,
            "parameters": self.parameters,
            "sections": self.sections,
            "versions": self.versions,
            "seed": self.seed,
            "vehicles": {str(aid): v.model_dump() for aid, v in self.vehicles.items()},
            "metrics": self.metrics,
            "planner_errors": [asdict(e) for e in self.planner_errors],
        }
        return json.dumps(meta, indent=2, default=_json_default)

    def save_record(self, run_dir: str | Path) -> Path:
        """Rewrite the ``run.json`` of a saved run directory (atomically), e.g. once its solution
        has been checked."""
        return atomic_write_text(Path(run_dir) / "run.json", self._record_json())

    def save(self, run_dir: str | Path, driven_scenario_xml: str | None = None,
             solution_xml: str | None = None, scenario_metadata: dict[str, Any] | None = None) -> Path:
        """Write the run directory atomically (built aside, then swapped into place)."""
        def write(tmp: Path) -> None:
            (tmp / "run.json").write_text(self._record_json())
            pq.write_table(self._trajectory_table(), tmp / "trajectories.parquet")
            if driven_scenario_xml is not None:
                (tmp / "driven.xml").write_text(driven_scenario_xml)
                if scenario_metadata:
                    (tmp / "driven.json").write_text(json.dumps(scenario_metadata, indent=2))
            if solution_xml is not None:
                (tmp / "solution.xml").write_text(solution_xml)

        return replace_directory(run_dir, write)

    def _trajectory_table(self) -> pa.Table:
        cols: dict[str, list] = {"kind": [], "agent_id": [], "plan_t": [], "k": []}
        third = ATTITUDE_FIELDS if self.attitudes else ()
        cols.update({f: [] for f in STATE_FIELDS + third})

        def add(kind: str, aid: int, plan_t: float, traj: Trajectory) -> None:
            n = len(traj)
            cols["kind"].extend([kind] * n)
            cols["agent_id"].extend([aid] * n)
            cols["plan_t"].extend([plan_t] * n)
            cols["k"].extend(range(n))
            for f in STATE_FIELDS:
                cols[f].extend(getattr(traj, f).tolist())
            attitudes = self.attitudes.get(aid, ()) if kind == "driven" else ()
            for f in third:
                cols[f].extend([getattr(a, f) for a in attitudes] if attitudes else [math.nan] * n)

        for aid, traj in sorted(self.driven.items()):
            add("driven", aid, float("nan"), traj)
        for aid, plans in sorted(self.plans.items()):
            for plan in plans:
                add("planned", aid, float(plan.t[0]), plan)
        schema = pa.schema([("kind", pa.string()), ("agent_id", pa.int64()), ("plan_t", pa.float64()),
                            ("k", pa.int32())] + [(f, pa.float64()) for f in STATE_FIELDS + third])
        return pa.table(cols, schema=schema)

    # ------------------------------------------------------------------ reading
    @classmethod
    def load(cls, run_dir: str | Path) -> "Run":
        run_dir = Path(run_dir)
        meta_path = run_dir / "run.json"
        if not meta_path.exists():
            raise InputError("not a run directory (no run.json)", file=run_dir)
        try:
            meta = json.loads(meta_path.read_text())
        except (OSError, ValueError) as exc:
            raise InputError(f"cannot read the run's record: {exc}", file=meta_path,
                             allowed="the run.json simgap wrote; run the scenario again") from None
        trajectories = run_dir / "trajectories.parquet"
        try:
            table = pq.read_table(trajectories).to_pydict()
        except (OSError, ValueError, pa.ArrowException) as exc:
            raise InputError(f"cannot read the run's trajectories: {exc}", file=trajectories,
                             allowed="the trajectories.parquet simgap wrote; run the scenario again") from None
        dt = float(meta["dt"])
        driven: dict[int, Trajectory] = {}
        plans: dict[int, list[Trajectory]] = {}
        groups: dict[tuple[str, int, float], list[int]] = {}
        for i, (kind, aid, pt) in enumerate(zip(table["kind"], table["agent_id"], table["plan_t"])):
            groups.setdefault((kind, aid, -1.0 if kind == "driven" else pt), []).append(i)
        attitudes: dict[int, tuple[Attitude, ...]] = {}
        for (kind, aid, _), rows in groups.items():
            traj = Trajectory(dt, **{f: [table[f][i] for i in rows] for f in STATE_FIELDS})
            if kind == "driven":
                driven[aid] = traj
                if "z" in table and not math.isnan(table["z"][rows[0]]):
                    attitudes[aid] = tuple(Attitude(*(table[f][i] for f in ATTITUDE_FIELDS)) for i in rows)
            else:
                plans.setdefault(aid, []).append(traj)
        return cls(
            scenario_id=meta["scenario_id"], backend=meta["backend"], dt=dt,
            agents=[AgentOutcome(**a) for a in meta["agents"]],
            driven=driven, plans=plans,
            events=[Event(**e) for e in meta.get("events", [])],
            timings=meta.get("timings", {}), wall_time_s=meta.get("wall_time_s", 0.0),
            settings=meta.get("settings", {}), scenario_path=meta.get("scenario_path"),
            parameters=meta.get("parameters", {}), sections=meta.get("sections", {}), versions=meta.get("versions", {}),
            seed=meta.get("seed", 0), failure=meta.get("failure"),
            vehicles={int(aid): Vehicle.model_validate(v) for aid, v in (meta.get("vehicles") or {}).items()},
            metrics=meta.get("metrics") or {},
            planner_errors=[PlannerError(**e) for e in meta.get("planner_errors") or []],
            attitudes=attitudes,
        )


def _json_default(obj: Any) -> Any:
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj)}")
