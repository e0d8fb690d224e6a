"""The MuJoCo cars without the planner: tracking, braking, cornering limit, real-time factor.

Sections (all on an open, flat proving ground, road friction 1.0 x each tyre's):

* tracking — each vehicle and controller follows receding 3 s windows of a constant-speed circle
  (R = 50 m) at 10, 15, 20 m/s; lateral error of the centre from the circle after 5 s (steady).
* braking — from 100 km/h, full brake held (no ABS), distance to standstill.
* cornering — speed sweep on the R = 50 m circle (pure pursuit); per speed the steady steering
  angle, yaw rate and lateral acceleration; the largest lateral acceleration held with the
  car still on its circle (lateral error < 0.5 m) is the steady limit. For the sedan the same
  sweep on CommonRoad's multi-body model (parameter set 2, `bench/mb_cornering.py`) is printed
  beside it, with the gap.
* realtime — physics + control of one and of four cars (no planner): simulated / wall time.

Usage: python bench/mujoco_vehicles.py [--sections tracking braking cornering realtime]
       [--vehicles sedan suv city] [--controllers pure_pursuit stanley lqr]
Prints tables and per-phase wall times; no pass/fail.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import mujoco
import numpy as np

from simgap.control import controller_names, make_controller, manoeuvres
from simgap.control.protocol import Command
from simgap.sim.dynamic import track_plans
from simgap.sim.mujoco import MujocoBackend
from simgap.sim.mujoco.plant import MujocoPlant, proving_ground
from simgap.sim.protocol import Agent, PhysicsDiverged
from simgap.trajectory import State
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


def braking(vehicles) -> None:
    print("\n## braking from 100 km/h, full brake held, dry road")
    print(f"{'vehicle':<7} {'distance [m]':>12} {'time [s]':>8} {'mean decel [m/s^2]':>18} {'mu v^2/2g [m]':>13}")
    v0 = 100.0 / 3.6
    for vname in vehicles:
        vehicle = load_vehicle(vname)
        plant = MujocoPlant(vehicle)
        state = plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=v0))
        # settle on the suspension for 0.5 s, coasting, then brake
        for _ in range(50):
            state = plant.step(Command(0.0, 0.0, 0.0), 0.01)
        x0, t0, v_start = state.x, state.t, state.v
        while state.v > 0.05 and state.t < t0 + 20.0:
            state = plant.step(Command(0.0, 0.0, 1.0), 0.01)
        dist, dur = state.x - x0, state.t - t0
        mu = vehicle.physics.tyre_friction
        print(f"{vname:<7} {dist:>12.1f} {dur:>8.2f} {v_start / dur:>18.2f} {v_start ** 2 / (2 * mu * 9.81):>13.1f}")


def cornering_sweep(vehicle, speeds) -> list[dict]:
    rows = []
    for speed in speeds:
        states, lateral = circle_drive(vehicle, "pure_pursuit", speed, duration=20.0)
        if states is None:
            rows.append({"speed": speed, "lateral_acceleration": float("nan"), "steer": float("nan"),
                         "sideslip": float("nan"),
                         "yaw_rate": float("nan"), "lateral_error": float("inf"), "lost": lateral})
            continue
        t = np.array([s.t for s in states])
        steady = t >= 12.0
        yaw_rate = float(np.mean([s.yaw_rate for s, k in zip(states, steady) if k]))
        # sideslip at the centre: direction of travel (from successive positions) minus heading
        x, y, yaw = (np.array([getattr(s, f) for s in states]) for f in ("x", "y", "yaw"))
        travel = np.arctan2(np.diff(y), np.diff(x))
        slip = np.angle(np.exp(1j * (travel - yaw[:-1])))
        rows.append({"speed": speed, "lateral_acceleration": speed * yaw_rate,
                     "sideslip": float(np.mean(slip[steady[:-1]])),
                     "steer": float(np.mean([s.steer for s, k in zip(states, steady) if k])),
                     "yaw_rate": yaw_rate, "lateral_error": float(np.abs(lateral[steady]).max())})
    return rows


def cornering(vehicles) -> None:
    print(f"\n## steady cornering on R = {RADIUS:g} m (pure pursuit), speed sweep")
    speeds = [float(v) for v in np.arange(6.0, 26.0, 2.0)]
    mb = None
    if "sedan" in vehicles:
        sys.path.insert(0, str(Path(__file__).parent))
        from mb_cornering import mb_steady_state_cornering

        mb = mb_steady_state_cornering(RADIUS, speeds)
    for vname in vehicles:
        vehicle = load_vehicle(vname)
        rows = cornering_sweep(vehicle, speeds)
        held = [r for r in rows if r["lateral_error"] < 0.5]
        lost = [r["speed"] for r in rows if r["lateral_error"] >= 0.5]
        if held and lost:        # refine the limit by bisection between the last held and first lost speed
            lo, hi = max(r["speed"] for r in held), min(lost)
            for _ in range(3):
                mid = (lo + hi) / 2
                row = cornering_sweep(vehicle, [mid])[0]
                if row["lateral_error"] < 0.5:
                    lo = mid
                    held.append(row)
                else:
                    hi = mid
        limit = max(r["lateral_acceleration"] for r in held) if held else float("nan")
        print(f"\n{vname}: steady lateral-acceleration limit held on the circle: {limit:.2f} m/s^2 "
              f"(tyre friction {vehicle.physics.tyre_friction:g} -> mu g = {vehicle.physics.tyre_friction * 9.81:.2f})")
        header = f"{'v':>5} {'a_y':>6} {'steer [deg]':>11} {'yaw rate':>8} {'beta [deg]':>10} {'lat err':>7}"
        if vname == "sedan" and mb:
            header += (f" | {'MB a_y':>6} {'MB steer':>8} {'MB yaw r':>8} {'MB beta':>7} | {'d steer':>7} "
                       f"{'d yaw r':>7} {'d beta':>6}")
        print(header)
        mb_by_speed = {round(r["speed"], 3): r for r in (mb or [])}
        for r in rows:
            line = (f"{r['speed']:>5.1f} {r['lateral_acceleration']:>6.2f} {math.degrees(r['steer']):>11.3f} "
                    f"{r['yaw_rate']:>8.4f} {math.degrees(r['sideslip']):>10.3f} {r['lateral_error']:>7.3f}")
            m = mb_by_speed.get(round(r["speed"], 3)) if vname == "sedan" else None
            if m:
                line += (f" | {m['lateral_acceleration']:>6.2f} {math.degrees(m['steer']):>8.3f} {m['yaw_rate']:>8.4f}"
                         f" {math.degrees(m['sideslip']):>7.3f} | {math.degrees(r['steer'] - m['steer']):>+7.3f} "
                         f"{r['yaw_rate'] - m['yaw_rate']:>+7.4f} {math.degrees(r['sideslip'] - m['sideslip']):>+6.2f}")
            print(line)
        if vname == "sedan" and mb:
            print(f"MB model held the circle up to {mb[-1]['speed']:g} m/s "
                  f"({mb[-1]['lateral_acceleration']:.2f} m/s^2); above, it is reported as not held")


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
        backend = MujocoBackend(controller=controller)
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
    parser.add_argument("--sections", nargs="+", default=["tracking", "braking", "cornering", "realtime"])
    parser.add_argument("--vehicles", nargs="+", default=vehicle_names())
    parser.add_argument("--controllers", nargs="+", default=controller_names())
    args = parser.parse_args()
    print(f"mujoco {mujoco.__version__}")
    for section in args.sections:
        start = time.perf_counter()
        if section == "tracking":
            tracking(args.vehicles, args.controllers)
        elif section == "braking":
            braking(args.vehicles)
        elif section == "cornering":
            cornering(args.vehicles)
        elif section == "realtime":
            realtime("sedan", args.controllers[0])
        print(f"[{section}: {time.perf_counter() - start:.1f} s wall]")


if __name__ == "__main__":
    main()
