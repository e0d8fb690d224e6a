"""The MuJoCo cars under their tracking controllers, without the planner."""

from __future__ import annotations

import numpy as np
import pytest

from simgap.control import controller_names, make_controller, manoeuvres
from simgap.sim.dynamic import track_plans
from simgap.sim.mujoco.plant import MujocoPlant
from simgap.vehicles import load_vehicle, vehicle_names

CIRCLE_BOUND_M = 0.05     # steady lateral error on a 50 m circle at 15 m/s (measured: < 0.01 m)


@pytest.mark.parametrize("vehicle_name", vehicle_names())
@pytest.mark.parametrize("controller", controller_names())
def test_each_controller_tracks_a_circle(vehicle_name, controller):
    vehicle = load_vehicle(vehicle_name)
    man = manoeuvres.circle(vehicle, 50.0, 15.0, duration=15.0)
    states = track_plans(MujocoPlant(vehicle), make_controller(controller, vehicle, 100.0),
                         lambda t, s: man.plan(t, 3.0), man.initial_state(), man.duration)
    t = np.array([s.t for s in states])
    lateral = np.array([man.lateral_error(s.x, s.y) for s in states])
    v = np.array([s.v for s in states])
    steady = t >= 5.0
    assert np.abs(lateral[steady]).max() < CIRCLE_BOUND_M
    assert np.abs(v[steady] - 15.0).max() < 0.1
    # the car really went round: 225 m of the 314 m circle in 15 s, 4.5 rad of heading
    heading = np.unwrap([s.yaw for s in states])
    assert heading[-1] - heading[0] == pytest.approx(4.5, abs=0.05)


@pytest.mark.parametrize("vehicle_name", vehicle_names())
def test_a_moving_start_keeps_its_speed(vehicle_name):
    vehicle = load_vehicle(vehicle_name)
    man = manoeuvres.speed_step(vehicle, 20.0, 20.0, duration=5.0)
    states = track_plans(MujocoPlant(vehicle), make_controller("pure_pursuit", vehicle, 100.0),
                         lambda t, s: man.plan(t, 3.0), man.initial_state(), man.duration)
    v = np.array([s.v for s in states])
    y = np.array([s.y for s in states])
    assert v[0] == pytest.approx(20.0, abs=1e-6)        # measured from the physics at once
    assert np.abs(v - 20.0).max() < 0.25                  # no launch from standstill, no jolt
    assert np.abs(y).max() < 0.02
    assert states[-1].x == pytest.approx(100.0, abs=0.5)
