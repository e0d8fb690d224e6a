"""Stanley steering (front-axle cross-track and heading error) with curvature feed-forward.

The front axle is projected onto the plan's front-axle path; with cross-track error ``e``
(> 0 left of the path), heading error ``psi_e = yaw_plan - yaw`` and the plan's curvature
``kappa`` at the foot point::

    delta = atan(L kappa) + K_us v^2 kappa                       (feed-forward)
          + heading_gain * psi_e
          - atan(cross_track_gain * e / (softening_speed + v))
          + yaw_rate_damping * (kappa v - yaw_rate)
          - lateral_integral_gain * integral(e) dt     (see `TrackingGains`)

(after Hoffmann, Tomlin, Montemerlo and Thrun, ACC 2007, whose yaw-rate damping this includes).
"""

from __future__ import annotations

import math

from pydantic import Field

from simgap.control.planned_path import PlannedPath, Projection
from simgap.control.tracking import CONTROLLER_HZ, TrackingController, TrackingGains
from simgap.trajectory import State, wrap_angle


class StanleyGains(TrackingGains):
    """Gains of `StanleyController` (vehicle file key ``controllers.stanley``)."""

    cross_track_gain: float = Field(2.5, ge=0, description="k in atan(k e / (v_s + v)) [1/s]")
    softening_speed: float = Field(1.0, gt=0, description="v_s, keeps the gain finite at standstill [m/s]")
    heading_gain: float = Field(1.0, ge=0, description="heading error -> steering [-]")
    yaw_rate_damping: float = Field(0.1, ge=0, description="yaw-rate error -> steering [s]")
    lateral_integral_gain: float = Field(
        4.0, ge=0, description="as in `TrackingGains`; Stanley's stiffer cross-track term "
        "needs a faster integral to remove the same offset [1/s^3]")


class StanleyController(TrackingController):
    name = "stanley"
    Gains = StanleyGains

    def __init__(self, vehicle, gains: StanleyGains | None = None, rate_hz: float = CONTROLLER_HZ):
        super().__init__(vehicle, gains or StanleyGains(), rate_hz)
        self.reference_offset = self.front_axle_to_center

    def _steer(self, measured: State, path: PlannedPath, t: float, dt: float
               ) -> tuple[float, Projection]:
        g = self.gains
        fx, fy = self.reference_point(measured)
        proj = path.project(fx, fy)
        v = max(measured.v, 0.0)
        kappa = path.value("curvature", proj.index)
        offset = self.steady_heading_offset(kappa, v)
        heading_error = wrap_angle(path.value("yaw", proj.index) + offset - measured.yaw)
        # the front axle of a car turned in by ``offset`` sits that much inside the planned one
        lateral = proj.lateral - self.reference_offset * math.sin(offset)
        cross_track = -math.atan2(g.cross_track_gain * lateral, g.softening_speed + v)
        damping = g.yaw_rate_damping * (kappa * v - measured.yaw_rate)
        steer = (g.curvature_feedforward * self.feedforward_steer(kappa, v)
                 + g.heading_gain * heading_error + cross_track + damping
                 + self.lateral_integral(v, dt))
        self.diagnostics.update(heading_error=heading_error, curvature=kappa)
        return steer, proj
