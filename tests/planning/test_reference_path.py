"""The reference path: smooth, ~1 m spacing, on the lane centre, extended beyond both ends."""

from __future__ import annotations

import math

import numpy as np
import pytest

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
