"""Planning-cycle time of the Frenet planner, split by phase.

A closed-loop ideal run (the vehicle stands on its plan at t + dt, replanning every step) on the
paper's curve road, r = 10 m and r = 50 m, 90 degrees, from standstill, with the default
settings (about 800 samples per cycle). Prints median / p95 / max cycle time and the median of
each phase: projection (initial state into the Frenet frame), sampling (matrix + polynomials in
frenetix), evaluation (frenetix: coordinates, feasibility, costs, sort), collision (our road,
traffic and limit checks in cost order), conversion (to a centre-convention Trajectory).

The core evaluates only the samples a cycle looks at and those that might come before them in
its cost order (`simgap.planning.cost_order`); ``--whole`` has it evaluate every sample first (as
before that), and both are timed when ``--compare`` is given: the columns ``evaluated`` (median
samples the core evaluated per cycle) and ``misses`` (samples whose cost came out below the floor:
0, or a bug) show the difference; the plans are the same.

    taskset -c 1 .venv/bin/python bench/planners/planning_cycle.py            # sequential evaluation in the core
    taskset -c 1 .venv/bin/python bench/planners/planning_cycle.py --compare  # lazy against whole, alternated
    .venv/bin/python bench/planners/planning_cycle.py --concurrent
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from commonroad.scenario.state import CustomState

import simgap.planning.frenet_evaluation as frenet_evaluation
from simgap.files import BenchmarkResults
from simgap.planning.frenet import PHASES, FrenetPlanner
from simgap.planning.protocol import PlannerSetup, World
from simgap.planning.settings import FrenetSettings
from simgap.scenario import build_scenario
from simgap.trajectory import State
from simgap.vehicles import load_vehicle


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
    evaluated, misses, states = [], 0, []
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
        evaluated.append(cycle.evaluated)
        misses += cycle.floor_misses
        if plan is None:
            outcome = f"no plan at t = {t:.1f} s ({cycle.outcome})"
            break
        state = plan.at(t + dt).replace(t=t + dt)
        states.append((state.x, state.y, state.v))
        if problem.goal.is_reached(CustomState(position=state.position, orientation=state.yaw, velocity=state.v,
                                               time_step=k + 1)):
            outcome = f"goal at t = {state.t:.1f} s"
            break
    ms = 1e3 * np.array(totals)
    return {"build_s": build_s, "cycles": len(ms), "median": np.median(ms), "p95": np.percentile(ms, 95),
            "max": ms.max(), "phases": {p: 1e3 * float(np.median(v)) for p, v in phases.items()},
            "checked": float(np.median(checked)), "samples": float(np.median(samples)),
            "evaluated": float(np.median(evaluated)), "misses": misses, "outcome": outcome,
            "states": np.array(states)}


def whole_evaluation(matrix, *args, **kwargs):
    """A floor of 0: the core evaluates every sample before the first is handed out."""
    return np.zeros(len(matrix))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--concurrent", action="store_true", help="evaluate samples on all cores (frenetix)")
    parser.add_argument("--repeat", type=int, default=1, help="runs per road (cycle times pooled by median)")
    parser.add_argument("--whole", action="store_true", help="the core evaluates every sample (no floor)")
    parser.add_argument("--compare", action="store_true",
                        help="time lazy and whole evaluation alternately, print their ratio and check the "
                             "driven states are the same")
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="also write what is printed, with commit, date, machine and load, to this results file")
    args = parser.parse_args()
    results_file = BenchmarkResults(tee=args.json)
    settings = FrenetSettings(concurrent_evaluation=args.concurrent)
    print(f"Frenet planner, {settings.sampling.samples_per_cycle} samples/cycle (default), "
          f"{'concurrent' if args.concurrent else 'sequential'} evaluation, replanning every step\n")
    head = f"{'road':<14}{'mode':<7}{'cycles':>7}{'median':>8}{'p95':>7}{'max':>7}  " \
        + "".join(f"{p:>11}" for p in PHASES)
    print(head + f"{'checked':>9}{'evaluated':>10}{'misses':>7}  outcome")
    print(" " * 21 + " " * 7 + f"{'[ms]':>8}{'[ms]':>7}{'[ms]':>7}  " + "".join(f"{'[ms]':>11}" for _ in PHASES))
    modes = ("lazy", "whole") if args.compare else ("whole",) if args.whole else ("lazy",)
    floor = frenet_evaluation.cost_floor
    for radius, angle in ((10.0, 90.0), (50.0, 90.0)):
        medians: dict[str, list[float]] = {m: [] for m in modes}
        driven: dict[str, np.ndarray] = {}
        for _ in range(args.repeat):
            for mode in modes:
                frenet_evaluation.cost_floor = floor if mode == "lazy" else whole_evaluation
                r = closed_loop(radius, angle, settings)
                medians[mode].append(r["median"])
                driven[mode] = r["states"]
                print(f"r={radius:>3.0f} g={angle:>3.0f}  {mode:<7}{r['cycles']:>7}{r['median']:>8.2f}{r['p95']:>7.2f}"
                      f"{r['max']:>7.2f}  " + "".join(f"{r['phases'][p]:>11.2f}" for p in PHASES)
                      + f"{r['checked']:>9.0f}{r['evaluated']:>10.0f}{r['misses']:>7}  {r['outcome']} "
                      f"(planner built in {r['build_s']:.2f} s)")
        frenet_evaluation.cost_floor = floor
        if args.compare:
            lazy, whole = float(np.median(medians["lazy"])), float(np.median(medians["whole"]))
            same = driven["lazy"].shape == driven["whole"].shape and bool((driven["lazy"] == driven["whole"]).all())
            print(f"r={radius:>3.0f} g={angle:>3.0f}  lazy/whole median cycle {lazy:.2f}/{whole:.2f} ms = "
                  f"{lazy / whole:.2f}; driven states {'identical' if same else 'DIFFERENT'}")
    if args.json:
        results_file.write(args.json, {"arguments": vars(args)})


if __name__ == "__main__":
    main()
