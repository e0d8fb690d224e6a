"""A run directory written and read: the one place that knows how a `RunRecord` is kept on disk,
and how older run directories and store rows are read (`migrate`, `migrate_row`).

A run directory holds:

- ``run.json``            the record but its trajectories: ``format_version``, ``settings``,
                          ``history`` (agents, events, planning-call times, plan latencies, timings),
                          ``evaluation`` (metrics, scores, solution cost and validity, criticality),
                          ``timings`` (scoring, io, validation), the run's ``fingerprint`` (over its
                          driven states quantised: the same on any machine) and ``machine_fingerprint``
                          (over their raw bits: this machine's)
- ``trajectories.parquet`` the states, one row each, by ``kind``: ``driven`` (with ``z``, ``pitch``,
                          ``roll`` from a 3D world), ``planned`` (by the plan's start ``plan_t``),
                          ``observed`` (what the planner saw at each call), ``standing`` (an agent
                          still in the world after its outcome), ``traffic`` (road users the loop
                          drove itself; ``agent_id`` is the obstacle's id), and ``controls`` (per control
                          tick of a physical world: ``t`` and what the controller asked and the car did,
                          ``steer_requested``, ``steer_at_wheels``, ``accel_requested``, ``accel_achieved``;
                          the state columns but ``t`` empty, as these columns are on the states' rows)
- ``driven.xml``          the driven scenario as CommonRoad XML (agents as dynamic obstacles, their ids
                          offset by `AGENT_ID_OFFSET`), and ``driven.json`` its sidecar (the road's relief)
- ``solution.xml``        every agent's driven trajectory as a CommonRoad solution

The directory is built next to its destination and swapped into place (`simgap.files.replace_directory`),
so a reader never sees a half-written run. Format 1 — ``run.json`` without ``format_version``, as
simgap wrote it until 2026-11-27 — is read through `migrate`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq
from pydantic import BaseModel, ConfigDict, ValidationError

from simgap.cosim.history import AgentHistory, Event, History, Outcome, PlannerError
from simgap.cosim.loop import CosimSettings
from simgap.cosim.sensing import LocalisationAccuracy
from simgap.errors import InputError, validation_error
from simgap.evaluate import EvaluationSettings
from simgap.evaluate.criticality import PairCriticality
from simgap.evaluate.errors import Aggregate, Comfort
from simgap.evaluate.run_evaluation import AgentEvaluation, AgentTracking, RunEvaluation, SolutionCheckSource
from simgap.evaluate.solution import PartialCost
from simgap.files import atomic_write_text, replace_directory
from simgap.planning.protocol import PlannerReport
from simgap.planning.registry import DEFAULT_PLANNER
from simgap.record.integrity import JsonObject, check_driven, check_record, check_states, record_object
from simgap.record.run_record import FORMAT_VERSION, PlannerRecord, RunRecord, RunSettings
from simgap.scenario.sections import RoadSections
from simgap.scenario.sidecar import ScenarioSidecar
from simgap.sim.protocol import REFERENCE, Realism
from simgap.sim.registry import BACKENDS, settings_model
from simgap.trajectory import ATTITUDE_FIELDS, CONTROL_FIELDS, STATE_FIELDS, Attitude, ControlTrace, Trajectory
from simgap.vehicles import Vehicle, load_vehicle

RUN_FILE = "run.json"
TRAJECTORIES_FILE = "trajectories.parquet"
CONTROL_COLUMNS = CONTROL_FIELDS[1:]     # a ``controls`` row's own columns (its time is the ``t`` column)
RECORD_TIMINGS = ("scoring", "criticality", "io", "validation")      # phases outside the loop, timed by the writer


# ------------------------------------------------------------------------------ writing
@dataclass(frozen=True)
class DrivenScenarioFile:
    """The scenario as the run drove it: CommonRoad XML (``driven.xml``; agents as dynamic obstacles)
    and the sidecar of the scenario it was driven on (``driven.json``; none for a scenario without one)."""

    xml: str
    sidecar: ScenarioSidecar | None = None


@dataclass(frozen=True)
class RunFiles:
    """What a run directory holds: the record (``run.json``, ``trajectories.parquet``), the driven
    scenario and the solution's CommonRoad XML (``solution.xml``), each optional but the record."""

    record: RunRecord
    driven: DrivenScenarioFile | None = None
    solution_xml: str | None = None


def write_run(files: RunFiles, run_dir: str | Path) -> Path:
    """Write the run directory of ``files`` atomically (built aside, then swapped into place)."""
    def write(tmp: Path) -> None:
        (tmp / RUN_FILE).write_text(_run_json(files.record))
        pq.write_table(_trajectory_table(files.record.history), tmp / TRAJECTORIES_FILE)
        if files.driven is not None:
            (tmp / "driven.xml").write_text(files.driven.xml)
            if files.driven.sidecar:
                (tmp / "driven.json").write_text(json.dumps(files.driven.sidecar.as_json(), indent=2))
        if files.solution_xml is not None:
            (tmp / "solution.xml").write_text(files.solution_xml)

    return replace_directory(run_dir, write)


def rewrite_record(record: RunRecord, run_dir: str | Path) -> Path:
    """Rewrite the ``run.json`` of a written run directory (atomically), e.g. once its solution has
    been checked; its trajectories are the same."""
    return atomic_write_text(Path(run_dir) / RUN_FILE, _run_json(record))


def _run_json(record: RunRecord) -> str:
    return json.dumps({"format_version": record.format_version, "fingerprint": record.fingerprint,
                       "machine_fingerprint": record.machine_fingerprint,
                       "settings": _settings_json(record.settings), "history": _history_json(record.history),
                       "evaluation": _evaluation_json(record.evaluation),
                       "timings": dict(record.timings)},
                      indent=2, default=_json_default)


def _settings_json(s: RunSettings) -> dict[str, Any]:
    return {"scenario_id": s.scenario_id, "scenario_path": s.scenario_path, "parameters": dict(s.parameters),
            "parameter_units": dict(s.parameter_units), "sections": s.sections.as_json(), "seed": s.seed,
            "cosim": s.cosim.model_dump(mode="json"), "evaluation": s.evaluation.model_dump(mode="json"),
            "backend": s.backend.model_dump(mode="json"),
            "sensing_accuracy": None if s.sensing_accuracy is None else s.sensing_accuracy.model_dump(mode="json"),
            "planner": _planner_json(s.planner), "planner_vehicle": s.planner_vehicle,
            "recorded_as": {str(k): v for k, v in s.recorded_as.items()}, "versions": dict(s.versions)}


def _planner_json(p: PlannerRecord) -> dict[str, Any]:
    out: dict[str, Any] = {"name": p.name, "planner": p.planner, "settings": dict(p.settings)}
    if p.process is not None:
        out["process"] = asdict(p.process)
    if p.agents:
        out["agents"] = {str(aid): _planner_json(a) for aid, a in p.agents.items()}
    return out


def _history_json(h: History) -> dict[str, Any]:
    return {"scenario_id": h.scenario_id, "backend": h.backend, "dt": h.dt, "realism": h.realism.value,
            "wall_time_s": h.wall_time_s, "failure": h.failure,
            "agents": [{"id": a.id, "vehicle": a.vehicle.model_dump(mode="json"), "outcome": a.outcome.value,
                        "planner_failures": a.planner_failures, "planner_exceptions": a.planner_exceptions,
                        "planning_call_s": list(a.planning_call_s), "plan_latency_s": list(a.plan_latency_s)}
                       for a in h.agents],
            "events": [asdict(e) for e in h.events], "timings": dict(h.timings),
            "planner_errors": [asdict(e) for e in h.planner_errors], "backend_notes": list(h.backend_notes)}


def _evaluation_json(e: RunEvaluation) -> dict[str, Any]:
    return {"agents": [_agent_evaluation_json(a) for a in e.agents], "metrics": dict(e.metrics),
            "criticality": [asdict(c) for c in e.criticality],
            "solution_check": None if e.solution_check is None else e.solution_check.value}


def _agent_evaluation_json(a: AgentEvaluation) -> dict[str, Any]:
    out = {f.name: getattr(a, f.name) for f in fields(a)}
    out["tracking"] = None if a.tracking is None else asdict(a.tracking)
    out["score_components"] = dict(a.score_components)
    out["score_measures"] = dict(a.score_measures)
    out["solution_partial_costs"] = {k: asdict(v) for k, v in a.solution_partial_costs.items()}
    return out


def _trajectory_table(history: History) -> pa.Table:
    attitudes = any(a.attitudes for a in history.agents)
    third = ATTITUDE_FIELDS if attitudes else ()
    commands = CONTROL_COLUMNS if any(a.controls is not None for a in history.agents) else ()
    cols: dict[str, list] = {"kind": [], "agent_id": [], "plan_t": [], "k": []}
    cols.update({f: [] for f in STATE_FIELDS + third + commands})

    def add(kind: str, aid: int, plan_t: float, traj: Trajectory, attitude: tuple[Attitude, ...] = ()) -> None:
        n = len(traj)
        cols["kind"].extend([kind] * n)
        cols["agent_id"].extend([aid] * n)
        cols["plan_t"].extend([plan_t] * n)
        cols["k"].extend(range(n))
        for f in STATE_FIELDS:
            cols[f].extend(getattr(traj, f).tolist())
        for f in third:
            cols[f].extend([getattr(a, f) for a in attitude] if attitude else [math.nan] * n)
        for f in commands:
            cols[f].extend([math.nan] * n)

    def add_controls(aid: int, trace: ControlTrace) -> None:
        n = len(trace)
        cols["kind"].extend(["controls"] * n)
        cols["agent_id"].extend([aid] * n)
        cols["plan_t"].extend([math.nan] * n)
        cols["k"].extend(range(n))
        for f in STATE_FIELDS + third:
            cols[f].extend(trace.t.tolist() if f == "t" else [math.nan] * n)
        for f in commands:
            cols[f].extend(getattr(trace, f).tolist())

    agents = sorted(history.agents, key=lambda a: a.id)
    for a in agents:
        add("driven", a.id, math.nan, a.driven, a.attitudes)
    for a in agents:
        for plan in a.plans:
            add("planned", a.id, float(plan.t[0]), plan)
    for a in agents:
        if a.observed is not None and len(a.observed):
            add("observed", a.id, math.nan, a.observed)
        if a.standing is not None and len(a.standing):
            add("standing", a.id, math.nan, a.standing)
    for oid, traj in sorted(history.traffic.items()):
        add("traffic", oid, math.nan, traj)
    for a in agents:
        if a.controls is not None:
            add_controls(a.id, a.controls)
    schema = pa.schema([("kind", pa.string()), ("agent_id", pa.int64()), ("plan_t", pa.float64()),
                        ("k", pa.int32())] + [(f, pa.float64()) for f in STATE_FIELDS + third + commands])
    return pa.table(cols, schema=schema)


def _json_default(obj: Any) -> Any:
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    if isinstance(obj, Mapping):
        return dict(obj)
    raise TypeError(f"not JSON serialisable: {type(obj)}")


# ------------------------------------------------------------------------------ reading
def read_run(run_dir: str | Path) -> RunRecord:
    """The record of a run directory (of any format: older ones through `migrate`); a damaged one
    is refused (`simgap.record.integrity`)."""
    run_dir = Path(run_dir)
    with _not_written_by_simgap(run_dir / RUN_FILE):
        meta = _checked_meta(run_dir)
        states = _read_states(run_dir / TRAJECTORIES_FILE, float(meta["history"]["dt"]))
        check_driven(_agent_ids(meta), states["driven"], run_dir / TRAJECTORIES_FILE)
        return RunRecord(history=_history(meta["history"], states), evaluation=_evaluation(meta["evaluation"]),
                         settings=_settings(meta["settings"], meta["history"]["backend"], run_dir / RUN_FILE),
                         timings=meta.get("timings") or {},
                         format_version=int(meta["format_version"]))


def check_run(run_dir: str | Path) -> None:
    """Refuse a damaged run directory as `read_run` does, without building its record (a few
    milliseconds: what a results store checks of every run it counts as finished)."""
    run_dir = Path(run_dir)
    with _not_written_by_simgap(run_dir / RUN_FILE):
        meta = _checked_meta(run_dir)
        table = _checked_table(run_dir / TRAJECTORIES_FILE)
        driven = table.filter(pc.equal(table.column("kind"), "driven")).column("agent_id")
        check_driven(_agent_ids(meta), set(pc.unique(driven).to_pylist()), run_dir / TRAJECTORIES_FILE)


def _checked_meta(run_dir: Path) -> dict[str, Any]:
    """The ``run.json`` of ``run_dir`` in the current format, checked."""
    meta_path = run_dir / RUN_FILE
    if not meta_path.exists():
        raise InputError("not a run directory (no run.json)", file=run_dir)
    try:
        meta = json.loads(meta_path.read_text())
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read the run's record: {exc}", file=meta_path,
                         allowed="the run.json simgap wrote; run the scenario again") from None
    meta = migrate(record_object(meta, meta_path), run_dir)
    check_record(meta, meta_path)
    return meta


def _agent_ids(meta: JsonObject) -> list[int]:
    return [int(a["id"]) for a in meta["history"]["agents"]]


@contextmanager
def _not_written_by_simgap(meta_path: Path) -> Iterator[None]:
    """What a record that is not one simgap wrote raises while it is read, as an `InputError`."""
    try:
        yield
    except InputError:
        raise
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"the run's record is not one simgap wrote ({type(exc).__name__}: {exc})", file=meta_path,
                         allowed=f"a run.json of format {FORMAT_VERSION} or older; run the scenario again") from None


def _checked_table(path: Path) -> pa.Table:
    """The trajectories table at ``path``, checked."""
    try:
        table = pq.read_table(path)
    except (OSError, ValueError, pa.ArrowException) as exc:
        raise InputError(f"cannot read the run's trajectories: {exc}", file=path,
                         allowed="the trajectories.parquet simgap wrote; run the scenario again") from None
    check_states(table, path)
    return table


def _read_states(path: Path, dt: float) -> dict[str, Any]:
    """The trajectories of a run directory by kind: ``driven`` etc. agent id -> Trajectory,
    ``planned`` agent id -> [Trajectory], ``attitudes`` agent id -> (Attitude, ...), ``controls``
    agent id -> ControlTrace."""
    table = _checked_table(path).to_pydict()
    missing = [f for f in CONTROL_COLUMNS if f not in table]
    if missing and "controls" in table["kind"]:
        raise InputError(f"rows of kind 'controls' without the columns {', '.join(missing)}", file=path,
                         field="controls", allowed=f"the columns {', '.join(CONTROL_COLUMNS)} beside them, as simgap "
                                                   "wrote them; run the scenario again")
    groups: dict[tuple[str, int, float], list[int]] = {}
    for i, (kind, aid, pt) in enumerate(zip(table["kind"], table["agent_id"], table["plan_t"])):
        groups.setdefault((kind, aid, pt if kind == "planned" else -1.0), []).append(i)
    out: dict[str, Any] = {"driven": {}, "planned": {}, "observed": {}, "standing": {}, "traffic": {},
                           "attitudes": {}, "controls": {}}
    for (kind, aid, _), rows in groups.items():
        if kind == "controls":
            out["controls"][aid] = ControlTrace(t=[table["t"][i] for i in rows],
                                                **{f: [table[f][i] for i in rows] for f in CONTROL_COLUMNS})
            continue
        traj = Trajectory(dt, **{f: [table[f][i] for i in rows] for f in STATE_FIELDS})
        if kind == "planned":
            out["planned"].setdefault(aid, []).append(traj)
            continue
        out.setdefault(kind, {})[aid] = traj
        if kind == "driven" and "z" in table and not math.isnan(table["z"][rows[0]]):
            out["attitudes"][aid] = tuple(Attitude(*(table[f][i] for f in ATTITUDE_FIELDS)) for i in rows)
    return out


def _history(h: JsonObject, states: dict[str, Any]) -> History:
    agents = tuple(AgentHistory(
        id=int(a["id"]), vehicle=Vehicle.model_validate(a["vehicle"]), outcome=Outcome(a["outcome"]),
        driven=states["driven"][int(a["id"])], plans=tuple(states["planned"].get(int(a["id"]), ())),
        observed=states["observed"].get(int(a["id"])), attitudes=states["attitudes"].get(int(a["id"]), ()),
        standing=states["standing"].get(int(a["id"])),
        planning_call_s=tuple(a.get("planning_call_s") or ()), plan_latency_s=tuple(a.get("plan_latency_s") or ()),
        planner_failures=int(a.get("planner_failures", 0)), planner_exceptions=int(a.get("planner_exceptions", 0)),
        controls=states["controls"].get(int(a["id"])))
        for a in h["agents"])
    return History(scenario_id=h["scenario_id"], backend=h["backend"], dt=float(h["dt"]),
                   realism=Realism(h["realism"]), agents=agents, events=tuple(Event(**e) for e in h.get("events") or ()),
                   timings=h.get("timings") or {}, wall_time_s=float(h.get("wall_time_s") or 0.0),
                   failure=h.get("failure"), planner_errors=tuple(PlannerError(**e) for e in h.get("planner_errors") or ()),
                   backend_notes=tuple(h.get("backend_notes") or ()), traffic=states["traffic"])


def _evaluation(e: JsonObject) -> RunEvaluation:
    agents = []
    for a in e["agents"]:
        a = dict(a)
        tracking = a.pop("tracking", None)
        agents.append(AgentEvaluation(
            **a | {"solution_partial_costs": {k: PartialCost(**v) for k, v in (a.get("solution_partial_costs") or {}).items()}},
            tracking=None if tracking is None else AgentTracking(
                **{k: Aggregate(**tracking[k]) for k in ("position", "orientation", "velocity", "lateral", "longitudinal")},
                comfort=Comfort(**tracking["comfort"]), lane_excursion_m=tracking["lane_excursion_m"])))
    check = e.get("solution_check")
    return RunEvaluation(tuple(agents), e.get("metrics") or {},
                         tuple(PairCriticality(**c) for c in e.get("criticality") or ()),
                         None if check is None else SolutionCheckSource(check))


def _planner(p: JsonObject) -> PlannerRecord:
    return PlannerRecord(name=p.get("name") or DEFAULT_PLANNER, planner=p.get("planner", ""),
                         settings=p.get("settings") or {},
                         process=None if p.get("process") is None else PlannerReport(**p["process"]),
                         agents={int(aid): _planner(a) for aid, a in (p.get("agents") or {}).items()})


def _settings(s: JsonObject, backend: str, file: Path) -> RunSettings:
    accuracy = s.get("sensing_accuracy")
    return RunSettings(
        scenario_id=s["scenario_id"], cosim=CosimSettings.model_validate(s.get("cosim") or {}),
        evaluation=EvaluationSettings.model_validate(s.get("evaluation") or {}),
        planner=_planner(s.get("planner") or {}), scenario_path=s.get("scenario_path"),
        parameters=s.get("parameters") or {}, parameter_units=s.get("parameter_units") or {},
        sections=RoadSections.of_json(s.get("sections")), backend=_backend_settings(backend, s.get("backend") or {}, file),
        sensing_accuracy=None if accuracy is None else LocalisationAccuracy.model_validate(accuracy),
        planner_vehicle=s.get("planner_vehicle") or "", recorded_as={int(k): v for k, v in (s.get("recorded_as") or {}).items()},
        seed=int(s.get("seed") or 0), versions=s.get("versions") or {})


class UnknownBackendSettings(BaseModel):
    """The settings of a backend this installation does not have (an installed one since removed),
    as the record kept them: nothing here can validate them."""

    model_config = ConfigDict(extra="allow", frozen=True)


def _backend_settings(backend: str, values: JsonObject, file: Path) -> BaseModel:
    """A run's backend settings validated again, through the settings model of its backend; a value
    that model no longer takes is refused naming the field."""
    if backend not in BACKENDS:
        return UnknownBackendSettings.model_validate(values)
    model = settings_model(backend)
    try:
        return model.model_validate(values)
    except ValidationError as err:
        raise validation_error(err, file=file, prefix="settings.backend", model=model,
                               allowed=f"the settings of the {backend} backend; run the scenario again") from None


# ------------------------------------------------------------------------------ older formats
def migrate(meta: JsonObject, run_dir: Path | None = None) -> JsonObject:
    """A ``run.json`` of any format as one of the current format (`FORMAT_VERSION`).

    Format 1 (no ``format_version``) kept every agent's outcome, metrics and scores in one list
    and the settings as one mapping; it is split into history, evaluation and settings. What it did
    not keep stays empty: planning-call times and plan latencies (their statistics are kept), what
    the planners observed, tracking; its vehicles, where not kept (runs before 2026-11), are the
    catalogue's of that name; its realism, where not kept, ideal; its planner, where not named,
    ``frenet``. The criticality a report cached in the run directory (``criticality.json``) is
    read as its evaluation's. Formats 1 to 3 kept the evaluation's settings (``cost_function``,
    ``score``) among the loop's (``settings.cosim``); they are the settings' ``evaluation``."""
    version = int(meta.get("format_version", 1))
    if version > FORMAT_VERSION:
        raise InputError(f"run.json of format {version}, newer than this simgap reads",
                         file=None if run_dir is None else Path(run_dir) / RUN_FILE, field="format_version",
                         allowed=f"formats 1 to {FORMAT_VERSION}: update simgap")
    if version == FORMAT_VERSION:
        return dict(meta)
    if version in (2, 3):           # 2: its fingerprint hashed raw float bits; both are computed from the states
        settings = meta.get("settings")         # (one that is no mapping is refused by its check)
        return dict(meta) | {"format_version": FORMAT_VERSION} | \
            ({"settings": _evaluation_apart(settings)} if isinstance(settings, dict) else {})
    settings = dict(meta.get("settings") or {})
    vehicles = meta.get("vehicles") or {}
    timings = meta.get("timings") or {}
    agents = meta["agents"]
    history = {
        "scenario_id": meta["scenario_id"], "backend": meta["backend"], "dt": meta["dt"],
        "realism": settings.get("realism", Realism.IDEAL.value), "wall_time_s": meta.get("wall_time_s", 0.0),
        "failure": meta.get("failure"), "events": meta.get("events") or [],
        "timings": {k: v for k, v in timings.items() if k not in RECORD_TIMINGS},
        "planner_errors": meta.get("planner_errors") or [], "backend_notes": settings.get("backend_notes") or [],
        "agents": [{"id": a["id"], "outcome": a["outcome"],
                    "vehicle": vehicles.get(str(a["id"])) or load_vehicle(a["vehicle"]).model_dump(mode="json"),
                    "planner_failures": a.get("planner_failures", 0),
                    "planner_exceptions": a.get("planner_exceptions", 0)} for a in agents]}
    kept = {f.name for f in fields(AgentEvaluation)} - {"tracking"}
    criticality_file = None if run_dir is None else Path(run_dir) / "criticality.json"
    criticality = json.loads(criticality_file.read_text()) if criticality_file and criticality_file.is_file() else []
    evaluation = {"agents": [{k: v for k, v in a.items() if k in kept} for a in agents],
                  "metrics": meta.get("metrics") or {}, "criticality": criticality,
                  "solution_check": settings.get("solution_check")}
    cosim = settings.get("cosim") or {}
    planner_names = {a["id"]: a.get("planner") for a in agents}
    planner = dict(settings.get("planner") or {})
    if not planner.get("name"):
        planner["name"] = next((n for n in planner_names.values() if n), DEFAULT_PLANNER)
    run_settings = {
        "scenario_id": meta["scenario_id"], "scenario_path": meta.get("scenario_path"),
        "parameters": meta.get("parameters") or {}, "parameter_units": settings.get("parameter_units") or {},
        "sections": meta.get("sections") or {}, "seed": meta.get("seed", 0),
        "cosim": {k: v for k, v in cosim.items() if k in CosimSettings.model_fields},
        "evaluation": {k: v for k, v in cosim.items() if k in EvaluationSettings.model_fields},
        "backend": _format1_backend(meta["backend"], settings), "sensing_accuracy": settings.get("sensing_accuracy"),
        "planner": planner, "planner_vehicle": settings.get("planner_vehicle") or "",
        "recorded_as": {str(a["id"]): a["recorded_as"] for a in agents if a.get("recorded_as") is not None},
        "versions": meta.get("versions") or {}}
    return {"format_version": FORMAT_VERSION, "settings": run_settings, "history": history, "evaluation": evaluation,
            "timings": {k: v for k, v in timings.items() if k in RECORD_TIMINGS}}


def _evaluation_apart(settings: JsonObject) -> JsonObject:
    """Settings of formats 2 and 3 with the evaluation's (``cost_function``, ``score``) moved from
    ``cosim`` to ``evaluation``."""
    cosim = dict(settings.get("cosim") or {})
    evaluation = {k: cosim.pop(k) for k in EvaluationSettings.model_fields if k in cosim}
    return dict(settings) | {"cosim": cosim, "evaluation": evaluation}


def _format1_backend(backend: str, settings: JsonObject) -> JsonObject:
    """The backend settings of a format-1 record as its backend's settings model reads them: a
    physical world's run kept before realism was one of its settings (until 2026-11-27) was an
    ideal car (as its history says), so it takes the record's realism, where the model's default
    would make it a real one."""
    values = dict(settings.get("backend") or {})
    if backend != REFERENCE and "realism" not in values:
        values["realism"] = settings.get("realism", Realism.IDEAL.value)
    return values


def migrate_row(columns: JsonObject) -> JsonObject:
    """A results-store row of any format as one of the current format: rows written before the
    ``stage`` column name their stage (and a repeat 0) in their key only; rows of formats 1 and 2
    kept the hash of raw float bits as their ``fingerprint``, which is their ``machine_fingerprint``
    (the portable one is their run directory's: `read_run`)."""
    cols = dict(columns)
    version = cols.get("format_version")
    if version is None and cols.get("stage") is None:
        key, fidelity = str(cols["key"]), str(cols.get("fidelity") or "")
        named = key.split("/")[1] if key.count("/") else ""
        cols["stage"] = named if named and named != fidelity else ""
    if version is None or int(version) < 3:
        cols["machine_fingerprint"] = cols.get("fingerprint")
        cols["fingerprint"] = None
    cols["format_version"] = FORMAT_VERSION
    return cols
