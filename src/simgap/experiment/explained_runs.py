"""An experiment's runs explained (`ExplainSpec`): after the runs, each physical run that failed,
or that parted from the ideal run of its scenario and planner by more than a threshold, is
explained (`simgap.experiment.attribution.explain`), the worst first; an explanation is kept in
its run directory, so a resumed experiment explains only what it has not."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from simgap.cosim import REFERENCE, Outcome
from simgap.evaluate.compare import compare_histories
from simgap.experiment.attribution import Attribution, explain, read_explanation
from simgap.experiment.run_row import RunRow
from simgap.experiment.spec import ExplainSpec
from simgap.record import read_run
from simgap.scenario import load_scenario


@dataclass(frozen=True)
class ExplainedRun:
    key: str
    run_dir: Path
    attribution: Attribution
    new: bool                      # explained now (not by an earlier invocation)


def explain_runs(root: Path, rows: list[RunRow], spec: ExplainSpec, workers: int) -> list[ExplainedRun]:
    """Explain the runs of ``rows`` (an experiment's in ``root``) that ``spec`` chooses."""
    chosen = _chosen(root, rows, spec)
    out = []
    for row, _ in chosen[:spec.limit]:
        run_dir = root / str(row.run_dir)
        kept = read_explanation(run_dir)
        attribution = kept or explain(run_dir, workers, spec.assumptions)
        out.append(ExplainedRun(row.id.key, run_dir, attribution, kept is None))
    return out


def _chosen(root: Path, rows: list[RunRow], spec: ExplainSpec) -> list[tuple[RunRow, float]]:
    """The physical runs to explain with their gap, failed ones first, then the largest gap."""
    ideal = {(r.id.scenario, r.id.planner, r.id.repeat): r for r in rows
             if r.id.fidelity.backend == REFERENCE and r.status == "ok" and r.run_dir}
    chosen = []
    for row in rows:
        if row.id.fidelity.backend == REFERENCE or row.status != "ok" or not row.run_dir:
            continue
        failed = spec.failed and row.outcome not in (None, Outcome.GOAL_REACHED)
        twin = ideal.get((row.id.scenario, row.id.planner, row.id.repeat)) or \
            ideal.get((row.id.scenario, row.id.planner, None))
        gap = _gap(root, row, twin) if spec.gap_above_m is not None and twin is not None else math.nan
        if failed or (spec.gap_above_m is not None and math.isfinite(gap) and gap > spec.gap_above_m):
            chosen.append((row, gap))
    return sorted(chosen, key=lambda c: (c[0].outcome == Outcome.GOAL_REACHED,
                                         -(c[1] if math.isfinite(c[1]) else 0.0), c[0].id.key))


def _gap(root: Path, row: RunRow, ideal: RunRow) -> float:
    """max |d| of ``row``'s run against ``ideal``'s, by arc length (`compare_histories`)."""
    ideal_dir = root / str(ideal.run_dir)
    scenario, problems = load_scenario(ideal_dir / "driven.xml")
    comparisons = compare_histories(read_run(ideal_dir).history, read_run(root / str(row.run_dir)).history,
                                    scenario, problems)
    gaps = [c.lateral_displacement.max for c in comparisons if math.isfinite(c.lateral_displacement.max)]
    return max(gaps, default=math.nan)
