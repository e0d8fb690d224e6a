"""Steady-state cornering of CommonRoad's multi-body model (parameter set 2, BMW 320i) on a
circle, held by a dedicated constant-radius driver rather than a tracking controller: a
controller-independent check of the reference `bench/vehicles/vehicle_dynamics.py` compares the sedan with.

Method (`simgap.sim.multibody`): the model is stepped every 10 ms; the driver holds a steering
angle of feed-forward + PI on the distance from the circle + P on the heading error (the model's
steering rate stays within +-0.4 rad/s) and sets the pedals from a P on speed. After 20 s the last
5 s are averaged. A speed is reported when the car held the circle (radius within 2 %); the sweep
stops at the first speed at which it could not.

Usage: python bench/vehicles/mb_cornering.py [--radius 50] [--speeds 6 8 ... 24]
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

from simgap.files import BenchmarkResults
from simgap.sim.multibody import NAME, MultiBodyPlant, hold_circle


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--radius", type=float, default=50.0)
    parser.add_argument("--speeds", type=float, nargs="+", default=[float(v) for v in np.arange(6.0, 26.0, 2.0)])
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="also write what is printed, with commit, date, machine and load, to this results file")
    args = parser.parse_args()
    results_file = BenchmarkResults(tee=args.json)
    start = time.perf_counter()
    plant = MultiBodyPlant()
    wheelbase = plant.vehicle.wheelbase
    rows = []
    for speed in args.speeds:
        row = hold_circle(plant, plant.vehicle, args.radius, speed)
        if row is None:
            break
        rows.append(row)
    print(f"{NAME}, R = {args.radius:g} m (kinematic steer {math.degrees(math.atan(wheelbase / args.radius)):.3f} deg)")
    print(f"{'v [m/s]':>7} {'a_y [m/s^2]':>11} {'steer [deg]':>11} {'yaw rate':>8} {'sideslip [deg]':>14} {'R [m]':>6}")
    for r in rows:
        print(f"{r.speed:>7.1f} {r.lateral_acceleration:>11.2f} {math.degrees(r.steer):>11.3f} "
              f"{r.yaw_rate:>8.4f} {math.degrees(r.sideslip):>14.3f} {r.radius:>6.2f}")
    linear = [r for r in rows if r.lateral_acceleration < 4.0]
    if len(linear) >= 2:
        gradient = np.polyfit([r.lateral_acceleration for r in linear], np.degrees([r.steer for r in linear]), 1)[0]
        print(f"understeer gradient (a_y < 4 m/s^2): {gradient * 9.81:.2f} deg/g")
    print(f"[wall {time.perf_counter() - start:.1f} s]")
    if args.json:
        results_file.write(args.json, {"arguments": vars(args),
                                       "rows": [vars(r) for r in rows]})


if __name__ == "__main__":
    main()
