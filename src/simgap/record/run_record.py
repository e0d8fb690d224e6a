"""`RunRecord`: one run as it is kept — what happened (`History`), what it scored
(`RunEvaluation`), what it was run with (`RunSettings`) — and the version of the format it is
written in. Written and read by `simgap.record.run_files` only.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import asdict, dataclass, field, fields
from typing import Any

from pydantic import BaseModel, JsonValue

from simgap.cosim.fidelity import Fidelity
from simgap.cosim.history import AgentHistory, History
from simgap.cosim.loop import CosimSettings
from simgap.cosim.sensing import LocalisationAccuracy
from simgap.evaluate import EvaluationSettings
from simgap.evaluate.run_evaluation import AgentEvaluation, RunEvaluation
from simgap.planning.protocol import PlannerReport
from simgap.scenario.sections import RoadSections
from simgap.sim.ideal import NoSettings
from simgap.sim.protocol import Realism
from simgap.sim.settings import TrackingSettings

FORMAT_VERSION = 4      # 1: run.json without a format_version (simgap before the run record, 2026-11-27);
                        # 2: a fingerprint over raw float bits (until 2026-12-02); 3: over quantised states;
                        # 4: the evaluation's settings (cost function, score) apart from the loop's


@dataclass(frozen=True)
class PlannerRecord:
    """The planner that drove (every agent, or with ``agents`` each its own): its name (label),
    what it was loaded by, its settings in full, and — in a process of its own — that process."""

    name: str
    planner: str = ""                                      # the reference it was loaded by
    settings: Mapping[str, JsonValue] = field(default_factory=dict)   # its own settings model, dumped
    process: PlannerReport | None = None                   # the planner process's record
    agents: Mapping[int, PlannerRecord] = field(default_factory=dict)   # per agent, when they differ

    def of_agent(self, agent_id: int) -> PlannerRecord:
        return self.agents.get(agent_id, self)


@dataclass(frozen=True)
class RunSettings:
    """What a run was run with: the scenario, the loop's and the backend's settings, what it was
    evaluated by, the planner, the vehicle the planner assumed, the seed and the software's versions."""

    scenario_id: str
    cosim: CosimSettings
    planner: PlannerRecord
    scenario_path: str | None = None
    parameters: Mapping[str, JsonValue] = field(default_factory=dict)   # the scenario's parameters
    parameter_units: Mapping[str, str] = field(default_factory=dict)
    sections: RoadSections = field(default_factory=RoadSections)
    backend: BaseModel = field(default_factory=NoSettings)          # the backend's settings model (validated)
    sensing_accuracy: LocalisationAccuracy | None = None            # what the planners observed through
    planner_vehicle: str = ""
    recorded_as: Mapping[int, int] = field(default_factory=dict)    # agent -> the recorded road user it replaces
    seed: int = 0
    versions: Mapping[str, str] = field(default_factory=dict)
    evaluation: EvaluationSettings = field(default_factory=EvaluationSettings)   # cost function, score settings

    def __post_init__(self) -> None:
        for name in ("parameters", "parameter_units", "recorded_as", "versions"):
            object.__setattr__(self, name, dict(getattr(self, name)))

    @property
    def controller(self) -> str | None:
        """The tracking controller of a world whose cars track their plans (None: the ideal world)."""
        return self.backend.controller if isinstance(self.backend, TrackingSettings) else None


@dataclass(frozen=True)
class AgentRecord:
    """One agent's part of a record: its history (what happened: ``history.outcome``, ...), its
    evaluation (what it scored: ``evaluation.score``, ...), its planner and the road user it replaces."""

    history: AgentHistory
    evaluation: AgentEvaluation
    planner: str                         # the planner's name (label)
    recorded_as: int | None              # the recorded road user it replaces

    @property
    def id(self) -> int:
        return self.history.id


@dataclass(frozen=True)
class RunRecord:
    """One run: its history, its evaluation, its settings, and the phases outside the loop's
    timings (``scoring``, ``io``, ``validation``)."""

    history: History
    evaluation: RunEvaluation
    settings: RunSettings
    timings: Mapping[str, float] = field(default_factory=dict)
    format_version: int = FORMAT_VERSION

    def __post_init__(self) -> None:
        object.__setattr__(self, "timings", dict(self.timings))

    # what readers ask of a run
    @property
    def scenario_id(self) -> str:
        return self.settings.scenario_id

    @property
    def failure(self) -> str | None:
        return self.history.failure

    @property
    def fingerprint(self) -> str:
        """The run's identity on any machine (`History.fingerprint`)."""
        return self.history.fingerprint

    @property
    def machine_fingerprint(self) -> str:
        """The run's identity bit for bit, on this machine (`History.machine_fingerprint`)."""
        return self.history.machine_fingerprint

    @property
    def realism(self) -> Realism:
        return self.history.realism

    @property
    def planner(self) -> str:
        return self.settings.planner.name

    @property
    def fidelity(self) -> Fidelity:
        """What produced the run: its backend, its agents' vehicles, its controller and realism."""
        vehicles = "+".join(sorted({a.vehicle.name for a in self.history.agents}))
        return Fidelity(self.history.backend, vehicles, self.settings.controller, self.realism)

    @property
    def all_timings(self) -> dict[str, float]:
        """Seconds per phase: the loop's and the backend's, then scoring, io and validation."""
        return dict(self.history.timings) | dict(self.timings)

    @property
    def agents(self) -> tuple[AgentRecord, ...]:
        return tuple(self._agent_records())

    def agent(self, agent_id: int) -> AgentRecord:
        return next(a for a in self._agent_records() if a.id == agent_id)

    def summary(self) -> dict[str, Any]:
        """What ``simgap run --json`` prints: the run's identity, how it ended, its timings, and per
        agent its planner, vehicle, outcome and evaluation."""
        agents = []
        for a in self._agent_records():
            evaluation = {f.name: getattr(a.evaluation, f.name) for f in fields(a.evaluation)}
            evaluation["tracking"] = None if a.evaluation.tracking is None else asdict(a.evaluation.tracking)
            evaluation["solution_partial_costs"] = {k: asdict(v) for k, v in a.evaluation.solution_partial_costs.items()}
            evaluation |= {k: dict(evaluation[k]) for k in ("score_components", "score_measures")}
            agents.append({"id": a.id, "planner": a.planner, "vehicle": a.history.vehicle.name,
                           "outcome": a.history.outcome.value, "recorded_as": a.recorded_as,
                           "planner_failures": a.history.planner_failures,
                           "planner_exceptions": a.history.planner_exceptions} | evaluation)
        return {"scenario_id": self.scenario_id, "backend": self.history.backend, "fidelity": self.fidelity.label,
                "wall_time_s": round(self.history.wall_time_s, 4), "fingerprint": self.fingerprint,
                "machine_fingerprint": self.machine_fingerprint, "seed": self.settings.seed, "failure": self.failure, "agents": agents,
                "timings": {k: round(v, 4) for k, v in self.all_timings.items()}}

    def _agent_records(self) -> Iterator[AgentRecord]:
        for h in self.history.agents:
            yield AgentRecord(h, self.evaluation.agent(h.id), self.settings.planner.of_agent(h.id).name,
                              self.settings.recorded_as.get(h.id))
