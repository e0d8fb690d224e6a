"""Full high-fidelity co-simulations of `curve`: wall time against the ideal backend, measured back
to back, and the lateral displacement between the ideal and the MuJoCo run per road section.

For each (radius, angle) and vehicle: the ideal run, then the MuJoCo run of the same scenario,
same planner settings (replanning every step, 770 samples), same seed. The wall time is the
loop's (planning + execution + monitoring, without writing files). Lateral displacement is
|d_mujoco - d_ideal| by arc length along the route's centre line, per road section
(straight / curve), as `simgap compare` computes it.

Usage: python bench/paper/hifi_study.py [--curves 50,90 10,90] [--vehicles sedan suv city]
       [--controller pure_pursuit] [--replan-every 1] [--repeat 1]
Prints a table; no pass/fail.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
from pathlib import Path

import mujoco

from simgap.cosim import CosimSettings
from simgap.evaluate.compare import compare_histories
from simgap.experiment.single_run import RunRequest, execute
from simgap.files import BenchmarkResults
from simgap.scenario import build_scenario, load_scenario, read_sidecar, write_scenario
from simgap.vehicles import vehicle_names


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--curves", nargs="+", default=["50,90", "10,90"], help="RADIUS,ANGLE")
    parser.add_argument("--vehicles", nargs="+", default=vehicle_names())
    parser.add_argument("--controller", default="pure_pursuit")
    parser.add_argument("--replan-every", type=int, default=1)
    parser.add_argument("--repeat", type=int, default=1, help="repeat each pair, report the median")
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="also write what is printed, with commit, date, machine and load, to this results file")
    args = parser.parse_args()
    results_file = BenchmarkResults(tee=args.json)
    cosim = CosimSettings(replan_every=args.replan_every)
    print(f"mujoco {mujoco.__version__}; controller {args.controller}; replanning every "
          f"{args.replan_every} step(s); wall = the loop's time (no file writing)")
    header = (f"{'curve':<10} {'vehicle':<6} {'outcome':<13} {'ideal [s]':>9} {'mujoco [s]':>10} {'ratio':>5} "
              f"{'plan/exec/phys/ctrl [s]':>24} {'d all rms/max':>14} {'d straight max':>14} {'d curve max':>11}")
    print(header)
    print("-" * len(header))
    with tempfile.TemporaryDirectory() as tmp:
        for spec in args.curves:
            radius, angle = (float(x) for x in spec.split(","))
            xml = write_scenario(build_scenario("curve", {"radius": radius, "angle": angle}), Path(tmp), preview=False)
            scenario, problems = load_scenario(xml)
            sections = read_sidecar(xml).sections
            for vehicle in args.vehicles:
                ideal_walls, hifi_walls = [], []
                for _ in range(args.repeat):
                    ideal = execute(RunRequest(scenario=xml, backend="ideal", vehicles=vehicle, cosim=cosim))
                    hifi = execute(RunRequest(scenario=xml, backend="mujoco", vehicles=vehicle, cosim=cosim,
                                              backend_settings={"controller": args.controller}))
                    ideal_walls.append(ideal.history.wall_time_s)
                    hifi_walls.append(hifi.history.wall_time_s)
                wi, wh = statistics.median(ideal_walls), statistics.median(hifi_walls)
                cmp = compare_histories(ideal.history, hifi.history, scenario, problems, sections)[0]
                by = cmp.by_section
                tm = hifi.all_timings
                phases = f"{tm['planning']:.2f}/{tm['execution']:.2f}/{tm['physics']:.2f}/{tm['control']:.2f}"
                straight = by.get("straight")
                curve = by.get("curve")
                print(f"{radius:g} m {angle:g}°".ljust(10) + f" {vehicle:<6} {hifi.history.agents[0].outcome:<13} {wi:>9.2f} "
                      f"{wh:>10.2f} {wh / wi:>5.2f} {phases:>24} "
                      f"{cmp.lateral_displacement.rms:>6.3f}/{cmp.lateral_displacement.max:<7.3f}"
                      f"{straight.max if straight else float('nan'):>14.3f} {curve.max if curve else float('nan'):>11.3f}")
    if args.json:
        results_file.write(args.json, {"arguments": vars(args)})


if __name__ == "__main__":
    main()
