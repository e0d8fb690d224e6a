"""The curve heatmap study: `curve` at radius {10, 20, 30, 50, 75, 100} m x angle {0, 30, ..., 180}
deg (42 scenarios) in the ideal world and MuJoCo with the sedan, plus suv and city on the first
eight scenarios of the grid (radius 10 m at every angle, and radius 20 m at 0 deg): 100 runs as
three experiments — then the report, the heatmap of max |d| and the per-vehicle gaps of one
scenario, from the report's collection.

Usage: python bench/paper/curve_study.py [--out DIR] [--workers N]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import yaml

from simgap.experiment.runner import run_experiment
from simgap.files import BenchmarkResults
from simgap.report.collection import collect
from simgap.report.site import build_report

RADII = [10, 20, 30, 50, 75, 100]
ANGLES = [0, 30, 60, 90, 120, 150, 180]
SPECS = [
    {"name": "curve-heatmap", "logical": "curve",
     "parameters": {"radius": {"values": RADII}, "angle": {"values": ANGLES}},
     "fidelities": [{"backend": "ideal"}, {"backend": "mujoco", "vehicles": ["sedan"]}]},
    {"name": "curve-heatmap-vehicles", "logical": "curve",
     "parameters": {"radius": {"values": [10]}, "angle": {"values": ANGLES}},
     "fidelities": [{"backend": "mujoco", "vehicles": ["suv", "city"]}]},
    {"name": "curve-heatmap-vehicles-20", "logical": "curve",
     "parameters": {"radius": {"values": [20]}, "angle": {"values": [0]}},
     "fidelities": [{"backend": "mujoco", "vehicles": ["suv", "city"]}]},
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("curve-study"))
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="also write what is printed, with commit, date, machine and load, to this results file")
    args = parser.parse_args()
    results_file = BenchmarkResults(tee=args.json)
    start = time.perf_counter()
    total = 0
    with tempfile.TemporaryDirectory() as tmp:
        for spec in SPECS:
            path = Path(tmp) / f"{spec['name']}.yaml"
            path.write_text(yaml.safe_dump(spec))
            result = run_experiment(path, args.out / spec["name"], args.workers)
            total += result.total
            print(f"{spec['name']}: {result.total} runs, {result.failed} failed, {result.wall_time_s:.1f} s")
    print(f"{total} runs in {time.perf_counter() - start:.1f} s with {args.workers} workers")
    t0 = time.perf_counter()
    index = build_report(args.out, args.out / "report")
    print(f"report of {total} runs: {time.perf_counter() - t0:.1f} s -> {index}")

    groups = {(g.parameters["radius"], g.parameters["angle"]): g for g in collect(args.out)}
    print("\nmax |d| [m] of mujoco/sedan against ideal (rows: radius [m], columns: angle [deg])")
    print("radius " + " ".join(f"{a:>6}" for a in ANGLES))
    for r in RADII:
        cells = []
        for a in ANGLES:
            comps = groups[(r, a)].comparisons.get("mujoco/sedan", [])
            cells.append(f"{max(c.lateral_displacement.max for c in comps):>6.3f}" if comps else "     —")
        print(f"{r:>6} " + " ".join(cells))
    focus = groups[(10, 90)]
    print(f"\n{focus.scenario_id}: each vehicle against the ideal run")
    print(f"{'fidelity':<14} {'max |d|':>8} {'rms |d|':>8} {'max |dv|':>9} {'rms |dv|':>9} {'tracking lat max':>16}")
    for fidelity, comps in sorted(focus.comparisons.items()):
        c = comps[0]
        print(f"{fidelity:<14} {c.lateral_displacement.max:>8.3f} {c.lateral_displacement.rms:>8.3f} "
              f"{c.velocity_error.max:>9.3f} {c.velocity_error.rms:>9.3f} {c.tracking_lateral_b.max:>16.3f}")
    if args.json:
        results_file.write(args.json, {"arguments": vars(args)})


if __name__ == "__main__":
    main()
