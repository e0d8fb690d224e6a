"""Actuator delay: a reality knob. Real steering and powertrain/brake systems act some time after
they are asked to; the ideal world assumes they act at once.

`DelayedActuators` wraps any controller and delivers each channel's command a whole number of
controller periods late (a pure transport delay, rounded to the controller's rate): the steering
request after ``steer_delay_s``, throttle and brake after ``pedal_delay_s``. Until the first
request comes through, the steering holds the angle it had at reset and the pedals are released.
"""

from __future__ import annotations

from collections import deque

from simgap.control.protocol import Command, Controller
from simgap.trajectory import State, Trajectory


class DelayedActuators:
    """``controller`` with its steering and pedal commands delayed (see the module doc)."""

    def __init__(self, controller: Controller, steer_delay_s: float = 0.0, pedal_delay_s: float = 0.0):
        if steer_delay_s < 0 or pedal_delay_s < 0:
            raise ValueError("actuator delays must be >= 0")
        self.controller = controller
        self.rate_hz = controller.rate_hz
        self.steer_ticks = round(steer_delay_s * self.rate_hz)
        self.pedal_ticks = round(pedal_delay_s * self.rate_hz)
        self._steer: deque[float] = deque()
        self._pedals: deque[tuple[float, float]] = deque()

    def reset(self, state: State) -> None:
        self.controller.reset(state)
        self._steer = deque([state.steer] * self.steer_ticks)
        self._pedals = deque([(0.0, 0.0)] * self.pedal_ticks)

    def command(self, measured: State, plan: Trajectory, t: float) -> Command:
        asked = self.controller.command(measured, plan, t)
        self._steer.append(asked.steer)
        self._pedals.append((asked.throttle, asked.brake))
        throttle, brake = self._pedals.popleft()
        return Command(steer=self._steer.popleft(), throttle=throttle, brake=brake)


def with_actuator_delay(controller: Controller, steer_delay_s: float, pedal_delay_s: float) -> Controller:
    """``controller`` itself when both delays are zero, else wrapped in `DelayedActuators`."""
    if steer_delay_s == 0 and pedal_delay_s == 0:
        return controller
    return DelayedActuators(controller, steer_delay_s, pedal_delay_s)
