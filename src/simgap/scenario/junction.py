"""Junctions: straight approach roads (arms) meeting at a point, with turning lanelets through
the junction from every incoming lane to every outgoing lane of another arm.

One lane per direction on each arm. Arms are given by the direction they leave the junction
in (degrees, counter-clockwise from +x): a T-junction is arms at 0, 180 and 270 degrees, a
four-way intersection arms at 0, 90, 180 and 270 degrees.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from commonroad.scenario.lanelet import Lanelet, LaneletType, LineMarking

from simgap.errors import InputError
from simgap.scenario.geometry import MAX_ROAD_LENGTH_M, SectionKind


@dataclass
class Arm:
    angle_deg: float
    incoming: int = 0          # lanelet id driving towards the junction
    outgoing: int = 0          # lanelet id driving away from it


@dataclass
class Junction:
    arms: list[Arm]
    lanelets: list[Lanelet] = field(default_factory=list)
    connectors: dict[tuple[int, int], int] = field(default_factory=dict)  # (from arm, to arm) -> id
    section_by_id: dict[int, SectionKind] = field(default_factory=dict)


def _unit(angle_deg: float) -> np.ndarray:
    a = math.radians(angle_deg)
    return np.array([math.cos(a), math.sin(a)])


def _left(t: np.ndarray) -> np.ndarray:
    return np.array([-t[1], t[0]])


def _straight(p0: np.ndarray, p1: np.ndarray, step: float = 1.0) -> np.ndarray:
    n = max(2, math.ceil(np.linalg.norm(p1 - p0) / step) + 1)
    return p0 + np.linspace(0.0, 1.0, n)[:, None] * (p1 - p0)


def _hermite(p0, t0, p1, t1, n: int = 25) -> np.ndarray:
    """A cubic Hermite curve from p0 (heading t0) to p1 (heading t1)."""
    scale = np.linalg.norm(p1 - p0)
    u = np.linspace(0.0, 1.0, n)[:, None]
    h00, h10 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u
    h01, h11 = -2 * u**3 + 3 * u**2, u**3 - u**2
    return h00 * p0 + h10 * scale * t0 + h01 * p1 + h11 * scale * t1


def _offset(centre: np.ndarray, d: float) -> np.ndarray:
    tangent = np.gradient(centre, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1)[:, None]
    return centre + d * np.column_stack([-tangent[:, 1], tangent[:, 0]])


def build_junction(arm_angles: list[float], approach_length: float, lane_width: float,
                   first_id: int, centre_marking: str = "solid") -> Junction:
    if not 10.0 <= approach_length <= MAX_ROAD_LENGTH_M:
        raise InputError(f"approach length {approach_length:g} m is too {'short' if approach_length < 10 else 'long'}",
                         field="approach_length", allowed=f"10 to {MAX_ROAD_LENGTH_M:g} m")
    w = lane_width
    c = 2.0 * w + 1.0                    # junction box half size: room for the turning lanelets
    junction = Junction([Arm(a) for a in arm_angles])
    next_id = first_id
    mark = LineMarking.SOLID if centre_marking == "solid" else LineMarking.DASHED
    for arm in junction.arms:
        u = _unit(arm.angle_deg)
        # outgoing: from the box edge outwards, lane right of the arm's axis
        out_c = _straight(c * u, (c + approach_length) * u) + (-w / 2) * _left(u)
        inc_c = _straight((c + approach_length) * u, c * u) + (-w / 2) * _left(-u)
        arm.outgoing, arm.incoming = next_id, next_id + 1
        next_id += 2
        junction.lanelets.append(Lanelet(
            _offset(out_c, w / 2), out_c, _offset(out_c, -w / 2), arm.outgoing,
            adjacent_left=arm.incoming, adjacent_left_same_direction=False,
            line_marking_left_vertices=mark, line_marking_right_vertices=LineMarking.SOLID,
            lanelet_type={LaneletType.URBAN}))
        junction.lanelets.append(Lanelet(
            _offset(inc_c, w / 2), inc_c, _offset(inc_c, -w / 2), arm.incoming,
            adjacent_left=arm.outgoing, adjacent_left_same_direction=False,
            line_marking_left_vertices=mark, line_marking_right_vertices=LineMarking.SOLID,
            lanelet_type={LaneletType.URBAN}))
        junction.section_by_id[arm.outgoing] = junction.section_by_id[arm.incoming] = "straight"

    successors: dict[int, list[int]] = {}
    predecessors: dict[int, list[int]] = {}
    for i, a in enumerate(junction.arms):
        for j, b in enumerate(junction.arms):
            if i == j:
                continue
            ua, ub = _unit(a.angle_deg), _unit(b.angle_deg)
            p0 = c * ua + (-w / 2) * _left(-ua)     # end of a's incoming lane
            p1 = c * ub + (-w / 2) * _left(ub)      # start of b's outgoing lane
            if abs(float(np.dot(ua, ub)) + 1.0) < 1e-6:
                centre = _straight(p0, p1)
            else:
                centre = _hermite(p0, -ua, p1, ub)
            lid = next_id
            next_id += 1
            junction.lanelets.append(Lanelet(
                _offset(centre, w / 2), centre, _offset(centre, -w / 2), lid,
                predecessor=[a.incoming], successor=[b.outgoing],
                line_marking_left_vertices=LineMarking.NO_MARKING,
                line_marking_right_vertices=LineMarking.NO_MARKING,
                lanelet_type={LaneletType.INTERSECTION}))
            junction.connectors[(i, j)] = lid
            junction.section_by_id[lid] = "junction"
            successors.setdefault(a.incoming, []).append(lid)
            predecessors.setdefault(b.outgoing, []).append(lid)
    for lanelet in junction.lanelets:
        for s in successors.get(lanelet.lanelet_id, []):
            lanelet.add_successor(s)
        for p in predecessors.get(lanelet.lanelet_id, []):
            lanelet.add_predecessor(p)
    return junction
