"""The MuJoCo world built from a scenario: road surface, markings, surface map, static ride height, and on a
road with a relief its terrain."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from commonroad.scenario.lanelet import LineMarking
from shapely.geometry import Polygon
from shapely.ops import unary_union

from simgap.scenario import build_scenario
from simgap.scenario.markings import MARKING_STYLE, marking_lines
from simgap.scenario.relief import tilt_of
from simgap.sim.mujoco.backend import MujocoPhysics
from simgap.sim.mujoco.road import DRAPE_M, ROAD_Z
from simgap.sim.mujoco.settings import WorldSettings
from simgap.sim.mujoco.world import build_world
from simgap.sim.protocol import Agent
from simgap.trajectory import State
from simgap.vehicles import load_vehicle, vehicle_names


def _mesh_top_faces(world, name: str) -> list[np.ndarray]:
    """The upward faces of a drawn mesh, in world coordinates (MuJoCo re-centres and re-orients
    meshes; the geom's pose puts them back)."""
    model, data = world.model, world.data
    mujoco.mj_forward(model, data)
    mesh, geom = model.mesh(name), model.geom(name)
    vert = model.mesh_vert[mesh.vertadr[0]:mesh.vertadr[0] + mesh.vertnum[0]]
    face = model.mesh_face[mesh.faceadr[0]:mesh.faceadr[0] + mesh.facenum[0]]
    world_vert = vert @ data.geom_xmat[geom.id].reshape(3, 3).T + data.geom_xpos[geom.id]
    top = world_vert[:, 2].max()
    return [world_vert[f] for f in face if np.allclose(world_vert[f][:, 2], top, atol=1e-6)]


def _upward_vertices(world, name: str) -> np.ndarray:
    """The vertices of a drawn mesh's faces that look up, in world coordinates."""
    model, data = world.model, world.data
    mujoco.mj_forward(model, data)
    mesh, geom = model.mesh(name), model.geom(name)
    vert = model.mesh_vert[mesh.vertadr[0]:mesh.vertadr[0] + mesh.vertnum[0]]
    face = model.mesh_face[mesh.faceadr[0]:mesh.faceadr[0] + mesh.facenum[0]]
    corners = (vert @ data.geom_xmat[geom.id].reshape(3, 3).T + data.geom_xpos[geom.id])[face]
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    up = normal[:, 2] > 0.9 * np.linalg.norm(normal, axis=1)
    return corners[up].reshape(-1, 3)


@pytest.mark.parametrize("logical, parameters", [("curve", {"radius": 10, "angle": 90}),
                                                 ("t-junction", {}), ("intersection", {})])
def test_road_surface_covers_exactly_the_lanelets(logical, parameters):
    concrete = build_scenario(logical, parameters)
    world = build_world(concrete.scenario, [])
    network = concrete.scenario.lanelet_network
    lanelets = unary_union([Polygon(l.polygon.vertices).buffer(0) for l in network.lanelets])
    triangles = [Polygon(tri[:, :2]) for tri in _mesh_top_faces(world, "road_surface")]
    surface = unary_union([t.buffer(1e-6) for t in triangles])
    assert surface.symmetric_difference(lanelets).area < 1e-3 * lanelets.area
    # every lanelet is drawn and the surface map agrees with the lanelets
    for lanelet in network.lanelets:
        c = np.asarray(lanelet.center_vertices)[len(lanelet.center_vertices) // 2]
        assert world.surface.on_road(np.array([c[0]]), np.array([c[1]]))[0]
    x0, y0, x1, y1 = lanelets.bounds
    assert not world.surface.on_road(np.array([x1 + 5.0]), np.array([y1 + 5.0]))[0]


@pytest.mark.parametrize("logical", ["curve", "intersection"])
def test_markings_follow_the_commonroad_line_markings(logical):
    concrete = build_scenario(logical, {})
    network = concrete.scenario.lanelet_network
    lines = marking_lines(network)
    marked = {m for l in network.lanelets
              for m in (l.line_marking_left_vertices, l.line_marking_right_vertices)} & set(MARKING_STYLE)
    assert marked, "the generated roads carry markings"
    assert {round(line.width, 2) for line in lines} <= {0.12, 0.25}
    for line in lines:
        # every drawn line lies on a lanelet bound (its centre line within half a line width)
        bound = min(np.min(np.linalg.norm(np.asarray(b)[:, None, :] - line.xy[None, :, :], axis=2), axis=0).max()
                     for l in network.lanelets for b in (l.left_vertices, l.right_vertices))
        assert bound < 0.13
    dashed = [line for line in lines if line.dash > 0]
    if LineMarking.DASHED in marked:
        assert dashed
    world = build_world(concrete.scenario, [])
    assert world.model.mesh("road_markings").facenum[0] > 0


@pytest.mark.parametrize("name", vehicle_names())
def test_each_vehicle_stands_still_at_its_static_ride_height(name):
    vehicle = load_vehicle(name)
    concrete = build_scenario("curve", {"radius": 50, "angle": 90})
    world = build_world(concrete.scenario, [Agent(1, vehicle, State(0.0, 10.0, -1.5, 0.0, 0.0))])
    world.place(1, State(0.0, 10.0, -1.5, 0.0, 0.0))
    car = world.cars[1]
    mujoco.mj_forward(world.model, world.data)
    for i in range(4):      # hold the car on its brakes, as a parked car
        world.model.dof_frictionloss[car.spin_dofs[i]] = 500.0
    world.step(1500)                                             # 3 s
    q, v = world.data.qpos, world.data.qvel
    assert q[car.qpos + 2] == pytest.approx(vehicle.physics.cg_height, abs=0.005)
    for adr in car.suspension_qpos:
        assert abs(q[adr]) < 0.005                       # springs at their static deflection
    assert np.abs(v[car.qvel:car.qvel + 6]).max() < 1e-3
    assert q[car.qpos] == pytest.approx(10.0, abs=5e-3) and q[car.qpos + 1] == pytest.approx(-1.5, abs=5e-3)


def test_on_a_relief_the_road_is_drawn_on_the_terrain_and_the_plane_sinks_below_it():
    concrete = build_scenario("curve", {"radius": 30, "angle": 90, "grade": 6, "grade_change": -12, "bank": 6})
    relief = concrete.blueprint.road_relief()
    world = build_world(concrete.scenario, [], relief=relief)
    vertices = _upward_vertices(world, "road_surface")
    below = relief.surface(vertices[:, 0], vertices[:, 1]).z
    assert np.abs(vertices[:, 2] - below - DRAPE_M - ROAD_Z).max() < 0.01      # lifted onto the surface
    assert np.ptp(vertices[:, 2]) > 5.0
    ground = world.model.geom("ground")
    assert ground.contype[0] == 0 and ground.conaffinity[0] == 0       # the plane only draws the land beyond
    assert world.model.geom_pos[ground.id][2] < world.terrain.lowest
    assert world.model.geom("terrain").type[0] == mujoco.mjtGeom.mjGEOM_HFIELD


def test_a_car_placed_on_a_banked_grade_stands_on_it_and_holds_on_its_brakes():
    concrete = build_scenario("curve", {"radius": 50, "angle": 90, "grade": 8, "bank": 8})
    relief = concrete.blueprint.road_relief()
    at = State(0.0, 130.0, 6.0, 0.6, 0.0)                      # in the banked curve, facing uphill
    world = build_world(concrete.scenario, [Agent(1, load_vehicle("sedan"), at)], relief=relief)
    world.place(1, at)
    car = world.cars[1]
    mujoco.mj_forward(world.model, world.data)
    for i in range(4):
        world.model.dof_frictionloss[car.spin_dofs[i]] = 2000.0
    world.step(1500)                                             # 3 s
    q = world.data.qpos[car.qpos:car.qpos + 7]
    surface = relief.surface(q[0], q[1])
    pitch, roll = tilt_of(surface.normal, at.yaw)
    assert pitch > math.radians(3.0) and roll < -math.radians(6.0)      # uphill; the curve's left side lower
    chassis = MujocoPhysics(WorldSettings())
    chassis.world = world
    attitude = chassis.attitude(1)
    assert attitude.pitch == pytest.approx(pitch, abs=math.radians(0.5))
    assert roll - math.radians(2.0) < attitude.roll < roll     # the body leans a little further downhill on its springs
    assert attitude.z - surface.z == pytest.approx(0.575 / surface.normal[2], abs=0.01)
    assert np.hypot(q[0] - at.x, q[1] - at.y) < 0.03       # settled on its springs, where it was put
    assert world.tyres.load.sum() == pytest.approx(1093.3 * 9.81 * surface.normal[2], rel=0.01)
