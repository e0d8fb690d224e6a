"""The paper's curve study across fidelities: a grid of `curve` scenarios, each run in the ideal
world and in MuJoCo, then the HTML report — with the time of every phase.

Default grid: radius {10, 20, 30, 50, 75, 100} m x angle {0, 30, ..., 180} deg (42 scenarios),
ideal and mujoco/sedan for all, plus mujoco/suv and mujoco/city for the first --extra scenarios
(default 8, which makes 100 runs). Runs execute in --workers processes (default: the cores).

Usage: python bench/curve_study.py [--out DIR] [--workers N] [--extra 8] [--replan-every 1]
Prints run counts, wall times per phase, the heatmap of max |d| as a table, and per vehicle the
gaps of --focus (default radius 10, angle 90).
"""

from __future__ import annotations

import argparse
import os
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from simgap.cosim import CosimSettings
from simgap.experiment.single_run import RunRequest, execute
from simgap.report.collection import collect
from simgap.report.site import build_report
from simgap.scenario import build_scenario, write_scenario

RADII = [10, 20, 30, 50, 75, 100]
ANGLES = [0, 30, 60, 90, 120, 150, 180]


def _run(job: tuple[str, str, str, str, int]) -> tuple[str, float, str]:
    xml, backend, vehicle, run_dir, replan_every = job
    start = time.perf_counter()
    try:
        run = execute(RunRequest(scenario=Path(xml), backend=backend, vehicles=vehicle,
                                 cosim=CosimSettings(replan_every=replan_every)), Path(run_dir))
        outcome = run.agents[0].outcome
    except Exception as exc:     # recorded and reported; the study goes on
        outcome = f"failed: {exc}"
    return run_dir, time.perf_counter() - start, outcome


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("curve-study"))
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--extra", type=int, default=8)
    parser.add_argument("--replan-every", type=int, default=1)
    parser.add_argument("--focus", default="10,90")
    args = parser.parse_args()
    t0 = time.perf_counter()
    jobs = []
    for i, (radius, angle) in enumerate((r, a) for r in RADII for a in ANGLES):
        xml = write_scenario(build_scenario("curve", {"radius": radius, "angle": angle}), args.out / "scenarios",
                             preview=False)
        fidelities = [("ideal", "sedan"), ("mujoco", "sedan")]
        if i < args.extra or f"{radius},{angle}" == args.focus:
            fidelities += [("mujoco", "suv"), ("mujoco", "city")]
        for backend, vehicle in fidelities:
            label = "ideal" if backend == "ideal" else f"{backend}-{vehicle}"
            jobs.append((str(xml), backend, vehicle, str(args.out / "runs" / xml.stem / label), args.replan_every))
    t1 = time.perf_counter()
    with ProcessPoolExecutor(args.workers) as pool:
        results = list(pool.map(_run, jobs))
    t2 = time.perf_counter()
    failed = [r for r in results if r[2].startswith("failed")]
    outcomes: dict[str, int] = {}
    for _, _, outcome in results:
        outcomes[outcome if not outcome.startswith("failed") else "failed"] = outcomes.get(outcome, 0) + 1
    print(f"{len(jobs)} runs in {args.workers} processes: generation {t1 - t0:.1f} s, runs {t2 - t1:.1f} s "
          f"(per run: median {np.median([r[1] for r in results]):.2f} s, max {max(r[1] for r in results):.2f} s); "
          f"outcomes {outcomes}")
    for run_dir, _, outcome in failed:
        print(f"  {run_dir}: {outcome}")

    t3 = time.perf_counter()
    index = build_report(args.out / "runs", args.out / "report")
    t4 = time.perf_counter()
    print(f"report of {len(jobs)} runs: {t4 - t3:.1f} s -> {index}")

    groups = {(g.parameters["radius"], g.parameters["angle"]): g for g in collect(args.out / "runs")}
    print("\nmax |d| [m] of mujoco/sedan against ideal (rows: radius [m], columns: angle [deg])")
    print("radius " + " ".join(f"{a:>6}" for a in ANGLES))
    for r in RADII:
        cells = []
        for a in ANGLES:
            comps = groups[(r, a)].comparisons.get("mujoco/sedan", [])
            cells.append(f"{max(c.lateral_displacement.max for c in comps):>6.3f}" if comps else "     —")
        print(f"{r:>6} " + " ".join(cells))
    fr, fa = (float(x) for x in args.focus.split(","))
    focus = groups[(fr, fa)]
    print(f"\n{focus.scenario_id}: each vehicle against the ideal run")
    print(f"{'fidelity':<14} {'max |d|':>8} {'rms |d|':>8} {'max |dv|':>9} {'rms |dv|':>9} {'tracking lat max':>16}")
    for fidelity, comps in sorted(focus.comparisons.items()):
        c = comps[0]
        print(f"{fidelity:<14} {c.lateral_displacement.max:>8.3f} {c.lateral_displacement.rms:>8.3f} "
              f"{c.velocity_error.max:>9.3f} {c.velocity_error.rms:>9.3f} {c.tracking_lateral_b.max:>16.3f}")


if __name__ == "__main__":
    main()
