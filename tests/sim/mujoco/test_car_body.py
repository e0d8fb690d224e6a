"""How a car looks in the MuJoCo world: a body of the vehicle's size shaped like a car, wheels that
show through their arches, and a collision box that is not drawn."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from simgap.scenario import build_scenario
from simgap.sim.mujoco.car import COLLISION_GROUP
from simgap.sim.mujoco.world import build_world
from simgap.sim.protocol import Agent
from simgap.trajectory import State
from simgap.vehicles import load_vehicle, vehicle_names

DRAWN = np.array([1 if g != COLLISION_GROUP else 0 for g in range(6)], dtype=np.uint8)


def _world(name: str):
    vehicle = load_vehicle(name)
    world = build_world(build_scenario("curve", {"radius": 20, "angle": 90}).scenario,
                        [Agent(1, vehicle, State(0.0, 0.0, 0.0, 0.0, 0.0))])
    world.place(1, State(0.0, 0.0, 0.0, 0.0, 0.0))
    mujoco.mj_forward(world.model, world.data)
    return world, world.cars[1]


def _world_vertices(world, geom: int) -> np.ndarray:
    model, data = world.model, world.data
    mesh = model.geom_dataid[geom]
    vert = model.mesh_vert[model.mesh_vertadr[mesh]:model.mesh_vertadr[mesh] + model.mesh_vertnum[mesh]]
    return vert @ data.geom_xmat[geom].reshape(3, 3).T + data.geom_xpos[geom]


@pytest.mark.parametrize("name", vehicle_names())
def test_the_drawn_body_has_the_vehicles_length_width_and_height(name):
    world, car = _world(name)
    body = _world_vertices(world, world.model.geom(f"{car.prefix}body_look").id)
    greenhouse = _world_vertices(world, world.model.geom(f"{car.prefix}greenhouse").id)
    length, width = car.vehicle.length, car.vehicle.width
    assert body[:, 0].min() == pytest.approx(-length / 2) and body[:, 0].max() == pytest.approx(length / 2)
    assert body[:, 1].min() == pytest.approx(-width / 2) and body[:, 1].max() == pytest.approx(width / 2)
    assert greenhouse[:, 2].max() == pytest.approx(car.physics.height)          # it stands on z = 0
    assert np.ptp(greenhouse[:, 0]) < 0.7 * length and np.ptp(greenhouse[:, 1]) < width   # a cabin, not a box


@pytest.mark.parametrize("name", vehicle_names())
def test_every_wheel_shows_through_its_arch_and_the_collision_box_is_not_drawn(name):
    world, car = _world(name)
    model, data = world.model, world.data
    hit = np.zeros(1, dtype=np.int32)
    for k, body in enumerate(car.wheel_bodies):
        centre = data.xpos[body]
        side = np.sign(car.corners[k][1])
        distance = mujoco.mj_ray(model, data, centre + [0.0, 3.0 * side, 0.0], [0.0, -side, 0.0], DRAWN, 1, -1, hit)
        assert distance > 0 and model.geom_bodyid[hit[0]] == body            # seen from the side: the wheel
    collides = [g for g in car.geoms if model.geom_contype[g] or model.geom_conaffinity[g]]
    assert [model.geom(g).name for g in collides] == [f"{car.prefix}body"]
    assert model.geom_group[collides[0]] == COLLISION_GROUP
