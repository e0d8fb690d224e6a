"""Lanes along a centre line: CommonRoad lanelets with line markings and all their relations.

Right-hand traffic: lanes right of the centre line run along it, lanes left of it (on a two-way
road) run against it. There is one lanelet per road section per lane, linked as successors, so
that every lanelet lies in exactly one section (straight, curve, clothoid).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from commonroad.scenario.lanelet import Lanelet, LaneletType, LineMarking

from simgap.scenario.geometry import CentreLine


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

    def section_of(self, lanelet_id: int) -> str:
        return self._section_by_id[lanelet_id]

    _section_by_id: dict[int, str] = field(default_factory=dict)


def _split_indices(centre: CentreLine) -> list[tuple[int, int, str]]:
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
    n = layout.lanes_per_direction
    w = layout.lane_width
    pieces = _split_indices(centre)
    next_id = first_id
    road = Road(centre, layout)

    def ids(count: int) -> list[int]:
        nonlocal next_id
        out = list(range(next_id, next_id + count))
        next_id += count
        return out

    fwd_ids = [ids(len(pieces)) for _ in range(n)]
    bwd_ids = [ids(len(pieces)) for _ in range(n)] if layout.two_way else []
    centre_mark = _marking(layout.centre_marking)

    for lane in range(n):
        lanelets = []
        for j, (i0, i1, kind) in enumerate(pieces):
            sl = slice(i0, i1 + 1)
            left = centre.offset(-lane * w)[sl]
            right = centre.offset(-(lane + 1) * w)[sl]
            mid = centre.offset(-(lane + 0.5) * w)[sl]
            if lane == 0:
                adj_left, same_left = (bwd_ids[0][len(pieces) - 1 - j], False) if layout.two_way else (None, None)
                mark_left = centre_mark if layout.two_way else LineMarking.SOLID
            else:
                adj_left, same_left = fwd_ids[lane - 1][j], True
                mark_left = LineMarking.DASHED
            if lane == n - 1:
                adj_right, same_right, mark_right = None, None, LineMarking.SOLID
            else:
                adj_right, same_right, mark_right = fwd_ids[lane + 1][j], True, LineMarking.DASHED
            lanelets.append(Lanelet(
                left, mid, right, fwd_ids[lane][j],
                predecessor=[fwd_ids[lane][j - 1]] if j > 0 else None,
                successor=[fwd_ids[lane][j + 1]] if j < len(pieces) - 1 else None,
                adjacent_left=adj_left, adjacent_left_same_direction=same_left,
                adjacent_right=adj_right, adjacent_right_same_direction=same_right,
                line_marking_left_vertices=mark_left, line_marking_right_vertices=mark_right,
                lanelet_type={LaneletType.URBAN}))
            road._section_by_id[fwd_ids[lane][j]] = kind
        road.forward.append(lanelets)

    for lane in range(n if layout.two_way else 0):
        lanelets = []
        for jj, (i0, i1, kind) in enumerate(reversed(pieces)):
            j = len(pieces) - 1 - jj          # index of the same section in forward order
            sl = slice(i0, i1 + 1)
            left = centre.offset((lane) * w)[sl][::-1]
            right = centre.offset((lane + 1) * w)[sl][::-1]
            mid = centre.offset((lane + 0.5) * w)[sl][::-1]
            if lane == 0:
                adj_left, same_left, mark_left = fwd_ids[0][j], False, centre_mark
            else:
                adj_left, same_left, mark_left = bwd_ids[lane - 1][jj], True, LineMarking.DASHED
            if lane == n - 1:
                adj_right, same_right, mark_right = None, None, LineMarking.SOLID
            else:
                adj_right, same_right, mark_right = bwd_ids[lane + 1][jj], True, LineMarking.DASHED
            lanelets.append(Lanelet(
                left, mid, right, bwd_ids[lane][jj],
                predecessor=[bwd_ids[lane][jj - 1]] if jj > 0 else None,
                successor=[bwd_ids[lane][jj + 1]] if jj < len(pieces) - 1 else None,
                adjacent_left=adj_left, adjacent_left_same_direction=same_left,
                adjacent_right=adj_right, adjacent_right_same_direction=same_right,
                line_marking_left_vertices=mark_left, line_marking_right_vertices=mark_right,
                lanelet_type={LaneletType.URBAN}))
            road._section_by_id[bwd_ids[lane][jj]] = kind
        road.backward.append(lanelets)
    return road
