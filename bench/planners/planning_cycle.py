"""Planning-cycle time of the Frenet planner, split by phase.

A closed-loop ideal run (the vehicle stands on its plan at t + dt, replanning every step) on the
paper's curve road, r = 10 m and r = 50 m, 90 degrees, from standstill, with the default
settings (about 800 samples per cycle). Prints median / p95 / max cycle time and the median of
each phase: projection (initial state into the Frenet frame), sampling (matrix + polynomials in
frenetix), evaluation (frenetix: coordinates, feasibility, costs, sort), collision (our road,
traffic and limit checks in cost order), conversion (to a centre-convention Trajectory).

    .venv/bin/python bench/planners/planning_cycle.py            # sequential evaluation in the core
    .venv/bin/python bench/planners/planning_cycle.py --concurrent
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from commonroad.scenario.state import CustomState

from simgap.planning.frenet import PHASES, FrenetPlanner
from simgap.planning.protocol import PlannerSetup
from simgap.planning.protocol import World
from simgap.planning.settings import FrenetSettings
from simgap.scenario import build_scenario
from simgap.trajectory import State
from simgap.vehicles import load_vehicle
from pathlib import Path
from simgap.files import BenchmarkResults


def curve_scenario(radius: float, angle: float):
    """(lanelet network, planning problem, dt) of the paper's curve road."""
    built = build_scenario("curve", {"radius": radius, "angle": angle})
    problem = next(iter(built.problems.planning_problem_dict.values()))
    return built.scenario.lanelet_network, problem, float(built.scenario.dt)


def closed_loop(radius: float, angle: float, settings: FrenetSettings, max_steps: int = 600) -> dict:
    network, problem, dt = curve_scenario(radius, angle)
    vehicle = load_vehicle("sedan")
    t0 = time.perf_counter()
    planner = FrenetPlanner(PlannerSetup.for_problem(problem, vehicle, network), settings)
    build_s = time.perf_counter() - t0
    ini = problem.initial_state
    state = State(0.0, float(ini.position[0]), float(ini.position[1]), float(ini.orientation), float(ini.velocity))
    world = World(network, problem.goal, dt)
    totals, phases, checked, samples, outcome = [], {p: [] for p in PHASES}, [], [], "timeout"
    for k in range(max_steps):
        t = k * dt
        start = time.perf_counter()
        plan = planner.plan(state, t, world)
        totals.append(time.perf_counter() - start)
        cycle = planner.last_cycle
        for p in PHASES:
            phases[p].append(cycle.timings[p])
        checked.append(cycle.checked)
        samples.append(cycle.samples)
        if plan is None:
            outcome = f"no plan at t = {t:.1f} s ({cycle.outcome})"
            break
        state = plan.at(t + dt).replace(t=t + dt)
        if problem.goal.is_reached(CustomState(position=state.position, orientation=state.yaw, velocity=state.v,
                                               time_step=k + 1)):
            outcome = f"goal at t = {state.t:.1f} s"
            break
    ms = 1e3 * np.array(totals)
    return {"build_s": build_s, "cycles": len(ms), "median": np.median(ms), "p95": np.percentile(ms, 95),
            "max": ms.max(), "phases": {p: 1e3 * float(np.median(v)) for p, v in phases.items()},
            "checked": float(np.median(checked)), "samples": float(np.median(samples)), "outcome": outcome}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--concurrent", action="store_true", help="evaluate samples on all cores (frenetix)")
    parser.add_argument("--repeat", type=int, default=1, help="runs per road (cycle times pooled by median)")
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="also write what is printed, with commit, date, machine and load, to this results file")
    args = parser.parse_args()
    results_file = BenchmarkResults(tee=args.json)
    settings = FrenetSettings(concurrent_evaluation=args.concurrent)
    print(f"Frenet planner, {settings.sampling.samples_per_cycle} samples/cycle (default), "
          f"{'concurrent' if args.concurrent else 'sequential'} evaluation, replanning every step\n")
    head = f"{'road':<14}{'cycles':>7}{'median':>8}{'p95':>7}{'max':>7}  " + "".join(f"{p:>11}" for p in PHASES)
    print(head + f"{'checked':>9}  outcome")
    print(" " * 14 + " " * 7 + f"{'[ms]':>8}{'[ms]':>7}{'[ms]':>7}  " + "".join(f"{'[ms]':>11}" for _ in PHASES))
    for radius, angle in ((10.0, 90.0), (50.0, 90.0)):
        for _ in range(args.repeat):
            r = closed_loop(radius, angle, settings)
            print(f"r={radius:>3.0f} g={angle:>3.0f}  {r['cycles']:>7}{r['median']:>8.2f}{r['p95']:>7.2f}"
                  f"{r['max']:>7.2f}  " + "".join(f"{r['phases'][p]:>11.2f}" for p in PHASES)
                  + f"{r['checked']:>9.0f}  {r['outcome']} (planner built in {r['build_s']:.2f} s)")
    if args.json:
        results_file.write(args.json, {"arguments": vars(args)})


if __name__ == "__main__":
    main()
