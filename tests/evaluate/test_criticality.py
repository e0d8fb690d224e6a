"""commonroad-crime measures on a constructed two-vehicle scene with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from commonroad.geometry.shape import Rectangle
from commonroad.prediction.prediction import TrajectoryPrediction
from commonroad.scenario.lanelet import Lanelet, LaneletNetwork
from commonroad.scenario.obstacle import DynamicObstacle, ObstacleType
from commonroad.scenario.scenario import Scenario
from commonroad.scenario.state import CustomState, InitialState
from commonroad.scenario.trajectory import Trajectory as CRTrajectory

from simgap.evaluate.criticality import pair_criticality


def car(oid, x0, v, steps=60, dt=0.1):
    shape = Rectangle(4.5, 1.8)
    init = InitialState(time_step=0, position=np.array([x0, 1.75]), orientation=0.0, velocity=v,
                        acceleration=0.0, yaw_rate=0.0, slip_angle=0.0)
    states = [CustomState(time_step=k, position=np.array([x0 + v * k * dt, 1.75]), orientation=0.0,
                          velocity=v, acceleration=0.0, yaw_rate=0.0, slip_angle=0.0) for k in range(1, steps)]
    return DynamicObstacle(oid, ObstacleType.CAR, shape, init, TrajectoryPrediction(CRTrajectory(1, states), shape))


def scene(follower_speed, leader_speed, gap):
    lanelet = Lanelet(np.array([[0, 3.5], [400, 3.5]]), np.array([[0, 1.75], [400, 1.75]]),
                      np.array([[0, 0.0], [400, 0.0]]), 1)
    scenario = Scenario(0.1)
    scenario.add_objects(LaneletNetwork.create_from_lanelet_list([lanelet]))
    scenario.add_objects(car(11, 10.0, follower_speed))
    scenario.add_objects(car(12, 10.0 + 4.5 + gap, leader_speed))
    return scenario


def worst(results, ego, measure):
    return next(r for r in results if r.ego_id == ego and r.measure == measure)


def test_closing_in_on_a_slower_car():
    # 40 m bumper-to-bumper gap, closing at 10 m/s on constant-speed recordings: they touch at 4 s
    results = pair_criticality(scene(20.0, 10.0, 40.0), {1: 11, 2: 12}, every=1)
    ttc = worst(results, 1, "ttc")
    assert ttc.worst == pytest.approx(0.0, abs=1e-6) and ttc.at_t == pytest.approx(4.0, abs=0.11)
    thw = worst(results, 1, "thw")
    assert thw.worst < 0.2 and thw.at_t == pytest.approx(4.0, abs=0.21)
    assert worst(results, 1, "stn").worst > 0.0          # steering away is needed near the end
    assert math.isinf(worst(results, 2, "ttc").worst)   # the leader is not closing in on anyone


def test_time_to_collision_and_headway_early_on():
    results = pair_criticality(scene(20.0, 10.0, 40.0), {1: 11, 2: 12}, every=100)   # step 0 only
    assert worst(results, 1, "ttc").worst == pytest.approx(4.0, abs=0.05)   # 40 m / 10 m/s
    assert worst(results, 1, "thw").worst == pytest.approx(2.0, abs=0.11)   # 40 m / 20 m/s, to a step


def test_a_faster_leader_is_not_critical():
    results = pair_criticality(scene(10.0, 20.0, 20.0), {1: 11, 2: 12}, every=2)
    assert math.isinf(worst(results, 1, "ttc").worst)


def test_a_single_agent_has_no_pairs():
    assert pair_criticality(scene(10.0, 10.0, 20.0), {1: 11}) == []
