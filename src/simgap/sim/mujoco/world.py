"""The MuJoCo world of one scenario: ground, road, cars for the agents, recorded traffic.

`build_world` compiles it; `World` holds the model, the data, where each car and obstacle lives,
the surface map and, on a road with a relief, its terrain. A flat road's ground is MuJoCo's plane
at z = 0; a road with a relief stands on its terrain (`simgap.sim.mujoco.terrain`: a height field
that collides, the road drawn on it), and the plane, sunk below the terrain's lowest point, only
draws the land beyond it. The backend (`simgap.sim.mujoco.backend`) drives it; the 3D renderer
(`simgap.sim.mujoco.replay`) poses it from a finished run.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import mujoco
import numpy as np
from commonroad.scenario.scenario import Scenario

from simgap.scenario.obstacles import RecordedObstacle, recorded_obstacles
from simgap.scenario.relief import Surface
from simgap.sim.mujoco.car import CarIndex, ackermann_angles, add_car, yaw_quaternion
from simgap.sim.mujoco.road import SurfaceMap, add_road
from simgap.sim.mujoco.settings import WorldSettings
from simgap.sim.mujoco.terrain import Terrain
from simgap.sim.mujoco.tyre import SlipTyres
from simgap.sim.protocol import Agent
from simgap.trajectory import State
from simgap.vehicles.constants import GRAVITY

#: car body colours per agent (Okabe-Ito, as the 2D pictures)
CAR_COLOURS = [(0.0, 0.45, 0.70, 1), (0.84, 0.37, 0.0, 1), (0.0, 0.62, 0.45, 1), (0.8, 0.47, 0.65, 1),
               (0.9, 0.62, 0.0, 1), (0.34, 0.71, 0.91, 1)]
TRAFFIC_HEIGHT = 1.5    # m, height of a recorded obstacle's box
SETTLED_MIN_SPEED = 0.5  # m/s: a car placed slower than this starts without sideslip or roll
MAX_PLACED_ROLL = 0.1    # rad: bound on the body roll of a car placed in a turn
NOSLIP_ITERATIONS = 2    # MuJoCo's post-pass on friction constraints (the brakes)
SUNKEN_PLANE_M = 1.0     # with a terrain, the plane lies this far below its lowest point


@dataclass
class World:
    model: mujoco.MjModel
    data: mujoco.MjData
    cars: dict[int, CarIndex]                       # by agent id
    traffic: list[tuple[RecordedObstacle, int]]     # obstacle and its mocap index
    traffic_geoms: dict[int, int]                   # geom id -> obstacle id
    surface: SurfaceMap
    settings: WorldSettings
    tyres: SlipTyres                                # every car's four, in the order of `cars`
    owner: dict[int, int] = field(default_factory=dict)   # geom id -> agent id
    road_bounds: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)   # x0, y0, x1, y1 of the lanelets
    terrain: Terrain | None = None                  # the ground of a road with a relief (None: the plane z = 0)

    def step(self, n: int) -> None:
        """``n`` physics steps, the tyre forces computed for each from its positions and velocities."""
        m, d, tyres = self.model, self.data, self.tyres
        for _ in range(n):
            mujoco.mj_step1(m, d)
            tyres.apply()
            mujoco.mj_step2(m, d)

    def place(self, agent_id: int, state: State) -> None:
        """Put a car at ``state`` (pose and velocity), at rest on its suspension.

        The state says where the car goes: its centre moves in the direction ``yaw + atan(b
        tan(steer) / L)`` of the planner's kinematic model. A real car on that course at that
        speed and yaw rate has the sideslip of steady cornering (`VehiclePhysics.steady_sideslip`),
        so its heading is set to the course minus that sideslip; with its tyres settled
        (`SlipTyres.apply`) it starts as if it had long been driving so. On a terrain the car
        stands on the ground's tangent plane at (x, y), its speed the horizontal one along it."""
        car, vehicle = self.cars[agent_id], self.cars[agent_id].vehicle
        course = heading = state.yaw
        roll = 0.0
        if abs(state.v) > SETTLED_MIN_SPEED:
            course += math.atan(vehicle.rear_axle_to_center / vehicle.wheelbase * math.tan(state.steer))
            heading = course - car.physics.steady_sideslip(vehicle.wheelbase, vehicle.rear_axle_to_center,
                                                           state.v, state.yaw_rate)
            roll = min(max(car.physics.steady_roll(state.v * state.yaw_rate), -MAX_PLACED_ROLL), MAX_PLACED_ROLL)
        q, v = self.data.qpos, self.data.qvel
        q[car.qpos:car.qpos + 3] = [state.x, state.y, car.physics.cg_height]
        v[car.qvel:car.qvel + 3] = [state.v * math.cos(course), state.v * math.sin(course), 0.0]
        attitude, speed = yaw_quaternion(heading), state.v
        if self.terrain is not None:
            z, normal = self.terrain.at(state.x, state.y)
            q[car.qpos + 2] = z + car.physics.cg_height / normal[2]
            attitude = _standing(heading, normal)
            v[car.qvel + 2] = -(normal[0] * v[car.qvel] + normal[1] * v[car.qvel + 1]) / normal[2]
            speed = math.copysign(float(np.linalg.norm(v[car.qvel:car.qvel + 3])), state.v)
        mujoco.mju_mulQuat(q[car.qpos + 3:car.qpos + 7], attitude,
                           np.array([math.cos(roll / 2), math.sin(roll / 2), 0.0, 0.0]))
        v[car.qvel + 3:car.qvel + 6] = [0.0, 0.0, state.yaw_rate]
        for dof in car.spin_dofs:
            v[dof] = speed / car.physics.wheel_radius
        for adr, (_, y) in zip(car.suspension_qpos, car.corners):
            q[adr] = -y * math.sin(roll)            # every wheel stays on the ground under the rolled body
        left, right = ackermann_angles(state.steer, car.vehicle.wheelbase, car.physics.track_front)
        q[car.steer_qpos[0]], q[car.steer_qpos[1]] = left, right
        self.data.ctrl[car.steer_actuators[0]], self.data.ctrl[car.steer_actuators[1]] = left, right

    def move_traffic(self, t: float) -> None:
        """Put every recorded obstacle where its recording says it is at time ``t`` (or park it
        far below the ground when it is not in the scene)."""
        for obstacle, mocap in self.traffic:
            m = obstacle.motion
            if m.t[0] - 1e-9 <= t <= m.t_end + 1e-9:
                st = m.at(t)
                ground = self.terrain.at(st.x, st.y)[0] if self.terrain is not None else 0.0
                self.data.mocap_pos[mocap] = [st.x, st.y, ground + TRAFFIC_HEIGHT / 2]
                self.data.mocap_quat[mocap] = yaw_quaternion(st.yaw)
            else:
                self.data.mocap_pos[mocap] = [0.0, 0.0, -100.0]


def _standing(heading: float, normal: np.ndarray) -> np.ndarray:
    """The quaternion of a body facing ``heading`` whose up axis is ``normal``."""
    forward = np.array([math.cos(heading), math.sin(heading), 0.0])
    forward -= forward.dot(normal) * normal
    forward /= np.linalg.norm(forward)
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, np.column_stack([forward, np.cross(normal, forward), normal]).ravel())
    return quat


def _add_scenery(spec: mujoco.MjSpec, extent: float) -> None:
    spec.add_texture(name="grass", type=mujoco.mjtTexture.mjTEXTURE_2D, builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
                     rgb1=[0.36, 0.46, 0.27], rgb2=[0.33, 0.43, 0.25], width=512, height=512)
    spec.add_material(name="grass", textures=["", "grass"], texrepeat=[extent / 4, extent / 4], reflectance=0.0)
    spec.add_material(name="asphalt", rgba=[0.32, 0.32, 0.34, 1.0], reflectance=0.0)
    spec.add_texture(name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX, builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
                     rgb1=[0.62, 0.75, 0.90], rgb2=[0.95, 0.97, 1.0], width=256, height=256)
    spec.worldbody.add_light(name="sun", pos=[0, 0, 200], dir=[0.3, 0.2, -1.0], type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
                             diffuse=[0.8, 0.8, 0.8], specular=[0.1, 0.1, 0.1], castshadow=False)
    spec.visual.headlight.ambient = [0.45, 0.45, 0.45]
    spec.visual.headlight.diffuse = [0.35, 0.35, 0.35]


def build_world(scenario: Scenario, agents: Sequence[Agent], settings: WorldSettings | None = None,
                relief: Surface | None = None, looks: bool = True) -> World:
    """The MuJoCo world of ``scenario`` with a car per agent, on the road's ``relief`` (None: flat);
    ``looks`` adds what is drawn only (the cars' bodies and wheels as pictures show them), which a
    world that only simulates leaves out."""
    settings = settings or WorldSettings()
    spec = mujoco.MjSpec()
    spec.modelname = str(scenario.scenario_id)
    spec.compiler.degree = False
    spec.option.timestep = 1.0 / settings.physics_hz
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    # brakes are dry friction on the wheels' spin joints: the noslip pass makes that friction
    # rigid (a soft one lets a braked wheel creep under a steady torque, a car down a slope)
    spec.option.noslip_iterations = NOSLIP_ITERATIONS
    spec.option.gravity = [0, 0, -GRAVITY]

    lanelets = scenario.lanelet_network.lanelets
    pts = np.vstack([np.asarray(l.polygon.vertices) for l in lanelets]) if lanelets else np.zeros((1, 2))
    centre = (pts.min(axis=0) + pts.max(axis=0)) / 2
    extent = float(np.max(pts.max(axis=0) - pts.min(axis=0))) / 2 + 60.0
    _add_scenery(spec, 6 * extent)
    spec.stat.center = [float(centre[0]), float(centre[1]), 0.0]
    spec.stat.extent = extent
    spec.visual.map.zfar = 50.0
    bounds = (*pts.min(axis=0).tolist(), *pts.max(axis=0).tolist())
    terrain = Terrain.of(relief, bounds) if relief is not None else None
    plane = dict(contype=1, conaffinity=1, z=0.0) if terrain is None else \
        dict(contype=0, conaffinity=0, z=terrain.lowest - SUNKEN_PLANE_M)
    spec.worldbody.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[3 * extent, 3 * extent, 1.0],
                            pos=[float(centre[0]), float(centre[1]), plane["z"]], material="grass",
                            contype=plane["contype"], conaffinity=plane["conaffinity"],
                            friction=[settings.offroad_friction, 0.005, 0.0001])
    if terrain is not None:
        terrain.add_to(spec, "grass", settings.offroad_friction)
    add_road(spec, scenario.lanelet_network, terrain.heights if terrain is not None else None)

    cars = {}
    for i, agent in enumerate(agents):
        cars[agent.id] = add_car(spec, f"agent{agent.id}_", agent.vehicle, CAR_COLOURS[i % len(CAR_COLOURS)], looks)

    traffic_specs = []
    for obstacle in recorded_obstacles(scenario):
        body = spec.worldbody.add_body(name=f"obstacle{obstacle.id}", mocap=True, pos=[0, 0, -100])
        body.add_geom(name=f"obstacle{obstacle.id}", type=mujoco.mjtGeom.mjGEOM_BOX,
                      size=[obstacle.length / 2, obstacle.width / 2, TRAFFIC_HEIGHT / 2],
                      rgba=[0.55, 0.55, 0.58, 1.0], contype=1, conaffinity=1)
        traffic_specs.append(obstacle)

    model = spec.compile()
    data = mujoco.MjData(model)
    for car in cars.values():
        car.resolve(model)
    traffic = [(o, int(model.body_mocapid[model.body(f"obstacle{o.id}").id])) for o in traffic_specs]
    traffic_geoms = {model.geom(f"obstacle{o.id}").id: o.id for o in traffic_specs}
    owner = {g: aid for aid, car in cars.items() for g in car.geoms}
    wheels = [wheel for car in cars.values() for wheel in car.wheels()]
    tyres = SlipTyres(model, data, wheels) if terrain is None else \
        SlipTyres(model, data, wheels, (terrain.grid, terrain.frame))
    return World(model, data, cars, traffic, traffic_geoms, SurfaceMap(scenario.lanelet_network), settings, tyres,
                 owner, bounds, terrain)
