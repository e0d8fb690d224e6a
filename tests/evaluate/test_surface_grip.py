"""Grip use on a road's relief (`simgap.evaluate.surface_grip`) against the textbook: braking on
a grade, a steady turn on a bank, braking over the top of a crest; a flat surface gives the 2D
figure."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simgap.evaluate.surface_grip import grip_use_on_surface
from simgap.scenario.relief import SurfacePoints
from simgap.trajectory import Trajectory
from simgap.vehicles.constants import GRAVITY as G

MU = 0.9


class Plane:
    """z = gx * x + gy * y."""

    def __init__(self, gx: float, gy: float):
        self.gx, self.gy = gx, gy

    def surface(self, x, y):
        x = np.asarray(x, dtype=float)
        n = np.array([-self.gx, -self.gy, 1.0]) / math.sqrt(1 + self.gx ** 2 + self.gy ** 2)
        return SurfacePoints(self.gx * x + self.gy * np.asarray(y), np.broadcast_to(n, x.shape + (3,)))


class Crest:
    """z = -x^2 / (2 R): a crest of radius R at x = 0."""

    def __init__(self, radius: float):
        self.r = radius

    def surface(self, x, y):
        x = np.asarray(x, dtype=float)
        slope = -x / self.r
        norm = np.sqrt(1 + slope ** 2)
        n = np.stack([-slope / norm, np.zeros_like(x), 1 / norm], axis=-1)
        return SurfacePoints(-x ** 2 / (2 * self.r), n)


def straight(v0: float, a: float, yaw_rate: float = 0.0, t0: float = -1.0, n: int = 21, dt: float = 0.1):
    """Along +x at v0 (at t = 0, x = 0) with acceleration a: x = v0 t + a t^2 / 2."""
    t = t0 + dt * np.arange(n)
    return Trajectory(dt, t=t, x=v0 * t + 0.5 * a * t ** 2, y=np.zeros(n), yaw=np.zeros(n), v=v0 + a * t,
                      a=np.full(n, a), yaw_rate=np.full(n, yaw_rate), steer=np.zeros(n))


def test_without_a_surface_it_is_the_2d_grip_use():
    traj = straight(10.0, -3.0, yaw_rate=0.2)
    expected = np.hypot(traj.a, traj.v * traj.yaw_rate) / (MU * G)
    assert np.array_equal(grip_use_on_surface(traj, None, MU), expected)
    assert grip_use_on_surface(traj, Plane(0, 0), MU) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("grade", [-0.10, 0.10])
def test_braking_on_a_grade_needs_gravitys_share_along_it(grade):
    theta = math.atan(grade)
    decel = 4.0                                      # along the slope
    traj = straight(15.0 * math.cos(theta), -decel * math.cos(theta))   # horizontal speed and acceleration
    use = grip_use_on_surface(traj, Plane(grade, 0.0), MU)
    # friction along the slope m(a - (-g sin)) = m(-decel + g sin theta); normal m g cos theta
    expected = abs(-decel + G * math.sin(theta)) / (MU * G * math.cos(theta))
    assert use[5:-5] == pytest.approx(expected, rel=1e-6)
    # downhill braking asks more than on the flat, uphill less
    assert (use[10] > decel / (MU * G)) == (grade < 0)


@pytest.mark.parametrize("bank_deg", [-8.0, 8.0])
def test_a_steady_turn_on_a_bank_needs_the_textbook_side_friction(bank_deg):
    phi = math.radians(bank_deg)                     # positive: the left (inside of a left turn) lower
    v, radius = 12.0, 30.0
    traj = straight(v, 0.0, yaw_rate=v / radius)
    use = grip_use_on_surface(traj, Plane(0.0, -math.tan(phi)), MU)
    a = v * v / radius
    expected = abs(a * math.cos(phi) - G * math.sin(phi)) / (MU * (G * math.cos(phi) + a * math.sin(phi)))
    assert use == pytest.approx(expected, rel=1e-9)
    assert (use[0] > a / (MU * G)) == (bank_deg < 0)     # an adverse camber takes grip away


def test_braking_over_a_crest_has_less_load_to_brake_on():
    v, decel, radius = 15.0, 3.0, 75.0
    traj = straight(v, -decel)
    use = grip_use_on_surface(traj, Crest(radius), MU)
    top = int(np.argmin(np.abs(traj.x)))
    assert traj.x[top] == pytest.approx(0.0)
    assert use[top] == pytest.approx(decel / (MU * (G - v * v / radius)), rel=1e-3)


def test_a_car_that_would_leave_the_ground_needs_infinite_grip():
    traj = straight(30.0, 0.0)                         # v^2 / R = 18 m/s^2 > g
    assert math.isinf(grip_use_on_surface(traj, Crest(50.0), MU)[10])
