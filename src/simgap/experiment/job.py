"""What an experiment or a search runs: a run's identity (`JobId`), the run to execute (`Job`),
and what every job of a batch shares (`JobContext`).

A job's key — ``scenario/fidelity`` (``/PLANNER`` unless the planner is the default ``frenet``,
``/rN`` when the experiment repeats runs; a search names its ladder's rungs instead of fidelities:
``c00012/high``) — is printed only by `JobId.key`; code that needs the parts of a job holds its
`JobId`, never a key taken apart.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from simgap.cosim import CosimSettings, Fidelity
from simgap.evaluate import EvaluationSettings
from simgap.planning.registry import DEFAULT_PLANNER, PlannerChoice
from simgap.vehicles import DEFAULT_VEHICLE


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
                "repeat": self.repeat or 0, "seed": self.seed, "stage": self.stage or ""}

    @classmethod
    def from_columns(cls, cols: Mapping[str, Any]) -> JobId:
        """The identity of a stored row (the inverse of `columns`; older rows through
        `simgap.record.migrate_row`)."""
        fidelity = Fidelity(cols["backend"], cols["vehicle"], cols.get("controller") or None,
                            Fidelity.realism_of_label(str(cols.get("fidelity") or "")))
        key = str(cols["key"])
        repeat = int(cols.get("repeat") or 0)
        stage = cols["stage"]
        return cls(cols["scenario"], fidelity, repeat if repeat or key.endswith("/r0") else None,
                   int(cols.get("seed") or 0), cols.get("planner") or DEFAULT_PLANNER, stage or None)


@dataclass(frozen=True)
class Job:
    """One run to execute: its identity, the concrete scenario, and every setting it runs with."""

    id: JobId
    parameters: dict[str, float]                    # the scenario's parameters
    vehicle: str                                    # catalogue name or data file the vehicle is loaded from
    backend_settings: BaseModel | None = None       # the backend's settings model (None: its defaults)
    cosim: CosimSettings = field(default_factory=CosimSettings)   # the loop's settings
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
class JobContext:
    """What every job of an experiment or a search shares: where it writes, the scenario file of
    each scenario, the vehicle the planner assumes, what each run is evaluated by and whether its
    solution is checked."""

    root: Path
    scenarios: dict[str, str] | None = None       # scenario name -> file (else each job names its file)
    planner_vehicle: str = DEFAULT_VEHICLE        # catalogue name or data file
    validate: bool = False                        # check each run's solution (slow; the CLI asks unless --no-validate)
    criticality: bool = True                      # evaluate the criticality of agent pairs (a search need not)
    evaluation: EvaluationSettings = field(default_factory=EvaluationSettings)   # cost function, score settings
