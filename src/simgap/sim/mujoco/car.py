"""A four-wheeled car in MuJoCo, built with `MjSpec` from a vehicle's ``physics`` section.

Bodies: a sprung chassis on a free joint; at each corner an upright on a vertical slide joint
(the suspension: wheel rate and damping from the data file, pre-loaded so that the car stands at
its static ride height; an axle's anti-roll bar is a spring tendon on its left and right travel;
its camber gain enters the tyres' camber, not the drawn wheel) with, at the front, a vertical
steering hinge; in each upright a wheel spinning on a hinge, with its mass and spin inertia. The
chassis frame has its origin at the vehicle's centre of gravity at static ride height (x
forward, y left, z up), so the chassis pose *is* the `State`'s reference point.

Actuation, all at the wheels: the front steering hinges follow position servos (the Ackermann
angles of the requested road-wheel angle, after the rate and angle limits of the steering
system); drive torque through motors on the driven wheels' spin joints; brakes as dry friction
on every spin joint (MuJoCo's ``frictionloss``, solved implicitly, so a braked car holds still).
Tyre-road forces: not MuJoCo contacts but slip-based tyres (`simgap.sim.mujoco.tyre`) applied
at each wheel's contact patch every physics step; the wheels' geoms only draw. How the body and
the wheels look: `simgap.sim.mujoco.car_body`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np

from simgap.sim.mujoco.car_body import WAIST, add_body_look, add_wheel_look
from simgap.sim.mujoco.tyre import Wheel
from simgap.vehicles import Vehicle
from simgap.vehicles.constants import GRAVITY
from simgap.vehicles.physics import VehiclePhysics

CORNERS = ("front_left", "front_right", "rear_left", "rear_right")
UPRIGHT_MASS = 2.0          # kg of each corner's unsprung mass that does not spin
STEER_ARMATURE = 2.0        # kg m^2 reflected inertia of the steering rack at each wheel
STEER_KP = 6.0e4            # N m/rad steering servo stiffness at each wheel
STEER_KV = 1.2e3            # N m s/rad steering servo damping
ROLLING_BRAKE_SPEED = 0.5   # m/s: below this the rolling resistance torque fades in
COLLISION_GROUP = 3         # geom group of the shapes that collide and are not drawn


def requires_physics(vehicle: Vehicle) -> VehiclePhysics:
    from simgap.errors import InputError

    if vehicle.physics is None:
        raise InputError(f"vehicle '{vehicle.name}' has no physics section, so it cannot be "
                         "built in a physics world", field="physics")
    if isinstance(vehicle.physics, VehiclePhysics):
        return vehicle.physics
    return VehiclePhysics.model_validate(vehicle.physics)


def ackermann_angles(steer: float, wheelbase: float, track: float) -> tuple[float, float]:
    """Left and right road-wheel angles realising the single-track angle ``steer``."""
    if abs(steer) < 1e-6:
        return steer, steer
    radius = wheelbase / math.tan(steer)       # signed: > 0 turning left
    left = math.atan(wheelbase / (radius - track / 2.0))
    right = math.atan(wheelbase / (radius + track / 2.0))
    return left, right


def single_track_angle(left: float, right: float) -> float:
    """The single-track angle of a pair of front-wheel angles (exact for Ackermann geometry:
    the cotangents average)."""
    tl, tr = math.tan(left), math.tan(right)
    if tl * tr <= 1e-12:
        return 0.5 * (left + right)
    return math.atan(2.0 * tl * tr / (tl + tr))


def max_single_track_angle(physics: VehiclePhysics, wheelbase: float) -> float:
    """The largest single-track angle whose inner wheel stays within ``steering.max_angle``."""
    inner = physics.steering.max_angle
    radius_inner = wheelbase / math.tan(inner)
    return math.atan(wheelbase / (radius_inner + physics.track_front / 2.0))


@dataclass
class CarIndex:
    """Where one car lives in the compiled model (filled by `CarIndex.resolve`)."""

    prefix: str
    vehicle: Vehicle
    physics: VehiclePhysics
    chassis_body: int = -1
    qpos: int = -1                      # free joint: x y z qw qx qy qz
    qvel: int = -1                      # free joint: vx vy vz (world) wx wy wz (local)
    steer_qpos: tuple[int, int] = (-1, -1)
    steer_actuators: tuple[int, int] = (-1, -1)
    spin_dofs: list[int] = field(default_factory=list)         # in CORNERS order
    spin_qpos: list[int] = field(default_factory=list)         # in CORNERS order: each wheel's roll angle
    suspension_qpos: list[int] = field(default_factory=list)   # in CORNERS order
    drive_actuators: list[int] = field(default_factory=list)   # in CORNERS order (-1: not driven)
    wheel_bodies: list[int] = field(default_factory=list)      # in CORNERS order
    upright_bodies: list[int] = field(default_factory=list)    # in CORNERS order
    geoms: set[int] = field(default_factory=set)               # every geom of this car

    @property
    def corners(self) -> list[tuple[float, float]]:
        """(x forward, y left) of each wheel centre from the centre of gravity, in CORNERS order."""
        geometry = _corner_geometry(self.vehicle, self.physics)
        return [geometry[c] for c in CORNERS]

    def wheels(self) -> list[Wheel]:
        """The car's four tyre mounts, in CORNERS order (after `resolve`). A linkage's camber gain
        turns a wheel's top inwards in bump (gain < 0): a right wheel about +x, a left one about -x."""
        loads = static_tyre_loads(self.vehicle, self.physics)
        mounts = []
        for k, corner in enumerate(CORNERS):
            susp = self.physics.suspension_front if k < 2 else self.physics.suspension_rear
            side = -1.0 if corner.endswith("left") else 1.0
            mounts.append(Wheel(self.wheel_bodies[k], self.upright_bodies[k], self.spin_dofs[k],
                                self.suspension_qpos[k], self.physics, loads[k], side * susp.camber_gain))
        return mounts

    def resolve(self, model: mujoco.MjModel) -> CarIndex:
        p = self.prefix
        self.chassis_body = model.body(f"{p}chassis").id
        jnt = model.joint(f"{p}free")
        self.qpos, self.qvel = int(jnt.qposadr[0]), int(jnt.dofadr[0])
        left, right = CORNERS[:2]
        self.steer_qpos = (int(model.joint(f"{p}steer_{left}").qposadr[0]),
                           int(model.joint(f"{p}steer_{right}").qposadr[0]))
        self.steer_actuators = (model.actuator(f"{p}steer_{left}").id, model.actuator(f"{p}steer_{right}").id)
        self.spin_dofs = [int(model.joint(f"{p}spin_{c}").dofadr[0]) for c in CORNERS]
        self.spin_qpos = [int(model.joint(f"{p}spin_{c}").qposadr[0]) for c in CORNERS]
        self.suspension_qpos = [int(model.joint(f"{p}suspension_{c}").qposadr[0]) for c in CORNERS]
        self.drive_actuators = []
        for c in CORNERS:
            try:
                self.drive_actuators.append(model.actuator(f"{p}drive_{c}").id)
            except KeyError:
                self.drive_actuators.append(-1)
        self.wheel_bodies = [model.body(f"{p}wheel_{c}").id for c in CORNERS]
        self.upright_bodies = [model.body(f"{p}upright_{c}").id for c in CORNERS]
        self.geoms = {g for g in range(model.ngeom)
                      if model.body(model.geom_bodyid[g]).name.startswith(p)}
        return self


def _corner_geometry(vehicle: Vehicle, physics: VehiclePhysics) -> dict[str, tuple[float, float]]:
    a, b = vehicle.front_axle_to_center, vehicle.rear_axle_to_center
    return {"front_left": (a, physics.track_front / 2), "front_right": (a, -physics.track_front / 2),
            "rear_left": (-b, physics.track_rear / 2), "rear_right": (-b, -physics.track_rear / 2)}


def static_wheel_loads(vehicle: Vehicle, physics: VehiclePhysics) -> dict[str, float]:
    """Sprung weight carried by each corner's spring at standstill [N]."""
    a, b, wb = vehicle.front_axle_to_center, vehicle.rear_axle_to_center, vehicle.wheelbase
    sprung = physics.sprung_mass * GRAVITY
    front, rear = sprung * b / wb / 2.0, sprung * a / wb / 2.0
    return {"front_left": front, "front_right": front, "rear_left": rear, "rear_right": rear}


def static_tyre_loads(vehicle: Vehicle, physics: VehiclePhysics) -> list[float]:
    """Load on each tyre at standstill [N], in CORNERS order: its spring's share and its corner."""
    springs = static_wheel_loads(vehicle, physics)
    return [springs[c] + physics.wheel_mass * GRAVITY for c in CORNERS]


def add_car(spec: mujoco.MjSpec, prefix: str, vehicle: Vehicle,
            rgba: tuple[float, float, float, float], looks: bool = True) -> CarIndex:
    """Add a car named ``prefix`` to ``spec`` at the origin (`place` puts it elsewhere); with
    ``looks``, the geoms that are drawn only (`car_body`): a world that only simulates leaves them
    out, they would cost its physics step their kinematics and change nothing else."""
    ph = requires_physics(vehicle)
    h, r = ph.cg_height, ph.wheel_radius
    corners = _corner_geometry(vehicle, ph)
    loads = static_wheel_loads(vehicle, ph)

    chassis = spec.worldbody.add_body(name=f"{prefix}chassis", pos=[0, 0, h])
    chassis.add_freejoint(name=f"{prefix}free")
    # sprung mass placed so that the whole car's centre of gravity is the chassis origin
    a, b = vehicle.front_axle_to_center, vehicle.rear_axle_to_center
    m_s = ph.sprung_mass
    chassis.explicitinertial = True
    chassis.mass = m_s
    chassis.ipos = [-2.0 * ph.wheel_mass * (a - b) / m_s, 0.0, -4.0 * ph.wheel_mass * (r - h) / m_s]
    unsprung_yaw = sum(ph.wheel_mass * (x * x + y * y) for x, y in corners.values())
    chassis.inertia = [ph.inertia_roll, ph.inertia_pitch, max(ph.inertia_yaw - unsprung_yaw, 0.5 * ph.inertia_yaw)]

    # the collision shape: a box from the wheel centres' height to the waist line; it collides with
    # other cars and traffic, in geom group 3, which pictures leave out. What is drawn: `car_body`.
    bottom, waist = r - h, WAIST * ph.height - h
    chassis.add_geom(name=f"{prefix}body", type=mujoco.mjtGeom.mjGEOM_BOX,
                     size=[vehicle.length / 2, vehicle.width / 2, (waist - bottom) / 2],
                     pos=[0, 0, (waist + bottom) / 2], rgba=list(rgba), contype=1, conaffinity=1,
                     mass=0, group=COLLISION_GROUP)
    if looks:
        add_body_look(spec, chassis, prefix, vehicle, ph, rgba)

    for corner, (x, y) in corners.items():
        front = corner.startswith("front")
        susp = ph.suspension_front if front else ph.suspension_rear
        upright = chassis.add_body(name=f"{prefix}upright_{corner}", pos=[x, y, r - h])
        upright.explicitinertial = True
        upright.mass = UPRIGHT_MASS
        upright.inertia = [0.05, 0.05, 0.05]
        j = upright.add_joint(name=f"{prefix}suspension_{corner}", type=mujoco.mjtJoint.mjJNT_SLIDE,
                              axis=[0, 0, 1])
        j.stiffness[0] = susp.stiffness
        j.damping[0] = susp.damping
        # pre-load: at q = 0 the spring carries this corner's share of the sprung weight
        j.springref = -loads[corner] / susp.stiffness
        j.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        j.range = [-susp.travel, susp.travel]
        if front:
            s = upright.add_joint(name=f"{prefix}steer_{corner}", type=mujoco.mjtJoint.mjJNT_HINGE,
                                  axis=[0, 0, 1], armature=STEER_ARMATURE)
            s.limited = mujoco.mjtLimited.mjLIMITED_TRUE
            s.range = [-ph.steering.max_angle - 0.05, ph.steering.max_angle + 0.05]
        wheel = upright.add_body(name=f"{prefix}wheel_{corner}")
        wheel.explicitinertial = True
        wheel.mass = ph.wheel_mass - UPRIGHT_MASS
        wheel.inertia = [ph.wheel_inertia * 0.55, ph.wheel_inertia, ph.wheel_inertia * 0.55]
        wheel.add_joint(name=f"{prefix}spin_{corner}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0])
        if looks:
            add_wheel_look(wheel, prefix, corner, ph)

        if front:
            act = spec.add_actuator(name=f"{prefix}steer_{corner}", target=f"{prefix}steer_{corner}",
                                    trntype=mujoco.mjtTrn.mjTRN_JOINT)
            act.set_to_position(kp=STEER_KP, kv=STEER_KV)
        front_share, rear_share = ph.drive_shares()
        if (front and front_share > 0) or (not front and rear_share > 0):
            act = spec.add_actuator(name=f"{prefix}drive_{corner}", target=f"{prefix}spin_{corner}",
                                    trntype=mujoco.mjtTrn.mjTRN_JOINT)
            act.set_to_motor()
    for axle, susp, track in (("front", ph.suspension_front, ph.track_front),
                              ("rear", ph.suspension_rear, ph.track_rear)):
        if susp.anti_roll > 0.0:
            _add_anti_roll_bar(spec, prefix, axle, susp.anti_roll, track)
    return CarIndex(prefix, vehicle, ph)


def _add_anti_roll_bar(spec: mujoco.MjSpec, prefix: str, axle: str, stiffness: float, track: float) -> None:
    """An axle's anti-roll bar: a spring on the difference of its left and right suspension
    travel. Body roll phi moves the wheels by -+ phi t / 2 against the body, so a spring of rate
    ``stiffness / t^2`` on (q_left - q_right) resists roll with ``stiffness`` [N m/rad] and leaves
    heave alone."""
    bar = spec.add_tendon(name=f"{prefix}anti_roll_{axle}")
    bar.wrap_joint(f"{prefix}suspension_{axle}_left", 1.0)
    bar.wrap_joint(f"{prefix}suspension_{axle}_right", -1.0)
    bar.stiffness[0] = stiffness / track ** 2
    bar.springlength[:] = [0.0, 0.0]


def yaw_quaternion(yaw: float) -> np.ndarray:
    return np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])


def yaw_of(quat: np.ndarray) -> float:
    w, x, y, z = quat
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def up_z(quat: np.ndarray) -> float:
    """z component of the chassis' up axis (1 upright, < 0 upside down)."""
    w, x, y, z = quat
    return 1.0 - 2.0 * (x * x + y * y)
