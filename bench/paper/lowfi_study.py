"""Low-fidelity (ideal backend) study: the figures of the co-simulation issue.

1. Wall time of whole runs of `curve` at (10 m, 90°), (50 m, 90°), (100 m, 180°), from standstill
   and from 10 m/s, with the paper's planner settings (replanning every 3 steps) and every step.
2. The 78-scenario grid r ∈ {10, 20, 30, 50, 75, 100} × γ ∈ {−180, −150, …, 180}: how many reach
   the goal without collision or leaving the road, and the worst planned-path deviation from the
   lane centre.
3. A `t-junction` and an `intersection` run with three agents.

Usage: python bench/paper/lowfi_study.py [--skip-grid] [--out /tmp/simgap-lowfi]
Prints tables; no pass/fail.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from simgap.cosim import CosimSettings, History
from simgap.experiment.single_run import RunRequest, execute
from simgap.files import BenchmarkResults
from simgap.scenario import load_scenario
from simgap.scenario.road_frame import PathFrame


def generate(logical: str, out: Path, **params) -> list[Path]:
    cmd = [sys.executable, "-m", "simgap", "generate", logical, "--out", str(out), "--no-preview"]
    for k, v in params.items():
        cmd += ["--set", f"{k}={v}"]
    subprocess.run(cmd, check=True, capture_output=True)
    return sorted(out.glob("*.xml"))


def lane_centre_deviation(history: History, scenario_path: Path) -> float:
    """Largest distance of any planned position from the centre line of the lanelets it is on."""
    scenario, _ = load_scenario(scenario_path)
    centres = [PathFrame(l.center_vertices) for l in scenario.lanelet_network.lanelets]
    worst = 0.0
    for plans in history.plans.values():
        pts = np.vstack([np.column_stack([p.x, p.y]) for p in plans])
        dists = np.min(np.vstack([np.abs(c.project(pts)[1]) for c in centres]), axis=0)
        worst = max(worst, float(dists.max()))
    return worst


def timed_runs(out: Path) -> None:
    print("\n## Whole low-fidelity runs of `curve` (ideal backend)")
    print(f"{'r [m]':>6} {'γ [°]':>6} {'v0 [m/s]':>8} {'replan':>6} {'outcome':>14} {'t_goal [s]':>10} "
          f"{'cycles':>6} {'wall [s]':>8} {'planning [s]':>12}")
    for radius, angle in [(10, 90), (50, 90), (100, 180)]:
        for v0 in (0, 10):
            path = generate("curve", out / f"r{radius}a{angle}v{v0}", radius=radius, angle=angle,
                            initial_speed=v0)[0]
            for replan in (3, 1):
                record = execute(RunRequest(scenario=path, cosim=CosimSettings(replan_every=replan)))
                a = record.history.agents[0]
                cycles = sum(len(p) for p in record.history.plans.values())
                print(f"{radius:>6} {angle:>6} {v0:>8} {replan:>6} {a.outcome:>14} "
                      f"{(a.time_to_goal_s or float('nan')):>10.1f} {cycles:>6} {record.history.wall_time_s:>8.2f} "
                      f"{record.all_timings['planning']:>12.2f}")


def grid(out: Path) -> None:
    print("\n## The paper's grid (78 curve scenarios, standstill start, replanning every step)")
    paths = generate("curve", out / "grid")
    outcomes: dict[str, int] = {}
    worst, walls, failures = 0.0, [], []
    t0 = time.perf_counter()
    for path in paths:
        record = execute(RunRequest(scenario=path))
        walls.append(record.history.wall_time_s)
        o = record.history.agents[0].outcome
        outcomes[o] = outcomes.get(o, 0) + 1
        if o != "goal_reached":
            failures.append((path.stem, o))
        worst = max(worst, lane_centre_deviation(record.history, path))
    print(f"scenarios: {len(paths)}; outcomes: {outcomes}; total {time.perf_counter() - t0:.1f} s")
    print(f"run wall time: median {statistics.median(walls):.2f} s, max {max(walls):.2f} s")
    print(f"worst planned-path deviation from a lane centre: {worst:.2f} m")
    for name, o in failures:
        print(f"  not reached: {name}: {o}")


def junctions(out: Path) -> None:
    print("\n## Multi-agent junctions (3 agents)")
    for logical in ("t-junction", "intersection"):
        path = generate(logical, out / logical, agents=3)[0]
        record = execute(RunRequest(scenario=path))
        print(f"{logical}: wall {record.history.wall_time_s:.2f} s")
        for a in record.agents:
            ev = a.evaluation
            t_goal = "—" if ev.time_to_goal_s is None else f"{ev.time_to_goal_s:.1f} s"
            print(f"  agent {a.id}: {a.history.outcome:>13}  goal at {t_goal:>7}  "
                  f"min distance to other agents {ev.min_distance_to_traffic_m:.2f} m")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=Path("/tmp/simgap-lowfi"))
    ap.add_argument("--skip-grid", action="store_true")
    ap.add_argument("--json", type=Path, metavar="FILE",
                        help="also write what is printed, with commit, date, machine and load, to this results file")
    args = ap.parse_args()
    results_file = BenchmarkResults(tee=args.json)
    timed_runs(args.out)
    junctions(args.out)
    if not args.skip_grid:
        grid(args.out)
    if args.json:
        results_file.write(args.json, {"arguments": vars(args)})


if __name__ == "__main__":
    main()
