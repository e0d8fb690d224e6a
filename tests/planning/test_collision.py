"""Collision checks against shapely: the drivable-area grid never accepts a footprint off the
road, and the oriented-box test agrees with polygon intersection."""

from __future__ import annotations

import math

import numpy as np

from simgap.planning.collision import (
    footprint_outline,
    footprints_on_road,
    predict_traffic,
    traffic_collisions,
)
from simgap.planning.protocol import TrafficParticipant
from simgap.scenario.road_frame import DrivableArea, footprint
from simgap.trajectory import State, Trajectory


def test_grid_accepts_only_footprints_on_the_road(curve_planner, curve_road, sedan):
    rng = np.random.default_rng(1)
    area = DrivableArea(curve_road.lanelet_network, tolerance=0.0)
    frame, grid = curve_planner.frame, curve_planner.drivable_area
    outline = footprint_outline(sedan.length, sedan.width, 0.5)
    accepted = rejected_inside = 0
    for _ in range(600):
        # anywhere along the road but its very end (beyond which the grid continues the road)
        x, y, heading = curve_road.ego_lane_pose(rng.uniform(0.0, curve_road.centre_s[-1] - 6.0),
                                                 rng.uniform(-2.0, 4.5))
        yaw = heading + rng.normal(0.0, 0.3)
        cx, cy = frame.xy_to_local(x, y)
        on = footprints_on_road(grid, outline, np.array([cx]), np.array([cy]),
                                np.array([frame.local_heading(yaw)]))[0]
        inside = area.contains(footprint(State(0.0, x, y, yaw, 0.0), sedan.length, sedan.width))
        assert inside or not on, (x, y, yaw)
        accepted += on
        rejected_inside += inside and not on
    assert accepted > 150
    # conservative by about a grid cell, not more: few footprints on the road are refused
    assert rejected_inside < 0.1 * accepted


def test_grid_continues_the_road_beyond_its_end(curve_planner, curve_road, sedan):
    frame, grid = curve_planner.frame, curve_planner.drivable_area
    outline = footprint_outline(sedan.length, sedan.width, 0.5)
    x, y, heading = curve_road.ego_lane_pose(curve_road.centre_s[-1])
    for ahead in (5.0, 40.0):
        cx, cy = frame.xy_to_local(x + ahead * math.cos(heading), y + ahead * math.sin(heading))
        assert footprints_on_road(grid, outline, np.array([cx]), np.array([cy]),
                                  np.array([frame.local_heading(heading)]))[0]


def test_box_test_agrees_with_polygons():
    rng = np.random.default_rng(2)
    n = 400
    ego = rng.uniform([-4, -4, -math.pi], [4, 4, math.pi], size=(n, 3))
    other = TrafficParticipant(1, 4.0, 2.0, Trajectory.from_states([State(0.0, 0.0, 0.0, 0.3, 0.0)], 0.1))
    traffic = predict_traffic([other], np.zeros(1), lambda x, y: (x, y), 0.0, margin=0.0)
    hits = traffic_collisions(ego[:, :1], ego[:, 1:2], ego[:, 2:3], 2.25, 0.8, traffic)[:, 0]
    shape = footprint(other.prediction[0], 4.0, 2.0)
    expected = np.array([footprint(State(0.0, x, y, yaw, 0.0), 4.5, 1.6).intersects(shape) for x, y, yaw in ego])
    assert np.array_equal(hits, expected)
    assert 50 < hits.sum() < n - 50


def test_predictions_are_interpolated_and_extrapolated():
    moving = TrafficParticipant(3, 4.0, 2.0, Trajectory.from_states(
        [State(1.0, 0.0, 0.0, 0.0, 10.0), State(1.1, 1.0, 0.0, 0.0, 10.0)], 0.1))
    times = np.array([0.5, 1.05, 1.1, 1.6])
    pred = predict_traffic([moving], times, lambda x, y: (x, y), 0.0, margin=0.5)
    # absent before its recording starts (it enters the scene at 1.0 s), constant speed after it
    assert np.isnan(pred.x[0, 0]) and np.allclose(pred.x[0, 1:], [0.5, 1.0, 6.0])
    ego_where_it_enters = traffic_collisions(np.zeros((1, 4)), np.zeros((1, 4)), np.zeros((1, 4)), 2.25, 0.8, pred)
    assert ego_where_it_enters.tolist() == [[False, True, True, False]]
    assert pred.half_length[0] == 2.5 and pred.half_width[0] == 1.5
