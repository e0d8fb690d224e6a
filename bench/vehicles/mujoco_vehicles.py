"""The MuJoCo cars without the planner: tracking and real-time factor.

Sections (all on an open, flat proving ground, road friction 1.0 x each tyre's):

* tracking — each vehicle and controller follows receding 3 s windows of a constant-speed circle
  (R = 50 m) at 10, 15, 20 m/s; lateral error of the centre from the circle after 5 s (steady).
* realtime — physics + control of one and of four cars (no planner): simulated / wall time.

Handling (steady circle, step steer, braking, double lane change, beside CommonRoad's multi-body
model) is `bench/vehicles/vehicle_dynamics.py`.

Usage: python bench/vehicles/mujoco_vehicles.py [--sections tracking realtime]
       [--vehicles sedan suv city] [--controllers pure_pursuit stanley lqr]
Prints tables and per-phase wall times; no pass/fail.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import mujoco
import numpy as np

from simgap.control import controller_names, make_controller, manoeuvres
from simgap.files import BenchmarkResults
from simgap.sim.dynamic import track_plans
from simgap.sim.mujoco import MujocoBackend
from simgap.sim.mujoco.plant import MujocoPlant, proving_ground
from simgap.sim.mujoco.settings import MujocoSettings
from simgap.sim.protocol import Agent, PhysicsDiverged
from simgap.vehicles import load_vehicle, vehicle_names

RADIUS = 50.0


def circle_drive(vehicle, controller: str, speed: float, duration: float = 25.0):
    """States and lateral errors on the circle; ``None, reason`` when the physics gave up (a car
    that rolled over)."""
    man = manoeuvres.circle(vehicle, RADIUS, speed, duration=duration)
    plant = MujocoPlant(vehicle)
    try:
        states = track_plans(plant, make_controller(controller, vehicle, 100.0),
                             lambda t, s: man.plan(t, 3.0), man.initial_state(), man.duration)
    except PhysicsDiverged as exc:
        return None, str(exc)
    lateral = np.array([man.lateral_error(s.x, s.y) for s in states])
    return states, lateral


def tracking(vehicles, controllers) -> None:
    print(f"\n## tracking: circle R = {RADIUS:g} m, steady from 5 s, controller 100 Hz, physics 500 Hz")
    print(f"{'vehicle':<7} {'controller':<13} {'v [m/s]':>7} {'a_y':>5} {'rms [m]':>8} {'max [m]':>8} "
          f"{'|dv| max':>8} {'x real time':>11}")
    for vname in vehicles:
        vehicle = load_vehicle(vname)
        for controller in controllers:
            for speed in (10.0, 15.0, 20.0):
                start = time.perf_counter()
                states, lateral = circle_drive(vehicle, controller, speed)
                wall = time.perf_counter() - start
                if states is None:
                    print(f"{vname:<7} {controller:<13} {speed:>7.0f} {speed ** 2 / RADIUS:>5.1f}  lost: {lateral}")
                    continue
                steady = np.array([s.t for s in states]) >= 5.0
                v = np.array([s.v for s in states])
                print(f"{vname:<7} {controller:<13} {speed:>7.0f} {speed ** 2 / RADIUS:>5.1f} "
                      f"{np.sqrt(np.mean(lateral[steady] ** 2)):>8.3f} {np.abs(lateral[steady]).max():>8.3f} "
                      f"{np.abs(v[steady] - speed).max():>8.3f} {25.0 / wall:>11.1f}")


def realtime(vehicle_name: str, controller: str) -> None:
    print("\n## real-time factor, physics 500 Hz + control 100 Hz, no planner (circle R = 50 m at 15 m/s)")
    vehicle = load_vehicle(vehicle_name)
    for n in (1, 4):
        mans = [manoeuvres.circle(vehicle, RADIUS, 15.0, duration=20.0) for _ in range(n)]
        offsets = [(200.0 * k, 0.0) for k in range(n)]
        agents = []
        for k, (man, (ox, oy)) in enumerate(zip(mans, offsets)):
            s = man.initial_state()
            agents.append(Agent(k + 1, vehicle, s.replace(x=s.x + ox, y=s.y + oy)))
        backend = MujocoBackend(MujocoSettings(controller=controller))
        backend.load(proving_ground(), agents)
        backend.reset()
        steps = int(20.0 / 0.1)
        start = time.perf_counter()
        for i in range(steps):
            plans = {}
            for k, man in enumerate(mans):
                plan = man.plan(i * 0.1, 3.0)
                plans[k + 1] = _shift(plan, *offsets[k])
            backend.step(plans)
        wall = time.perf_counter() - start
        tm = backend.timings
        print(f"{n} car(s): {20.0 / wall:6.1f}x real time (wall {wall:.2f} s for 20 s; control "
              f"{tm['control']:.2f} s, physics {tm['physics']:.2f} s, tyres {tm['tyres']:.2f} s = "
              f"{100 * tm['tyres'] / wall:.0f} % of the wall time)")


def _shift(plan, dx: float, dy: float):
    from simgap.trajectory import Trajectory

    cols = {f: getattr(plan, f) for f in ("t", "yaw", "v", "a", "yaw_rate", "steer")}
    return Trajectory(plan.dt, x=plan.x + dx, y=plan.y + dy, **cols)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sections", nargs="+", choices=["tracking", "realtime"], default=["tracking", "realtime"])
    parser.add_argument("--vehicles", nargs="+", default=vehicle_names())
    parser.add_argument("--controllers", nargs="+", default=controller_names())
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="also write what is printed, with commit, date, machine and load, to this results file")
    args = parser.parse_args()
    results_file = BenchmarkResults(tee=args.json)
    print(f"mujoco {mujoco.__version__}")
    for section in args.sections:
        start = time.perf_counter()
        if section == "tracking":
            tracking(args.vehicles, args.controllers)
        elif section == "realtime":
            realtime("sedan", args.controllers[0])
        print(f"[{section}: {time.perf_counter() - start:.1f} s wall]")
    if args.json:
        results_file.write(args.json, {"arguments": vars(args)})


if __name__ == "__main__":
    main()
