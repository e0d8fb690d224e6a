"""How a car looks in the MuJoCo world, from its length, width, height and wheels: a body shaped
like a car (a side profile with bonnet, boot and wheel arches; a greenhouse of tinted glass with
a roof in the body's colour; head and tail lamps) and wheels whose spokes show them roll.

Everything here is drawn only: no geom collides or weighs (the chassis' collision box is built
with the car, `simgap.sim.mujoco.car`). The chassis frame is the car's: x forward, y left, z up,
origin at the centre of gravity at static ride height, so the ground is at z = -cg_height.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import shapely
from shapely.geometry import Point, Polygon

from simgap.vehicles import Vehicle
from simgap.vehicles.physics import VehiclePhysics

GLASS = (0.16, 0.19, 0.24, 1.0)
HEAD_LAMP = (0.96, 0.94, 0.78, 1.0)
TAIL_LAMP = (0.78, 0.06, 0.06, 1.0)
TYRE = (0.08, 0.08, 0.08, 1.0)
RIM = (0.75, 0.75, 0.78, 1.0)
SPOKE = (0.35, 0.35, 0.38, 1.0)

# the side profile, in fractions of the body height H above the ground and of the length L
CLEARANCE = 0.5          # of the wheel radius: the sills' height above the ground
WAIST = 0.58             # of H: the belt line, where the glass starts
BONNET = 0.48            # of H: the nose's top edge
BOOT = 0.55              # of H: the boot lid's rear edge
WINDSCREEN_BASE = 0.30   # of L behind the front
REAR_WINDOW_BASE = 0.17  # of L ahead of the rear
WINDSCREEN_RAKE = 1.1    # horizontal run of the windscreen per metre of glass height
REAR_WINDOW_RAKE = 0.8
GREENHOUSE_WIDTH = (0.90, 0.78)   # of W: the glass at the belt line and at the roof
ARCH_GAP = 0.06          # m between the tyre and its wheel arch
LAMP = (0.05, 0.11)      # m: a lamp's depth and height


def add_body_look(spec: mujoco.MjSpec, chassis: mujoco.MjsBody, prefix: str, vehicle: Vehicle,
                  physics: VehiclePhysics, rgba: tuple[float, float, float, float]) -> None:
    """Draw the body of ``vehicle`` on ``chassis``, painted ``rgba``."""
    length, width, height, ground = vehicle.length, vehicle.width, physics.height, -physics.cg_height
    front, rear = length / 2, -length / 2
    waist, roof = ground + WAIST * height, ground + height
    screen, back = front - WINDSCREEN_BASE * length, rear + REAR_WINDOW_BASE * length

    arches = [Point(x, physics.wheel_radius + ground).buffer(physics.wheel_radius + ARCH_GAP, quad_segs=8)
              for x in (vehicle.front_axle_to_center, -vehicle.rear_axle_to_center)]
    sill = ground + CLEARANCE * physics.wheel_radius
    nose, boot = ground + BONNET * height, ground + BOOT * height
    profile = Polygon([(rear + 0.10, sill), (front - 0.15, sill), (front, sill + 0.15), (front, nose - 0.05),
                       (front - 0.10, nose), (screen, waist), (back, waist), (rear + 0.05, boot),
                       (rear, boot - 0.08), (rear, sill + 0.12)]).difference(shapely.union_all(arches))
    _add_mesh(spec, chassis, f"{prefix}body_look", _prism(profile, width / 2), rgba)

    glass_low, glass_high = (f * width / 2 for f in GREENHOUSE_WIDTH)
    roof_front = screen - WINDSCREEN_RAKE * (roof - waist)
    roof_rear = back + REAR_WINDOW_RAKE * (roof - waist)
    greenhouse = np.array([(x, side * half, z) for x, z, half in ((screen, waist, glass_low), (back, waist, glass_low),
                                                                   (roof_front, roof, glass_high),
                                                                   (roof_rear, roof, glass_high))
                           for side in (-1.0, 1.0)])
    _add_mesh(spec, chassis, f"{prefix}greenhouse", (greenhouse, None), GLASS)
    chassis.add_geom(name=f"{prefix}roof", type=mujoco.mjtGeom.mjGEOM_BOX,
                     size=[(roof_front - roof_rear) / 2 + 0.02, glass_high + 0.01, 0.015],
                     pos=[(roof_front + roof_rear) / 2, 0, roof], rgba=list(rgba),
                     contype=0, conaffinity=0, mass=0)

    for name, x, z, colour in (("head_lamp", front, nose - 0.05 - LAMP[1], HEAD_LAMP),
                               ("tail_lamp", rear, boot - 0.08 - LAMP[1], TAIL_LAMP)):
        for side in (-1.0, 1.0):
            chassis.add_geom(name=f"{prefix}{name}_{'left' if side > 0 else 'right'}",
                             type=mujoco.mjtGeom.mjGEOM_BOX, size=[LAMP[0] / 2, 0.1 * width, LAMP[1] / 2],
                             pos=[x - math.copysign(LAMP[0] / 2 - 0.01, x), side * 0.34 * width, z],
                             rgba=list(colour), contype=0, conaffinity=0, mass=0)


def add_wheel_look(wheel: mujoco.MjsBody, prefix: str, corner: str, physics: VehiclePhysics) -> None:
    """Draw a wheel on its spinning body: the tyre, the rim and a cross of spokes that shows it turn."""
    r, half_width = physics.wheel_radius, physics.wheel_width / 2
    upright = [math.sqrt(0.5), math.sqrt(0.5), 0, 0]          # a cylinder's axis along the spin axis y
    for part, radius, half, colour in (("tyre_look", r, half_width, TYRE), ("rim", 0.6 * r, half_width + 0.005, RIM)):
        wheel.add_geom(name=f"{prefix}{part}_{corner}", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[radius, half, 0],
                       quat=upright, rgba=list(colour), contype=0, conaffinity=0, mass=0)
    for k, angle in enumerate((0.0, math.pi / 2)):
        wheel.add_geom(name=f"{prefix}spoke{k}_{corner}", type=mujoco.mjtGeom.mjGEOM_BOX,
                       size=[0.55 * r, half_width + 0.008, 0.07 * r],
                       quat=[math.cos(angle / 2), 0, math.sin(angle / 2), 0], rgba=list(SPOKE),
                       contype=0, conaffinity=0, mass=0)


def _prism(profile: Polygon, half_width: float) -> tuple[np.ndarray, np.ndarray]:
    """A side profile (x, z), extruded across y = -half_width .. half_width: vertices and faces,
    every face's normal pointing out."""
    ring = np.asarray(profile.exterior.coords)[:-1]
    if shapely.LinearRing(ring).is_ccw is False:
        ring = ring[::-1]
    n = len(ring)
    vertices = np.vstack([np.column_stack([ring[:, 0], np.full(n, y), ring[:, 1]]) for y in (half_width, -half_width)])
    index = {tuple(p): i for i, p in enumerate(ring)}
    faces = []
    for triangle in shapely.constrained_delaunay_triangles(profile).geoms:
        a, b, c = (index[tuple(p)] for p in np.asarray(triangle.exterior.coords)[:3])
        if shapely.LinearRing(ring[[a, b, c]]).is_ccw:
            a, b, c = a, c, b                                  # now clockwise in (x, z)
        faces += [[a, b, c], [n + a, n + c, n + b]]            # left side faces +y, right side -y
    for i in range(n):
        j = (i + 1) % n
        faces += [[i, n + j, n + i], [i, j, n + j]]            # the outline's walls face outwards
    return vertices, np.asarray(faces)


def _add_mesh(spec: mujoco.MjSpec, body: mujoco.MjsBody, name: str, mesh: tuple[np.ndarray, np.ndarray | None],
              rgba: tuple[float, float, float, float]) -> None:
    """A drawn mesh on ``body`` (no faces: their convex hull)."""
    vertices, faces = mesh
    asset = spec.add_mesh(name=name)
    asset.uservert = vertices.ravel().tolist()
    if faces is not None:
        asset.userface = faces.ravel().astype(int).tolist()
    body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=name, rgba=list(rgba),
                  contype=0, conaffinity=0, mass=0)
