"""Where the road ends along an agent's route, where its events happened, and the series of its
run's timeline, all read from the record."""

from __future__ import annotations

import numpy as np
import pytest

from simgap.cosim.history import Event
from simgap.evaluate.route_centre import route_centre
from simgap.evaluate.route_edges import event_places, route_edges
from simgap.scenario import build_scenario
from simgap.sim.protocol import EventKind, Outcome


@pytest.fixture(scope="module")
def curve():
    concrete = build_scenario("curve", {"radius": 20, "angle": 90})
    problem = next(iter(concrete.problems.planning_problem_dict.values()))
    return concrete.scenario.lanelet_network, problem, route_centre(concrete.scenario.lanelet_network, problem)


def test_the_lane_edges_are_half_a_lane_either_side_and_the_road_reaches_beyond(curve):
    network, problem, frame = curve
    edges = route_edges(network, problem, frame)
    lane = network.find_lanelet_by_id(next(iter(network.lanelets)).lanelet_id)
    half = 0.5 * float(np.linalg.norm(lane.left_vertices[0] - lane.right_vertices[0]))
    inside = np.isfinite(edges.lane_left)
    assert inside.mean() > 0.95                                   # along the whole route
    assert edges.lane_left[inside] == pytest.approx(half, abs=0.05)
    assert edges.lane_right[inside] == pytest.approx(-half, abs=0.05)
    # the oncoming lane beside it: the road reaches a lane further left, and no further right
    assert np.nanmin(edges.road_left - edges.lane_left) > 2 * half - 0.1
    assert np.nanmax(np.abs(edges.road_right - edges.lane_right)) < 0.05


def test_an_event_is_placed_along_the_route_where_it_happened(curve):
    network, problem, frame = curve
    k = len(frame.xy) // 2
    normal = np.array([-frame.seg[k, 1], frame.seg[k, 0]]) / frame.seg_len[k]
    x, y = frame.xy[k] + 0.5 * frame.seg[k] + 0.7 * normal        # 0.7 m left of the centre line
    late, early, nowhere = (Event(5.0, 1, Outcome.OFF_ROAD, float(x), float(y), "footprint 0.1 m beyond the road"),
                            Event(1.0, 1, EventKind.PLANNER_NO_SOLUTION, float(frame.xy[0, 0]), float(frame.xy[0, 1])),
                            Event(2.0, 2, Outcome.COLLISION, 0.0, 0.0))
    first, second, third = event_places([late, early, nowhere], {1: frame, 2: None})
    assert [p.event for p in (first, second, third)] == [early, nowhere, late]      # in time order
    assert third.s == pytest.approx(frame.s[k] + 0.5 * frame.seg_len[k], abs=1e-6)
    assert third.d == pytest.approx(0.7, abs=1e-6)
    assert second.s is None and second.d is None                  # an agent without a route
    assert "t = 5.00 s agent 1 off_road at (" in third.describe() and "d = +0.70 m" in third.describe()
