"""Planning problems: an agent's initial state on a lane and its goal region."""

from __future__ import annotations

import math

import numpy as np
from commonroad.common.util import Interval
from commonroad.geometry.shape import Circle, Rectangle
from commonroad.planning.goal import GoalRegion
from commonroad.planning.planning_problem import PlanningProblem
from commonroad.scenario.lanelet import Lanelet
from commonroad.scenario.state import CustomState, InitialState

from simgap.errors import InputError
from simgap.trajectory import DEFAULT_TIME_STEP_S


def pose_on_lanelet(lanelet: Lanelet, s: float) -> tuple[np.ndarray, float]:
    """Centre-line position and heading at arc length ``s`` along ``lanelet``."""
    length = float(lanelet.distance[-1])
    if not 0.0 <= s <= length + 1e-6:
        raise InputError(f"position {s:.1f} m is not on lanelet {lanelet.lanelet_id}",
                         field="s", allowed=f"0 to {length:.1f} m")
    centre = lanelet.center_vertices
    k = int(np.clip(np.searchsorted(lanelet.distance, s) - 1, 0, len(centre) - 2))
    seg = centre[k + 1] - centre[k]
    u = (s - lanelet.distance[k]) / max(np.linalg.norm(seg), 1e-12)
    return centre[k] + u * seg, math.atan2(seg[1], seg[0])


def planning_problem(
    problem_id: int,
    start: tuple[Lanelet, float],
    goal: tuple[Lanelet, float],
    *,
    initial_speed: float = 0.0,
    goal_length: float = 10.0,
    goal_width: float | None = None,
    time_limit_s: float = 30.0,
    dt: float = DEFAULT_TIME_STEP_S,
    goal_speed: tuple[float, float] | None = None,
    goal_on_lanelet: bool = False,
    heading: float | None = None,
    goal_disc: tuple[np.ndarray, float] | None = None,
) -> PlanningProblem:
    """An agent starting on ``start`` (lanelet, s) at ``initial_speed`` heading along the lane (or
    ``heading`` [rad]).

    The goal region is a ``goal_length`` x lane-width rectangle centred at ``goal`` (lanelet, s),
    oriented along the lane — or, with ``goal_on_lanelet``, the whole goal lanelet; with
    ``goal_disc`` (centre, radius [m]), that disc — to be reached within ``time_limit_s``,
    optionally within a speed interval.
    """
    if initial_speed < 0:
        raise InputError(f"initial speed {initial_speed} is negative", field="initial_speed",
                         allowed=">= 0 m/s")
    pos, lane_heading = pose_on_lanelet(*start)
    init = InitialState(position=pos, orientation=lane_heading if heading is None else float(heading),
                        velocity=float(initial_speed), acceleration=0.0, yaw_rate=0.0, slip_angle=0.0, time_step=0)
    goal_lanelet, goal_s = goal
    fields = {"time_step": Interval(0, int(round(time_limit_s / dt)))}
    if goal_speed is not None:
        fields["velocity"] = Interval(*goal_speed)
    if goal_disc is not None:
        fields["position"] = Circle(float(goal_disc[1]), np.asarray(goal_disc[0], dtype=float))
        lanelets_of_goal = None
    elif goal_on_lanelet:
        fields["position"] = goal_lanelet.polygon
        lanelets_of_goal = {0: [goal_lanelet.lanelet_id]}
    else:
        gpos, gheading = pose_on_lanelet(goal_lanelet, goal_s)
        width = goal_width or float(np.linalg.norm(goal_lanelet.left_vertices[0] - goal_lanelet.right_vertices[0]))
        fields["position"] = Rectangle(goal_length, width, gpos, gheading)
        lanelets_of_goal = None   # CommonRoad would write the lanelet instead of the rectangle
    region = GoalRegion([CustomState(**fields)], lanelets_of_goal_position=lanelets_of_goal)
    return PlanningProblem(problem_id, init, region)

