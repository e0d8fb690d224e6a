"""Whether the ego was at fault in a collision, decided as nuPlan decides it
(``nuplan/planning/metrics/evaluation_metrics/common/no_ego_at_fault_collisions.py``).

A collision is classified, in this order, as:

1. *stopped ego*: the ego stood (speed at most ``stopped_speed_m_s``) — not at fault;
2. *stopped track*: the other road user stood — at fault (the ego drove into it);
3. *active rear*: the other is behind the ego (the direction to its centre, seen from the ego's
   rear axle, more than ``behind_angle_deg`` from the ego's heading) — not at fault (it hit the ego
   from behind);
4. *active front*: the ego's front edge touches the other's box — at fault;
5. *active lateral*: anything else — at fault only when the ego straddled lanes or was partly off
   the lanelets (changing lanes, cutting a corner); a vehicle that keeps its lane and is hit from
   the side is not at fault.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

from shapely.geometry import LineString

from simgap.scenario.road_frame import footprint
from simgap.trajectory import State
from simgap.vehicles.reference_points import along_heading


class CollisionType(StrEnum):
    STOPPED_EGO = "stopped_ego"
    STOPPED_TRACK = "stopped_track"
    ACTIVE_REAR = "active_rear"
    ACTIVE_FRONT = "active_front"
    ACTIVE_LATERAL = "active_lateral"


@dataclass(frozen=True)
class Collision:
    other_id: int
    kind: str                   # the other's kind (simgap.evaluate.road_users.RoadUserKind)
    type: CollisionType
    at_fault: bool


def relative_angle(ego: State, rear_axle_to_center: float, x: float, y: float) -> float:
    """The angle [rad, 0..pi] between the ego's heading and the direction from its rear axle to (x, y)."""
    rx, ry = along_heading(ego.x, ego.y, ego.yaw, -rear_axle_to_center)
    dx, dy = x - rx, y - ry
    norm = math.hypot(dx, dy)
    if norm == 0.0:
        return 0.0
    return math.acos(max(-1.0, min(1.0, (dx * math.cos(ego.yaw) + dy * math.sin(ego.yaw)) / norm)))


def collision_type(ego: State, ego_length: float, ego_width: float, rear_axle_to_center: float,
                   other: State, other_length: float, other_width: float, stopped_speed_m_s: float,
                   behind_angle_deg: float) -> CollisionType:
    """nuPlan's classification of a collision between ``ego`` and ``other`` (centre states)."""
    if ego.v <= stopped_speed_m_s:
        return CollisionType.STOPPED_EGO
    if abs(other.v) <= stopped_speed_m_s:
        return CollisionType.STOPPED_TRACK
    if relative_angle(ego, rear_axle_to_center, other.x, other.y) > math.radians(behind_angle_deg):
        return CollisionType.ACTIVE_REAR
    corners = footprint(ego, ego_length, ego_width).exterior.coords      # front left, rear left, rear right, front right
    if LineString([corners[0], corners[3]]).intersects(footprint(other, other_length, other_width)):
        return CollisionType.ACTIVE_FRONT
    return CollisionType.ACTIVE_LATERAL


def at_fault(kind: CollisionType, ego_straddles_lanes: bool) -> bool:
    """Front collisions and collisions with a standing road user are the ego's fault; lateral ones
    when it straddled lanes."""
    return kind in (CollisionType.ACTIVE_FRONT, CollisionType.STOPPED_TRACK) or \
        (kind == CollisionType.ACTIVE_LATERAL and ego_straddles_lanes)
