"""The single-track plant: CommonRoad's ST model behind a steering servo and the pedal map."""

from __future__ import annotations

import math

import pytest

from simgap.control import Command
from simgap.control.longitudinal import LongitudinalMap
from simgap.errors import InputError
from simgap.sim.dynamic import SingleTrackPlant, single_track_parameters
from simgap.sim.dynamic.plant import Slope
from simgap.trajectory import State
from simgap.vehicles import load_vehicle


@pytest.fixture(scope="module")
def sedan():
    return load_vehicle("sedan")


def _hold(plant, cmd, seconds, dt=0.01):
    states = []
    for _ in range(round(seconds / dt)):
        states.append(plant.step(cmd, dt))
    return states


def test_parameters_follow_the_vehicle(sedan):
    p = single_track_parameters(sedan, 2)
    assert p.a == pytest.approx(1.1561957, abs=1e-3) and p.b == pytest.approx(1.4227, abs=1e-6)
    assert p.m == pytest.approx(1093.3, abs=0.1)
    assert p.steering.v_max == 0.4 and p.longitudinal.a_max == 11.5
    heavy = sedan.model_copy(update={"physics": {"mass": 2186.6}})
    assert single_track_parameters(heavy, 2).I_z == pytest.approx(2 * p.I_z, rel=1e-3)
    with pytest.raises(InputError) as err:
        single_track_parameters(sedan, 7)
    assert err.value.field == "params_id"


def test_throttle_gives_the_mapped_acceleration(sedan):
    plant = SingleTrackPlant(sedan)
    plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=3.0))
    states = _hold(plant, Command(0.0, 0.4, 0.0), 1.0)
    expected = LongitudinalMap.for_vehicle(sedan).acceleration(0.4, 0.0, states[-1].v)
    assert states[-1].a == pytest.approx(expected, rel=0.02)      # after the 0.1 s lag
    assert states[-1].y == 0.0 and states[-1].yaw == 0.0


def test_brake_stops_and_never_reverses(sedan):
    plant = SingleTrackPlant(sedan)
    plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=5.0))
    states = _hold(plant, Command(0.0, 0.0, 1.0), 3.0)
    assert min(s.v for s in states) == 0.0
    assert states[-1].v == 0.0 and states[-1].a == 0.0
    x_stop = states[-1].x
    # full brake as the pedal map says, reached through the 0.1 s powertrain/brake lag
    decel = -LongitudinalMap.for_vehicle(sedan).acceleration(0.0, 1.0, 2.5)
    assert x_stop == pytest.approx(5.0 ** 2 / (2 * decel) + 5.0 * 0.1, rel=0.05)
    assert _hold(plant, Command(0.0, 0.0, 1.0), 1.0)[-1].x == x_stop


def test_steering_rate_and_angle_limits(sedan):
    plant = SingleTrackPlant(sedan)
    plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=5.0))
    s = _hold(plant, Command(0.3, 0.0, 0.0), 0.25)[-1]
    assert s.steer == pytest.approx(0.1, abs=0.002)      # 0.4 rad/s
    s = _hold(plant, Command(3.0, 0.0, 0.0), 5.0)[-1]
    assert s.steer == pytest.approx(1.066, abs=1e-6)


def test_low_speed_turn_is_kinematic(sedan):
    plant = SingleTrackPlant(sedan)
    lwb = sedan.wheelbase
    steer = 0.2
    plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=2.0, steer=steer))
    hold = Command(steer, LongitudinalMap.for_vehicle(sedan).pedals(0.0, 2.0)[0], 0.0)
    s = _hold(plant, hold, 2.0)[-1]
    beta = math.atan(math.tan(steer) * sedan.rear_axle_to_center / lwb)
    assert s.v == pytest.approx(2.0, abs=1e-3)
    assert s.yaw_rate == pytest.approx(2.0 * math.cos(beta) * math.tan(steer) / lwb, rel=0.02)


def test_integration_has_converged(sedan):
    def run(step):
        plant = SingleTrackPlant(sedan, integration_step=step)
        plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=15.0))
        for k in range(300):
            plant.step(Command(0.05 * math.sin(0.02 * k), 0.2, 0.0), 0.01)
        return plant.state

    coarse, fine = run(1e-3), run(2.5e-4)
    assert coarse.x == pytest.approx(fine.x, abs=1e-4)
    assert coarse.y == pytest.approx(fine.y, abs=1e-4)
    assert coarse.yaw == pytest.approx(fine.yaw, abs=1e-5)


def test_step_needs_a_reset(sedan):
    with pytest.raises(RuntimeError):
        SingleTrackPlant(sedan).step(Command(0.0, 0.0, 0.0), 0.01)


@pytest.mark.parametrize("integration_step", [0.001, 0.004, 0.01])
@pytest.mark.parametrize("speed", [0.11, 0.2, 0.5])
def test_walking_pace_stays_stable_with_a_coarse_sub_step(sedan, integration_step, speed):
    """Above 0.1 m/s the model's slip dynamics are stiff (rates grow as 1/v): with a 4 ms sub-step
    a car at 0.2 m/s once spun at 2000 rad/s. Steering gently at walking pace turns it gently."""
    plant = SingleTrackPlant(sedan, integration_step=integration_step)
    plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=speed))
    states = _hold(plant, Command(steer=0.05, throttle=0.0, brake=0.0), 0.1, dt=0.1)
    kinematic = speed * math.tan(0.05) / (plant.p.a + plant.p.b)     # the yaw rate it can reach at most
    assert abs(states[-1].yaw_rate) <= kinematic + 1e-3


def _stop(plant, state: State, dt: float = 0.01) -> float:
    """Distance to standstill on full brakes from ``state``."""
    plant.reset(state)
    x0 = state.x
    while plant.state.v > 1e-6:
        plant.step(Command(0.0, 0.0, 1.0), dt)
    return plant.state.x - x0


@pytest.mark.parametrize("grade", [10.0, -10.0])
def test_a_slope_pulls_the_car_along_it(sedan, grade):
    pull = -9.81 * math.sin(math.atan(grade / 100.0))
    start = State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=20.0)
    flat = _stop(SingleTrackPlant(sedan, accel_time_constant=0.0), start)
    plant = SingleTrackPlant(sedan, accel_time_constant=0.0)
    plant.slope = Slope(along=pull, across=0.0)
    braking = 20.0 ** 2 / (2.0 * flat)                     # the flat road's deceleration
    assert _stop(plant, start) == pytest.approx(20.0 ** 2 / (2.0 * (braking - pull)), rel=0.01)


def test_brakes_hold_a_car_on_a_slope_and_a_side_pull_turns_its_course(sedan):
    plant = SingleTrackPlant(sedan)
    plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=0.0))
    plant.slope = Slope(along=9.81 * math.sin(math.atan(0.2)), across=0.0)       # 20 % downhill ahead
    assert _hold(plant, Command(0.0, 0.0, 1.0), 3.0)[-1].x == 0.0
    rolling = _hold(plant, Command(0.0, 0.0, 0.0), 1.0)[-1]
    assert rolling.v == pytest.approx(1.9, abs=0.1)      # brakes off: it rolls away at g sin(theta)
    drift = {}
    for across in (1.0, -1.0):                           # a bank falling to the left, to the right
        plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=15.0))
        plant.slope = Slope(along=0.0, across=across)
        drift[across] = _hold(plant, Command(0.0, 0.0, 0.0), 2.0)[-1].y
    assert drift[1.0] > 0.05 and drift[-1.0] == pytest.approx(-drift[1.0])    # the tyres' slip holds most of it
