"""The runs a report is made of: their records (`simgap.record`), found under a directory,
labelled by fidelity, grouped by scenario and planner, each physics run compared with the
reference (ideal) run of its scenario with the same planner (the comparison is
`simgap.evaluate.compare`'s; the report computes no metric of its own).

A run's fidelity (`simgap.cosim.Fidelity`) labels it: ``ideal``, ``mujoco/suv``, ...; its planner
is the one its record names (`simgap.record.RunSettings.planner`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.scenario import Scenario

from simgap.cosim import REFERENCE, Outcome
from simgap.errors import InputError
from simgap.evaluate.compare import AgentComparison, compare_histories
from simgap.planning.registry import DEFAULT_PLANNER
from simgap.record import RunRecord, read_run
from simgap.scenario import load_scenario
from simgap.scenario.sections import RoadSections

@dataclass(frozen=True)
class RunEntry:
    run_dir: Path
    run: RunRecord
    fidelity: str

    @property
    def failed(self) -> bool:
        return self.run.failure is not None or self.run.history.outcome != Outcome.GOAL_REACHED


@dataclass
class ScenarioGroup:
    scenario_id: str
    parameters: dict
    scenario: Scenario
    problems: PlanningProblemSet
    sections: RoadSections
    runs: dict[str, RunEntry]                                           # by fidelity, the reference first
    comparisons: dict[str, list[AgentComparison]] = field(default_factory=dict)   # fidelity vs reference
    planner: str = DEFAULT_PLANNER                                      # every run's planner

    @property
    def name(self) -> str:
        """The scenario, and the planner unless it is the default one (names its report page)."""
        return self.scenario_id if self.planner == DEFAULT_PLANNER else f"{self.scenario_id}@{self.planner}"

    @property
    def reference(self) -> RunEntry | None:
        return self.runs.get(REFERENCE)

    def largest_gap(self) -> tuple[float, str | None]:
        """The largest max |d| of any fidelity against the reference, and that fidelity."""
        gaps = [(c.lateral_displacement.max, fidelity) for fidelity, comps in self.comparisons.items()
                for c in comps if math.isfinite(c.lateral_displacement.max)]
        return max(gaps) if gaps else (float("nan"), None)


def find_run_dirs(root: Path) -> list[Path]:
    root = Path(root)
    if not root.exists():
        raise InputError("no such directory", file=root)
    dirs = sorted({p.parent for p in root.rglob("run.json") if not p.parent.name.startswith(".")})
    if not dirs:
        raise InputError("no run directories (with run.json) below this directory", file=root)
    return dirs


def _scenario_of(entry: RunEntry) -> tuple[Scenario, PlanningProblemSet]:
    xml = entry.run_dir / "driven.xml"
    if not xml.exists():
        raise InputError("run has no driven.xml (the scenario it ran)", file=entry.run_dir)
    return load_scenario(xml)


def collect(root: Path) -> list[ScenarioGroup]:
    """Every run below ``root``, grouped by scenario and planner, each physics run compared with its
    scenario's reference run (`simgap.evaluate.compare`)."""
    groups: dict[tuple[str, str], ScenarioGroup] = {}
    for run_dir in find_run_dirs(root):
        run = read_run(run_dir)
        entry = RunEntry(run_dir, run, run.fidelity.label)
        planner = run.planner
        group = groups.get((run.scenario_id, planner))
        if group is None:
            scenario, problems = _scenario_of(entry)
            group = groups[run.scenario_id, planner] = ScenarioGroup(
                run.scenario_id, dict(run.settings.parameters), scenario, problems, run.settings.sections, {},
                planner=planner)
        if entry.fidelity in group.runs:
            raise InputError(f"two runs of scenario '{run.scenario_id}' with fidelity '{entry.fidelity}' and planner "
                             f"'{planner}' (the other: {group.runs[entry.fidelity].run_dir})", file=run_dir,
                             field="fidelity", allowed="one run per scenario, fidelity and planner")
        group.runs[entry.fidelity] = entry
    for group in groups.values():
        group.runs = dict(sorted(group.runs.items(), key=lambda kv: (kv[0] != REFERENCE, kv[0])))   # ideal first
        ref = group.reference
        if ref is None:
            continue
        for fidelity, entry in group.runs.items():
            if fidelity != REFERENCE:
                group.comparisons[fidelity] = compare_histories(ref.run.history, entry.run.history, group.scenario,
                                                                group.problems, group.sections)
    return sorted(groups.values(), key=lambda g: (g.scenario_id, g.planner))
