"""Tracking a circle: steady-state lateral error of every controller on the single-track plant.

Each controller gets receding 3 s windows of a constant-speed circle (a new window every 0.1 s,
as from a planner), runs at its rate, and drives CommonRoad's single-track model (parameter
set 2, BMW 320i; RK4 at 1 kHz, steering servo 0.05 s with the 0.4 rad/s rate limit,
powertrain lag 0.1 s). The vehicle starts on the circle with the kinematic steering angle, so
the first seconds are a transient (tyre slip building up); "steady" is from --settle on.

Usage: python bench/vehicles/controller_circle.py [--radius 50] [--speeds 10 15 20] [--duration 25]
       [--settle 5] [--rate 100] [--controllers pure_pursuit stanley lqr] [--vehicle sedan]
       [--set lateral_integral_gain=0 --set speed.kp=1.0]   (gain overrides, all controllers)
Prints a table (lateral error of the vehicle centre from the circle, m); no pass/fail.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from simgap.control import controller_names, make_controller, manoeuvres
from simgap.files import BenchmarkResults
from simgap.sim.dynamic import SingleTrackPlant, track_plans
from simgap.vehicles import load_vehicle


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--radius", type=float, default=50.0)
    parser.add_argument("--speeds", type=float, nargs="+", default=[10.0, 15.0, 20.0])
    parser.add_argument("--duration", type=float, default=25.0)
    parser.add_argument("--settle", type=float, default=5.0)
    parser.add_argument("--rate", type=float, default=100.0, help="controller rate [Hz]")
    parser.add_argument("--horizon", type=float, default=3.0, help="plan length [s]")
    parser.add_argument("--controllers", nargs="+", default=controller_names())
    parser.add_argument("--vehicle", default="sedan")
    parser.add_argument("--set", action="append", default=[], metavar="GAIN=VALUE",
                        help="override a gain of every controller (dotted for speed.*)")
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="also write what is printed, with commit, date, machine and load, to this results file")
    args = parser.parse_args()
    results_file = BenchmarkResults(tee=args.json)
    overrides: dict = {}
    for item in args.set:
        key, _, value = item.partition("=")
        *parents, leaf = key.split(".")
        node = overrides
        for part in parents:
            node = node.setdefault(part, {})
        node[leaf] = float(value)

    vehicle = load_vehicle(args.vehicle)
    print(f"circle R = {args.radius:g} m, {args.duration:g} s, steady from {args.settle:g} s, "
          f"controller {args.rate:g} Hz, plans {args.horizon:g} s every 0.1 s, "
          f"vehicle {vehicle.name}, plant: CommonRoad ST, parameter set 2"
          + (f", overrides {overrides}" if overrides else ""))
    header = (f"{'controller':<13} {'v [m/s]':>7} {'a_y':>5} {'rms':>7} {'max':>7} {'mean':>7} "
              f"{'max all':>8} {'|dv| max':>8} {'wall [s]':>8} {'x real time':>11}")
    print(header)
    print("-" * len(header))
    for name in args.controllers:
        for speed in args.speeds:
            man = manoeuvres.circle(vehicle, args.radius, speed, duration=args.duration)
            controller = make_controller(name, vehicle, rate_hz=args.rate,
                                         overrides=overrides or None)
            plant = SingleTrackPlant(vehicle)
            start = time.perf_counter()
            states = track_plans(plant, controller, lambda t, s, man=man: man.plan(t, args.horizon),
                                 man.initial_state(), man.duration)
            wall = time.perf_counter() - start
            t = np.array([s.t for s in states])
            v = np.array([s.v for s in states])
            lat = np.array([man.lateral_error(s.x, s.y) for s in states])
            steady = t >= args.settle
            print(f"{name:<13} {speed:>7.1f} {speed ** 2 / args.radius:>5.1f} "
                  f"{np.sqrt(np.mean(lat[steady] ** 2)):>7.3f} {np.max(np.abs(lat[steady])):>7.3f} "
                  f"{np.mean(lat[steady]):>+7.3f} {np.max(np.abs(lat)):>8.3f} "
                  f"{np.max(np.abs(v[steady] - speed)):>8.3f} {wall:>8.2f} "
                  f"{args.duration / wall:>11.1f}")
    if args.json:
        results_file.write(args.json, {"arguments": vars(args)})


if __name__ == "__main__":
    main()
