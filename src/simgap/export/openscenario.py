"""A run as OpenSCENARIO (1.2 by default, the oldest version every rule of ASAM's Quality Checker
checks; 1.0 for CARLA's ScenarioRunner, 1.1 and 1.3 on request),
built with scenariogeneration's ``xosc``.

Every agent and every recorded road user is an entity with its dimensions and category, placed
at its first state and following what it drove in the run — a timed ``FollowTrajectoryAction``
(absolute times, position following) along a polyline of its states — so that a simulator replays
the run as it happened in the fidelity that ran it. An entity's reference point is the centre of
its box, as in CommonRoad (its bounding box is centred on it; the axles lie at their distances
from the centre). The road friction is the environment's friction scale factor; the goal regions
end the story (every agent within its goal's circumscribed circle, and past the start of its goal
time window), or the recorded time runs out. What OpenSCENARIO has no place for (actuator delays,
sensing and latency, the goals' velocity and orientation windows) is said in the file's description.
"""

from __future__ import annotations

import datetime
from dataclasses import dataclass
from enum import StrEnum

from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.obstacle import ObstacleType
from commonroad.scenario.scenario import Scenario
from pydantic import BaseModel
from scenariogeneration import xosc

from simgap.cosim.history import AGENT_ID_OFFSET
from simgap.errors import InputError
from simgap.record import RunRecord
from simgap.scenario.goal import Goal
from simgap.scenario.obstacles import recorded_obstacles
from simgap.sim.assumptions import Assumption, restorations
from simgap.sim.protocol import Realism
from simgap.sim.settings import TrackingSettings
from simgap.trajectory import Trajectory
from simgap.vehicles import Vehicle


class OpenScenarioVersion(StrEnum):
    V1_0 = "1.0"
    V1_1 = "1.1"
    V1_2 = "1.2"
    V1_3 = "1.3"

    @property
    def minor(self) -> int:
        return int(self.value.split(".")[1])

    @classmethod
    def parse(cls, text: str) -> OpenScenarioVersion:
        try:
            return cls(text)
        except ValueError:
            raise InputError(f"OpenSCENARIO {text} is not written", field="--version",
                             allowed=", ".join(v.value for v in cls)) from None


#: ASAM's Quality Checker skips most of its rules on files older than 1.2; more simulators read 1.2 than 1.3
DEFAULT_VERSION = OpenScenarioVersion.V1_2


class Category(StrEnum):
    CAR = "car"
    TRUCK = "truck"
    BUS = "bus"
    MOTORBIKE = "motorbike"
    BICYCLE = "bicycle"
    PEDESTRIAN = "pedestrian"
    OBJECT = "object"          # anything else that stands on the road


_CATEGORY = {ObstacleType.TRUCK: Category.TRUCK, ObstacleType.BUS: Category.BUS,
             ObstacleType.MOTORCYCLE: Category.MOTORBIKE, ObstacleType.BICYCLE: Category.BICYCLE,
             ObstacleType.PEDESTRIAN: Category.PEDESTRIAN}
_VEHICLES = {ObstacleType.CAR, ObstacleType.TAXI, ObstacleType.PRIORITY_VEHICLE, ObstacleType.PARKED_VEHICLE,
             ObstacleType.UNKNOWN, ObstacleType.TRUCK, ObstacleType.BUS, ObstacleType.MOTORCYCLE,
             ObstacleType.BICYCLE}
#: height [m] of a road user whose recording has none
HEIGHT = {Category.CAR: 1.5, Category.TRUCK: 3.5, Category.BUS: 3.2, Category.MOTORBIKE: 1.4,
          Category.BICYCLE: 1.7, Category.PEDESTRIAN: 1.8, Category.OBJECT: 1.0}
_VEHICLE_CATEGORY = {Category.CAR: "car", Category.TRUCK: "truck", Category.BUS: "bus",
                     Category.MOTORBIKE: "motorbike", Category.BICYCLE: "bicycle"}


@dataclass(frozen=True)
class RoadUser:
    """An entity as written: its name, what it is, its box and the states it drove (box centres)."""

    name: str
    category: Category
    length: float
    width: float
    height: float
    trajectory: Trajectory
    vehicle: Vehicle | None = None       # an agent's vehicle model
    standing: bool = False               # a static obstacle: placed, never moved


def road_users(run: RunRecord, scenario: Scenario) -> list[RoadUser]:
    """Every agent of ``run`` (what it drove), every road user the run's traffic drove itself (as
    it drove: IDM traffic) and every other recorded road user of ``scenario`` (its recording;
    agents stored in a driven scenario are left out)."""
    users = []
    history = run.history
    for agent in history.agents:
        vehicle = agent.vehicle
        height = vehicle.physics.height if vehicle.physics is not None else HEIGHT[Category.CAR]
        users.append(RoadUser(f"agent_{agent.id}", Category.CAR, vehicle.length, vehicle.width, height,
                              agent.driven, vehicle))
    for obstacle in recorded_obstacles(scenario):
        if obstacle.id >= AGENT_ID_OFFSET:
            continue
        kind = scenario.obstacle_by_id(obstacle.id).obstacle_type
        category = _CATEGORY.get(kind, Category.CAR if kind in _VEHICLES else Category.OBJECT)
        motion = history.traffic.get(obstacle.id, obstacle.motion)
        if obstacle.static:
            motion = Trajectory.from_states([motion[0]], history.dt)
        users.append(RoadUser(f"obstacle_{obstacle.id}", category, obstacle.length, obstacle.width, HEIGHT[category],
                              motion, standing=obstacle.static))
    return users


def _entity(user: RoadUser, minor: int):
    box = xosc.BoundingBox(user.width, user.length, user.height, 0.0, 0.0, 0.5 * user.height)
    if user.category is Category.PEDESTRIAN:
        return xosc.Pedestrian(user.name, 75.0, xosc.PedestrianCategory.pedestrian, box, model="pedestrian")
    if user.category is Category.OBJECT:
        return xosc.MiscObject(user.name, 100.0, xosc.MiscObjectCategory.obstacle, box)
    v = user.vehicle
    if v is not None:
        physics = v.physics
        wheel = 2 * physics.wheel_radius if physics is not None else 0.6
        front_track = physics.track_front if physics is not None else v.width - 0.2
        rear_track = physics.track_rear if physics is not None else v.width - 0.2
        front = xosc.Axle(v.limits.max_steer, wheel, front_track, v.front_axle_to_center, 0.5 * wheel)
        rear = xosc.Axle(0.0, wheel, rear_track, -v.rear_axle_to_center, 0.5 * wheel)
        limits = (v.limits.max_speed, v.limits.max_accel, v.limits.max_accel)
        mass = physics.mass if physics is not None and minor >= 1 else None
        name = v.name
    else:
        front = xosc.Axle(0.5, 0.6, user.width - 0.2, 0.3 * user.length, 0.3)
        rear = xosc.Axle(0.0, 0.6, user.width - 0.2, -0.3 * user.length, 0.3)
        limits, mass, name = (70.0, 10.0, 10.0), None, user.category.value
    category = getattr(xosc.VehicleCategory, _VEHICLE_CATEGORY[user.category])
    return xosc.Vehicle(name, category, box, front, rear, *limits, mass=mass)


def _polyline(trajectory: Trajectory) -> xosc.Polyline:
    return xosc.Polyline([float(t) for t in trajectory.t],
                         [xosc.WorldPosition(float(x), float(y), 0.0, float(yaw))
                          for x, y, yaw in zip(trajectory.x, trajectory.y, trajectory.yaw)])


def _at_start() -> xosc.ValueTrigger:
    return xosc.ValueTrigger("at_start", 0, xosc.ConditionEdge.none, xosc.SimulationTimeCondition(0, xosc.Rule.greaterThan))


def _goal_conditions(run: RunRecord, problems: PlanningProblemSet, minor: int) -> list:
    """Each agent within its goal (the first goal state with a position), after its window opens."""
    conditions = []
    for agent in run.history.agents:
        problem = problems.planning_problem_dict.get(agent.id)
        if problem is None:
            continue
        goal = Goal.of(problem.goal, run.history.dt)
        state = next((gs for gs in goal.states if gs.position is not None), None)
        if state is None or state.position is None:     # (a state it finds has a position)
            continue
        area = state.position.shapely_object
        centre = area.centroid
        radius = max(centre.distance(type(centre)(p)) for p in area.convex_hull.exterior.coords)
        extra = {"distance_type": xosc.RelativeDistanceType.euclidianDistance,
                 "coordinate_system": xosc.CoordinateSystem.entity} if minor >= 1 else {}
        conditions.append(xosc.EntityTrigger(
            f"agent_{agent.id}_in_goal", 0, xosc.ConditionEdge.none,
            xosc.DistanceCondition(float(radius), xosc.Rule.lessThan, xosc.WorldPosition(centre.x, centre.y, 0, 0),
                                   alongroute=False, freespace=False, **extra), f"agent_{agent.id}"))
        if state.time is not None and state.time.lo > 0:
            conditions.append(xosc.ValueTrigger(f"agent_{agent.id}_goal_window_open", 0, xosc.ConditionEdge.none,
                                                xosc.SimulationTimeCondition(state.time.lo, xosc.Rule.greaterThan)))
    return conditions


def openscenario(run: RunRecord, users: list[RoadUser], problems: PlanningProblemSet, road_file: str,
                 version: OpenScenarioVersion, description: str, friction: float) -> xosc.Scenario:
    """The OpenSCENARIO scenario of ``run`` and its road ``users`` on the road network in
    ``road_file`` (a path relative to the written .xosc)."""
    minor = version.minor
    xosc.VersionBase().setVersion(1, minor)           # scenariogeneration's checks read a global version
    entities, init = xosc.Entities(), xosc.Init()
    story = xosc.Story("replay")
    act = xosc.Act("as_driven", _at_start())
    for k, user in enumerate(users):
        entity = _entity(user, minor)
        if user.vehicle is not None:
            entity.add_property("simgap_agent", user.name.removeprefix("agent_"))
            if k == 0:
                entity.add_property("type", "ego_vehicle")       # ScenarioRunner's hero
        entities.add_scenario_object(user.name, entity)
        first = user.trajectory[0]
        init.add_init_action(user.name, xosc.TeleportAction(xosc.WorldPosition(first.x, first.y, 0.0, first.yaw)))
        if user.category is not Category.OBJECT and not user.standing:
            init.add_init_action(user.name, xosc.AbsoluteSpeedAction(
                first.v, xosc.TransitionDynamics(xosc.DynamicsShapes.step, xosc.DynamicsDimension.time, 0)))
        if user.standing or len(user.trajectory) < 2:
            continue
        trajectory = xosc.Trajectory(f"{user.name}_driven", False)
        trajectory.add_shape(_polyline(user.trajectory))
        event = xosc.Event(f"{user.name}_drives", xosc.Priority.override if minor >= 2 else xosc.Priority.overwrite)
        event.add_action(f"{user.name}_follows", xosc.FollowTrajectoryAction(
            trajectory, xosc.FollowingMode.position, xosc.ReferenceContext.absolute, 1, 0))
        event.add_trigger(_at_start())
        maneuver = xosc.Maneuver(f"{user.name}_maneuver")
        maneuver.add_event(event)
        group = xosc.ManeuverGroup(f"{user.name}_group")
        group.add_actor(user.name)
        group.add_maneuver(maneuver)
        act.add_maneuver_group(group)
    story.add_act(act)
    weather = xosc.Weather(xosc.CloudState.free if minor < 2 else xosc.FractionalCloudCover.zeroOktas,
                           sun=xosc.Sun(50000, 0.0, 1.0), fog=xosc.Fog(100000),
                           precipitation=xosc.Precipitation(xosc.PrecipitationType.dry, 0.0))
    environment = xosc.Environment("road", xosc.TimeOfDay(False, 2024, 6, 1, 12, 0, 0), weather,
                                   xosc.RoadCondition(friction))
    init.add_global_action(xosc.EnvironmentAction(environment))
    end = max(float(u.trajectory.t[-1]) for u in users) + run.history.dt
    stop = xosc.Trigger("stop")
    goals = _goal_conditions(run, problems, minor)
    if goals:
        reached = xosc.ConditionGroup("stop")
        for condition in goals:
            reached.add_condition(condition)
        stop.add_conditiongroup(reached)
    timeout = xosc.ConditionGroup("stop")
    timeout.add_condition(xosc.ValueTrigger("recording_ends", 0, xosc.ConditionEdge.rising,
                                            xosc.SimulationTimeCondition(round(end, 6), xosc.Rule.greaterThan)))
    stop.add_conditiongroup(timeout)
    storyboard = xosc.StoryBoard(init, stop)
    storyboard.add_story(story)
    return xosc.Scenario(description, "simgap", xosc.ParameterDeclarations(), entities, storyboard,
                         xosc.RoadNetwork(road_file), xosc.Catalog(), osc_minor_version=minor,
                         creation_date=datetime.datetime.now().replace(microsecond=0))


def description(run: RunRecord, users: list[RoadUser], notes: list[str]) -> str:
    """The file's description: what ran, and the settings OpenSCENARIO has no place for."""
    late = [u.name for u in users if u.trajectory.t[0] > 1e-9]
    if late:
        notes = notes + [f"{len(late)} road user(s) recorded from a later time ({', '.join(late[:3])}"
                         f"{', ...' if len(late) > 3 else ''}) stand at their first position until then"]
    backend, controller = run.settings.backend, run.settings.controller
    cosim = run.settings.cosim
    sensing = {k: v for k, v in cosim.sensing.model_dump(mode="json").items() if v is not None}
    planner = run.settings.planner.name
    parts = [f"simgap run of {run.scenario_id} in the {run.history.backend} world"
             + (f" (controller {controller})" if controller else "")
             + (f", planner {planner}" if planner else "") + f", seed {run.settings.seed}"]
    settings = _reality_settings(backend)
    if run.realism is Realism.REAL:
        settings |= {f"sensing.{k}": v for k, v in sensing.items()} | {"latency": cosim.latency}
    if cosim.traffic.value != "replay":
        settings["traffic"] = cosim.traffic.value
        notes = notes + ["recorded traffic moved by the IDM in the run: written as it drove" if run.history.traffic else
                         "recorded traffic moved by the IDM in the run; its motion is not in the run record, the "
                         "recording is written"]
    if settings:
        parts.append("settings: " + ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                                            for k, v in settings.items()))
    outcomes = ", ".join(f"agent {a.id} {a.outcome.value}" for a in run.history.agents)
    parts.append(f"outcome: {outcomes}")
    parts.append("goals end the story by position and window start; their velocity and orientation windows "
                 "are not conditions here")
    return "; ".join(parts + notes)


def _reality_settings(backend: BaseModel) -> dict[str, object]:
    """The backend's settings that make its world unlike the ideal one and that OpenSCENARIO has no
    place for (its friction has one): its realism, then the fields that break an assumption of the
    planner (`simgap.sim.assumptions`), each where it is set."""
    dumped = backend.model_dump(mode="json")
    fields = [f for a in Assumption if a is not Assumption.FRICTION for f in restorations(backend).get(a, {})]
    return {k: dumped[k] for k in (["realism"] if isinstance(backend, TrackingSettings) else []) + fields if dumped[k]}
