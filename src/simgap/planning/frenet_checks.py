"""The Frenet planner's checks of a batch of plans beyond the core's: the vehicle's limits from
exact values (`within_limits`), then traffic, the road and the lateral-acceleration bound
(`PlanChecks`), each giving per-plan verdicts (`Verdicts`) that `plan_choice` chooses from.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simgap.planning.collision import (
    DrivableAreaGrid,
    RoadBand,
    TrafficPrediction,
    footprint_outline,
    footprints_on_road,
    struck_from_behind,
    traffic_collisions,
    traffic_overlaps,
)
from simgap.planning.frenet_frame import CartesianBatch, FrenetFrame
from simgap.planning.plan_choice import Encounters
from simgap.planning.settings import FrenetSettings

__all__ = ["ROAD_EDGE_M", "PlanChecks", "RoadLeeway", "Verdicts", "within_limits"]

# a vehicle whose footprint grown by this much leaves the road is at the road's edge [m]
ROAD_EDGE_M = 0.3


@dataclass(frozen=True)
class RoadLeeway:
    """How a plan may use the road's edge when the vehicle is not safely on the road now: for
    ``steps`` after the present it may leave the safe cells but must keep within ``band`` (the
    band the vehicle is in now; None when it is off the road already: anywhere). After them
    every plan is on the safe cells."""

    steps: int = 0
    band: RoadBand | None = RoadBand.SAFE


@dataclass(frozen=True)
class Verdicts:
    """Per plan of a batch: hits traffic?, stays on the road? (looked at only for plans clear of
    traffic), within the lateral-acceleration bound and the steering rate?"""

    hit: np.ndarray
    on_road: np.ndarray
    lateral_ok: np.ndarray


def within_limits(batch: CartesianBatch, limits, wheelbase: float) -> np.ndarray:
    """Per plan: acceleration and curvature within the vehicle's ``limits``, from the exact
    values (the core's own checks see halved second derivatives, see `frenet_frame`)."""
    v, a, kappa = batch.v[:, 1:], batch.a[:, 1:], batch.kappa[:, 1:]
    a_max = np.where(v > limits.v_switch, limits.max_accel * limits.v_switch / np.maximum(v, 1e-9),
                     limits.max_accel)
    tol = 1e-6
    ok_a = ((a <= a_max + tol) & (a >= -limits.max_accel - tol)).all(axis=1)
    ok_k = (np.abs(kappa) <= math.tan(limits.max_steer) / wheelbase + tol).all(axis=1)
    return ok_a & ok_k


class PlanChecks:
    """Traffic, road and lateral-acceleration checks of plans in the local frame of ``frame``
    (rear-axle reference) against ``drivable_area``, for ``vehicle`` at ``settings``."""

    def __init__(self, vehicle, settings: FrenetSettings, frame: FrenetFrame, drivable_area: DrivableAreaGrid):
        self.vehicle, self.settings, self.frame, self.drivable_area = vehicle, settings, frame, drivable_area
        spacing = settings.collision.footprint_point_spacing_m
        self.outline = footprint_outline(vehicle.length, vehicle.width, spacing)
        self.edge_outline = footprint_outline(vehicle.length + 2 * ROAD_EDGE_M, vehicle.width + 2 * ROAD_EDGE_M,
                                              spacing)

    def recovery_steps(self, dt: float) -> int:
        return int(round(self.settings.collision.recovery_s / dt))

    def leeway(self, x_rear: float, y_rear: float, yaw: float, dt: float) -> RoadLeeway:
        """The plans' leeway at the road's edge for a vehicle at (``x_rear``, ``y_rear``, ``yaw``):
        none when it is safely on the road; ``recovery_s`` to get back when it is not, without
        going further out than it is now (a tracking error of centimetres at the edge is no
        licence to leave the road); anywhere when it is off the road already."""
        cx, cy = self.vehicle.centre_of(x_rear, y_rear, yaw)
        centre = (np.array([cx]), np.array([cy]), np.array([yaw]))
        band = next((b for b in RoadBand if footprints_on_road(self.drivable_area, self.outline, *centre, b)[0]),
                    None)
        if band is RoadBand.SAFE:
            return RoadLeeway()
        return RoadLeeway(self.recovery_steps(dt), band)

    def at_road_edge(self, x_rear: float, y_rear: float, yaw: float) -> bool:
        """The footprint grown by `ROAD_EDGE_M` on every side leaves the road."""
        cx0, cy0 = self.vehicle.centre_of(x_rear, y_rear, yaw)
        return not footprints_on_road(self.drivable_area, self.edge_outline, np.array([cx0]), np.array([cy0]),
                                      np.array([yaw]))[0]

    def check(self, batch: CartesianBatch, traffic: TrafficPrediction, leeway: RoadLeeway, dt: float,
              lateral_bound: float) -> Verdicts:
        """Per plan of ``batch``: hits traffic?, stays on the road?, within ``lateral_bound`` and the
        steering rate?"""
        veh, s = self.vehicle, self.settings
        hl, hw = veh.length / 2, veh.width / 2
        n = len(batch.x)
        cx, cy = veh.centre_of(batch.x, batch.y, batch.yaw)
        if traffic.empty:
            hit = np.zeros(n, dtype=bool)
        else:
            # the present (step 0) is not checked: what overlaps now cannot be planned away
            hit = traffic_collisions(cx, cy, batch.yaw, hl, hw, traffic)[:, 1:].any(axis=1)
            b = s.collision.stopping_deceleration
            if b is not None and not hit.all():
                # braking beyond the horizon along the path must stop clear of traffic braking
                # from where it is at the horizon's end
                v_end = np.maximum(batch.v[:, -1], 0.0)
                steps = int(math.ceil(float(v_end.max()) / b / dt))
                if steps > 0:
                    tau = dt * np.arange(1, steps + 1)
                    t_stop = (v_end / b)[:, None]
                    tt = np.minimum(tau[None, :], t_stop)
                    travel = v_end[:, None] * tt - 0.5 * b * tt**2
                    ex, ey, eyaw = self.frame.curvilinear_to_local(batch.s[:, -1:] + travel, batch.d[:, -1:])
                    ex, ey = veh.centre_of(ex, ey, eyaw)
                    last = traffic.braking_from_end(steps, dt, s.collision.traffic_deceleration)
                    hit |= traffic_collisions(ex, ey, eyaw, hl, hw, last).any(axis=1)
        # the road only for plans clear of traffic (the road test costs most: many points)
        on_road = np.ones(n, dtype=bool)
        safe_from = min(1 + leeway.steps, cx.shape[1])
        rows = np.flatnonzero(~hit)
        if safe_from < cx.shape[1] and len(rows):
            on_road[rows] = footprints_on_road(self.drivable_area, self.outline, cx[rows, safe_from:],
                                               cy[rows, safe_from:], batch.yaw[rows, safe_from:]).all(axis=1)
        rows = rows[on_road[rows]]
        if safe_from > 1 and leeway.band is not None and len(rows):
            on_road[rows] = footprints_on_road(self.drivable_area, self.outline, cx[rows, 1:safe_from],
                                               cy[rows, 1:safe_from], batch.yaw[rows, 1:safe_from],
                                               leeway.band).all(axis=1)
        a_lat = (batch.v[:, 1:] ** 2 * np.abs(batch.kappa[:, 1:])).max(axis=1)
        steer_rate = np.abs(np.diff(np.arctan(veh.wheelbase * batch.kappa), axis=1)).max(axis=1) / dt
        return Verdicts(hit, on_road, (a_lat <= lateral_bound) & (steer_rate <= veh.limits.max_steer_rate))

    def encounters(self, batch: CartesianBatch, leeway: RoadLeeway, dt: float, lateral_bound: float,
                   traffic: TrafficPrediction) -> Encounters:
        """Per plan of ``batch``: within the limits and on the road, and met by ``traffic`` only
        where another road user runs into the ego from behind (replayed traffic does not brake for
        it, and braking would only bring it sooner; what the stopping distance beyond the horizon
        would meet is not counted here)? And the step at which it is met first (inf: never)."""
        veh = self.vehicle
        hl, hw = veh.length / 2, veh.width / 2
        no_traffic = TrafficPrediction(*(np.zeros((0, 1)),) * 3, np.zeros(0), np.zeros(0), np.zeros(0))
        cx, cy = veh.centre_of(batch.x, batch.y, batch.yaw)
        overlaps = traffic_overlaps(cx, cy, batch.yaw, hl, hw, traffic)
        if overlaps is None:      # met only beyond the horizon (braking to a stop): nobody the ego hits
            at_fault = np.zeros(len(cx), dtype=bool)
            met_at = np.full(len(cx), np.inf)
        else:        # judged where each participant is met first (replayed, it drives on through the ego)
            met, struck = overlaps[:, 1:], struck_from_behind(cx, cy, batch.yaw, hl, traffic)[:, 1:]
            first = met.argmax(axis=1)                                  # (plans, participants)
            struck_first = np.take_along_axis(struck, first[:, None, :], axis=1)[:, 0, :]
            at_fault = (met.any(axis=1) & ~struck_first).any(axis=1)
            touched = met.any(axis=2)                                   # (plans, steps)
            met_at = np.where(touched.any(axis=1), touched.argmax(axis=1), np.inf)
        on_road = self.check(batch, no_traffic, leeway, dt, lateral_bound).on_road
        return Encounters(within_limits(batch, veh.limits, veh.wheelbase) & on_road & ~at_fault, met_at)
