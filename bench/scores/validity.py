"""The KS feasibility check's fast path (`simgap.evaluate.feasibility`) against
commonroad-drivability-checker's own `trajectory_feasibility`, on saved runs: per run the two
verdicts (feasible, else the first infeasible time step), their times, and how many transitions the
fast path left to the library. Any verdict that differs is listed; the exit code is 1 then.

    .venv/bin/python bench/scores/validity.py RUNS_DIR [RUNS_DIR ...] [--limit N] [--json-out FILE]

RUNS_DIR: any folder holding run directories (``solution.xml`` beside ``run.json``), searched
recursively — an experiment's ``runs/``, a study's output.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from commonroad.common.solution import CommonRoadSolutionReader
from commonroad_dc.feasibility.feasibility_checker import trajectory_feasibility
from commonroad_dc.feasibility.vehicle_dynamics import VehicleDynamics

from simgap.evaluate.feasibility import ks_feasibility
from simgap.files import BenchmarkResults
from simgap.record import read_run


def _dt(run_dir: Path) -> float:
    return float(read_run(run_dir).history.dt)


def compare(run_dir: Path) -> list[dict]:
    solution = CommonRoadSolutionReader.open(str(run_dir / "solution.xml"))
    dt, rows = _dt(run_dir), []
    for pps in solution.planning_problem_solutions:
        dynamics = VehicleDynamics.from_model(pps.vehicle_model, pps.vehicle_type)
        clock = time.perf_counter()
        library, inputs = trajectory_feasibility(pps.trajectory, dynamics, dt)
        library_s = time.perf_counter() - clock
        library_at = None if library else inputs.state_list[-1].time_step
        clock = time.perf_counter()
        fast = ks_feasibility(pps.trajectory, dynamics, dt)
        fast_s = time.perf_counter() - clock
        rows.append({"run": str(run_dir), "agent": pps.planning_problem_id,
                     "transitions": len(pps.trajectory.state_list) - 1,
                     "library": [bool(library), library_at], "fast": [fast.feasible, fast.infeasible_from],
                     "library_checks": fast.library_checks, "library_s": library_s, "fast_s": fast_s})
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("roots", nargs="+", type=Path)
    parser.add_argument("--limit", type=int, default=None, help="at most this many runs (spread evenly)")
    parser.add_argument("--json-out", type=Path, default=None)
    args = parser.parse_args()
    results_file = BenchmarkResults()
    runs = sorted(p.parent for root in args.roots for p in root.rglob("solution.xml"))
    if args.limit and len(runs) > args.limit:
        runs = [runs[i] for i in np.linspace(0, len(runs) - 1, args.limit).round().astype(int)]
    rows = []
    for i, run_dir in enumerate(runs, 1):
        rows.extend(compare(run_dir))
        print(f"\r{i}/{len(runs)} runs", end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    differ = [r for r in rows if r["library"] != r["fast"]]
    transitions = sum(r["transitions"] for r in rows)
    checks = sum(r["library_checks"] for r in rows)
    library_s = np.array([r["library_s"] for r in rows])
    fast_s = np.array([r["fast_s"] for r in rows])
    infeasible = sum(not r["library"][0] for r in rows)
    print(f"{len(rows)} trajectories in {len(runs)} runs ({infeasible} infeasible by the library), "
          f"{transitions} transitions; the library checked {checks} of them ({100 * checks / max(transitions, 1):.1f} %)")
    print(f"per trajectory: library {np.median(library_s):.3f} s median ({library_s.mean():.3f} mean, "
          f"{library_s.max():.3f} max); fast path {np.median(fast_s):.4f} s median ({fast_s.mean():.4f} mean, "
          f"{fast_s.max():.3f} max); {library_s.sum() / max(fast_s.sum(), 1e-9):.1f}x less time")
    print(f"verdicts that differ: {len(differ)}")
    for r in differ:
        print(f"  {r['run']} agent {r['agent']}: library {r['library']}, fast {r['fast']}")
    if args.json_out:
        results_file.write(args.json_out, {
            "runs": len(runs), "trajectories": len(rows),
            "transitions": transitions, "library_checks": checks, "differ": differ,
            "library_s": {"median": float(np.median(library_s)), "mean": float(library_s.mean()),
                          "max": float(library_s.max())},
            "fast_s": {"median": float(np.median(fast_s)), "mean": float(fast_s.mean()), "max": float(fast_s.max())},
            "infeasible": infeasible})
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
