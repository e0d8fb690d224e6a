"""The actuator-delay knob: commands arrive whole controller periods late, per channel."""

from __future__ import annotations

from simgap.control.delay import DelayedActuators, with_actuator_delay
from simgap.control.protocol import Command
from simgap.trajectory import State


class Scripted:
    """A controller that asks for steer = k, throttle = k/100, brake = 0 at its k-th call."""

    rate_hz = 100.0

    def __init__(self):
        self.calls = 0

    def reset(self, state):
        self.calls = 0

    def command(self, measured, plan, t):
        self.calls += 1
        return Command(steer=float(self.calls), throttle=self.calls / 100.0, brake=0.0)


def start(steer=0.25):
    return State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=10.0, a=0.0, yaw_rate=0.0, steer=steer)


def test_each_channel_is_delayed_by_its_own_number_of_periods():
    delayed = DelayedActuators(Scripted(), steer_delay_s=0.03, pedal_delay_s=0.05)
    delayed.reset(start(steer=0.25))
    out = [delayed.command(start(), None, k / 100.0) for k in range(8)]
    # steering: 3 periods of the angle held at reset, then the requests in order
    assert [c.steer for c in out] == [0.25, 0.25, 0.25, 1.0, 2.0, 3.0, 4.0, 5.0]
    # pedals: 5 periods released, then the requests in order
    assert [c.throttle for c in out] == [0.0] * 5 + [0.01, 0.02, 0.03]


def test_reset_empties_the_pipeline():
    delayed = DelayedActuators(Scripted(), steer_delay_s=0.02)
    delayed.reset(start())
    for k in range(5):
        delayed.command(start(), None, k / 100.0)
    delayed.reset(start(steer=-0.1))
    assert delayed.command(start(), None, 0.0).steer == -0.1


def test_no_delay_is_the_controller_itself():
    controller = Scripted()
    assert with_actuator_delay(controller, 0.0, 0.0) is controller
    assert isinstance(with_actuator_delay(controller, 0.01, 0.0), DelayedActuators)
