"""Lanes along a centre line: CommonRoad lanelets with line markings and all their relations.

Right-hand traffic: lanes right of the centre line run along it, lanes left of it (on a two-way
road) run against it. There is one lanelet per road section per lane, linked as successors, so
that every lanelet lies in exactly one section (straight, curve, clothoid).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from commonroad.scenario.lanelet import Lanelet, LaneletType, LineMarking

from simgap.scenario.geometry import CentreLine, SectionKind


@dataclass(frozen=True)
class LaneLayout:
    lanes_per_direction: int = 1
    lane_width: float = 3.0
    two_way: bool = True
    centre_marking: str = "solid"   # "solid" | "dashed" (two-way roads)

    @property
    def half_width_left(self) -> float:
        return self.lanes_per_direction * self.lane_width if self.two_way else 0.0

    @property
    def half_width_right(self) -> float:
        return self.lanes_per_direction * self.lane_width


@dataclass
class Road:
    """The lanelets of one road, by direction and lane index (0 = next to the centre line)."""

    centre: CentreLine
    layout: LaneLayout
    forward: list[list[Lanelet]] = field(default_factory=list)    # [lane][section]
    backward: list[list[Lanelet]] = field(default_factory=list)   # [lane][section], in driving order

    @property
    def lanelets(self) -> list[Lanelet]:
        return [l for lane in self.forward + self.backward for l in lane]

    section_by_id: dict[int, SectionKind] = field(default_factory=dict)    # lanelet id -> road section kind


def _split_indices(centre: CentreLine) -> list[tuple[int, int, SectionKind]]:
    """(first, last) sample index of each section (inclusive, sharing the boundary sample)."""
    out = []
    for sec in centre.sections:
        i0 = int(np.argmin(np.abs(centre.s - sec.s_start)))
        i1 = int(np.argmin(np.abs(centre.s - sec.s_end)))
        if i1 > i0:
            out.append((i0, i1, sec.kind))
    return out


def _marking(kind: str) -> LineMarking:
    return {"solid": LineMarking.SOLID, "dashed": LineMarking.DASHED,
            "broad_solid": LineMarking.BROAD_SOLID, "none": LineMarking.NO_MARKING}[kind]


def build_road(centre: CentreLine, layout: LaneLayout, first_id: int) -> Road:
    """Lanelets for ``layout`` along ``centre``; ids are allocated from ``first_id`` upwards."""
    n, w = layout.lanes_per_direction, layout.lane_width
    pieces = _split_indices(centre)
    m = len(pieces)
    ids = {(direction, lane): [first_id + (d_index * n + lane) * m + j for j in range(m)]
           for d_index, direction in enumerate(("forward", "backward")) for lane in range(n)}
    centre_mark = _marking(layout.centre_marking)
    road = Road(centre, layout)

    def lane_lanelets(direction: str) -> list[list[Lanelet]]:
        # forward lanes lie right of the centre line and run along it; backward lanes mirror them
        sign, other = (-1.0, "backward") if direction == "forward" else (1.0, "forward")
        order = pieces if direction == "forward" else pieces[::-1]
        lanes = []
        for lane in range(n):
            own = ids[(direction, lane)]
            lanelets = []
            for k, (i0, i1, kind) in enumerate(order):
                sl = slice(i0, i1 + 1)
                flip = slice(None) if direction == "forward" else slice(None, None, -1)
                left, mid, right = (centre.offset(sign * f * w)[sl][flip] for f in (lane, lane + 0.5, lane + 1))
                if lane > 0:
                    adj_left, same_left, mark_left = ids[(direction, lane - 1)][k], True, LineMarking.DASHED
                elif layout.two_way:
                    adj_left, same_left, mark_left = ids[(other, 0)][m - 1 - k], False, centre_mark
                else:
                    adj_left, same_left, mark_left = None, None, LineMarking.SOLID
                if lane < n - 1:
                    adj_right, same_right, mark_right = ids[(direction, lane + 1)][k], True, LineMarking.DASHED
                else:
                    adj_right, same_right, mark_right = None, None, LineMarking.SOLID
                lanelets.append(Lanelet(
                    left, mid, right, own[k],
                    predecessor=[own[k - 1]] if k > 0 else None,
                    successor=[own[k + 1]] if k < m - 1 else None,
                    adjacent_left=adj_left, adjacent_left_same_direction=same_left,
                    adjacent_right=adj_right, adjacent_right_same_direction=same_right,
                    line_marking_left_vertices=mark_left, line_marking_right_vertices=mark_right,
                    lanelet_type={LaneletType.URBAN}))
                road.section_by_id[own[k]] = kind
            lanes.append(lanelets)
        return lanes

    road.forward = lane_lanelets("forward")
    road.backward = lane_lanelets("backward") if layout.two_way else []
    return road
