"""Pure pursuit steering with a speed-dependent look-ahead, plus PID on speed.

This is what the paper's high-fidelity runs used (BeamNG's script AI steers by pure pursuit
towards time-stamped waypoints and holds speed with a PID). The rear axle pursues a point
``lookahead = clip(lookahead_min + lookahead_time * v, lookahead_min, lookahead_max)`` ahead
along the plan's rear-axle path, commanding the arc curvature ``2 sin(alpha) / d``.

Plain pure pursuit cuts corners wherever the plan's curvature changes within the look-ahead.
The feed-forward removes that bias: the command is
``kappa = kappa_pp(vehicle) + w * (kappa_plan - kappa_pp(foot point on the plan))``, i.e. the
plan's own curvature plus the pure-pursuit correction of the deviation only. ``w =
curvature_feedforward`` (default 1); ``w = 0`` is classic pure pursuit. ``kappa_plan`` is read
``preview_time * v`` ahead of the foot point, to make up for the steering and tyre lag.
"""

from __future__ import annotations

import math

from pydantic import Field, model_validator

from simgap.control.planned_path import PlannedPath, Projection
from simgap.control.tracking import CONTROLLER_HZ, TrackingController, TrackingGains
from simgap.trajectory import State


class PurePursuitGains(TrackingGains):
    """Gains of `PurePursuitController` (vehicle file key ``controllers.pure_pursuit``)."""

    lookahead_time: float = Field(0.4, ge=0, description="look-ahead per speed [s]")
    lookahead_min: float = Field(4.0, gt=0, description="look-ahead at standstill [m]")
    lookahead_max: float = Field(30.0, gt=0, description="longest look-ahead [m]")
    preview_time: float = Field(
        0.1, ge=0, description="the plan's curvature for the feed-forward is taken this far "
        "ahead of the rear axle's foot point, to make up for steering and tyre lag [s]")

    @model_validator(mode="after")
    def _ordered(self) -> PurePursuitGains:
        if self.lookahead_max < self.lookahead_min:
            raise ValueError("lookahead_max must be >= lookahead_min")
        return self


def _pursuit_curvature(px: float, py: float, yaw: float, tx: float, ty: float) -> float:
    dx, dy = tx - px, ty - py
    d2 = dx * dx + dy * dy
    if d2 < 1e-12:
        return 0.0
    # 2 sin(alpha) / d, with sin(alpha) = lateral offset of the target / d
    lateral = -math.sin(yaw) * dx + math.cos(yaw) * dy
    return 2.0 * lateral / d2


class PurePursuitController(TrackingController):
    name = "pure_pursuit"
    Gains = PurePursuitGains

    def __init__(self, vehicle, gains: PurePursuitGains | None = None, rate_hz: float = CONTROLLER_HZ):
        super().__init__(vehicle, gains or PurePursuitGains(), rate_hz)
        self.reference_offset = -self.rear_axle_to_center
        self._plan_curvature = 0.0

    def _reset_lateral(self, state: State) -> None:
        super()._reset_lateral(state)
        self._plan_curvature = 0.0

    def lookahead(self, v: float) -> float:
        g = self.gains
        return min(max(g.lookahead_min + g.lookahead_time * max(v, 0.0), g.lookahead_min),
                   g.lookahead_max)

    def _steer(self, measured: State, path: PlannedPath, t: float, dt: float
               ) -> tuple[float, Projection]:
        v = max(measured.v, 0.0)
        # the pose of the kinematic car the plan is for: a real car in a turn runs turned in by
        # the steady heading offset (curvature of the last update: feed-forward, no feedback)
        yaw = measured.yaw - self.steady_heading_offset(self._plan_curvature, v)
        rx, ry = self.reference_point(measured.replace(yaw=yaw))
        proj = path.project(rx, ry)
        ld = self.lookahead(v)
        tx, ty = path.point_at(proj.s + ld)
        kappa_pp = _pursuit_curvature(rx, ry, yaw, tx, ty)
        w = self.gains.curvature_feedforward
        kappa = kappa_pp
        if w > 0.0:
            fx, fy = path.point_at(proj.s)
            kappa_pp_ref = _pursuit_curvature(fx, fy, proj.heading, tx, ty)
            kappa_plan = path.value(
                "curvature", path.index_at_s(proj.s + v * self.gains.preview_time))
            kappa += w * (kappa_plan - kappa_pp_ref)
            self._plan_curvature = kappa_plan
        self.diagnostics.update(lookahead=ld, curvature=kappa)
        return self.feedforward_steer(kappa, v) + self.lateral_integral(v, dt), proj
