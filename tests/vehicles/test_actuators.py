"""Each vehicle's actuators respond to a step as their data file says: the dead time, then 63 % of
the step one time constant later (within 10 %)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simgap.vehicles import load_vehicle, vehicle_names
from simgap.vehicles.actuators import ActuatorChannel
from simgap.vehicles.channels import CHANNELS

PERIOD = 0.001      # s: finer than any controller, so the measured figures are the model's own


def step_response(channel: ActuatorChannel, seconds: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    response = channel.response(PERIOD)
    out = np.array([response.step(1.0) for _ in range(int(seconds / PERIOD))])
    return PERIOD * np.arange(1, len(out) + 1), out


def dead_time_and_rise(t: np.ndarray, out: np.ndarray) -> tuple[float, float]:
    """When the output first moves, and how long after that it reaches 63 % of the step."""
    moved = t[np.argmax(out > 1e-9)] - PERIOD
    return moved, t[np.argmax(out >= 1.0 - math.exp(-1.0))] - moved


@pytest.mark.parametrize("name", vehicle_names())
@pytest.mark.parametrize("channel", CHANNELS.values(), ids=list(CHANNELS))
def test_each_actuator_steps_as_its_source_says(name, channel):
    spec = load_vehicle(name).actuators[channel]
    assert spec.source, f"{name}: {channel.section} has no source"
    dead, rise = dead_time_and_rise(*step_response(spec))
    assert dead == pytest.approx(spec.dead_time, rel=0.1, abs=PERIOD)
    assert rise == pytest.approx(spec.time_constant, rel=0.1, abs=PERIOD)


def test_a_second_order_lag_overshoots_by_its_damping():
    zeta, wn = 0.5, 20.0
    t, out = step_response(ActuatorChannel(dead_time=0.05, natural_frequency=wn, damping_ratio=zeta))
    overshoot = out.max() - 1.0
    assert overshoot == pytest.approx(math.exp(-math.pi * zeta / math.sqrt(1 - zeta ** 2)), rel=0.02)
    assert out[-1] == pytest.approx(1.0, abs=1e-3)


def test_a_lag_needs_one_form():
    with pytest.raises(ValueError):
        ActuatorChannel(time_constant=0.1, natural_frequency=10.0, damping_ratio=0.7)
    with pytest.raises(ValueError):
        ActuatorChannel(natural_frequency=10.0)


def test_dead_time_holds_the_starting_value_and_rounds_to_periods():
    response = ActuatorChannel(dead_time=0.03).response(0.01, initial=0.25)
    assert [response.step(v) for v in (1.0, 2.0, 3.0, 4.0, 5.0)] == [0.25, 0.25, 0.25, 1.0, 2.0]


def test_a_channel_says_what_it_is_in_a_line():
    assert ActuatorChannel(dead_time=0.12, time_constant=0.1).summary() == "0.12 s dead time + lag 0.1 s"
    assert ActuatorChannel(dead_time=0.05, natural_frequency=20, damping_ratio=0.7).summary() == \
        "0.05 s dead time + 2nd-order lag 20 rad/s, zeta 0.7"
    assert ActuatorChannel().summary() == "0 s dead time"
