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

    from simgap.planning.route import lanelet_routes, route_centre_line
    from simgap.scenario.logical import build_scenario

    built = build_scenario(logical, params)
    network = built.scenario.lanelet_network
    for problem in built.problems.planning_problem_dict.values():
        found = lanelet_routes(network, problem)
        assert len(found.routes) == 1 and found.network is network
        library = ReferencePathPlanner(network, found.problem, found.routes,
                                       logging_level=logging.ERROR).plan_shortest_reference_path()
        with monkeypatch.context() as m:        # not asked: a call would fall back to the joined centre lines
            m.setattr(planner_module, "ReferencePathPlanner", None)
            ours, ids = route_centre_line(network, problem)
        assert ids == tuple(library.lanelet_ids)
        assert np.array_equal(ours, library.reference_path), logical


def _parallel_lanes(pieces_m: tuple[float, ...], lanes: int = 2, width: float = 3.5, linked: bool = True):
    """Straight lanes along +x (lane 0 on the right, centre y = 1.75), each cut into lanelets of
    ``pieces_m`` with two vertices a side, as recorded maps draw them; id = 10 * (lane + 1) + piece.
    ``linked``: neighbours know each other (else the map leaves them unlinked)."""
    from commonroad.scenario.lanelet import Lanelet, LaneletNetwork

    ends = np.concatenate([[0.0], np.cumsum(pieces_m)])
    lanelets = []
    for lane in range(lanes):
        for k in range(len(pieces_m)):
            x = ends[k:k + 2]
            side = lambda y, x=x: np.stack([x, np.full(2, y)], 1)     # noqa: E731
            lid = 10 * (lane + 1) + k
            lanelets.append(Lanelet(
                side((lane + 1) * width), side((lane + 0.5) * width), side(lane * width), lid,
                predecessor=[lid - 1] if k else None, successor=[lid + 1] if k < len(pieces_m) - 1 else None,
                adjacent_left=lid + 10 if linked and lane < lanes - 1 else None, adjacent_left_same_direction=True,
                adjacent_right=lid - 10 if linked and lane else None, adjacent_right_same_direction=True))
    return LaneletNetwork.create_from_lanelet_list(lanelets)


def _monotone_move(path: np.ndarray) -> tuple[float, float]:
    """(smallest step along x, steepest sideways slope) of a path along +x."""
    step = np.diff(path[:, 0])
    return float(step.min()), float(np.abs(np.diff(path[:, 1]) / np.maximum(step, 1e-9)).max())


def test_a_lane_change_onto_a_short_last_lanelet_starts_on_the_lanelets_before_it():
    # the route planner changes lanes on the last lanelet before the goal, 12 m long on this map
    # (AAH-4's ramp): the change starts beside the car, on the lanelet before, and takes its full
    # length (35 m) instead of being squeezed into 12 m
    from simgap.planning.route import _joined_centre_lines

    network = _parallel_lanes((60.0, 12.0))
    path = _joined_centre_lines(network, (10, 11, 21), np.array([5.0, 1.75]), change_m=35.0)
    smallest_step, slope = _monotone_move(path)
    assert smallest_step > 0.0                                   # never back along the road
    assert slope <= 1.875 * 3.5 / 35.0 + 0.01                    # a smoothstep over 35 m
    y_at = lambda x: float(np.interp(x, path[:, 0], path[:, 1]))  # noqa: E731
    assert y_at(5.0) == pytest.approx(1.75, abs=0.01) and y_at(41.0) == pytest.approx(5.25, abs=0.01)


def test_lane_changes_in_a_row_share_the_stretch_before_the_junction():
    # two changes to the right lane of three within 40 m (Peachtree's right turn from the left lane):
    # each takes half of the stretch beside the car, not the first all of it and the second a jump
    from simgap.planning.route import _joined_centre_lines

    network = _parallel_lanes((40.0,), lanes=3)
    path = _joined_centre_lines(network, (10, 20, 30), np.array([2.0, 1.75]), change_m=35.0)
    smallest_step, slope = _monotone_move(path)
    assert smallest_step > 0.0
    assert slope <= 1.875 * 3.5 / 19.0 + 0.02                    # two smoothsteps over 19 m each
    assert float(np.interp(21.0, path[:, 0], path[:, 1])) == pytest.approx(5.25, abs=0.01)
    assert path[-1, 1] == pytest.approx(8.75, abs=1e-6)


def test_a_map_that_leaves_side_by_side_lanes_unlinked_is_routed_with_them_linked():
    # DEU_Muc-2's two lanes share a boundary but the file links neither as the other's neighbour:
    # the goal in the lane beside was refused ("no route"); it is routed with a lane change now,
    # on a copy of the network (the file's network is left as it was)
    from commonroad.scenario.state import InitialState

    from simgap.planning.route import lanelet_routes

    network = _parallel_lanes((200.0,), linked=False)
    initial = InitialState(position=np.array([10.0, 1.75]), orientation=0.0, velocity=10.0, acceleration=0.0,
                           yaw_rate=0.0, slip_angle=0.0, time_step=0)
    goal = GoalRegion([CustomState(position=Rectangle(10.0, 3.0, np.array([160.0, 5.25])), time_step=Interval(0, 200))])
    problem = PlanningProblem(1, initial, goal)
    found = lanelet_routes(network, problem)
    assert {tuple(int(i) for i in r.lanelet_ids) for r in found.routes} == {(10, 20)}
    assert found.network is not network and network.find_lanelet_by_id(10).adj_left is None
    assert found.network.find_lanelet_by_id(10).adj_left == 20 and found.network.find_lanelet_by_id(20).adj_right == 10
    ref = plan_reference_path(network, problem)
    assert float(np.interp(160.0, ref.xy[:, 0], ref.xy[:, 1])) == pytest.approx(5.25, abs=0.05)


def test_a_recorded_turn_drawn_with_a_few_vertices_is_eased_within_the_kink_tolerance(monkeypatch):
    # a 90 degree turn of 8 m radius drawn as four chords between straights (recorded maps'
    # turning lanelets): smoothed within a hand's breadth only, its curvature ramps over a metre or
    # two, which the steering rate follows at walking pace; eased within KINK_DEVIATION_TOLERANCE_M
    # the ramp is half as steep. A curve whose curvature ramps gently keeps the narrow tolerance.
    import simgap.planning.path_smoothing as path_smoothing

    phi = np.linspace(0.0, math.pi / 2, 5)
    turn = np.stack([8.0 * np.sin(phi), -8.0 + 8.0 * np.cos(phi)], 1)
    line = np.vstack([np.stack([np.arange(-40.0, 0.0, 10.0), np.zeros(4)], 1), turn,
                      np.stack([np.full(4, 8.0), -8.0 - np.arange(10.0, 41.0, 10.0)], 1)])

    def ramp_and_offset(centre):
        """The path's steepest curvature ramp [1/m^2], the path, and its largest offset from ``centre``."""
        path = smooth_reference_path(centre, 1.0, 1.0, 10.0, 20.0)
        on = (path.s >= path.route_s[0]) & (path.s <= path.route_s[1])
        return (float(np.abs(np.gradient(path.kappa, path.s))[on].max()), path,
                max(abs(lateral_offset(centre, *p)) for p in path.xy[on]))

    tolerance = path_smoothing.KINK_DEVIATION_TOLERANCE_M
    eased, _, off = ramp_and_offset(line)
    arc = _straight_arc_straight(radius=30.0)
    _, arc_path, _ = ramp_and_offset(arc)
    monkeypatch.setattr(path_smoothing, "KINK_DEVIATION_TOLERANCE_M", path_smoothing.DEVIATION_TOLERANCE_M)
    narrow, _, _ = ramp_and_offset(line)
    _, arc_narrow, _ = ramp_and_offset(arc)
    assert eased <= 0.6 * narrow
    assert path_smoothing.DEVIATION_TOLERANCE_M < off <= tolerance + 0.01
    assert np.allclose(arc_path.xy, arc_narrow.xy)
