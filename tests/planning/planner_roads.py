"""Test roads for the planner, built directly with commonroad-io, and an ideal closed loop.

A two-lane road as in the paper's generated scenarios: a straight, an arc (radius r, angle γ,
positive = left), a straight; two lanes of ``lane_width`` in opposite directions. The ego lane is
the right one (driving direction = the road's direction). Planning problem: start ``start_s``
metres in, goal a 10 m x lane-width rectangle centred ``goal_before_end`` metres before the end.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from commonroad.common.util import Interval
from commonroad.geometry.shape import Rectangle
from commonroad.planning.goal import GoalRegion
from commonroad.planning.planning_problem import PlanningProblem, PlanningProblemSet
from commonroad.scenario.lanelet import Lanelet, LaneletNetwork
from commonroad.scenario.scenario import Scenario
from commonroad.scenario.state import CustomState, InitialState

from simgap.trajectory import State

DT = 0.1
EGO_LANE_IDS = (1, 2, 3)


@dataclass
class TestRoad:
    scenario: Scenario
    problem: PlanningProblem
    centre: np.ndarray          # road centre line (between the lanes), ~0.5 m spacing
    centre_s: np.ndarray        # its arc length
    lane_width: float

    @property
    def lanelet_network(self) -> LaneletNetwork:
        return self.scenario.lanelet_network

    @property
    def problems(self) -> PlanningProblemSet:
        return PlanningProblemSet([self.problem])

    def ego_lane_pose(self, s: float, d: float = 0.0) -> tuple[float, float, float]:
        """(x, y, heading) of the point ``s`` along the road, ``d`` left of the ego lane centre."""
        x = np.interp(s, self.centre_s, self.centre[:, 0])
        y = np.interp(s, self.centre_s, self.centre[:, 1])
        k = min(np.searchsorted(self.centre_s, s), len(self.centre_s) - 1)
        k = max(k, 1)
        dx, dy = self.centre[k] - self.centre[k - 1]
        heading = math.atan2(dy, dx)
        offset = -self.lane_width / 2 + d
        return x - offset * math.sin(heading), y + offset * math.cos(heading), heading


def _sections(straight: float, radius: float, angle_deg: float, step: float = 0.5):
    """Centre-line pieces [(points, kind)] of straight - arc - straight, starting at the origin."""
    pieces = []
    n = max(2, int(round(straight / step)) + 1)
    first = np.stack([np.linspace(0.0, straight, n), np.zeros(n)], axis=1)
    pieces.append(first)
    p0, heading = first[-1], 0.0
    angle = math.radians(angle_deg)
    if abs(angle) > 1e-9:
        sign = 1.0 if angle > 0 else -1.0
        centre = p0 + sign * radius * np.array([-math.sin(heading), math.cos(heading)])
        m = max(3, int(math.ceil(radius * abs(angle) / step)) + 1)
        phi = np.linspace(0.0, angle, m)
        start_angle = heading - sign * math.pi / 2
        arc = centre + radius * np.stack([np.cos(start_angle + phi), np.sin(start_angle + phi)], axis=1)
        pieces.append(arc)
        p0, heading = arc[-1], heading + angle
    d = np.linspace(0.0, straight, n)
    last = p0 + np.stack([d * math.cos(heading), d * math.sin(heading)], axis=1)
    pieces.append(last)
    return pieces


def _offset(points: np.ndarray, d: float) -> np.ndarray:
    """The polyline ``d`` to the left of ``points`` (vertex normals from central differences)."""
    tangent = np.gradient(points, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    normal = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)
    return points + d * normal


def two_lane_road(radius: float = 10.0, angle_deg: float = 90.0, straight: float = 100.0,
                  lane_width: float = 3.0, start_s: float = 10.0, v0: float = 0.0,
                  goal_before_end: float = 10.0, goal_velocity: Interval | None = None,
                  initial_yaw_error: float = 0.0, initial_offset: float = 0.0) -> TestRoad:
    pieces = _sections(straight, radius, angle_deg)
    whole = np.vstack([pieces[0]] + [p[1:] for p in pieces[1:]])
    half = lane_width / 2
    bounds = {d: _offset(whole, d) for d in (-lane_width, -half, 0.0, half, lane_width)}
    # piece i spans points first[i] .. first[i + 1] of the whole line (joints are shared)
    first = np.cumsum([0] + [len(p) - 1 for p in pieces])
    n = len(pieces)
    objects = []
    for i in range(n):
        sl = slice(first[i], first[i + 1] + 1)
        objects.append(Lanelet(bounds[0.0][sl], bounds[-half][sl], bounds[-lane_width][sl], lanelet_id=1 + i,
                               predecessor=[i] if i > 0 else None, successor=[2 + i] if i < n - 1 else None,
                               adjacent_left=n + 1 + i, adjacent_left_same_direction=False))
        objects.append(Lanelet(bounds[0.0][sl][::-1], bounds[half][sl][::-1], bounds[lane_width][sl][::-1],
                               lanelet_id=n + 1 + i,
                               predecessor=[n + 2 + i] if i < n - 1 else None,
                               successor=[n + i] if i > 0 else None,
                               adjacent_left=1 + i, adjacent_left_same_direction=False))
    scenario = Scenario(DT)
    scenario.add_objects(LaneletNetwork.create_from_lanelet_list(objects))
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(whole, axis=0), axis=1))])
    road = TestRoad(scenario, None, whole, s, lane_width)  # type: ignore[arg-type]
    x, y, heading = road.ego_lane_pose(start_s, initial_offset)
    init = InitialState(position=np.array([x, y]), orientation=heading + initial_yaw_error,
                        velocity=v0, acceleration=0.0, yaw_rate=0.0, slip_angle=0.0, time_step=0)
    gx, gy, gh = road.ego_lane_pose(s[-1] - goal_before_end)
    goal_state = dict(position=Rectangle(10.0, lane_width, np.array([gx, gy]), gh),
                      time_step=Interval(0, 600))
    if goal_velocity is not None:
        goal_state["velocity"] = goal_velocity
    road.problem = PlanningProblem(1, init, GoalRegion([CustomState(**goal_state)]))
    return road


def start_state(road: TestRoad) -> State:
    ini = road.problem.initial_state
    return State(0.0, float(ini.position[0]), float(ini.position[1]), float(ini.orientation),
                 float(ini.velocity))


@dataclass
class ClosedLoop:
    """An ideal closed loop: after each cycle the vehicle stands on its plan at t + dt."""

    states: list
    plans: list
    goal_time: float | None
    failures: int


def drive(planner, road: TestRoad, state=None, steps: int = 400, world=None, stop_at_goal: bool = True,
          dt: float = DT) -> ClosedLoop:
    from commonroad.scenario.state import CustomState

    from simgap.planning.protocol import World

    state = state or start_state(road)
    world = world or World(road.lanelet_network, road.problem.goal, dt)
    states, plans, failures = [state], [], 0
    for _ in range(steps):
        plan = planner.plan(state, state.t, world)
        plans.append(plan)
        if plan is None:
            failures += 1
            break
        state = plan.at(state.t + dt).replace(t=state.t + dt)
        states.append(state)
        if stop_at_goal and road.problem.goal.is_reached(CustomState(
                position=state.position, orientation=state.yaw, velocity=state.v,
                time_step=int(round(state.t / dt)))):
            return ClosedLoop(states, plans, state.t, failures)
    return ClosedLoop(states, plans, None, failures)


def lateral_offset(path_xy: np.ndarray, x: float, y: float) -> float:
    """Signed distance (positive = left) of (x, y) from the polyline ``path_xy``."""
    a, seg = path_xy[:-1], np.diff(path_xy, axis=0)
    rel = np.array([x, y]) - a
    u = np.clip(np.einsum("ij,ij->i", rel, seg) / np.einsum("ij,ij->i", seg, seg), 0.0, 1.0)
    foot = a + u[:, None] * seg
    dist = np.hypot(*(np.array([x, y]) - foot).T)
    j = int(np.argmin(dist))
    cross = seg[j, 0] * rel[j, 1] - seg[j, 1] * rel[j, 0]
    return float(np.sign(cross) * dist[j])
