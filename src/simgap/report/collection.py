"""The runs a report is made of: their records (`simgap.record`), found under a directory,
labelled by fidelity, grouped by scenario and planner, each physics run compared with the
reference (ideal) run of its scenario with the same planner (the comparison is
`simgap.evaluate.compare`'s; the report computes no metric of its own).

A run's fidelity (`simgap.cosim.Fidelity`) labels it: ``ideal``, ``mujoco/suv``, ...; its planner
is the one its record names (`simgap.record.RunSettings.planner`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.scenario import Scenario

from simgap.cosim import REFERENCE, Outcome
from simgap.errors import InputError
from simgap.evaluate.compare import AgentComparison, compare_histories
from simgap.experiment.attribution import Attribution, read_explanation
from simgap.planning.registry import DEFAULT_PLANNER
from simgap.record import RunRecord, read_run
from simgap.scenario import load_scenario
from simgap.scenario.sections import RoadSections


@dataclass(frozen=True)
class RunEntry:
    run_dir: Path
    run: RunRecord
    fidelity: str
    explanation: Attribution | None = None      # why it parted from the ideal run, where it was explained

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


READING_RUNS = "reading runs"        # phases of the report, as its progress names them
COMPARING_RUNS = "comparing runs with their ideal run"


def collect(root: Path, on_progress: Callable[[str, int, int], None] = lambda *_: None) -> list[ScenarioGroup]:
    """Every run below ``root``, grouped by scenario and planner, each physics run compared with its
    scenario's reference run (`simgap.evaluate.compare`). Runs of one scenario, planner and fidelity
    that differ in their settings (a knob, the latency, the seed of a repeat) sit side by side, each
    labelled with what differs (`variant_labels`); runs that differ in nothing are refused, all at once.
    ``on_progress(phase, done, total)`` after each run read and each run compared."""
    by_group: dict[tuple[str, str], list[RunEntry]] = {}
    run_dirs = find_run_dirs(root)
    for done, run_dir in enumerate(run_dirs, 1):
        on_progress(READING_RUNS, done - 1, len(run_dirs))
        run = read_run(run_dir)
        by_group.setdefault((run.scenario_id, run.planner), []).append(
            RunEntry(run_dir, run, run.fidelity.label, read_explanation(run_dir)))
    groups: dict[tuple[str, str], ScenarioGroup] = {}
    twins: list[str] = []
    for (scenario_id, planner), entries in by_group.items():
        labels = variant_labels(entries)
        twins += _twins(entries, labels)
        scenario, problems = _scenario_of(entries[0])
        first = entries[0].run
        group = groups[scenario_id, planner] = ScenarioGroup(
            scenario_id, dict(first.settings.parameters), scenario, problems, first.settings.sections, {},
            planner=planner)
        for e in entries:
            group.runs[labels[e.run_dir]] = replace(e, fidelity=labels[e.run_dir])
    if twins:
        raise InputError(f"{len(twins)} pairs of runs differ in nothing (scenario, planner, fidelity, settings, "
                         f"seed): {'; '.join(twins)}", file=root, field="runs",
                         allowed="runs that differ in their scenario, planner, fidelity or settings; move the "
                                 "copies away")
    on_progress(READING_RUNS, len(run_dirs), len(run_dirs))
    for done, group in enumerate(groups.values(), 1):
        group.runs = dict(sorted(group.runs.items(), key=lambda kv: (kv[0] != REFERENCE, kv[0])))   # ideal first
        ref = group.reference
        if ref is not None:
            for fidelity, entry in group.runs.items():
                if fidelity != REFERENCE:
                    group.comparisons[fidelity] = compare_histories(ref.run.history, entry.run.history,
                                                                    group.scenario, group.problems, group.sections)
        on_progress(COMPARING_RUNS, done, len(groups))
    return sorted(groups.values(), key=lambda g: (g.scenario_id, g.planner))


def variant_labels(entries: list[RunEntry]) -> dict[Path, str]:
    """Each run's label among runs of one scenario and planner: its fidelity, and where several runs
    share one, the settings that differ between them (``mujoco/sedan latency=0.0``,
    ``mujoco/sedan seed=3``). Of reference runs that share the label, the first keeps it plain."""
    by_fidelity: dict[str, list[RunEntry]] = {}
    for e in entries:
        by_fidelity.setdefault(e.fidelity, []).append(e)
    labels = {}
    for fidelity, same in by_fidelity.items():
        if len(same) == 1:
            labels[same[0].run_dir] = fidelity
            continue
        flat = [_flat_settings(e.run) for e in same]
        differ = [k for k in dict.fromkeys(k for f in flat for k in f) if len({repr(f.get(k)) for f in flat}) > 1]
        for e, f in zip(same, flat):
            labels[e.run_dir] = " ".join([fidelity] + [f"{k.rsplit('.', 1)[-1]}={f.get(k)}" for k in differ])
        if fidelity == REFERENCE:
            labels[min(same, key=lambda e: str(labels[e.run_dir])).run_dir] = REFERENCE
    return labels


def _twins(entries: list[RunEntry], labels: dict[Path, str]) -> list[str]:
    seen: dict[str, Path] = {}
    twins = []
    for e in entries:
        label = labels[e.run_dir]
        if label in seen:
            twins.append(f"{seen[label]} and {e.run_dir} ({label})")
        seen.setdefault(label, e.run_dir)
    return twins


def _flat_settings(run: RunRecord) -> dict[str, object]:
    """A run's settings that can tell two runs of one fidelity apart, flat: the seed, the backend's
    and the loop's settings (dotted names)."""
    flat: dict[str, object] = {"seed": run.settings.seed}

    def add(prefix: str, value: object) -> None:
        if isinstance(value, dict):
            for k, v in value.items():
                add(f"{prefix}.{k}" if prefix else str(k), v)
        else:
            flat[prefix] = value

    add("", run.settings.backend.model_dump(mode="json"))
    add("cosim", run.settings.cosim.model_dump(mode="json"))
    add("evaluation", run.settings.evaluation.model_dump(mode="json"))
    return flat
