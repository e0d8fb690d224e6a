"""Reference manoeuvres for validating tracking controllers: steady circle, speed step, lane changes.

Each manoeuvre is a kinematically consistent reference motion given as a function of time. A
test or benchmark hands the controller receding windows of it (`Manoeuvre.plan`), as a planner
would, and measures the driven path against it (`Manoeuvre.lateral_error`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from simgap.control.planned_path import PlannedPath
from simgap.trajectory import DEFAULT_TIME_STEP_S, State, Trajectory


@dataclass(frozen=True)
class Manoeuvre:
    name: str
    duration: float
    state_at: Callable[[float], State]
    wheelbase: float
    rear_axle_to_center: float

    def plan(self, t0: float, horizon: float = 3.0, dt: float = DEFAULT_TIME_STEP_S) -> Trajectory:
        """The reference from ``t0`` over ``horizon`` seconds on a ``dt`` grid."""
        n = int(round(horizon / dt)) + 1
        return Trajectory.from_states([self.state_at(t0 + k * dt) for k in range(n)], dt)

    def initial_state(self) -> State:
        return self.state_at(0.0)

    @cached_property
    def reference_path(self) -> PlannedPath:
        """The whole reference path of the centre, sampled every 0.01 s (5 s beyond the end)."""
        plan = self.plan(0.0, self.duration + 5.0, 0.01)
        return PlannedPath(plan, 0.0, wheelbase=self.wheelbase,
                           rear_axle_to_center=self.rear_axle_to_center)

    def lateral_error(self, x: float, y: float) -> float:
        """Signed distance of a centre position from the reference path (> 0: left)."""
        return self.reference_path.project(x, y).lateral


def circle(vehicle, radius: float, speed: float, duration: float = 25.0,
           left: bool = True) -> Manoeuvre:
    """Constant speed on a circle of ``radius`` (centre of the vehicle), starting at the origin
    heading along +x. Kinematic: the rear axle's circle has radius sqrt(R^2 - b^2)."""
    b, wb = vehicle.rear_axle_to_center, vehicle.wheelbase
    sign = 1.0 if left else -1.0
    beta = math.asin(b / radius)                 # centre velocity vs heading
    steer = sign * math.atan(wb / math.sqrt(radius ** 2 - b ** 2))
    omega = sign * speed / radius

    def state_at(t: float) -> State:
        phi = omega * t                          # direction of travel of the centre
        return State(t=t, x=sign * radius * math.sin(phi), y=sign * radius * (1.0 - math.cos(phi)),
                     yaw=phi - sign * beta, v=speed, a=0.0, yaw_rate=omega, steer=steer)

    return Manoeuvre(f"circle R={radius:g} m at {speed:g} m/s", duration, state_at, wb, b)


def speed_step(vehicle, v0: float, v1: float, t_step: float = 1.0, duration: float = 15.0
               ) -> Manoeuvre:
    """Straight along +x at ``v0``, then at ``v1`` from ``t_step`` (a step, not a ramp)."""

    def state_at(t: float) -> State:
        if t < t_step:
            return State(t=t, x=v0 * t, y=0.0, yaw=0.0, v=v0)
        return State(t=t, x=v0 * t_step + v1 * (t - t_step), y=0.0, yaw=0.0, v=v1)

    return Manoeuvre(f"speed step {v0:g} -> {v1:g} m/s", duration, state_at,
                     vehicle.wheelbase, vehicle.rear_axle_to_center)


def speed_ramp(vehicle, v0: float, v1: float, accel: float, t_start: float = 1.0,
               duration: float = 15.0) -> Manoeuvre:
    """Straight along +x, from ``v0`` to ``v1`` at constant ``|accel|`` from ``t_start``, then
    holding ``v1`` (``v1 = 0``: a stop that is held)."""
    acc = abs(accel) * (1.0 if v1 >= v0 else -1.0)
    t_end = t_start + (v1 - v0) / acc if acc else t_start

    def state_at(t: float) -> State:
        if t < t_start:
            return State(t=t, x=v0 * t, y=0.0, yaw=0.0, v=v0)
        x0 = v0 * t_start
        if t < t_end:
            tau = t - t_start
            return State(t=t, x=x0 + v0 * tau + 0.5 * acc * tau ** 2, y=0.0, yaw=0.0,
                         v=v0 + acc * tau, a=acc)
        tau = t_end - t_start
        x1 = x0 + v0 * tau + 0.5 * acc * tau ** 2
        return State(t=t, x=x1 + v1 * (t - t_end), y=0.0, yaw=0.0, v=v1)

    return Manoeuvre(f"speed ramp {v0:g} -> {v1:g} m/s at {abs(accel):g} m/s^2", duration,
                     state_at, vehicle.wheelbase, vehicle.rear_axle_to_center)


@dataclass(frozen=True)
class LateralShift:
    """A sideways move of ``offset`` metres (> 0: left) over ``length`` metres of travel along
    +x, starting ``start`` metres in (a quintic in distance: zero lateral speed and acceleration
    at both ends)."""

    start: float
    length: float
    offset: float

    def lateral(self, x: float) -> tuple[float, float, float]:
        """Displacement and its first and second derivatives in x at ``x``."""
        u = min(max((x - self.start) / self.length, 0.0), 1.0)
        a, n = self.offset, self.length
        return (a * (10 * u ** 3 - 15 * u ** 4 + 6 * u ** 5),
                a * (30 * u ** 2 - 60 * u ** 3 + 30 * u ** 4) / n,
                a * (60 * u - 180 * u ** 2 + 120 * u ** 3) / n ** 2)

    @property
    def end(self) -> float:
        return self.start + self.length


def lane_change(vehicle, speed: float, offset: float = 3.5, length: float = 60.0,
                start: float = 20.0, duration: float | None = None) -> Manoeuvre:
    """Straight at ``speed``, then a lateral shift of ``offset`` over ``length`` metres starting
    ``start`` metres in, then straight again."""
    return lane_changes(vehicle, speed, [LateralShift(start, length, offset)],
                        f"lane change {offset:g} m over {length:g} m at {speed:g} m/s", duration)


def lane_changes(vehicle, speed: float, shifts: list[LateralShift], name: str,
                 duration: float | None = None) -> Manoeuvre:
    """Straight along +x at ``speed`` with the rear axle moved sideways by each of ``shifts`` in
    turn (their displacements add up), e.g. a double lane change. The default duration ends 5 s
    after the last shift."""
    b, wb = vehicle.rear_axle_to_center, vehicle.wheelbase
    end = max(shift.end for shift in shifts)

    def lateral(xr: float) -> tuple[float, float, float]:
        parts = [shift.lateral(xr) for shift in shifts]
        return (sum((p[0] for p in parts), 0.0), sum((p[1] for p in parts), 0.0), sum((p[2] for p in parts), 0.0))

    # Parametrise the rear axle path by its x coordinate; convert arc length to time.
    xs = np.linspace(0.0, end + speed * 60.0, 20001)
    dys = np.array([lateral(x)[1] for x in xs])
    ds = np.hypot(1.0, dys)
    s = np.concatenate(([0.0], np.cumsum(0.5 * (ds[1:] + ds[:-1]) * np.diff(xs))))

    def state_at(t: float) -> State:
        xr = float(np.interp(speed * t, s, xs))
        y, dy, ddy = lateral(xr)
        yaw = math.atan(dy)
        kappa = ddy / (1.0 + dy * dy) ** 1.5
        steer = math.atan(wb * kappa)
        x_c = xr + b * math.cos(yaw)
        y_c = y + b * math.sin(yaw)
        return State(t=t, x=x_c, y=y_c, yaw=yaw, v=speed, a=0.0, yaw_rate=kappa * speed,
                     steer=steer)

    dur = duration if duration is not None else end / speed + 5.0
    return Manoeuvre(name, dur, state_at, wb, b)
