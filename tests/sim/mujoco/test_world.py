"""The MuJoCo world built from a scenario: road surface, markings, surface map, static ride height."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from commonroad.scenario.lanelet import LineMarking
from shapely.geometry import Polygon
from shapely.ops import unary_union

from simgap.scenario import build_scenario
from simgap.scenario.markings import MARKING_STYLE, marking_lines
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
        bound = min((np.min(np.linalg.norm(np.asarray(b)[:, None, :] - line.xy[None, :, :], axis=2), axis=0).max()
                     for l in network.lanelets for b in (l.left_vertices, l.right_vertices)))
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
