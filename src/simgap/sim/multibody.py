"""CommonRoad's multi-body model (commonroad-vehicle-models, parameter set 2, BMW 320i) as a plant
with the MuJoCo plant's interface: the reference the catalogue's sedan is held against.

`MultiBodyPlant` — ``reset(State) -> State`` places the car, ``step(Command, period) -> State``
holds a command for ``period`` seconds and returns the measured state, as
`simgap.sim.mujoco.plant.MujocoPlant` does, so that `simgap.sim.dynamic.track_plans` and the
project's tracking controllers drive it exactly like a MuJoCo car. The model (29 states, PAC2002
Magic Formula tyres with combined slip, suspension, roll axes, wheel spin) is integrated with
LSODA (rtol 1e-6, atol 1e-8) across each held command (fixed-step Runge-Kutta at 0.5 ms while the
brakes are on or a wheel slides or is locked, where LSODA crawls: one stop from 100 km/h took it
over ten minutes, the fixed step ~10 s, the same distance to 0.1 mm as at 0.25 ms). A command
becomes the model's two inputs:

* steering: the steering-angle rate that reaches ``command.steer`` within the period, within the
  set's +-0.4 rad/s (the same rate limit as the sedan's steering actuator);
* pedals: the model's longitudinal acceleration input ``u`` is the wheel torque of the sedan's
  pedal map over ``m R_w`` — ``(throttle * max_drive_torque - brake * max_brake_torque) /
  (mass * wheel_radius)``. The model turns ``u`` back into that torque (``m R_w u``, split over
  the axles by the set's T_sb / T_se) after clipping it to its ``[-a_max, a_max v_switch / v]``;
  full brake (12.2 m/s^2 of torque) is therefore clipped to -a_max = -11.5 m/s^2, beyond the
  tyres' friction limit: the wheels can lock. The model has no rolling or air resistance.

`hold_circle` — a constant-radius driver (feed-forward + PI on the distance from the circle + P
on the heading error, PI speed) for any such plant; `bench/vehicles/mb_cornering.py` runs it on the MB
model as a controller-independent check of its steady states.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from vehiclemodels.init_mb import init_mb
from vehiclemodels.parameters_vehicle2 import parameters_vehicle2
from vehiclemodels.vehicle_dynamics_mb import vehicle_dynamics_mb

from simgap.control.longitudinal import LongitudinalMap
from simgap.control.protocol import Command
from simgap.sim.protocol import PhysicsDiverged
from simgap.sim.rates import SpeedRate
from simgap.trajectory import State
from simgap.vehicles import Vehicle, load_vehicle

NAME = "MB model (CommonRoad parameter set 2)"


SLIDING = 0.9                  # wheel circumferential / forward speed below which (slip > 10 %) LSODA is not used
FALLBACK_STEP = 5e-4           # s
WHEEL_SPIN = slice(23, 27)     # the model's wheel angular speeds (front left, front right, rear left, rear right)


def _dynamics(x: np.ndarray, u: list[float], p) -> np.ndarray:
    """The model's right-hand side with a locked wheel held at rest: the model stops a wheel
    only once its speed has gone negative (and changes the integrator's state in place to do
    so), which makes an adaptive integrator crawl along the switch; here a wheel at or below
    zero speed stays there while brake torque exceeds the tyre's."""
    x = np.array(x, dtype=float)
    locked = x[WHEEL_SPIN] <= 0.0
    x[WHEEL_SPIN] = np.maximum(x[WHEEL_SPIN], 0.0)
    f = np.asarray(vehicle_dynamics_mb(x, u, p), dtype=float)
    spin = f[WHEEL_SPIN]
    spin[locked & (spin < 0.0)] = 0.0
    f[WHEEL_SPIN] = spin
    return f


def _fixed_step(x: np.ndarray, u: list[float], p, period: float) -> np.ndarray:
    """Classical Runge-Kutta at `FALLBACK_STEP` across ``period``, for braking or a wheel that
    slides or is locked: LSODA crawls along the tyres' steep slip curves and the switch between
    rolling and locked."""
    n = max(1, round(period / FALLBACK_STEP))
    h = period / n
    x = np.array(x, dtype=float)
    for _ in range(n):
        k1 = _dynamics(x, u, p)
        k2 = _dynamics(x + 0.5 * h * k1, u, p)
        k3 = _dynamics(x + 0.5 * h * k2, u, p)
        k4 = _dynamics(x + h * k3, u, p)
        x = x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        x[WHEEL_SPIN] = np.maximum(x[WHEEL_SPIN], 0.0)
    return x


class MultiBodyPlant:
    """CommonRoad's multi-body model of parameter set 2 behind ``reset`` / ``step``."""

    def __init__(self, vehicle: Vehicle | None = None):
        #: the catalogue car the model stands for: its pedal map, and geometry for the drivers
        self.vehicle = vehicle or load_vehicle("sedan")
        self.p = parameters_vehicle2()
        pedals = LongitudinalMap.for_vehicle(self.vehicle)
        scale = 1.0 / (pedals.mass * pedals.wheel_radius)
        self._drive, self._brake = pedals.max_drive_torque * scale, pedals.max_brake_torque * scale

    def reset(self, initial: State) -> State:
        """Place the car at ``initial`` moving along its heading, wheels rolling."""
        self.t = initial.t
        self.x = np.array(init_mb([initial.x, initial.y, initial.steer, initial.v, initial.yaw,
                                   initial.yaw_rate, 0.0], self.p), dtype=float)
        self._accel = SpeedRate(initial.t, initial.v, initial.a)
        return self.measure()

    def step(self, command: Command, period: float) -> State:
        p = self.p
        steer_rate = float(np.clip((command.steer - self.x[2]) / period, p.steering.v_min, p.steering.v_max))
        throttle, brake = (min(max(pedal, 0.0), 1.0) for pedal in (command.throttle, command.brake))
        u = [steer_rate, throttle * self._drive - brake * self._brake]
        if brake > 0.0 or np.any(self.x[WHEEL_SPIN] * p.R_w < SLIDING * self.x[3]):
            x = _fixed_step(self.x, u, p, period)
        else:
            sol = solve_ivp(lambda t, s: _dynamics(s, u, p), (0.0, period), self.x, method="LSODA", rtol=1e-6,
                            atol=1e-8)
            x = sol.y[:, -1] if sol.success else _fixed_step(self.x, u, p, period)
        if not np.all(np.isfinite(x)):
            raise PhysicsDiverged(f"the multi-body model's state is no longer finite at t = {self.t + period:.2f} s")
        self.x = x
        self.x[WHEEL_SPIN] = np.maximum(self.x[WHEEL_SPIN], 0.0)
        self.t += period
        return self.measure()

    def measure(self) -> State:
        x = self.x
        speed = math.copysign(math.hypot(x[3], x[10]), x[3])
        return State(t=self.t, x=float(x[0]), y=float(x[1]), yaw=float(x[4]), v=speed,
                     a=self._accel.update(self.t, speed), yaw_rate=float(x[5]), steer=float(x[2]))

    def body_roll(self) -> float:
        """Roll of the sprung mass [rad], > 0 left side up as the MuJoCo cars' (the model's x[6]
        has the other sign: on a left circle, rolled outwards, it is negative)."""
        return -float(self.x[6])

    def wheel_speeds(self) -> np.ndarray:
        """Circumferential speed of each wheel [m/s] (front left, front right, rear left, rear right)."""
        return self.x[WHEEL_SPIN] * self.p.R_w


def sideslip(before: State, after: State) -> float:
    """Sideslip angle of the centre between two states [rad]: direction of travel (the chord)
    minus the mean heading (a State carries no lateral velocity)."""
    travel = math.atan2(after.y - before.y, after.x - before.x)
    heading = before.yaw + 0.5 * math.atan2(math.sin(after.yaw - before.yaw), math.cos(after.yaw - before.yaw))
    return math.atan2(math.sin(travel - heading), math.cos(travel - heading))


@dataclass(frozen=True)
class CircleHold:
    """Steady state of `hold_circle`, averaged over the last seconds."""

    speed: float
    lateral_acceleration: float
    steer: float
    yaw_rate: float
    sideslip: float
    radius: float


def hold_circle(plant, vehicle: Vehicle, radius: float, speed: float, duration: float = 20.0,
                average_last: float = 5.0, period: float = 0.01) -> CircleHold | None:
    """Drive ``plant`` on a left circle of ``radius`` (centre at (0, radius)) at ``speed``; the
    steady state, or ``None`` when the car did not hold the circle (radius off by more than 2 %)."""
    delta0 = math.atan(vehicle.wheelbase / radius)
    pedals = LongitudinalMap.for_vehicle(vehicle)
    state = plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=speed, yaw_rate=speed / radius, steer=delta0))
    integral, rows, previous = 0.0, [], state
    for k in range(int(round(duration / period))):
        dx, dy = state.x, state.y - radius
        dist = math.hypot(dx, dy)
        e = dist - radius                               # > 0: outside the circle
        tangent = math.atan2(dy, dx) + math.pi / 2
        heading_error = math.atan2(math.sin(state.yaw - tangent), math.cos(state.yaw - tangent))
        integral += e * period
        target = delta0 + 0.05 * e + 0.01 * integral - 0.5 * heading_error
        throttle, brake = pedals.pedals(1.5 * (speed - state.v), max(state.v, 0.0))
        try:
            state = plant.step(Command(target, throttle, brake), period)
        except PhysicsDiverged:
            return None
        if abs(e) > 10.0:
            return None
        if (k + 1) * period > duration - average_last + 1e-9:
            rows.append((state.v, state.yaw_rate, state.steer, sideslip(previous, state),
                         math.hypot(state.x, state.y - radius)))
        previous = state
    v, r, delta, beta, dist = (float(np.mean(col)) for col in zip(*rows))
    if abs(dist - radius) > 0.02 * radius:
        return None
    return CircleHold(v, v * r, delta, r, beta, dist)
