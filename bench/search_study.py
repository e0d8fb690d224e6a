"""Multi-fidelity search against the baselines, at equal wall-clock budget: the built-in
`curve-gaps` search (the curve road under friction, actuator delay, observation noise, bank and
grade; ideal → single-track screen → MuJoCo) with each strategy on the same budget and workers.

Prints, per strategy: runs per rung, high-fidelity failures, violated assumptions (pass ideal,
fail MuJoCo), distinct ones after de-duplication, CPU hours, distinct failures per CPU hour, the
ratio to grid search, the distinct scenarios (road, start, vehicle) among the violations, the
share of ideal passes that fail in MuJoCo; then the per-phase timings of a run in each rung (runs
whose ideal verdict was copied from another candidate's run are not counted).

Usage: python bench/search_study.py [--budget 20m] [--workers 2] [--out DIR] [--strategy NAME ...]
Re-running on the same DIR resumes (a larger --budget goes on searching).
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from simgap.experiment.search import parse_budget, run_search
from simgap.experiment.store import ResultsStore

PHASES = ("job_time_s", "wall_time_s", "time_planning_s", "time_control_s", "time_physics_s", "time_monitoring_s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spec", default="curve-gaps")
    parser.add_argument("--budget", default="20m")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("search-study"))
    parser.add_argument("--strategy", action="append", default=None)
    args = parser.parse_args()
    start = time.perf_counter()
    results = run_search(args.spec, args.out, parse_budget(args.budget), args.workers, strategies=args.strategy)
    print(f"budget {args.budget} per strategy, {args.workers} workers; total {time.perf_counter() - start:.0f} s "
          f"including the report\n")
    grid = next((r for r in results if r.name == "grid"), None)
    head = (f"{'strategy':15s} {'wall min':>8s} {'runs':>5s} {'ideal':>5s} {'screen':>6s} {'high':>5s} "
            f"{'high fail':>9s} {'violations':>10s} {'distinct':>8s} {'scenarios':>9s} {'CPU h':>6s} {'per CPU h':>9s} "
            f"{'x grid':>6s} {'ideal pass→fail':>15s}")
    print(head)
    print("-" * len(head))
    for r in results:
        rows = ResultsStore(args.out / r.name).rows()
        per_rung = [sum(1 for x in rows if int(x["rung"]) == k and "ideal_of" not in x) for k in range(3)]
        high = [x for x in rows if int(x["rung"]) == 2 and x["status"] == "ok"]
        ideal_failed = {int(x["candidate"]) for x in rows if int(x["rung"]) == 0 and x.get("failed")}
        passes = len([x for x in high if int(x["candidate"]) not in ideal_failed])
        share = 100.0 * r.violations / passes if passes else float("nan")
        ratio = r.distinct / grid.distinct if grid and grid.distinct else float("nan")
        print(f"{r.name:15s} {r.wall_s / 60:8.1f} {r.runs:5d} {per_rung[0]:5d} {per_rung[1]:6d} {per_rung[2]:5d} "
              f"{r.high_failures:9d} {r.violations:10d} {r.distinct:8d} {r.scenarios:9d} {r.cpu_s / 3600:6.2f} {r.per_cpu_hour:9.1f} "
              f"{ratio:6.2f} {share:14.1f}%")
    print("\nmedian seconds per run, by rung (all strategies)")
    rows = [x for r in results for x in ResultsStore(args.out / r.name).rows()
            if x["status"] == "ok" and "ideal_of" not in x]
    print(f"{'rung':8s} {'runs':>5s} " + " ".join(f"{p.removeprefix('time_').removesuffix('_s'):>10s}" for p in PHASES))
    for k, label in enumerate(("ideal", "screen", "high")):
        sel = [x for x in rows if int(x["rung"]) == k]
        if not sel:
            continue
        meds = [statistics.median(float(x.get(p) or 0.0) for x in sel) for p in PHASES]
        print(f"{label:8s} {len(sel):5d} " + " ".join(f"{m:10.2f}" for m in meds))
    print(f"\nreport: {args.out / 'report' / 'index.html'}")


if __name__ == "__main__":
    main()
