"""Time to collision at every step of a driven trajectory, as nuPlan estimates it
(``nuplan/planning/metrics/evaluation_metrics/common/time_to_collision_within_bound.py``): the ego
and every relevant road user keep their speed and heading; the TTC is the first projection step,
up to the horizon, at which their boxes overlap (infinite when none does).

Relevant road users: those ahead of the ego (within ``ahead_angle_deg`` of its heading, seen from
its rear axle), and, while the ego straddles lanes or is in a junction, every one not behind it.
A standing ego has no TTC. At the step of an at-fault collision the TTC is 0; the road user it
collided with does not count after it.

The boxes are tested for overlap by separating axes, every road user and projection step at once.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from simgap.evaluate.road_users import RoadUser
from simgap.planning.collision import boxes_overlap
from simgap.trajectory import Trajectory
from simgap.vehicles.reference_points import along_heading


def time_to_collision(ego: Trajectory, length: float, width: float, rear_axle_to_center: float,
                      others: list[RoadUser], horizon_s: float, step_s: float, ahead_angle_deg: float,
                      behind_angle_deg: float, stopped_speed_m_s: float,
                      laterally_exposed: Callable[[int], bool]) -> np.ndarray:
    """The TTC [s] at each step of ``ego`` (``inf``: none within the horizon). ``laterally_exposed(k)``
    says whether the ego straddles lanes or is in a junction at step ``k`` (asked only when needed)."""
    n = len(ego)
    ttc = np.full(n, np.inf)
    if not others or n == 0:
        return ttc
    t = ego.t
    at = [o.at(t) for o in others]
    ox = np.stack([a.x for a in at], 1)                 # (n, m)
    oy = np.stack([a.y for a in at], 1)
    oyaw = np.stack([a.yaw for a in at], 1)
    ov = np.stack([a.v for a in at], 1)
    present = np.stack([a.present for a in at], 1)
    olen = np.array([o.length for o in others])[None, :]
    owid = np.array([o.width for o in others])[None, :]

    cos_e, sin_e = np.cos(ego.yaw), np.sin(ego.yaw)
    rear_x, rear_y = along_heading(ego.x, ego.y, ego.yaw, -rear_axle_to_center)
    dx, dy = ox - rear_x[:, None], oy - rear_y[:, None]
    dist = np.hypot(dx, dy)
    cos_angle = np.where(dist > 0, (dx * cos_e[:, None] + dy * sin_e[:, None]) / np.where(dist > 0, dist, 1.0), 1.0)
    angle = np.arccos(np.clip(cos_angle, -1.0, 1.0))
    ahead = angle < math.radians(ahead_angle_deg)
    not_behind = angle <= math.radians(behind_angle_deg)
    moving = ego.v > stopped_speed_m_s
    relevant = present & moving[:, None] & ahead
    sideways = present & moving[:, None] & not_behind & ~ahead
    for k in np.flatnonzero(sideways.any(axis=1)):
        if laterally_exposed(int(k)):
            relevant[k] |= sideways[k]
    if not relevant.any():
        return ttc

    k_steps = np.arange(1, int(math.ceil(horizon_s / step_s - 1e-9)))   # as nuPlan: step, 2 step, ... < horizon
    steps = k_steps * step_s
    ego_dx, ego_dy = cos_e * ego.v * step_s, sin_e * ego.v * step_s
    o_dx, o_dy = np.cos(oyaw) * ov * step_s, np.sin(oyaw) * ov * step_s
    k = k_steps[None, None, :]                                       # (1, 1, K)
    rx = (ox - ego.x[:, None])[..., None] + (o_dx - ego_dx[:, None])[..., None] * k      # (n, m, K)
    ry = (oy - ego.y[:, None])[..., None] + (o_dy - ego_dy[:, None])[..., None] * k
    overlap = boxes_overlap(rx, ry, ego.yaw[:, None, None], length / 2, width / 2,
                             oyaw[..., None], olen[..., None] / 2, owid[..., None] / 2)
    overlap &= relevant[..., None]
    hit = overlap.any(axis=2)
    first = np.where(hit, overlap.argmax(axis=2), len(steps))       # (n, m)
    earliest = first.min(axis=1)
    found = earliest < len(steps)
    ttc[found] = steps[earliest[found]]
    return ttc
