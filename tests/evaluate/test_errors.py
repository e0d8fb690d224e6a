"""Error metrics on constructed trajectories with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simgap.evaluate.errors import (
    Aggregate,
    comfort,
    frenet_tracking_errors,
    lateral_displacement_by_s,
    time_aligned_errors,
    tracking_errors,
)
from simgap.scenario.road_frame import PathFrame
from simgap.trajectory import Trajectory

DT = 0.1


def straight(n=100, v=10.0, y=0.0, yaw=0.0, t0=0.0, x0=0.0):
    t = t0 + DT * np.arange(n)
    return Trajectory(DT, t=t, x=x0 + v * (t - t0), y=np.full(n, y), yaw=np.full(n, yaw), v=np.full(n, v),
                      a=np.zeros(n), yaw_rate=np.zeros(n), steer=np.zeros(n))


def circle_path(r=20.0):
    phi = np.linspace(0, math.pi, 400)
    return PathFrame(np.column_stack([r * np.sin(phi), r - r * np.cos(phi)]))


def test_constant_lateral_offset_gives_that_d():
    ref = PathFrame(np.array([[-10.0, 0.0], [200.0, 0.0]]))
    s, d = lateral_displacement_by_s(straight(), straight(y=0.7), ref)
    assert len(s) > 100
    assert np.allclose(d, 0.7)


def test_offset_on_a_curve_is_signed_left_positive():
    ref = circle_path(20.0)
    s, d = ref.project(np.array([[0.0, 1.0], [0.0, -1.0], [20.0 - 0.5, 20.0]]))
    assert d[0] == pytest.approx(1.0, abs=1e-4) and d[1] == pytest.approx(-1.0, abs=1e-4)
    assert d[2] == pytest.approx(0.5, abs=1e-3)      # inside of a left turn is the left
    assert s[2] == pytest.approx(20.0 * math.pi / 2, rel=1e-3)


def test_time_shift_gives_zero_d_when_aligned_by_s():
    ref = PathFrame(np.array([[-10.0, 0.0], [300.0, 0.0]]))
    late = straight(x0=-5.0)                    # same path, half a second behind
    s, d = lateral_displacement_by_s(straight(), late, ref)
    assert np.abs(d).max() < 1e-9
    by_time = time_aligned_errors(straight(), late)
    assert by_time.position.max() == pytest.approx(5.0)   # by time it looks like 5 m


def test_angle_wrap_across_pi_gives_the_small_error():
    a = straight(yaw=math.pi - 0.01)
    b = straight(yaw=-math.pi + 0.01)
    err = time_aligned_errors(a, b)
    assert np.allclose(err.orientation, 0.02)


def test_aggregates():
    agg = Aggregate.of(np.array([3.0, -4.0]))
    assert agg.max == 4.0 and agg.mean == 3.5
    assert agg.rms == pytest.approx(math.sqrt(12.5))


def _plans_along(traj: Trajectory, dx: float = 0.0, dy: float = 0.0, every: int = 1, n: int = 30):
    """Plans made every ``every`` steps that promise ``traj`` shifted by (dx, dy)."""
    plans = []
    for k in range(0, len(traj) - 1, every):
        m = min(n, len(traj) - k)
        plans.append(Trajectory(DT, t=traj.t[k:k + m], x=traj.x[k:k + m] + dx, y=traj.y[k:k + m] + dy,
                                yaw=traj.yaw[k:k + m], v=traj.v[k:k + m], a=traj.a[k:k + m],
                                yaw_rate=traj.yaw_rate[k:k + m], steer=traj.steer[k:k + m]))
    return plans


def test_frenet_tracking_splits_the_error_into_lateral_and_longitudinal():
    ref = PathFrame(np.array([[-10.0, 0.0], [200.0, 0.0]]))
    driven = straight()
    # the plans promised 0.3 m further left and 1.5 m further ahead than the car got
    errs = frenet_tracking_errors(driven, _plans_along(driven, dx=1.5, dy=0.3), ref)
    assert len(errs.t) == len(driven) - 1
    assert np.allclose(errs.lateral, -0.3) and np.allclose(errs.longitudinal, -1.5)
    exact = tracking_errors(driven, _plans_along(driven))
    assert np.allclose(exact.position, 0.0) and np.allclose(exact.orientation, 0.0)


def test_comfort_peaks():
    n = 50
    t = DT * np.arange(n)
    a = np.where(t < 2.0, 0.0, 2.0)             # a step of 2 m/s^2 in one step: 20 m/s^3
    traj = Trajectory(DT, t=t, x=5.0 * t, y=np.zeros(n), yaw=np.zeros(n), v=np.full(n, 5.0), a=a,
                      yaw_rate=np.full(n, 0.4), steer=np.zeros(n))
    c = comfort(traj)
    assert c.peak_lateral_acceleration == pytest.approx(2.0)
    assert c.peak_longitudinal_acceleration == pytest.approx(2.0)
    assert c.peak_jerk == pytest.approx(20.0)


def test_tracking_errors_of_an_agent_that_never_planned_are_empty():
    """A planner that raised in its constructor leaves a run with no plan: nothing to compare, no crash."""
    errors = tracking_errors(straight(n=1), [])
    assert len(errors.t) == 0 and len(errors.position) == 0
