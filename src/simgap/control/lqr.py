"""Lateral LQR on a kinematic bicycle error model with a steering actuator, plus PID on speed.

In the spirit of nuPlan's LQR tracker, but with the steering servo in the model. The tracked
point is the rear axle, on the plan's rear-axle path. With lateral error ``e`` (> 0 left of the
path), heading error ``psi_e = yaw - yaw_plan``, the steering deviation ``d = steer - steer_ff``
from the feed-forward ``steer_ff = atan(L kappa) + K_us v^2 kappa``, linearised about the plan::

    e'     = v psi_e
    psi_e' = v / (L cos^2 steer_ff) d
    d'     = (u - d) / steer_time_constant          (first-order steering servo)

discretised (zero-order hold) at the controller period, and the infinite-horizon discrete LQR
gain ``K(v)`` computed per speed (1 m/s grid, interpolated, cached). The weights are stated in
lateral terms so that the closed loop does not speed up with speed (as it would with fixed
weights on angles, and then excite the yaw dynamics the kinematic model lacks): ``Q`` weighs
the lateral error, the lateral speed ``v psi_e`` and the lateral acceleration of the steering
deviation ``v^2 d / L``; ``R`` weighs the lateral acceleration commanded. Without the servo,
``lateral_weight = 1``, ``input_weight = r`` give a lateral loop with natural frequency
``r^(-1/4)`` rad/s and damping 0.71 (above ``low_speed``). The command is
``steer = steer_ff - K(v) [e, psi_e, d]``. The curvature feed-forward is taken
``preview_time`` ahead of the rear axle's foot point, to make up for the steering lag, and the
lateral integral of `TrackingGains` is added. The steering deviation ``d`` uses the measured
road-wheel angle (``State.steer``): a backend must report it.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from pydantic import Field

from simgap.control.planned_path import PlannedPath, Projection
from simgap.control.tracking import CONTROLLER_HZ, TrackingController, TrackingGains
from simgap.trajectory import State, wrap_angle

_SPEED_GRID = 1.0     # m/s between gain computations
_MIN_GAIN_SPEED = 1.0  # m/s; below this the gain of 1 m/s is used


class LqrGains(TrackingGains):
    """Weights of `LqrController` (vehicle file key ``controllers.lqr``)."""

    lateral_weight: float = Field(1.0, gt=0, description="Q on the lateral error [1/m^2]")
    lateral_speed_weight: float = Field(
        0.0, ge=0, description="Q on the lateral speed v psi_e [s^2/m^2]")
    steer_weight: float = Field(
        0.0, ge=0, description="Q on the steering deviation as lateral acceleration [s^4/m^2]")
    input_weight: float = Field(
        0.02, gt=0, description="R on the commanded lateral acceleration [s^4/m^2]")
    steer_time_constant: float = Field(
        0.05, ge=0, description="time constant of the steering servo assumed in the model [s]")
    low_speed: float = Field(
        5.0, gt=0, description="below this speed the weights are those of this speed, so the "
        "loop slows down with speed (like pure pursuit) instead of steering ever harder [m/s]")
    preview_time: float = Field(0.1, ge=0, description="curvature feed-forward taken this far ahead [s]")


@lru_cache(maxsize=4096)
def lqr_gain(v: float, period: float, wheelbase: float, steer_ff: float, q_lat: float,
             q_speed: float, q_steer: float, r: float, tau: float, weight_speed: float
             ) -> tuple[float, float, float]:
    """Discrete LQR gain (row of K) for the error model at speed ``v`` (see the module doc)."""
    from scipy.linalg import expm, solve_discrete_are  # only when an LQR controller runs
    b_psi = v / (wheelbase * math.cos(steer_ff) ** 2)
    # lateral acceleration per rad of steering, at the weighting speed
    lat_acc = max(v, weight_speed) ** 2 / (wheelbase * math.cos(steer_ff) ** 2)
    r = r * lat_acc ** 2
    if tau > 0.0:
        a = np.array([[0.0, v, 0.0], [0.0, 0.0, b_psi], [0.0, 0.0, -1.0 / tau]])
        b = np.array([[0.0], [0.0], [1.0 / tau]])
        q = np.diag([q_lat, q_speed * max(v, weight_speed) ** 2, q_steer * lat_acc ** 2])
    else:
        a = np.array([[0.0, v], [0.0, 0.0]])
        b = np.array([[0.0], [b_psi]])
        q = np.diag([q_lat, q_speed * max(v, weight_speed) ** 2])
    n = a.shape[0]
    m = np.zeros((n + 1, n + 1))
    m[:n, :n] = a * period
    m[:n, n:] = b * period
    em = expm(m)
    ad, bd = em[:n, :n], em[:n, n:]
    rr = np.array([[r]])
    p = solve_discrete_are(ad, bd, q, rr)
    k = np.linalg.solve(rr + bd.T @ p @ bd, bd.T @ p @ ad).ravel()
    if tau > 0.0:
        return float(k[0]), float(k[1]), float(k[2])
    return float(k[0]), float(k[1]), 0.0


class LqrController(TrackingController):
    name = "lqr"
    Gains = LqrGains

    def __init__(self, vehicle, gains: LqrGains | None = None, rate_hz: float = CONTROLLER_HZ):
        super().__init__(vehicle, gains or LqrGains(), rate_hz)
        self.reference_offset = -self.rear_axle_to_center

    def gain(self, v: float, steer_ff: float = 0.0) -> np.ndarray:
        """K(v), interpolated between speeds of the 1 m/s grid."""
        g = self.gains
        v = max(v, _MIN_GAIN_SPEED)
        lo = math.floor(v / _SPEED_GRID) * _SPEED_GRID
        hi = lo + _SPEED_GRID
        w = (v - lo) / _SPEED_GRID
        # the steering feed-forward enters through cos^2: a coarse grid is plenty
        sff = round(abs(steer_ff), 2)
        args = (self.period, self.wheelbase, sff, g.lateral_weight, g.lateral_speed_weight,
                g.steer_weight, g.input_weight, g.steer_time_constant, g.low_speed)
        k_lo = np.array(lqr_gain(max(lo, _MIN_GAIN_SPEED), *args))
        k_hi = np.array(lqr_gain(hi, *args))
        return (1.0 - w) * k_lo + w * k_hi

    def _steer(self, measured: State, path: PlannedPath, t: float, dt: float
               ) -> tuple[float, Projection]:
        g = self.gains
        rx, ry = self.reference_point(measured)
        proj = path.project(rx, ry)
        v = max(measured.v, 0.0)
        preview = path.index_at_s(proj.s + v * g.preview_time)
        kappa = path.value("curvature", preview)
        steer_ff = g.curvature_feedforward * self.feedforward_steer(kappa, v)
        offset = self.steady_heading_offset(kappa, v)
        heading_error = wrap_angle(measured.yaw - proj.heading - offset)
        lateral = proj.lateral - self.reference_offset * math.sin(offset)   # the rear axle swings out
        deviation = measured.steer - steer_ff
        k = self.gain(v, steer_ff)
        steer = (steer_ff - (k[0] * lateral + k[1] * heading_error + k[2] * deviation)
                 + self.lateral_integral(v, dt))
        self.diagnostics.update(heading_error=heading_error, curvature=kappa)
        return steer, proj
