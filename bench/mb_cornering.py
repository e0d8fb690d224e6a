"""Steady-state cornering of CommonRoad's multi-body model (commonroad-vehicle-models, parameter
set 2, BMW 320i) on a circle: the reference the MuJoCo sedan is held against.

Method: the multi-body model (29 states, Pacejka tyres) is integrated with LSODA between driver
updates every 10 ms. The driver steers (steering-rate input, within the set's +-0.4 rad/s) to
hold a steering angle of feed-forward + PI on the distance from the circle + P on the heading
error, and sets the longitudinal acceleration input from a PI on speed. After 20 s the last
5 s are averaged. A speed is reported when the car held the circle (radius within 2 %); the sweep
stops at the first speed at which it could not.

Usage: python bench/mb_cornering.py [--radius 50] [--speeds 6 8 ... 24]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from scipy.integrate import solve_ivp
from vehiclemodels.init_mb import init_mb
from vehiclemodels.parameters_vehicle2 import parameters_vehicle2
from vehiclemodels.vehicle_dynamics_mb import vehicle_dynamics_mb

DRIVER_DT = 0.01
DURATION = 20.0
AVERAGE_LAST = 5.0


def _hold_circle(p, radius: float, speed: float) -> dict | None:
    wheelbase = p.a + p.b
    delta0 = math.atan(wheelbase / radius)
    x = np.array(init_mb([0.0, 0.0, delta0, speed, 0.0, speed / radius, 0.0], p), dtype=float)
    integral = 0.0
    rows = []
    for k in range(int(DURATION / DRIVER_DT)):
        px, py, delta, vx, yaw, r, vy = x[0], x[1], x[2], x[3], x[4], x[5], x[10]
        # the circle's centre is (0, radius); e > 0 outside the circle
        dx, dy = px, py - radius
        dist = math.hypot(dx, dy)
        e = dist - radius
        tangent = math.atan2(dy, dx) + math.pi / 2
        heading_error = math.atan2(math.sin(yaw - tangent), math.cos(yaw - tangent))
        integral += e * DRIVER_DT
        target = delta0 + 0.05 * e + 0.01 * integral - 0.5 * heading_error
        steer_rate = float(np.clip(4.0 * (target - delta), p.steering.v_min, p.steering.v_max))
        accel = float(np.clip(1.5 * (speed - vx), -p.longitudinal.a_max, p.longitudinal.a_max))
        sol = solve_ivp(lambda t, s: vehicle_dynamics_mb(s, [steer_rate, accel], p), (0.0, DRIVER_DT), x,
                        method="LSODA", rtol=1e-6, atol=1e-8)
        x = sol.y[:, -1]
        if not np.all(np.isfinite(x)) or abs(e) > 10.0:
            return None
        if (k + 1) * DRIVER_DT > DURATION - AVERAGE_LAST:
            rows.append((math.hypot(x[3], x[10]), x[5], x[2], math.atan2(x[10], x[3]), dist))
    v, r, delta, beta, dist = (float(np.mean(col)) for col in zip(*rows))
    if abs(dist - radius) > 0.02 * radius:
        return None
    return {"speed": speed, "lateral_acceleration": v * r, "steer": delta, "yaw_rate": r,
            "sideslip": beta, "radius": dist}


def mb_steady_state_cornering(radius: float = 50.0, speeds: list[float] | None = None) -> list[dict]:
    """Steady states on a circle of ``radius`` for each speed up to the first one not held."""
    p = parameters_vehicle2()
    rows = []
    for speed in speeds or [float(v) for v in np.arange(6.0, 26.0, 2.0)]:
        row = _hold_circle(p, radius, speed)
        if row is None:
            break
        rows.append(row)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--radius", type=float, default=50.0)
    parser.add_argument("--speeds", type=float, nargs="+", default=None)
    args = parser.parse_args()
    start = time.perf_counter()
    rows = mb_steady_state_cornering(args.radius, args.speeds)
    print(f"multi-body model, parameter set 2, R = {args.radius:g} m "
          f"(kinematic steer {math.degrees(math.atan(2.5789 / args.radius)):.3f} deg)")
    print(f"{'v [m/s]':>7} {'a_y [m/s^2]':>11} {'steer [deg]':>11} {'yaw rate':>8} {'sideslip [deg]':>14} {'R [m]':>6}")
    for r in rows:
        print(f"{r['speed']:>7.1f} {r['lateral_acceleration']:>11.2f} {math.degrees(r['steer']):>11.3f} "
              f"{r['yaw_rate']:>8.4f} {math.degrees(r['sideslip']):>14.3f} {r['radius']:>6.2f}")
    if len(rows) >= 2:
        lin = [r for r in rows if r["lateral_acceleration"] < 4.0] or rows[:2]
        a = np.array([r["lateral_acceleration"] for r in lin])
        d = np.degrees([r["steer"] for r in lin])
        gradient = np.polyfit(a, d, 1)[0] * 9.81 if len(lin) >= 2 else float("nan")
        print(f"understeer gradient (a_y < 4 m/s^2): {gradient:.2f} deg/g")
    print(f"[wall {time.perf_counter() - start:.1f} s]")


if __name__ == "__main__":
    main()
