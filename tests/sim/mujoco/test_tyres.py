"""The slip-based tyres of the MuJoCo cars: the physics a kinematic bicycle does not have."""

from __future__ import annotations

import math
from importlib import resources

import numpy as np
import pytest

from simgap.control import make_controller, manoeuvres
from simgap.control.protocol import Command
from simgap.errors import InputError
from simgap.sim.dynamic import track_plans
from simgap.sim.mujoco.plant import MujocoPlant
from simgap.sim.protocol import PhysicsDiverged
from simgap.trajectory import State
from simgap.vehicles import load_vehicle
from simgap.vehicles.catalogue import load_vehicle_file

RADIUS = 50.0


@pytest.fixture(scope="module")
def sedan():
    return load_vehicle("sedan")


def _circle(vehicle, speed: float, duration: float = 8.0, **world):
    """Drive a R = 50 m circle; the plant (its tyres in their last state) and the states."""
    man = manoeuvres.circle(vehicle, RADIUS, speed, duration=duration)
    plant = MujocoPlant(vehicle, **world)
    states = track_plans(plant, make_controller("pure_pursuit", vehicle, 100.0),
                         lambda t, s: man.plan(t, 3.0), man.initial_state(), man.duration)
    lateral = np.array([man.lateral_error(s.x, s.y) for s in states])
    return plant, states, lateral


def _sideslip(plant) -> float:
    """Angle from the heading to the centre's velocity [rad], from the physics state."""
    world, car = plant.world, plant.world.cars[1]
    vx, vy = world.data.qvel[car.qvel:car.qvel + 2]
    state = plant.physics.measure(1, 0.0)
    return math.remainder(math.atan2(vy, vx) - state.yaw, math.tau)


def test_a_slip_angle_appears_and_grows_with_lateral_acceleration(sedan):
    slow, _, _ = _circle(sedan, 8.0)         # 0.13 g
    fast, _, _ = _circle(sedan, 16.0)        # 0.52 g
    alpha_slow = np.degrees(np.abs(slow.world.tyres.slip_angle))
    alpha_fast = np.degrees(np.abs(fast.world.tyres.slip_angle))
    assert alpha_slow.min() > 0.1                  # a Coulomb tyre: exactly 0 below the limit
    assert alpha_fast.min() > 3.0 * alpha_slow.max()   # a_y grew 4x; the linear range of the tyre
    assert alpha_fast.max() < 6.0                  # well below the peak, still held


def test_sideslip_falls_with_speed_on_a_circle(sedan):
    betas = [math.degrees(_sideslip(_circle(sedan, v)[0])) for v in (6.0, 12.0, 18.0)]
    kinematic = math.degrees(math.atan(sedan.rear_axle_to_center / RADIUS))     # 1.63 deg
    assert betas[0] == pytest.approx(kinematic, abs=0.3)      # slow: nearly the kinematic angle
    assert betas[0] > betas[1] + 0.3 > betas[2] + 0.6         # falls with speed ...
    assert betas[2] < 0.0                                     # ... and turns (the nose points in)


def test_yaw_lags_a_steering_step(sedan):
    speed = 80.0 / 3.6
    plant = MujocoPlant(sedan)
    state = plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=speed))
    target = math.radians(1.5)
    states = [state]
    for _ in range(300):                       # 3 s, 10 ms steps; a little throttle holds the speed
        states.append(plant.step(Command(target, 0.08, 0.0), 0.01))
    t = np.array([s.t for s in states])
    steer = np.array([s.steer for s in states])
    yaw_rate = np.array([s.yaw_rate for s in states])
    steady = yaw_rate[t > 2.5].mean()
    assert steady > 0.0
    steer_done = t[np.argmax(steer >= 0.9 * target)]
    yaw_done = t[np.argmax(yaw_rate >= 0.9 * steady)]
    assert yaw_done - steer_done > 0.05           # the tyres must build slip first
    assert yaw_rate[np.argmax(steer >= target * 0.999)] < 0.8 * steady


def test_lower_road_friction_lowers_the_limit(sedan):
    speed = 17.0                                     # 0.59 g on the 50 m circle
    _, _, dry = _circle(sedan, speed, duration=10.0)
    _, states, wet = _circle(sedan, speed, duration=10.0, road_friction=0.5)
    assert np.abs(dry[-200:]).max() < 0.1
    assert np.abs(wet).max() > 2.0                  # beyond 0.5 g: the car leaves the circle


def test_a_braked_car_holds_still_on_a_slope(sedan):
    plant = MujocoPlant(sedan, road_grade=8.0)       # 14 % uphill ahead of the car: the proving ground tilted
    plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=0.0))
    states = [plant.step(Command(0.0, 0.0, 1.0), 0.01) for _ in range(500)]    # 5 s on the brakes
    x = np.array([s.x for s in states])
    v = np.array([s.v for s in states])
    assert abs(x[-1] - x[0]) < 0.01                  # no creep down the slope
    assert np.abs(v[-200:]).max() < 2e-3             # and no jitter
    assert np.ptp(x[-200:]) < 1e-3
    assert math.degrees(plant.physics.attitude(1).pitch) == pytest.approx(8.0, abs=0.5)    # nose up, on the slope


def test_a_tilted_proving_ground_is_a_plane_along_the_cars_heading_and_takes_no_relief_too(sedan):
    from simgap.scenario.relief import RoadTilt
    from simgap.sim.mujoco.plant import tilted_ground

    ground = tilted_ground(RoadTilt(road_bank=3.0, road_grade=5.0), State(t=0.0, x=10.0, y=0.0, yaw=math.pi / 2, v=0.0))
    z = ground.surface(np.array([10.0, 10.0, 12.0]), np.array([0.0, 30.0, 0.0])).z     # the car faces +y
    assert z[1] - z[0] == pytest.approx(30.0 * math.tan(math.radians(5.0)))          # uphill ahead
    assert z[0] - z[2] == pytest.approx(2.0 * math.tan(math.radians(3.0)))           # falling to its right
    with pytest.raises(InputError, match="a proving ground of a given relief is not tilted"):
        MujocoPlant(sedan, ground, road_grade=2.0)


def test_a_car_on_its_side_is_diverged_physics_with_its_reason(sedan):
    plant = MujocoPlant(sedan)
    plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=10.0))
    car, data = plant.world.cars[1], plant.world.data
    data.qpos[car.qpos + 2] = 1.0
    data.qpos[car.qpos + 3:car.qpos + 7] = [math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0]    # rolled 90 deg
    with pytest.raises(PhysicsDiverged, match="on its side or roof"):
        plant.step(Command(0.0, 0.0, 0.0), 0.01)


def test_bad_tyre_data_names_the_file_and_field(tmp_path):
    text = (resources.files("simgap.vehicles") / "data" / "sedan.yaml").read_text()
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace("p_ky1: -21.92", "p_ky1: 21.92"))
    with pytest.raises(InputError) as err:
        load_vehicle_file(bad)
    assert "bad.yaml" in str(err.value) and "physics.tyres.magic_formula.p_ky1" in str(err.value)


@pytest.mark.parametrize("name", ["sedan", "suv", "city"])
def test_a_car_steered_beyond_its_limit_slides_and_does_not_roll_over(name):
    """80 km/h on flat ground, the wheels turned 8 deg (2.5 g on the kinematic radius): the
    tyres saturate and the car ploughs or spins, all four wheels on the ground, the body's roll
    bounded (no anti-roll bars and no load sensitivity: the sedan rolled over here)."""
    vehicle = load_vehicle(name)
    plant = MujocoPlant(vehicle)
    plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=80.0 / 3.6))
    world, car = plant.world, plant.world.cars[1]
    roll, least_load, slip = [], [], []
    for _ in range(300):                                   # 3 s
        state = plant.step(Command(math.radians(8.0), 0.0, 0.0), 0.01)
        m = world.data.xmat[car.chassis_body]
        roll.append(abs(math.atan2(m[7], m[8])))
        least_load.append(world.tyres.load.min())
        slip.append(np.abs(world.tyres.slip_angle).max())
    assert math.degrees(max(roll)) < 9.0
    assert min(least_load) > 100.0                         # N: no wheel lifts
    assert math.degrees(np.mean(slip[-100:])) > 7.0        # far past the linear range: sliding
    assert abs(state.v * state.yaw_rate) < 1.1 * 9.81      # the friction caps a_y


def test_a_world_given_a_tilt_but_no_ground_to_lay_it_on_refuses_to_drive_flat():
    from simgap.sim.mujoco.backend import MujocoPhysics
    from simgap.sim.mujoco.plant import proving_ground
    from simgap.sim.mujoco.settings import WorldSettings

    with pytest.raises(ValueError, match="road_bank and road_grade tilt the road's relief"):
        MujocoPhysics(WorldSettings(road_grade=5.0)).load(proving_ground(), [], None)
