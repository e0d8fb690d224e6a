"""Vehicle dynamics of the catalogue cars: standard handling tests, the sedan beside CommonRoad's
multi-body (MB) model of parameter set 2 run the same way.

Every car is a plant with ``reset(State)`` / ``step(Command, period)``: the MuJoCo cars through
`simgap.sim.mujoco.plant.MujocoPlant` (physics 500 Hz, road friction 1.0 x each tyre's), the MB
model through `simgap.sim.multibody.MultiBodyPlant`. Drivers and controllers run every 10 ms
and see only the measured `State`; steering commands pass through each car's steering-rate limit.

* circle — steady-state circular driving (ISO 4138 style, constant radius R = 50 m, speed sweep):
  pure pursuit follows the circle (`manoeuvres.circle`) for 20 s, the last 5 s are averaged. Per
  speed: single-track steering angle, sideslip beta of the centre, lateral acceleration
  a_y = v * yaw rate, and the largest distance from the circle. A speed is held while that
  distance stays under 1 m (2 % of R). Sweep: 4, 6, 8, ... m/s up to the first speed not held,
  then every 0.5 m/s within the 4 m/s below it. Understeer gradient = slope of
  (steer - kinematic steer for the driven radius v / yaw rate) against a_y / g, sideslip gradient =
  slope of beta against a_y / g, roll gradient = slope of the body roll against a_y / g, all
  fitted on the speeds with v^2 / R <= 0.4 g; limit = the largest a_y held; the lateral error
  over the last 2 m/s below the limiting speed is printed.
* step_steer — ISO 7401 style: straight at 80 km/h, speed held (P on speed through the pedal
  map), at t = 1 s the steering target jumps to the angle for ~4 m/s^2 of steady a_y (kinematic
  first guess, rescaled once by the measured a_y); each car turns its wheels at its own steering
  rate limit (sedan and MB 0.4 rad/s road wheel = 360 deg/s at the steering wheel). Yaw-rate rise
  time (10 -> 90 % of the steady yaw rate), response time (50 % steering -> 90 % yaw rate),
  overshoot of the peak over the steady yaw rate (the mean of the last second of 4 s).
* braking — straight, 100 km/h held for 0.5 s, then a constant brake pedal to standstill; the
  driver steers to keep the heading and the line (a car that spins past 0.5 rad has no distance).
  ``locked``: full pedal (wheel lock allowed). ``unlocked``: the largest constant pedal at which
  no wheel locks, found by bisection (5 runs); a wheel is locked when its circumferential speed
  falls under 10 % of the car's speed above 2 m/s. The MB model's input is an acceleration: the
  pedal maps to it through the sedan's brake torque (full pedal = 12.2 m/s^2, clipped by the
  model to its a_max = 11.5 m/s^2, past the friction limit; the unlocked figure is the largest
  non-locking deceleration input found by the same bisection).
* lane_change — double lane change on the ISO 3888-2 course (sections 12 / 13.5 / 11 / 12.5 /
  12 m, lane widths 1.1 W + 0.25, W + 1, 1.3 W + 0.25 >= 3 m, lane 3 shifted 1 m left of lane 1,
  lanes 1 and 5 sharing the right edge; W = car width) at 60 km/h with each tracking controller.
  The reference path runs through the lane centres with two quintic lane changes timed so that a
  car exactly on it clears every cone line by >= 0.17 m. Passed: the car's footprint stayed
  inside the lanes of sections 1, 3 and 5; peak lateral error from the reference path.
* beyond_limit — on flat ground at 60, 80 and 100 km/h, pedals off, the wheels turned 6 or 10 deg
  at 0.3 s (far past every car's limit) and held, or turned the other way 1 s later (a fishhook),
  4 s each: rollovers (diverged physics), the largest body roll and the longest time both wheels of
  one side were off the ground. MuJoCo cars only (the MB model's wheels cannot lift).

Usage: python bench/vehicles/vehicle_dynamics.py [--sections circle step_steer braking lane_change beyond_limit]
       [--vehicles sedan suv city] [--controllers pure_pursuit stanley lqr] [--no-mb] [--quick]
       [--json]
``--quick`` is a smoke run (3 speeds, short runs, 2 bisection steps, 2 runs past the limit). ``--json`` prints one JSON
object: per vehicle its figures, the sedan's MB reference under ``mb_reference`` (wall times go to
stderr). Prints tables and per-section wall time; no pass/fail.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from simgap.control import LongitudinalMap, controller_names, make_controller, manoeuvres  # noqa: E402
from simgap.control.protocol import Command  # noqa: E402
from simgap.files import BenchmarkResults
from simgap.sim.dynamic import track_plans  # noqa: E402
from simgap.sim.mujoco.plant import AGENT, MujocoPlant  # noqa: E402
from simgap.sim.multibody import MultiBodyPlant, sideslip
from simgap.sim.protocol import PhysicsDiverged  # noqa: E402
from simgap.trajectory import State  # noqa: E402
from simgap.vehicles import Vehicle, load_vehicle, vehicle_names  # noqa: E402

GRAVITY = 9.81
PERIOD = 0.01                   # s, drivers and controllers
RADIUS = 50.0                   # m, steady-state circle
LINEAR_RANGE_G = 0.4            # fit range of the gradients: v^2 / R up to this
HELD_DISTANCE = 0.02 * RADIUS   # m, largest distance from the circle of a held speed
STEP_SPEED = 80.0 / 3.6
STEP_LATERAL_ACCELERATION = 4.0
BRAKING_SPEED = 100.0 / 3.6
SPUN = 0.5                      # rad of heading: the car spun, the stop does not count
LOCKED_WHEEL = 0.1              # circumferential / car speed below which a wheel counts as locked
LANE_CHANGE_SPEED = 60.0 / 3.6
MB = "mb_reference"
SECTIONS = ("circle", "step_steer", "braking", "lane_change", "beyond_limit")


@dataclass(frozen=True)
class TestCar:
    """A car under test: its name in the output, the catalogue vehicle the drivers and
    controllers read (geometry, pedal map, gains), and how to build a fresh plant."""

    name: str
    vehicle: Vehicle
    make_plant: Callable[[], object]


def catalogue_car(name: str) -> TestCar:
    vehicle = load_vehicle(name)
    return TestCar(name, vehicle, lambda: MujocoPlant(vehicle))


def mb_car() -> TestCar:
    return TestCar(MB, load_vehicle("sedan"), MultiBodyPlant)


def wheel_speeds(plant) -> np.ndarray:
    """Circumferential speed of each wheel [m/s]."""
    if isinstance(plant, MujocoPlant):
        car = plant.world.cars[AGENT]
        return plant.world.data.qvel[car.spin_dofs] * car.physics.wheel_radius
    return plant.wheel_speeds()


def body_roll(plant) -> float:
    """Roll of the sprung body [rad, about the heading, > 0 left side up]."""
    if isinstance(plant, MujocoPlant):
        m = plant.world.data.xmat[plant.world.cars[AGENT].chassis_body]
        return math.atan2(m[7], m[8])
    return plant.body_roll()


class RollRecorder:
    """A plant that notes its body roll after every reset and step (in step with the states
    `track_plans` returns)."""

    def __init__(self, plant):
        self.plant, self.roll = plant, []

    def reset(self, initial: State) -> State:
        state = self.plant.reset(initial)
        self.roll = [body_roll(self.plant)]
        return state

    def step(self, command: Command, period: float) -> State:
        state = self.plant.step(command, period)
        self.roll.append(body_roll(self.plant))
        return state


def speed_hold(pedals: LongitudinalMap, target: float, v: float) -> tuple[float, float]:
    """(throttle, brake) of a P driver on speed."""
    return pedals.pedals(2.0 * (target - v), max(v, 0.0))


# --- steady-state circle ------------------------------------------------------------------------
@dataclass(frozen=True)
class CirclePoint:
    speed: float
    lateral_acceleration: float = math.nan
    steer: float = math.nan                 # rad, single-track
    kinematic_steer: float = math.nan       # rad, for the driven radius
    sideslip: float = math.nan              # rad, of the centre
    yaw_rate: float = math.nan
    roll: float = math.nan                  # rad, body roll (> 0 left side up: outwards on a left circle)
    lateral_error: float = math.inf         # m, largest distance from the circle, steady part
    lost: str = ""                          # why the physics gave up, if it did

    @property
    def held(self) -> bool:
        return not self.lost and self.lateral_error < HELD_DISTANCE


@dataclass(frozen=True)
class CircleResult:
    points: list[CirclePoint]
    understeer_gradient: float              # deg/g
    sideslip_gradient: float                # deg/g
    roll_gradient: float                    # deg/g
    max_lateral_acceleration: float         # m/s^2
    limit_speed: float                      # m/s

    def near_limit(self) -> list[CirclePoint]:
        """The held points within 2 m/s below the limiting speed."""
        return [p for p in self.points if p.held and p.speed >= self.limit_speed - 2.0 - 1e-9]


def circle_point(car: TestCar, speed: float, duration: float, average_last: float) -> CirclePoint:
    vehicle = car.vehicle
    man = manoeuvres.circle(vehicle, RADIUS, speed, duration=duration)
    plant = RollRecorder(car.make_plant())
    try:
        states = track_plans(plant, make_controller("pure_pursuit", vehicle, 1.0 / PERIOD),
                             lambda t, s: man.plan(t, 3.0), man.initial_state(), man.duration)
    except PhysicsDiverged as exc:
        return CirclePoint(speed, lost=str(exc))
    steady = [k for k, s in enumerate(states) if s.t >= duration - average_last - 1e-9]
    v = np.mean([states[k].v for k in steady])
    r = np.mean([states[k].yaw_rate for k in steady])
    driven_radius = v / r
    b, wb = vehicle.rear_axle_to_center, vehicle.wheelbase
    return CirclePoint(
        speed, lateral_acceleration=float(np.mean([states[k].v * states[k].yaw_rate for k in steady])),
        steer=float(np.mean([states[k].steer for k in steady])),
        kinematic_steer=math.atan(wb / math.sqrt(max(driven_radius ** 2 - b ** 2, wb ** 2))),
        sideslip=float(np.mean([sideslip(states[k - 1], states[k]) for k in steady])),
        yaw_rate=float(r), roll=float(np.mean([plant.roll[k] for k in steady])),
        lateral_error=float(max(abs(man.lateral_error(states[k].x, states[k].y)) for k in steady)))


def gradient(points: list[CirclePoint], value: Callable[[CirclePoint], float]) -> float:
    """Slope [deg/g] of ``value`` [rad] against a_y / g on the linear range."""
    linear = [p for p in points if p.held and p.speed ** 2 / RADIUS <= LINEAR_RANGE_G * GRAVITY + 1e-9]
    if len(linear) < 2:
        return math.nan
    return float(np.polyfit([p.lateral_acceleration / GRAVITY for p in linear],
                            np.degrees([value(p) for p in linear]), 1)[0])


def circle(car: TestCar, quick: bool) -> CircleResult:
    duration, average_last = (12.0, 4.0) if quick else (20.0, 5.0)
    points: dict[float, CirclePoint] = {}

    def run(speed: float) -> CirclePoint:
        points[speed] = circle_point(car, speed, duration, average_last)
        return points[speed]

    if quick:
        for speed in (6.0, 10.0, 14.0):
            run(speed)
    else:
        lost = None
        for speed in np.arange(4.0, 40.0, 2.0):
            if not run(float(speed)).held:
                lost = float(speed)
                break
        if lost is not None:
            for below in (3.5, 3.0, 2.5, 1.5, 1.0, 0.5):
                if lost - below > 0 and lost - below not in points:
                    run(lost - below)
    ordered = [points[s] for s in sorted(points)]
    held = [p for p in ordered if p.held]
    return CircleResult(
        ordered, understeer_gradient=gradient(ordered, lambda p: p.steer - p.kinematic_steer),
        sideslip_gradient=gradient(ordered, lambda p: p.sideslip),
        roll_gradient=gradient(ordered, lambda p: p.roll),
        max_lateral_acceleration=max((p.lateral_acceleration for p in held), default=math.nan),
        limit_speed=max((p.speed for p in held), default=math.nan))


# --- step steer ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class StepSteerResult:
    steer: float                            # rad, road wheel (single-track) step
    steady_lateral_acceleration: float      # m/s^2
    steady_yaw_rate: float                  # rad/s
    rise_time: float                        # s, yaw rate 10 -> 90 %
    response_time: float                    # s, 50 % steering -> 90 % yaw rate
    overshoot: float                        # %, peak yaw rate over the steady one


def crossing(t: np.ndarray, y: np.ndarray, level: float, after: float) -> float:
    """First time after ``after`` at which ``y`` reaches ``level`` (linear between samples)."""
    for k in range(1, len(t)):
        if t[k] > after and y[k] >= level > y[k - 1]:
            return float(t[k - 1] + (level - y[k - 1]) / (y[k] - y[k - 1]) * (t[k] - t[k - 1]))
    return math.nan


def step_steer_run(car: TestCar, steer: float, hold: float, t_step: float = 1.0):
    plant = car.make_plant()
    pedals = LongitudinalMap.for_vehicle(car.vehicle)
    state = plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=STEP_SPEED))
    rows = [(state.t, state.yaw_rate, state.steer, state.v)]
    for k in range(int(round((t_step + hold) / PERIOD))):
        target = steer if k * PERIOD >= t_step - 1e-9 else 0.0
        state = plant.step(Command(target, *speed_hold(pedals, STEP_SPEED, state.v)), PERIOD)
        rows.append(((k + 1) * PERIOD, state.yaw_rate, state.steer, state.v))
    return (np.array(col) for col in zip(*rows))


def step_steer(car: TestCar, quick: bool) -> StepSteerResult:
    hold, t_step = (3.0 if quick else 4.0), 1.0
    steer = car.vehicle.wheelbase * STEP_LATERAL_ACCELERATION / STEP_SPEED ** 2
    for _ in range(2):                      # kinematic guess, then rescaled by the measured a_y
        t, r, delta, v = step_steer_run(car, steer, hold, t_step)
        last = t >= t[-1] - 1.0
        r_ss = float(np.mean(r[last]))
        a_ss = float(np.mean(r[last] * v[last]))
        if a_ss <= 0:
            break
        previous, steer = steer, steer * STEP_LATERAL_ACCELERATION / a_ss
    steer = previous
    t10, t90 = crossing(t, r, 0.1 * r_ss, t_step), crossing(t, r, 0.9 * r_ss, t_step)
    t50_steer = crossing(t, delta, 0.5 * steer, t_step)
    after = t >= t_step
    return StepSteerResult(steer, a_ss, r_ss, t90 - t10, t90 - t50_steer,
                           100.0 * (float(r[after].max()) - r_ss) / r_ss)


# --- braking ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class BrakingRun:
    pedal: float
    distance: float                         # m, from brake onset to standstill
    duration: float                         # s
    locked: bool                            # a wheel locked above 2 m/s
    lost: str = ""                          # why the stop was not completed (the car spun)


@dataclass(frozen=True)
class BrakingResult:
    locked: BrakingRun                      # full pedal
    unlocked: BrakingRun | None             # largest constant pedal without wheel lock


def braking_run(car: TestCar, pedal: float) -> BrakingRun:
    plant = car.make_plant()
    pedals = LongitudinalMap.for_vehicle(car.vehicle)
    state = plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=BRAKING_SPEED))
    for _ in range(int(round(0.5 / PERIOD))):          # settle on the suspension at 100 km/h
        state = plant.step(Command(0.0, *speed_hold(pedals, BRAKING_SPEED, state.v)), PERIOD)
    t0, distance, locked = state.t, 0.0, False
    try:
        while state.v > 0.05 and state.t < t0 + 15.0:
            previous = state
            state = plant.step(Command(straight_ahead(state), 0.0, pedal), PERIOD)
            distance += math.hypot(state.x - previous.x, state.y - previous.y)
            if state.v > 2.0 and np.any(wheel_speeds(plant) < LOCKED_WHEEL * state.v):
                locked = True
            if abs(state.yaw) > SPUN:
                return BrakingRun(pedal, math.nan, math.nan, locked, f"spun ({math.degrees(state.yaw):.0f} deg) "
                                  f"at {state.v:.1f} m/s")
    except PhysicsDiverged as exc:
        return BrakingRun(pedal, math.nan, math.nan, locked, str(exc))
    return BrakingRun(pedal, distance, state.t - t0, locked)


def straight_ahead(state: State) -> float:
    """The braking driver's steering: keep the heading and the line y = 0."""
    return -1.0 * state.yaw - 0.05 * state.y


def braking(car: TestCar, quick: bool) -> BrakingResult:
    full = braking_run(car, 1.0)
    if not full.locked and not full.lost:
        return BrakingResult(full, full)
    lo, hi, best = 0.3, 1.0, None
    for _ in range(2 if quick else 5):
        run = braking_run(car, 0.5 * (lo + hi))
        if run.locked or run.lost:
            hi = run.pedal
        else:
            lo, best = run.pedal, run
    if best is None:
        best = braking_run(car, lo)
    return BrakingResult(full, None if best.locked or best.lost else best)


# --- double lane change ---------------------------------------------------------------------------
@dataclass(frozen=True)
class ConeLane:
    """One coned section of the course: x range and the lane's right and left edges."""

    x_start: float
    x_end: float
    right: float
    left: float


@dataclass(frozen=True)
class LaneChangeCourse:
    """ISO 3888-2 style obstacle-avoidance course for a car of ``width``, starting ``start``
    metres along +x from the car's start, lane 1 centred on y = 0."""

    width: float
    start: float = 30.0
    lanes: list[ConeLane] = field(init=False)

    def __post_init__(self):
        w, x0 = self.width, self.start
        h1, h3, h5 = 1.1 * w + 0.25, w + 1.0, max(1.3 * w + 0.25, 3.0)
        object.__setattr__(self, "lanes", [
            ConeLane(x0, x0 + 12.0, -h1 / 2, h1 / 2),
            ConeLane(x0 + 25.5, x0 + 36.5, h1 / 2 + 1.0, h1 / 2 + 1.0 + h3),
            ConeLane(x0 + 49.0, x0 + 61.0, -h1 / 2, -h1 / 2 + h5)])

    def reference(self, vehicle: Vehicle, speed: float) -> manoeuvres.Manoeuvre:
        """Through the lane centres: into lane 3 over 20 m from 10 m in (rear axle), back over
        22 m from 32 m in."""
        centre = [(lane.right + lane.left) / 2 for lane in self.lanes]
        shifts = [manoeuvres.LateralShift(self.start + 10.0, 20.0, centre[1] - centre[0]),
                  manoeuvres.LateralShift(self.start + 32.0, 22.0, centre[2] - centre[1])]
        return manoeuvres.lane_changes(vehicle, speed, shifts, f"ISO 3888-2 course at {speed:g} m/s",
                                       duration=(self.start + 61.0 + 20.0) / speed)

    def clearance(self, vehicle: Vehicle, state: State) -> float:
        """Smallest distance of the footprint's outline inside the coned lanes [m] (< 0: a cone
        line crossed), ``inf`` when the car is in none of the coned sections."""
        c, s = math.cos(state.yaw), math.sin(state.yaw)
        best = math.inf
        for along in np.linspace(-vehicle.length / 2, vehicle.length / 2, 9):
            for across in (-vehicle.width / 2, vehicle.width / 2):
                px, py = state.x + along * c - across * s, state.y + along * s + across * c
                for lane in self.lanes:
                    if lane.x_start <= px <= lane.x_end:
                        best = min(best, py - lane.right, lane.left - py)
        return best


@dataclass(frozen=True)
class LaneChangeRun:
    controller: str
    passed: bool
    clearance: float                        # m, smallest footprint clearance inside the lanes
    peak_lateral_error: float               # m, from the reference path
    lost: str = ""


def lane_change_run(car: TestCar, controller: str) -> LaneChangeRun:
    course = LaneChangeCourse(car.vehicle.width)
    man = course.reference(car.vehicle, LANE_CHANGE_SPEED)
    try:
        states = track_plans(car.make_plant(), make_controller(controller, car.vehicle, 1.0 / PERIOD),
                             lambda t, s: man.plan(t, 3.0), man.initial_state(), man.duration)
    except PhysicsDiverged as exc:
        return LaneChangeRun(controller, False, -math.inf, math.inf, str(exc))
    clearance = min(course.clearance(car.vehicle, s) for s in states)
    peak = max(abs(man.lateral_error(s.x, s.y)) for s in states)
    return LaneChangeRun(controller, bool(clearance >= 0.0), float(clearance), float(peak))


def lane_change(car: TestCar, controllers: list[str]) -> list[LaneChangeRun]:
    return [lane_change_run(car, c) for c in controllers]


# --- beyond the limit -----------------------------------------------------------------------------
@dataclass(frozen=True)
class LimitRun:
    speed: float
    steer: float                            # rad, road wheel
    fishhook: bool                          # turned the other way 1 s after the onset
    max_roll: float                         # rad
    two_wheel_lift: float                   # s, longest time both wheels of one side were off the ground
    lost: str = ""                          # why the physics gave up (a rollover), if it did


def limit_run(car: TestCar, speed: float, steer: float, fishhook: bool) -> LimitRun:
    plant = car.make_plant()
    plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=speed))
    load = plant.world.tyres.load                       # front left, front right, rear left, rear right
    max_roll = lifted = longest = 0.0
    try:
        for k in range(int(round(4.0 / PERIOD))):
            t = k * PERIOD
            target = 0.0 if t < 0.3 else -steer if fishhook and t >= 1.3 else steer
            plant.step(Command(target, 0.0, 0.0), PERIOD)
            max_roll = max(max_roll, abs(body_roll(plant)))
            side_up = (load[0] <= 0.0 and load[2] <= 0.0) or (load[1] <= 0.0 and load[3] <= 0.0)
            lifted = lifted + PERIOD if side_up else 0.0
            longest = max(longest, lifted)
    except PhysicsDiverged as exc:
        return LimitRun(speed, steer, fishhook, max_roll, longest, str(exc))
    return LimitRun(speed, steer, fishhook, max_roll, longest)


def beyond_limit(car: TestCar, quick: bool) -> list[LimitRun] | None:
    if car.name == MB:
        return None
    speeds, steers = ((80.0,), (10.0,)) if quick else ((60.0, 80.0, 100.0), (6.0, 10.0))
    return [limit_run(car, v / 3.6, math.radians(d), hook) for v in speeds for d in steers for hook in (False, True)]


# --- summary ------------------------------------------------------------------------------------
def finite(value: float) -> float | None:
    return float(value) if value is not None and math.isfinite(value) else None


def summary(results: dict) -> dict:
    """The JSON figures of one car from its section results (keyed by section name)."""
    out: dict = {}
    if "circle" in results:
        c: CircleResult = results["circle"]
        out.update(understeer_gradient_deg_per_g=finite(c.understeer_gradient),
                   sideslip_gradient_deg_per_g=finite(c.sideslip_gradient),
                   roll_gradient_deg_per_g=finite(c.roll_gradient),
                   max_lateral_acceleration=finite(c.max_lateral_acceleration),
                   circle_limit_speed=finite(c.limit_speed),
                   circle_near_limit_lateral_error_m={f"{p.speed:g}": finite(p.lateral_error)
                                                      for p in c.near_limit()})
    if "step_steer" in results:
        s: StepSteerResult = results["step_steer"]
        out.update(yaw_rate_rise_time_s=finite(s.rise_time), yaw_rate_response_time_s=finite(s.response_time),
                   yaw_rate_overshoot_percent=finite(s.overshoot), step_steer_deg=finite(math.degrees(s.steer)),
                   step_steer_lateral_acceleration=finite(s.steady_lateral_acceleration))
    if "braking" in results:
        b: BrakingResult = results["braking"]
        out.update(braking_distance_100_m=finite(b.locked.distance),
                   braking_distance_100_unlocked_m=finite(b.unlocked.distance) if b.unlocked else None,
                   braking_unlocked_pedal=finite(b.unlocked.pedal) if b.unlocked else None,
                   braking_full_pedal_locks=b.locked.locked, braking_full_pedal_lost=b.locked.lost or None)
    if results.get("beyond_limit"):
        runs: list[LimitRun] = results["beyond_limit"]
        out.update(beyond_limit_runs=len(runs), beyond_limit_rollovers=sum(1 for r in runs if r.lost),
                   beyond_limit_max_roll_deg=max(math.degrees(r.max_roll) for r in runs),
                   beyond_limit_longest_two_wheel_lift_s=max(r.two_wheel_lift for r in runs))
    if "lane_change" in results:
        out["lane_change_60"] = {r.controller: {"passed": r.passed, "peak_lateral_error_m": finite(r.peak_lateral_error),
                                                "clearance_m": finite(r.clearance)}
                                 for r in results["lane_change"]}
    return out


def run_section(section: str, car: TestCar, quick: bool, controllers: list[str]):
    if section == "circle":
        return circle(car, quick)
    if section == "step_steer":
        return step_steer(car, quick)
    if section == "braking":
        return braking(car, quick)
    if section == "beyond_limit":
        return beyond_limit(car, quick)
    return lane_change(car, controllers)


def benchmark_json(results: dict[str, dict]) -> dict:
    """One object: per vehicle its figures, the MB reference under the sedan's ``mb_reference``."""
    out = {name: summary(res) for name, res in results.items() if name != MB}
    if MB in results:
        out.setdefault("sedan", {})[MB] = summary(results[MB])
    return out


# --- printing -------------------------------------------------------------------------------------
def deg(value: float) -> float:
    return math.degrees(value)


def print_circle(results: dict[str, dict]) -> None:
    print(f"\n## steady-state circle, R = {RADIUS:g} m, pure pursuit (held: within {HELD_DISTANCE:g} m of the circle)")
    for name, res in results.items():
        if name == MB or "circle" not in res:
            continue
        rows = res["circle"].points
        mb = {p.speed: p for p in results.get(MB, {}).get("circle", CircleResult([], 0, 0, 0, 0, 0)).points} \
            if name == "sedan" else {}
        header = f"{'v':>5} {'a_y':>6} {'steer':>7} {'kin':>6} {'beta':>6} {'roll':>5} {'lat err':>7}"
        if mb:
            header += f" | {'MB a_y':>6} {'MB steer':>8} {'MB beta':>7} {'MB lat err':>10}"
        print(f"\n{name}:  (angles in deg, a_y in m/s^2, lateral error in m)\n{header}")
        for p in sorted(set(r.speed for r in rows) | set(mb)):
            r = next((q for q in rows if q.speed == p), None)
            line = (f"{p:>5.1f} {r.lateral_acceleration:>6.2f} {deg(r.steer):>7.3f} {deg(r.kinematic_steer):>6.3f} "
                    f"{deg(r.sideslip):>6.2f} {deg(r.roll):>5.2f} {r.lateral_error:>7.3f}" if r else f"{p:>5.1f} {'':>43}")
            if r and r.lost:
                line = f"{p:>5.1f} lost: {r.lost[:60]}"
            m = mb.get(p)
            if m:
                line += (f" | {m.lateral_acceleration:>6.2f} {deg(m.steer):>8.3f} {deg(m.sideslip):>7.2f} "
                         f"{m.lateral_error:>10.3f}" if not m.lost else f" | lost: {m.lost[:40]}")
            print(line)


def print_summary(results: dict[str, dict]) -> None:
    names = [n for n in results if n != MB] + ([MB] if MB in results else [])
    table = {n: summary(results[n]) for n in names}
    keys = [k for k in next(iter(table.values()), {}) if not isinstance(table[names[0]][k], dict)]
    print("\n## summary (MB = CommonRoad's multi-body model, parameter set 2, the sedan's reference)")
    print(f"{'':<36}" + "".join(f"{('MB' if n == MB else n):>10}" for n in names))
    for k in keys:
        cells = []
        for n in names:
            v = table[n].get(k)
            cells.append(f"{'-':>10}" if v is None else f"{str(v):>10}" if isinstance(v, bool) else f"{v:>10.3f}")
        print(f"{k:<36}" + "".join(cells))
    for n in names:
        if "circle" in results[n]:
            near = results[n]["circle"].near_limit()
            print(f"{('MB' if n == MB else n):<6} lateral error over the last 2 m/s below the limit: "
                  + ", ".join(f"{p.speed:g} m/s {p.lateral_error:.3f} m" for p in near))
    for n in names:
        for r in results[n].get("beyond_limit") or []:
            print(f"{n:<6} beyond the limit, {r.speed * 3.6:.0f} km/h, {math.degrees(r.steer):.0f} deg "
                  f"{'fishhook' if r.fishhook else 'step    '}: "
                  + (f"ROLLED OVER ({r.lost})" if r.lost else f"max roll {math.degrees(r.max_roll):.1f} deg, "
                     f"longest two-wheel lift {r.two_wheel_lift:.2f} s"))
    for n in names:
        if "lane_change" in results[n]:
            print(f"{('MB' if n == MB else n):<6} double lane change at 60 km/h: "
                  + "; ".join(f"{r.controller} {'pass' if r.passed else 'FAIL'} (peak lateral error "
                              f"{r.peak_lateral_error:.2f} m, clearance {r.clearance:+.2f} m)" for r in results[n]["lane_change"]))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sections", nargs="+", choices=SECTIONS, default=list(SECTIONS))
    parser.add_argument("--vehicles", nargs="+", choices=vehicle_names(), default=vehicle_names())
    parser.add_argument("--controllers", nargs="+", choices=controller_names(), default=controller_names())
    parser.add_argument("--no-mb", action="store_true", help="skip the MB reference beside the sedan")
    parser.add_argument("--quick", action="store_true", help="smoke run: fewer and shorter runs")
    parser.add_argument("--json", nargs="?", const="-", metavar="FILE",
                        help="alone: print one JSON object instead of tables; with FILE: print the tables and write "
                             "the figures, with commit, date, machine and load, to this results file")
    args = parser.parse_args(argv)
    results_file = BenchmarkResults()
    to_stdout = args.json == "-"
    cars = [catalogue_car(n) for n in args.vehicles]
    if "sedan" in args.vehicles and not args.no_mb:
        cars.append(mb_car())
    log = sys.stderr if to_stdout else sys.stdout
    results: dict[str, dict] = {car.name: {} for car in cars}
    total = time.perf_counter()
    for section in args.sections:
        start = time.perf_counter()
        for car in cars:
            results[car.name][section] = run_section(section, car, args.quick, args.controllers)
        if section == "circle" and not to_stdout:
            print_circle(results)
        print(f"[{section}: {time.perf_counter() - start:.1f} s wall]", file=log)
    if to_stdout:
        print(json.dumps(benchmark_json(results), indent=1))
    else:
        print_summary(results)
    print(f"[total: {time.perf_counter() - total:.1f} s wall]", file=log)
    if args.json and not to_stdout:
        results_file.write(args.json, {"arguments": vars(args), **benchmark_json(results)})


if __name__ == "__main__":
    main()
