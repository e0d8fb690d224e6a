"""The reference path: smooth, ~1 m spacing, on the lane centre, extended beyond both ends."""

from __future__ import annotations

import math

import numpy as np
import pytest
from commonroad.common.util import AngleInterval, Interval
from commonroad.geometry.shape import Rectangle
from commonroad.planning.goal import GoalRegion
from commonroad.planning.planning_problem import PlanningProblem
from commonroad.scenario.state import CustomState

from planner_roads import lateral_offset
from simgap.planning.reference_path import plan_reference_path, smooth_reference_path


def _straight_arc_straight(radius=20.0, angle=math.pi / 2, straight=50.0, step=2.0):
    a = np.stack([np.arange(0.0, straight, step), np.zeros(int(straight / step))], axis=1)
    phi = np.linspace(0.0, angle, int(radius * angle / step) + 1)
    arc = np.stack([straight + radius * np.sin(phi), radius - radius * np.cos(phi)], axis=1)
    d = np.arange(step, straight + step, step)
    end = arc[-1] + np.stack([d * math.cos(angle), d * math.sin(angle)], axis=1)
    return np.vstack([a, arc, end])


def test_smoothed_path_keeps_the_geometry():
    centre = _straight_arc_straight(radius=20.0)
    ref = smooth_reference_path(centre, spacing=1.0, smoothing=1.0, extension_back=10.0, extension_forward=40.0)
    spacing = np.diff(ref.s)
    assert spacing.min() > 0.95 and spacing.max() < 1.05
    assert ref.length == pytest.approx(10.0 + 50.0 + 20.0 * math.pi / 2 + 50.0 + 40.0, abs=1.0)
    # curvature: 1/r in the middle of the arc, 0 on the straights, a ramp (no jump) in between
    mid = np.argmin(np.hypot(*(ref.xy - [50 + 20 * math.sin(math.pi / 4), 20 - 20 * math.cos(math.pi / 4)]).T))
    assert ref.kappa[mid] == pytest.approx(1 / 20, rel=0.03)
    assert abs(ref.kappa[5]) < 1e-6 and abs(ref.kappa[-5]) < 1e-6
    assert np.abs(np.diff(ref.kappa)).max() < 0.02
    assert np.abs(np.diff(ref.theta)).max() < 0.06            # continuous, unwrapped heading
    # the route's own interval of arc length
    assert ref.route_s[0] == pytest.approx(10.0, abs=0.2)
    assert ref.route_s[1] == pytest.approx(ref.length - 40.0, abs=0.5)
    # smoothing moves the path by centimetres, not decimetres
    worst = max(abs(lateral_offset(ref.xy, *p)) for p in centre[::3])
    assert worst < 0.1


def test_route_reference_path_follows_the_ego_lane(curve_road, curve_planner, sedan):
    ref = curve_planner.reference_path
    assert ref.lanelet_ids == (1, 2, 3)
    # beyond the goal the path runs on for at least a horizon at the vehicle's top speed
    assert ref.length - ref.route_s[1] >= 3.0 * sedan.limits.max_speed
    # on the lane centre (the right lane, 1.5 m right of the road's centre line), within the
    # shrinking of a 11.5 m radius by a 1 m Gaussian
    lane_centre = np.array([curve_road.ego_lane_pose(s)[:2] for s in np.arange(0, curve_road.centre_s[-1], 2.0)])
    worst = max(abs(lateral_offset(ref.xy, *p)) for p in lane_centre)
    assert worst < 0.1


def test_plan_reference_path_alone(straight_road):
    ref = plan_reference_path(straight_road.lanelet_network, straight_road.problem, extension_forward=50.0)
    assert np.allclose(ref.xy[:, 1], -1.5, atol=1e-6)
    assert ref.xy[0, 0] == pytest.approx(-20.0, abs=0.2) and ref.xy[-1, 0] == pytest.approx(250.0, abs=0.2)


def _with_goal_beside(road, d: float, length: float = 4.0, width: float = 2.0,
                      turned: float | None = None) -> PlanningProblem:
    """``road``'s problem with its goal a ``length`` x ``width`` rectangle whose centre lies ``d``
    left of the ego lane's centre, 30 m before the road's end (a recorded driver's end pose);
    ``turned``: an orientation window of +-0.087 rad turned this much from the lane."""
    gx, gy, gh = road.ego_lane_pose(road.centre_s[-1] - 30.0, d)
    state = dict(position=Rectangle(length, width, np.array([gx, gy]), gh), time_step=Interval(0, 600))
    if turned is not None:
        state["orientation"] = AngleInterval(gh + turned - 0.087, gh + turned + 0.087)
    return PlanningProblem(1, road.problem.initial_state, GoalRegion([CustomState(**state)]))


def test_the_path_moves_over_onto_a_goal_area_beside_the_lane(straight_road):
    """A goal rectangle 1 m left of the lane centre (the car on the centre line would pass beside
    it): the path moves over onto its centre before it and is untouched near the start; a goal
    on the centre line, or within centimetres of it, leaves the path as it was."""
    x_goal = straight_road.ego_lane_pose(straight_road.centre_s[-1] - 30.0)[0]
    ref = plan_reference_path(straight_road.lanelet_network, _with_goal_beside(straight_road, 1.0))
    y_at = lambda x: float(np.interp(x, ref.xy[:, 0], ref.xy[:, 1]))      # noqa: E731 - the road runs along +x
    assert y_at(x_goal) == pytest.approx(-0.5, abs=0.05)
    assert y_at(x_goal - 40.0) == pytest.approx(-1.5, abs=0.01) and y_at(0.0) == pytest.approx(-1.5, abs=1e-6)
    assert np.abs(ref.kappa).max() < 0.01              # a gentle move over
    for d in (0.0, 0.2):
        ref = plan_reference_path(straight_road.lanelet_network, _with_goal_beside(straight_road, d))
        assert np.allclose(ref.xy[:, 1], -1.5, atol=1e-6), d


def test_the_path_arrives_at_a_goal_beside_the_lane_with_its_heading(straight_road):
    """The recorded driver was changing lanes at the end (the goal's orientation window turned
    0.05 rad to the left): the path reaches the goal's centre heading that way, and runs on
    beyond it without turning further."""
    x_goal = straight_road.ego_lane_pose(straight_road.centre_s[-1] - 30.0)[0]
    ref = plan_reference_path(straight_road.lanelet_network, _with_goal_beside(straight_road, 1.0, turned=0.05))
    heading_at = lambda x: float(np.interp(x, ref.xy[:, 0], ref.theta))     # noqa: E731 - the road runs along +x
    assert float(np.interp(x_goal, ref.xy[:, 0], ref.xy[:, 1])) == pytest.approx(-0.5, abs=0.05)
    assert heading_at(x_goal) == pytest.approx(0.05, abs=0.01)
    assert abs(heading_at(x_goal + 20.0)) < 0.01


def test_a_goal_on_the_lane_is_reached_with_the_heading_its_window_asks_for(straight_road):
    """The goal's centre lies on the lane's centre line, but its orientation window (+-0.087 rad)
    is turned 0.15 rad from the lane (a recorded driver changing lanes there): the path passes the
    goal's centre heading as the window asks (0.15 +- 0.087 rad: well inside it), and is untouched
    near the start."""
    x_goal = straight_road.ego_lane_pose(straight_road.centre_s[-1] - 30.0)[0]
    ref = plan_reference_path(straight_road.lanelet_network, _with_goal_beside(straight_road, 0.0, turned=0.15))
    assert 0.15 - 0.05 <= float(np.interp(x_goal, ref.xy[:, 0], ref.theta)) <= 0.15 + 0.05
    assert float(np.interp(x_goal, ref.xy[:, 0], ref.xy[:, 1])) == pytest.approx(-1.5, abs=0.05)
    assert float(np.interp(0.0, ref.xy[:, 0], ref.xy[:, 1])) == pytest.approx(-1.5, abs=1e-6)


@pytest.mark.parametrize("logical, params", [("curve", {"radius": 15, "angle": 120}), ("curve", {"radius": 90, "angle": -60}),
                                             ("s-curve", {}), ("t-junction", {}), ("intersection", {})])
def test_a_route_without_alternatives_is_the_route_planners_own_path(logical, params, monkeypatch):
    """Made from the route planner's polyline operations without its lane-change bookkeeping (which
    prints each lanelet's vertices to hash it), the path of the only route is the route planner's,
    point for point."""
    import logging

    import commonroad_route_planner.reference_path_planner as planner_module
    from commonroad_route_planner.reference_path_planner import ReferencePathPlanner

    from simgap.planning.reference_path import lanelet_routes, route_centre_line
    from simgap.scenario.logical import build_scenario

    built = build_scenario(logical, params)
    network = built.scenario.lanelet_network
    for problem in built.problems.planning_problem_dict.values():
        routes, start = lanelet_routes(network, problem)
        assert len(routes) == 1
        library = ReferencePathPlanner(network, start, routes, logging_level=logging.ERROR).plan_shortest_reference_path()
        with monkeypatch.context() as m:        # not asked: a call would fall back to the joined centre lines
            m.setattr(planner_module, "ReferencePathPlanner", None)
            ours, ids = route_centre_line(network, problem)
        assert ids == tuple(library.lanelet_ids)
        assert np.array_equal(ours, library.reference_path), logical
