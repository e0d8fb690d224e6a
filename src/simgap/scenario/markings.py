"""Line markings as CommonRoad states them, ready to be drawn by any 3D world: which lines are
painted along each marked lanelet bound, how wide, and with what dash pattern.

A bound shared by two lanelets (the centre line of a two-lane road) is listed once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from commonroad.scenario.lanelet import LaneletNetwork, LineMarking

from simgap.polyline import offset_polyline

SOLID, DASHED, BROAD_DASHED = (0.0, 0.0), (3.0, 6.0), (3.0, 3.0)   # (dash, gap) [m]; 0: solid
#: line width [m] and the painted lines as (offset to the left [m], (dash, gap))
MARKING_STYLE: dict[LineMarking, tuple[float, tuple[tuple[float, tuple[float, float]], ...]]] = {
    LineMarking.SOLID: (0.12, ((0.0, SOLID),)),
    LineMarking.DASHED: (0.12, ((0.0, DASHED),)),
    LineMarking.BROAD_SOLID: (0.25, ((0.0, SOLID),)),
    LineMarking.BROAD_DASHED: (0.25, ((0.0, BROAD_DASHED),)),
    LineMarking.SOLID_SOLID: (0.12, ((-0.12, SOLID), (0.12, SOLID))),
    LineMarking.DASHED_DASHED: (0.12, ((-0.12, DASHED), (0.12, DASHED))),
    LineMarking.SOLID_DASHED: (0.12, ((0.12, SOLID), (-0.12, DASHED))),
    LineMarking.DASHED_SOLID: (0.12, ((0.12, DASHED), (-0.12, SOLID))),
}
#: kerbs: a raised edge rather than paint (width [m]); drawn by worlds that can show them
CURB_WIDTH = {LineMarking.CURB: 0.3, LineMarking.LOWERED_CURB: 0.3}


@dataclass(frozen=True)
class MarkingLine:
    """One drawn line: its centre polyline, width, dash and gap (0: solid) and the CommonRoad
    marking it belongs to."""

    xy: np.ndarray
    width: float
    dash: float
    gap: float
    marking: LineMarking = LineMarking.SOLID

    @property
    def dashed(self) -> bool:
        return self.dash > 0.0


def marking_lines(network: LaneletNetwork, curbs: bool = False) -> list[MarkingLine]:
    """Every marked lanelet bound once, as the lines painted along it (and, with ``curbs``,
    the kerbs)."""
    seen: set[tuple] = set()
    lines = []
    for lanelet in network.lanelets:
        for xy, marking in ((lanelet.left_vertices, lanelet.line_marking_left_vertices),
                            (lanelet.right_vertices, lanelet.line_marking_right_vertices)):
            style = MARKING_STYLE.get(marking)
            if style is None and curbs and marking in CURB_WIDTH:
                style = (CURB_WIDTH[marking], ((0.0, SOLID),))
            if style is None:
                continue
            xy = np.asarray(xy, dtype=float)
            ends = tuple(sorted([tuple(np.round(xy[0], 2)), tuple(np.round(xy[-1], 2))]))
            key = (ends, len(xy), marking)
            if key in seen:
                continue
            seen.add(key)
            width, painted = style
            for d, (dash, gap) in painted:
                lines.append(MarkingLine(offset_polyline(xy, d), width, dash, gap, marking))
    return lines
