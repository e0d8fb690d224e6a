"""Delay compensation: a controller that knows its car's actuators are late steers the car it will
have when its command acts, not the one it measures now — as Autoware's MPC (``input_delay``,
``vehicle_model_steer_tau``) and openpilot's controls (``steerActuatorDelay``) do.

`DelayCompensation` wraps any tracking controller. It mirrors the car's steering actuator
(`simgap.vehicles.actuators.ChannelResponse`) with the angles it has asked for, and each period
predicts the measured state forward over the steering's effective delay (dead time + lag): the
road-wheel angle from the requests already in flight, the pose by a kinematic single-track model,
the speed with the measured acceleration. The wrapped controller then commands from that
predicted state at that later time. With ideal actuators there is nothing to compensate and the
controller is used as it is (`compensated`).
"""

from __future__ import annotations

import math

from simgap.control.protocol import Command, Controller
from simgap.trajectory import State, Trajectory
from simgap.vehicles.actuators import Actuators
from simgap.vehicles.channels import Steering


class DelayCompensation:
    """``controller`` commanding from the state predicted over the actuators' delay."""

    def __init__(self, controller: Controller, actuators: Actuators, wheelbase: float, rear_axle_to_center: float):
        self.controller, self.actuators = controller, actuators
        self.rate_hz = controller.rate_hz
        self.period = 1.0 / self.rate_hz
        self.wheelbase, self.rear_axle_to_center = wheelbase, rear_axle_to_center
        steering = actuators[Steering]
        self.dead_ticks = int(round(steering.dead_time / self.period))
        if steering.order == 2:
            wn, zeta = steering.second_order_lag()
            lag = 2.0 * zeta / wn
        else:
            lag = steering.time_constant if steering.order == 1 else 0.0
        self.lag_ticks = int(round(lag / self.period))
        self.horizon = (self.dead_ticks + self.lag_ticks) * self.period
        self._steering = steering.response(self.period)

    def reset(self, state: State) -> None:
        self.controller.reset(state)
        self._steering = self.actuators[Steering].response(self.period, Steering.start(state))

    def command(self, measured: State, plan: Trajectory, t: float) -> Command:
        asked = self.controller.command(self.predict(measured), plan, t + self.horizon)
        self._steering.step(asked.steer)
        return asked

    def predict(self, measured: State) -> State:
        """``measured`` carried forward over the horizon: the steering acts the requests in flight,
        then holds the last one; the centre follows the arc of the mean kinematic curvature
        (single-track, sideslip from the steering angle); the speed, the measured acceleration."""
        n = self.dead_ticks + self.lag_ticks
        if n == 0:
            return measured
        steer, tan_sum = self._steering_ahead(n)
        horizon, wheelbase = self.horizon, self.wheelbase
        v = measured.v
        v_end = max(0.0, v + measured.a * horizon)
        travel = 0.5 * (v + v_end) * horizon
        turn = travel * tan_sum / (n * wheelbase)                  # yaw change over the horizon
        slip = math.atan(self.rear_axle_to_center / wheelbase * math.tan(steer))
        chord = travel * (math.sin(0.5 * turn) / (0.5 * turn) if abs(turn) > 1e-9 else 1.0)
        heading = measured.yaw + 0.5 * turn + 0.5 * (slip + math.atan(self.rear_axle_to_center / wheelbase
                                                                      * math.tan(measured.steer)))
        yaw = (measured.yaw + turn + math.pi) % (2.0 * math.pi) - math.pi
        return State(measured.t + horizon, measured.x + chord * math.cos(heading), measured.y + chord * math.sin(heading),
                     yaw, v_end, measured.a, v_end * math.tan(steer) / wheelbase, steer)

    def _steering_ahead(self, n: int) -> tuple[float, float]:
        """The road-wheel angle ``n`` periods ahead and the sum of its tangents over them: the
        requests in flight, then the last one held (a first-order lag inline: a hot path)."""
        response = self._steering
        pending = response.in_flight
        held = pending[-1] if pending else response.output
        if response.order == 2:
            ahead = response.copy()
            angles = [ahead.step(held) for _ in range(n)]
            return angles[-1], sum(math.tan(a) for a in angles)
        alpha = response.alpha if response.order == 1 else 1.0
        angle, tan_sum, tan = response.output, 0.0, math.tan
        for k in range(n):
            angle += alpha * ((pending[k] if k < len(pending) else held) - angle)
            tan_sum += tan(angle)
        return angle, tan_sum


def compensated(controller: Controller, actuators: Actuators, wheelbase: float, rear_axle_to_center: float,
                compensate: bool = True) -> Controller:
    """``controller`` itself when the actuators are ideal or compensation is off, else wrapped in
    `DelayCompensation`."""
    if actuators.ideal or not compensate:
        return controller
    return DelayCompensation(controller, actuators, wheelbase, rear_axle_to_center)
