"""A recorded run replayed in the MuJoCo world: the cars' wheels steered and rolled as driven, and
a chase camera that follows the car's body as the world poses it (its height and pitch too)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from simgap.scenario import build_scenario
from simgap.sim.mujoco.car import CORNERS, ackermann_angles
from simgap.sim.mujoco.replay import CHASE_ABOVE, CHASE_AHEAD, CHASE_ELEVATION, CHASE_SIDE, MujocoReplay
from simgap.trajectory import State, Trajectory
from simgap.vehicles import load_vehicle

DT = 0.1


def _circling(speed: float, steer: float, seconds: float = 3.0) -> tuple[Trajectory, float]:
    """A car driven at constant ``speed`` and road-wheel angle ``steer`` (kinematic), and its yaw rate."""
    wheelbase = load_vehicle("sedan").wheelbase
    yaw_rate = speed * math.tan(steer) / wheelbase
    states, x, y = [], 0.0, 0.0
    for k in range(int(round(seconds / DT)) + 1):
        yaw = yaw_rate * k * DT
        states.append(State(k * DT, x, y, yaw, speed, 0.0, yaw_rate, steer))
        x, y = x + speed * math.cos(yaw) * DT, y + speed * math.sin(yaw) * DT
    return Trajectory.from_states(states, DT), yaw_rate


def _replay(driven: Trajectory) -> MujocoReplay:
    scenario = build_scenario("curve", {"radius": 20, "angle": 90}).scenario
    return MujocoReplay(scenario, {1: load_vehicle("sedan")}, {1: driven}, DT)


def test_front_wheels_steer_and_every_wheel_rolls_the_distance_its_corner_drove():
    driven, yaw_rate = _circling(speed=8.0, steer=0.25)
    replay = _replay(driven)
    car, data = replay.world.cars[1], replay.world.data
    replay.pose(2.05)                                   # between two steps

    chassis = data.xmat[car.chassis_body].reshape(3, 3)
    turned = []
    for body in car.wheel_bodies[:2]:
        axle = chassis.T @ data.xmat[body].reshape(3, 3)[:, 1]      # spin axis in the car's frame
        turned.append(math.atan2(-axle[0], axle[1]))
    left, right = ackermann_angles(0.25, car.vehicle.wheelbase, car.physics.track_front)
    assert turned == pytest.approx([left, right], abs=1e-9) and left > 0.25 > right > 0.2

    for k, corner in enumerate(CORNERS):
        offset_left = car.corners[k][1]
        rolled = (8.0 - yaw_rate * offset_left) * 2.05 / car.physics.wheel_radius
        assert data.qpos[car.spin_qpos[k]] == pytest.approx(rolled, rel=1e-9), corner
    assert data.qpos[car.spin_qpos[0]] < data.qpos[car.spin_qpos[1]]   # the inner wheel rolls less


def test_the_chase_camera_follows_the_body_up_a_grade_not_the_ground_plane():
    driven, _ = _circling(speed=10.0, steer=0.0)
    replay = _replay(driven)
    times = np.arange(0.0, 3.0, 0.04)
    flat = replay.chase_cameras(times, 1)
    assert [c.azimuth for c in flat] == pytest.approx([-CHASE_SIDE] * len(times))
    assert [c.elevation for c in flat] == pytest.approx([CHASE_ELEVATION] * len(times))
    assert [c.lookat[0] for c in flat] == pytest.approx(10.0 * times + CHASE_AHEAD)       # it keeps up

    place, car, pitch, lift = replay.world.place, replay.world.cars[1], 0.1, 5.0
    def on_a_grade(agent_id: int, state: State) -> None:             # a world whose road climbs
        place(agent_id, state)
        q = replay.world.data.qpos
        q[car.qpos + 2] += lift
        nose_up = np.array([math.cos(-pitch / 2), 0.0, math.sin(-pitch / 2), 0.0])
        mujoco.mju_mulQuat(q[car.qpos + 3:car.qpos + 7], q[car.qpos + 3:car.qpos + 7].copy(), nose_up)

    replay.world.place = on_a_grade
    climbing = replay.chase_cameras(times, 1)
    assert [c.elevation - CHASE_ELEVATION for c in climbing] == pytest.approx([math.degrees(pitch)] * len(times))
    rise = [c.lookat[2] - f.lookat[2] for c, f in zip(climbing, flat)]
    assert rise == pytest.approx([lift + CHASE_AHEAD * math.sin(pitch)] * len(times))
    assert flat[0].lookat[2] == pytest.approx(car.physics.cg_height + CHASE_ABOVE)


def test_a_replay_on_a_crest_poses_the_car_on_the_road_s_relief():
    """The replay builds the run's relief: along the crest the car's body climbs and falls with
    the road (its height above the surface stays) and pitches with the grade."""
    concrete = build_scenario("crest-curve", {"radius": 30, "vertical_radius": 100})
    relief = concrete.blueprint.road_relief()
    straight = [State(k * DT, 20.0 + 1.5 * k, -1.5, 0.0, 15.0) for k in range(41)]   # up the first straight
    replay = MujocoReplay(concrete.scenario, {1: load_vehicle("sedan")}, {1: Trajectory.from_states(straight, DT)},
                          DT, relief)
    car = replay.world.cars[1]
    heights, pitches = [], []
    for k in (0, 40):
        replay.pose(k * DT)
        body = replay.world.data.xpos[car.chassis_body]
        ground = relief.surface(np.array([body[0]]), np.array([body[1]]))
        heights.append(body[2] - ground.z[0])
        pitches.append(math.asin(replay.world.data.xmat[car.chassis_body].reshape(3, 3)[2, 0]))   # nose up
    assert heights[0] == pytest.approx(heights[1], abs=0.02)            # on the surface, not the plane
    assert replay.world.data.xpos[car.chassis_body][2] > 4.0             # 60 m up an 8 % grade: 4.8 m up
    assert pitches == pytest.approx([math.atan(0.08)] * 2, abs=0.01)
