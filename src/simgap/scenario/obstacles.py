"""Non-agent obstacles of a scenario as the simulation sees them: their box and recorded motion.

Every CommonRoad obstacle becomes an oriented box moving on the scenario's time grid:

* shapes: a rectangle as it is; a circle as its bounding square; a polygon or a shape group as
  the smallest rotated rectangle around it (offsets from the obstacle's reference point kept);
* motion: a trajectory prediction as recorded; a set-based prediction as its occupancies (the
  box around each step's occupied set; the obstacle's box is the largest of its first
  ``_SET_BOX_STEPS`` steps, the horizon a planner looks ahead); a static obstacle stands still for
  ever (a two-state motion whose second state lies ``STANDING_FOR_S`` later).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np
from commonroad.geometry.shape import Circle, Polygon, Rectangle, Shape, ShapeGroup
from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.prediction.prediction import SetBasedPrediction, TrajectoryPrediction
from commonroad.scenario.obstacle import DynamicObstacle, Obstacle, ObstacleType
from commonroad.scenario.scenario import Scenario
from commonroad.scenario.trajectory import Trajectory as CrTrajectory
from shapely.geometry import MultiPoint

from simgap.trajectory import State, Trajectory

STANDING_FOR_S = 1.0e6
_SET_BOX_STEPS = 30
_VEHICLE_TYPES = {ObstacleType.CAR, ObstacleType.TRUCK, ObstacleType.BUS, ObstacleType.MOTORCYCLE,
                  ObstacleType.PRIORITY_VEHICLE, ObstacleType.TAXI, ObstacleType.UNKNOWN}


@dataclass(frozen=True)
class RecordedObstacle:
    """An obstacle that follows its recorded motion (``motion``: box centres), whatever happens."""

    id: int
    length: float
    width: float
    motion: Trajectory
    vehicle: bool = True       # a vehicle (may be driven by an IDM), not a pedestrian or cyclist
    static: bool = False


@dataclass(frozen=True)
class Box:
    """An oriented box in an obstacle's own frame: centre offset, heading offset, size."""

    dx: float
    dy: float
    yaw: float
    length: float
    width: float


def box_of(shape: Shape) -> Box:
    """The oriented box that stands for ``shape`` (see the module docstring)."""
    if isinstance(shape, Rectangle):
        return Box(float(shape.center[0]), float(shape.center[1]), float(shape.orientation),
                   float(shape.length), float(shape.width))
    if isinstance(shape, Circle):
        return Box(float(shape.center[0]), float(shape.center[1]), 0.0, 2 * shape.radius, 2 * shape.radius)
    if isinstance(shape, ShapeGroup):
        points = np.vstack([_outline(s) for s in shape.shapes])
    elif isinstance(shape, Polygon):
        points = np.asarray(shape.vertices, dtype=float)
    else:
        points = _outline(shape)
    return _min_box(points)


def _outline(shape: Shape) -> np.ndarray:
    if isinstance(shape, Circle):
        a = np.linspace(0, 2 * math.pi, 16, endpoint=False)
        return np.asarray(shape.center) + shape.radius * np.stack([np.cos(a), np.sin(a)], 1)
    if isinstance(shape, ShapeGroup):
        return np.vstack([_outline(s) for s in shape.shapes])
    return np.asarray(shape.vertices, dtype=float)


def _min_box(points: np.ndarray) -> Box:
    rect = MultiPoint([tuple(p) for p in points]).minimum_rotated_rectangle
    corners = np.asarray(rect.exterior.coords)[:4] if rect.geom_type == "Polygon" else np.vstack([points.min(0)] * 4)
    e1, e2 = corners[1] - corners[0], corners[2] - corners[1]
    length, width = float(np.hypot(*e1)), float(np.hypot(*e2))
    if length < width:
        e1, length, width = e2, width, length
    centre = corners.mean(axis=0)
    return Box(float(centre[0]), float(centre[1]), math.atan2(e1[1], e1[0]), max(length, 0.1), max(width, 0.1))


def exact(value, default: float = 0.0):
    """A state attribute's value: an uncertain one (a shape, an interval; recorded files have
    them) as its centre."""
    if value is None:
        return default
    if hasattr(value, "center"):
        return np.asarray(value.center, dtype=float)
    if hasattr(value, "start") and hasattr(value, "end"):
        return 0.5 * (float(value.start) + float(value.end))
    return value


def _centre_state(st, box: Box, dt: float) -> State:
    yaw = float(exact(getattr(st, "orientation", None)))
    position = np.asarray(exact(st.position), dtype=float)
    c, s = math.cos(yaw), math.sin(yaw)
    return State(
        t=int(exact(st.time_step)) * dt, x=float(position[0]) + c * box.dx - s * box.dy,
        y=float(position[1]) + s * box.dx + c * box.dy, yaw=yaw + box.yaw,
        v=float(exact(getattr(st, "velocity", None))), a=float(exact(getattr(st, "acceleration", None))),
        yaw_rate=float(exact(getattr(st, "yaw_rate", None))))


def _trajectory_motion(obstacle: Obstacle, box: Box, dt: float) -> Trajectory:
    states = [obstacle.initial_state]
    if isinstance(obstacle.prediction, TrajectoryPrediction):
        states += [st for st in obstacle.prediction.trajectory.state_list if st.time_step > states[-1].time_step]
    return Trajectory.from_states([_centre_state(st, box, dt) for st in states], dt)


def _set_based(obstacle: DynamicObstacle, dt: float) -> tuple[Trajectory, Box]:
    """Box centres of a set-based prediction's occupancies (after the initial state), and the box."""
    own = box_of(obstacle.obstacle_shape)
    rows, boxes = [_centre_state(obstacle.initial_state, own, dt)], [own]
    previous = rows[0]
    for occupancy in sorted(obstacle.prediction.occupancy_set, key=lambda o: o.time_step):
        if occupancy.time_step * dt <= previous.t + 1e-9:
            continue
        box = box_of(occupancy.shape)    # occupancies are in the world frame
        boxes.append(box)
        t = occupancy.time_step * dt
        v = math.hypot(box.dx - previous.x, box.dy - previous.y) / max(t - previous.t, dt)
        previous = State(t=t, x=box.dx, y=box.dy, yaw=box.yaw, v=v)
        rows.append(previous)
    # occupancy steps can have gaps: fill the grid by interpolation
    grid = rows[0].t + dt * np.arange(int(round((rows[-1].t - rows[0].t) / dt)) + 1)
    motion = Trajectory.from_states([_at(rows, t) for t in grid], dt)
    size = boxes[: _SET_BOX_STEPS + 1]
    return motion, Box(0, 0, 0, max(b.length for b in size), max(b.width for b in size))


def _at(rows: list[State], t: float) -> State:
    times = np.array([r.t for r in rows])
    k = int(np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(rows) - 1))
    if k == len(rows) - 1 or times[k] >= t - 1e-9:
        return rows[k].replace(t=t)
    w = (t - times[k]) / (times[k + 1] - times[k])
    a, b = rows[k], rows[k + 1]
    dyaw = math.remainder(b.yaw - a.yaw, 2 * math.pi)
    return State(t, a.x + w * (b.x - a.x), a.y + w * (b.y - a.y), a.yaw + w * dyaw, a.v + w * (b.v - a.v))


def _standing(obstacle: Obstacle, dt: float) -> tuple[Trajectory, Box]:
    box = box_of(obstacle.obstacle_shape)
    here = _centre_state(obstacle.initial_state, box, dt).replace(v=0.0, a=0.0, yaw_rate=0.0)
    return Trajectory.from_states([here, here.replace(t=here.t + STANDING_FOR_S)], STANDING_FOR_S), box


def recorded_obstacles(scenario: Scenario) -> list[RecordedObstacle]:
    """Every static and dynamic obstacle of the scenario, of any shape and prediction kind."""
    dt = float(scenario.dt)
    out = []
    for obs in scenario.static_obstacles:
        motion, box = _standing(obs, dt)
        out.append(RecordedObstacle(obs.obstacle_id, box.length, box.width, motion,
                                    vehicle=obs.obstacle_type in _VEHICLE_TYPES, static=True))
    for obs in scenario.dynamic_obstacles:
        if isinstance(obs.prediction, SetBasedPrediction):
            motion, box = _set_based(obs, dt)
        else:
            box = box_of(obs.obstacle_shape)
            motion = _trajectory_motion(obs, box, dt)
        out.append(RecordedObstacle(obs.obstacle_id, box.length, box.width, motion,
                                    vehicle=obs.obstacle_type in _VEHICLE_TYPES))
    return out


# a dynamic obstacle this close to a planning problem's initial state (at its time step) is that
# problem's own recorded vehicle: converted datasets keep the human driver beside the problem
_SAME_POSITION_M, _SAME_HEADING_RAD = 0.05, 0.05


def recorded_egos(scenario: Scenario, problems: PlanningProblemSet) -> dict[int, int]:
    """Planning problem id -> the dynamic obstacle that is its own recording (the human driver it
    replaces): the obstacle standing exactly on the problem's initial state (position within
    `_SAME_POSITION_M`, heading within `_SAME_HEADING_RAD`, at the initial time step).

    Recorded datasets converted to CommonRoad (inD, MONA, highD, exiD with the ego kept) carry the
    ego's recorded vehicle as an obstacle; left in the traffic it would overlap the agent from t = 0."""
    found: dict[int, int] = {}
    for pid, problem in problems.planning_problem_dict.items():
        initial = problem.initial_state
        position = np.asarray(exact(initial.position), dtype=float)
        heading = float(exact(getattr(initial, "orientation", None)))
        step = int(exact(initial.time_step))
        for obstacle in scenario.dynamic_obstacles:
            state = obstacle.state_at_time(step)
            if state is None or obstacle.obstacle_id in found.values():
                continue
            offset = np.asarray(exact(state.position), dtype=float) - position
            turn = math.remainder(float(exact(getattr(state, "orientation", None))) - heading, 2 * math.pi)
            if math.hypot(*offset) <= _SAME_POSITION_M and abs(turn) <= _SAME_HEADING_RAD:
                found[pid] = obstacle.obstacle_id
                break
    return found


def without_recorded_egos(scenario: Scenario, problems: PlanningProblemSet) -> tuple[Scenario, dict[int, int]]:
    """``scenario`` in which every planning problem's agent takes over from its own recorded
    vehicle (a copy when there is any), and which obstacle each agent replaces (see
    `recorded_egos`). The recording drives on until the agent's initial time step (an agent that
    starts later than the scenario takes over a vehicle already on the road) and ends there."""
    egos = recorded_egos(scenario, problems)
    if not egos:
        return scenario, egos
    scenario = copy.deepcopy(scenario)
    for pid, oid in egos.items():
        obstacle = scenario.obstacle_by_id(oid)
        start = int(exact(problems.planning_problem_dict[pid].initial_state.time_step))
        if obstacle.initial_state.time_step >= start or not isinstance(obstacle.prediction, TrajectoryPrediction):
            scenario.remove_obstacle(obstacle)
            continue
        before = [st for st in obstacle.prediction.trajectory.state_list if st.time_step < start]
        obstacle.prediction = (TrajectoryPrediction(CrTrajectory(before[0].time_step, before), obstacle.obstacle_shape)
                               if before else None)
    return scenario, egos
