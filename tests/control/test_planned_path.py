"""Plan geometry as the controllers see it: projection, extension beyond the ends, curvature."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simgap.control.planned_path import PlannedPath, plan_curvature
from simgap.trajectory import State, Trajectory

WB, B = 2.578766, 1.4227


def _straight(n=11, v=10.0, yaw=0.0, dt=0.1):
    c, s = math.cos(yaw), math.sin(yaw)
    return Trajectory.from_states(
        [State(t=k * dt, x=c * v * k * dt, y=s * v * k * dt, yaw=yaw, v=v) for k in range(n)], dt)


def _arc(radius=20.0, v=5.0, n=21, dt=0.1):
    """Kinematic left turn: rear axle on a circle of radius ``radius`` around (0, radius)."""
    steer = math.atan(WB / radius)
    states = []
    for k in range(n):
        th = v * k * dt / radius
        rx, ry = radius * math.sin(th), radius * (1 - math.cos(th))
        states.append(State(t=k * dt, x=rx + B * math.cos(th), y=ry + B * math.sin(th), yaw=th,
                            v=v, steer=steer))
    return Trajectory.from_states(states, dt)


def test_projection_sign_and_arc_length():
    path = PlannedPath(_straight(), wheelbase=WB, rear_axle_to_center=B)
    p = path.project(3.0, 0.5)
    assert p.s == pytest.approx(3.0) and p.lateral == pytest.approx(0.5)
    assert path.project(3.0, -0.7).lateral == pytest.approx(-0.7)
    assert p.index == pytest.approx(3.0)


def test_extensions_beyond_both_ends():
    path = PlannedPath(_straight(yaw=0.5), wheelbase=WB, rear_axle_to_center=B)
    c, s = math.cos(0.5), math.sin(0.5)
    ahead = path.point_at(path.length + 7.0)
    assert ahead == pytest.approx((c * (path.length + 7.0), s * (path.length + 7.0)))
    behind = path.project(-4.0 * c - 1.0 * s, -4.0 * s + 1.0 * c)
    assert behind.s == pytest.approx(-4.0) and behind.lateral == pytest.approx(1.0)
    beyond = path.project(c * 120.0, s * 120.0)
    assert beyond.s == pytest.approx(120.0) and beyond.index == 10.0


def test_single_state_plan_is_a_line_along_its_heading():
    plan = Trajectory.from_states([State(t=0.0, x=1.0, y=2.0, yaw=math.pi / 2, v=0.0)], 0.1)
    path = PlannedPath(plan, wheelbase=WB, rear_axle_to_center=B)
    assert path.point_at(5.0) == pytest.approx((1.0, 7.0))
    p = path.project(0.0, 4.0)
    assert p.s == pytest.approx(2.0) and p.lateral == pytest.approx(1.0)


def test_standstill_plan_has_no_nan():
    plan = Trajectory.from_states([State(t=0.1 * k, x=0.0, y=0.0, yaw=0.2, v=0.0)
                                   for k in range(5)], 0.1)
    path = PlannedPath(plan, offset=-B, wheelbase=WB, rear_axle_to_center=B)
    p = path.project(0.5, 0.5)
    assert all(math.isfinite(x) for x in (p.s, p.lateral, p.index, p.heading))
    assert np.all(np.isfinite(path.curvature))


def test_offset_paths_and_curvature_of_an_arc():
    plan = _arc()
    rear = PlannedPath(plan, offset=-B, wheelbase=WB, rear_axle_to_center=B)
    # the rear axle draws the circle
    r = np.hypot(rear.x, rear.y - 20.0)
    np.testing.assert_allclose(r, 20.0, atol=1e-9)
    np.testing.assert_allclose(rear.curvature, 1 / 20.0, rtol=1e-3)
    # a point 0.3 m inside the circle (towards its centre) is left of a left turn
    th = 5 * 0.1 * 5.0 / 20.0
    p = rear.project(rear.x[5] - 0.3 * math.sin(th), rear.y[5] + 0.3 * math.cos(th))
    assert p.lateral == pytest.approx(0.3, abs=0.01)
    front = PlannedPath(plan, offset=WB - B, wheelbase=WB, rear_axle_to_center=B)
    assert front.x[0] == pytest.approx(WB) and front.y[0] == pytest.approx(0.0)


def test_curvature_falls_back_to_planned_steer_at_standstill():
    plan = Trajectory.from_states([State(t=0.1 * k, x=0.0, y=0.0, yaw=0.0, v=0.0, steer=0.1)
                                   for k in range(3)], 0.1)
    np.testing.assert_allclose(plan_curvature(plan, wheelbase=WB, rear_axle_to_center=B),
                               math.tan(0.1) / WB)


def test_interpolation_of_plan_columns():
    path = PlannedPath(_arc(), wheelbase=WB, rear_axle_to_center=B)
    assert path.value("v", 3.5) == pytest.approx(5.0)
    assert path.value("yaw", 2.5) == pytest.approx(0.5 * (path.value("yaw", 2) + path.value("yaw", 3)))
    assert path.index_at_time(0.25) == pytest.approx(2.5)
    assert path.index_at_time(99.0) == 20.0
    assert path.index_at_s(path.s_at_index(7.25)) == pytest.approx(7.25)
