"""Where the plan and the car part, per car, in one or more experiment directories (for example the
paper study or the demo run before and after a change of the physical world's defaults): max |d|
against the ideal run (lateral displacement by arc length), the drop of the closed-loop score
from the ideal run, and the runs whose goal the car missed, with the reason.

Usage: python bench/paper/realism_gaps.py DIR [DIR ...] [--json results.json]
(an experiment directory: `simgap experiment run ... --out DIR`, `bench/paper/paper_study.py --out DIR`,
`simgap demo --out DIR`). Prints one table per directory; no pass/fail.
"""

from __future__ import annotations

import argparse
from collections import defaultdict
from pathlib import Path

import numpy as np

from simgap.cosim import Outcome
from simgap.files import BenchmarkResults
from simgap.report.collection import collect


def gaps(root: Path) -> dict[str, dict]:
    """Per fidelity label: every run's max |d| and score drop, and the missed goals."""
    by_fidelity: dict[str, dict] = defaultdict(lambda: {"max_d": [], "score_drop": [], "missed": []})
    for group in collect(root):
        reference = group.reference
        if reference is None:
            continue
        ideal_score = reference.run.evaluation.agents[0].score
        for fidelity, entry in group.runs.items():
            if entry is reference:
                continue
            row = by_fidelity[fidelity]
            row["max_d"] += [c.lateral_displacement.max for c in group.comparisons.get(fidelity, [])]
            agent = entry.run.agents[0]
            score, outcome = agent.evaluation.score, agent.history.outcome
            if ideal_score is not None and score is not None:
                row["score_drop"].append(ideal_score - score)
            if outcome != Outcome.GOAL_REACHED:
                event = next((e for e in entry.run.history.events if e.kind == outcome), None)
                row["missed"].append({"scenario": group.scenario_id, "outcome": str(outcome),
                                      "detail": event.detail if event else ""})
    return dict(by_fidelity)


def summary(values: list[float]) -> str:
    if not values:
        return "—"
    v = np.asarray(values, dtype=float)
    return f"{np.median(v):.3f} / {np.percentile(v, 90):.3f} / {v.max():.3f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dirs", nargs="+", type=Path)
    parser.add_argument("--json", help="write the figures here")
    args = parser.parse_args()
    results_file = BenchmarkResults()
    results = {}
    for root in args.dirs:
        table = gaps(root)
        results[str(root)] = table
        print(f"\n{root}")
        print(f"{'fidelity':28} {'runs':>5} {'max |d| [m] median / p90 / max':>32} {'score drop median / p90 / max':>31}"
              f" {'drop > 0':>8} {'missed':>6}")
        for fidelity, row in sorted(table.items()):
            dropped = sum(1 for d in row["score_drop"] if d > 1e-9)
            print(f"{fidelity:28} {len(row['max_d']):5d} {summary(row['max_d']):>32} {summary(row['score_drop']):>31}"
                  f" {dropped:8d} {len(row['missed']):6d}")
            for miss in row["missed"]:
                print(f"    {miss['scenario']}: {miss['outcome']} ({miss['detail']})")
    if args.json:
        results_file.write(args.json, results)


if __name__ == "__main__":
    main()
