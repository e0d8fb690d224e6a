"""The runs a report is made of: found under a directory, labelled by fidelity, grouped by
scenario and planner, each physics run compared with the reference (ideal) run of its scenario
with the same planner.

A run's fidelity (`simgap.cosim.Fidelity`) labels it: ``ideal``, ``mujoco/suv``, ...; its planner
is the name run.json records (``settings.planner.name``; ``frenet`` for runs older than planners).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.scenario import Scenario

from simgap.cosim import REFERENCE, Outcome, Run
from simgap.errors import InputError
from simgap.evaluate.compare import AgentComparison, compare_runs
from simgap.evaluate.errors import Aggregate, Comfort, comfort, frenet_tracking_errors, tracking_errors
from simgap.evaluate.route_centre import route_centre
from simgap.evaluate.run_metrics import lane_excursion
from simgap.planning.registry import DEFAULT_PLANNER
from simgap.scenario import load_scenario

@dataclass
class AgentTracking:
    """Planned versus driven within one run, for one agent."""

    agent_id: int
    position: Aggregate
    orientation: Aggregate
    velocity: Aggregate
    lateral: Aggregate
    longitudinal: Aggregate
    comfort: Comfort
    lane_excursion: float          # largest distance [m] the footprint reached beyond the route's lanes


@dataclass
class RunEntry:
    run_dir: Path
    run: Run
    fidelity: str
    tracking: list[AgentTracking] = field(default_factory=list)

    @property
    def failed(self) -> bool:
        return self.run.failure is not None or any(a.outcome != Outcome.GOAL_REACHED for a in self.run.agents)


@dataclass
class ScenarioGroup:
    scenario_id: str
    parameters: dict
    scenario: Scenario
    problems: PlanningProblemSet
    sections: dict[str, str] | None
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


def _tracking(run: Run, scenario: Scenario, problems: PlanningProblemSet) -> list[AgentTracking]:
    out = []
    for aid, driven in sorted(run.driven.items()):
        plans = run.plans.get(aid, [])
        errs = tracking_errors(driven, plans)
        problem = problems.planning_problem_dict.get(aid)
        frame = route_centre(scenario.lanelet_network, problem) if problem is not None else None
        frenet = frenet_tracking_errors(driven, plans, frame) if frame is not None else None
        out.append(AgentTracking(aid, Aggregate.of(errs.position), Aggregate.of(errs.orientation),
                                 Aggregate.of(errs.velocity),
                                 Aggregate.of(frenet.lateral) if frenet else Aggregate.of([]),
                                 Aggregate.of(frenet.longitudinal) if frenet else Aggregate.of([]),
                                 comfort(driven),
                                 lane_excursion(driven, run.vehicle_of(aid), scenario, problem)
                                 if problem is not None else float("nan")))
    return out


def _scenario_of(entry: RunEntry) -> tuple[Scenario, PlanningProblemSet, dict | None]:
    run = entry.run
    xml = entry.run_dir / "driven.xml"
    if not xml.exists():
        raise InputError("run has no driven.xml (the scenario it ran)", file=entry.run_dir)
    scenario, problems = load_scenario(xml)
    return scenario, problems, run.sections or None


def collect(root: Path) -> list[ScenarioGroup]:
    """Every run below ``root``, grouped by scenario and planner, with tracking errors and comparisons."""
    groups: dict[tuple[str, str], ScenarioGroup] = {}
    for run_dir in find_run_dirs(root):
        run = Run.load(run_dir)
        entry = RunEntry(run_dir, run, run.fidelity.label)
        planner = run.planner
        group = groups.get((run.scenario_id, planner))
        if group is None:
            scenario, problems, sections = _scenario_of(entry)
            group = groups[run.scenario_id, planner] = ScenarioGroup(
                run.scenario_id, dict(run.parameters), scenario, problems, sections, {}, planner=planner)
        if entry.fidelity in group.runs:
            raise InputError(f"two runs of scenario '{run.scenario_id}' with fidelity '{entry.fidelity}' and planner "
                             f"'{planner}' (the other: {group.runs[entry.fidelity].run_dir})", file=run_dir,
                             field="fidelity", allowed="one run per scenario, fidelity and planner")
        entry.tracking = _tracking(run, group.scenario, group.problems)
        group.runs[entry.fidelity] = entry
    for group in groups.values():
        group.runs = dict(sorted(group.runs.items(), key=lambda kv: (kv[0] != REFERENCE, kv[0])))   # ideal first
        ref = group.reference
        if ref is None:
            continue
        for fidelity, entry in group.runs.items():
            if fidelity != REFERENCE:
                group.comparisons[fidelity] = compare_runs(ref.run, entry.run, group.scenario, group.problems,
                                                           group.sections)
    return sorted(groups.values(), key=lambda g: (g.scenario_id, g.planner))
