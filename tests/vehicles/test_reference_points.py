"""The one conversion between the vehicle's centre and its rear axle: a point moved along the
heading, for floats and arrays alike, and back."""

from __future__ import annotations

import math

import numpy as np

from simgap.vehicles import load_vehicle


def test_centre_and_rear_axle_are_the_wheelbase_share_apart_along_the_heading():
    sedan = load_vehicle("sedan")
    r = sedan.rear_axle_to_center
    x, y = sedan.rear_axle_of(10.0, -2.0, math.pi / 2)
    assert (x, y) == (10.0 + (-r) * math.cos(math.pi / 2), -2.0 - r)
    assert isinstance(x, float)
    back = sedan.centre_of(x, y, math.pi / 2)
    assert math.isclose(back[0], 10.0, abs_tol=1e-12) and math.isclose(back[1], -2.0, abs_tol=1e-12)


def test_arrays_move_point_by_point():
    sedan = load_vehicle("suv")
    yaw = np.linspace(-3.0, 3.0, 7)
    x, y = np.arange(7.0), np.zeros(7)
    cx, cy = sedan.centre_of(x, y, yaw)
    np.testing.assert_allclose(np.hypot(cx - x, cy - y), sedan.rear_axle_to_center)
    np.testing.assert_allclose(np.arctan2(cy - y, cx - x), yaw)
    rx, ry = sedan.rear_axle_of(cx, cy, yaw)
    np.testing.assert_allclose(rx, x, atol=1e-12)
    np.testing.assert_allclose(ry, y, atol=1e-12)
