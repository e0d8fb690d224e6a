"""The road in MuJoCo: a drawn surface for every lanelet, the line markings CommonRoad states, and
the surface under each tyre (road or off-road) for the tyre-road friction.

A flat world's tyres roll on one ground plane; on a road with a relief they roll on its terrain
(`simgap.sim.mujoco.terrain`), and the road is drawn lifted onto it (each vertex at the terrain's
height, `DRAPE_M` above it). What the tyre stands on — a lanelet or the verge — decides the
friction of its contact, looked up in the union of the lanelet polygons (`SurfaceMap`). The drawn
road is a mesh on top of the ground and never collides: MuJoCo collides meshes as their convex
hulls, which a curved road is not.
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np
import shapely
from commonroad.scenario.lanelet import LaneletNetwork
from shapely.ops import unary_union

from simgap.polyline import arc_length, offset_polyline
from simgap.scenario.markings import MarkingLine, marking_lines

ROAD_Z = 0.004          # drawn road above the ground plane [m]
MARKING_Z = 0.008       # drawn markings above the ground plane [m]
SLAB = 0.02             # thickness of the drawn slabs [m] (closed meshes have a volume)
DRAPE_M = 0.02          # on a terrain, the drawn road lies this much higher still: over its coarser height field
Ground = Callable[[np.ndarray], np.ndarray]     # height of the ground at each point of (n, 2)


def _strip_pieces(line: MarkingLine) -> list[np.ndarray]:
    """The polylines that are painted: the whole line, or its dashes."""
    xy = line.xy
    if not line.dashed:
        return [xy]
    s = arc_length(xy, by_norm=True)
    pieces, start = [], 0.0
    while start < s[-1]:
        end = min(start + line.dash, s[-1])
        ss = np.concatenate([[start], s[(s > start) & (s < end)], [end]])
        pieces.append(np.column_stack([np.interp(ss, s, xy[:, 0]), np.interp(ss, s, xy[:, 1])]))
        start += line.dash + line.gap
    return [p for p in pieces if len(p) >= 2]


class MeshBuilder:
    """Collects thin closed slabs (strips between two polylines) into one mesh, ``z`` above the
    plane z = 0 or above the ``ground``."""

    def __init__(self, ground: Ground | None = None) -> None:
        self.ground = ground
        self.vertices: list[np.ndarray] = []
        self.faces: list[np.ndarray] = []
        self._n = 0

    def add_strip(self, left: np.ndarray, right: np.ndarray, z: float) -> None:
        """A slab between two polylines running in the same direction, ``left`` on the left
        (its top faces up)."""
        n = len(left)
        if n < 2 or len(right) != n:
            return
        edges = np.vstack([left, right])
        top = np.column_stack([edges, np.full(2 * n, z) if self.ground is None else self.ground(edges) + DRAPE_M + z])
        bottom = top.copy()
        bottom[:, 2] = z - SLAB
        self.vertices += [top, bottom]
        o = self._n
        faces = []
        for i in range(n - 1):
            l0, l1, r0, r1 = o + i, o + i + 1, o + n + i, o + n + i + 1
            faces += [[l0, r0, r1], [l0, r1, l1]]                                   # top (up)
            b = 2 * n
            faces += [[l0 + b, r1 + b, r0 + b], [l0 + b, l1 + b, r1 + b]]          # bottom (down)
            faces += [[l0, l1 + b, l0 + b], [l0, l1, l1 + b]]                       # left side
            faces += [[r0, r0 + b, r1 + b], [r0, r1 + b, r1]]                       # right side
        self.faces.append(np.asarray(faces))
        self._n += 4 * n

    def add_ribbon(self, xy: np.ndarray, width: float, z: float) -> None:
        self.add_strip(offset_polyline(xy, width / 2), offset_polyline(xy, -width / 2), z)

    def add_to(self, spec: mujoco.MjSpec, name: str) -> bool:
        if not self.faces:
            return False
        mesh = spec.add_mesh(name=name)
        mesh.uservert = np.vstack(self.vertices).ravel().tolist()
        mesh.userface = np.vstack(self.faces).ravel().astype(int).tolist()
        mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
        return True


def add_road(spec: mujoco.MjSpec, network: LaneletNetwork, ground: Ground | None = None) -> None:
    """Draw every lanelet and every marking on the plane z = 0 or on the ``ground`` (visual only)."""
    road = MeshBuilder(ground)
    for lanelet in network.lanelets:
        left = np.asarray(lanelet.left_vertices, dtype=float)
        right = np.asarray(lanelet.right_vertices, dtype=float)
        road.add_strip(left, right, ROAD_Z)
    if road.add_to(spec, "road_surface"):
        spec.worldbody.add_geom(name="road_surface", type=mujoco.mjtGeom.mjGEOM_MESH, meshname="road_surface",
                                material="asphalt", contype=0, conaffinity=0, group=1, mass=0)
    paint = MeshBuilder(ground)
    for line in marking_lines(network):
        for piece in _strip_pieces(line):
            paint.add_ribbon(piece, line.width, MARKING_Z)
    if paint.add_to(spec, "road_markings"):
        spec.worldbody.add_geom(name="road_markings", type=mujoco.mjtGeom.mjGEOM_MESH, meshname="road_markings",
                                rgba=[0.95, 0.95, 0.92, 1.0], contype=0, conaffinity=0, group=1, mass=0)


class SurfaceMap:
    """Which surface a point of the ground belongs to: a lanelet (road) or the verge (off-road). A
    network without lanelets is an open proving ground: asphalt everywhere."""

    def __init__(self, network: LaneletNetwork, tolerance: float = 0.02):
        self.area = None
        if network.lanelets:
            self.area = unary_union([l.polygon.shapely_object.buffer(tolerance) for l in network.lanelets])
            shapely.prepare(self.area)

    def on_road(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        if self.area is None:
            return np.ones(np.shape(x), dtype=bool)
        return shapely.contains_xy(self.area, x, y)
