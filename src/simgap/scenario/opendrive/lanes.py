"""Lane borders along a road: each lane section cut into pieces where the reference line changes
kind (one lanelet per lane and piece, as simgap's own roads have one per section of a kind),
each piece sampled densely and thinned to the vertices that keep every border within
`VERTEX_TOLERANCE_M` of the dense line.

A lane's borders lie at lateral offsets t (positive to the left of the reference line) built
outwards from the lane offset by the lanes' widths. Superelevation rolls the cross section about
the reference line: a border at t lies t cos(superelevation) from the line in the plane and
t sin(superelevation) above its elevation (as libOpenDRIVE and ASAM's t axis have it).
"""

from __future__ import annotations

import bisect
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from simgap.scenario.geometry import SectionKind
from simgap.scenario.opendrive.document import Lane, LaneSection, Road, piecewise
from simgap.scenario.opendrive.reference_line import Poses, reference_poses

DENSE_STEP_M = 0.25              # the dense sampling a piece's vertices are chosen from
VERTEX_TOLERANCE_M = 0.01        # no border of the dense sampling lies farther than this from the chosen vertices
MAX_VERTEX_SPACING_M = 1.0       # ... which are at most this far apart (simgap's own roads: 1 m)
MIN_PIECE_M = 1.0                # a shorter piece of geometry joins the one before it in its lane section
STRAIGHT_CURVATURE = 1e-4        # a polynomial geometry that curves less than this [1/m] is a straight
_KIND: dict[str, SectionKind] = {"line": "straight", "arc": "curve", "spiral": "clothoid"}


@dataclass(frozen=True)
class Piece:
    """A stretch of one lane section over which the reference line is of one kind."""

    section: int
    index: int
    s_start: float
    s_end: float
    kind: SectionKind


@dataclass(frozen=True)
class LaneStrip:
    """One lane over one piece: its borders on the low-t (right of the reference line) and high-t
    side, in the plane and as heights, at the piece's vertices (in the reference line's direction)."""

    lane: Lane
    low: np.ndarray          # (n, 2)
    high: np.ndarray         # (n, 2)
    low_z: np.ndarray        # (n,)
    high_z: np.ndarray       # (n,)

    @property
    def widest(self) -> float:
        return float(np.max(np.linalg.norm(self.high - self.low, axis=1)))


def section_ends(road: Road) -> list[tuple[float, float]]:
    """(start, end) station of each lane section (the last ends with the road, or with its
    reference line where the geometries end first)."""
    end = min(road.length, road.geometries[-1].s + road.geometries[-1].length)
    starts = [sec.s for sec in road.sections]
    return [(s0, min(s1, end)) for s0, s1 in zip(starts, starts[1:] + [end])]


def _piece_kind(road: Road, s0: float, s1: float) -> SectionKind:
    """The kind of the reference line's geometry in the middle of [s0, s1] (junction: a connecting
    road's)."""
    if road.junction is not None:
        return "junction"
    starts = [g.s for g in road.geometries]
    geometry = road.geometries[max(0, bisect.bisect_right(starts, 0.5 * (s0 + s1)) - 1)]
    if geometry.kind in _KIND:
        return "straight" if geometry.kind == "arc" and geometry.values[0] == 0.0 else _KIND[geometry.kind]
    curvature = reference_poses(road.geometries, np.linspace(s0, s1, 9)).curvature
    return "straight" if float(np.max(np.abs(curvature))) < STRAIGHT_CURVATURE else "curve"


def road_pieces(road: Road) -> list[Piece]:
    """Every lane section of ``road`` cut where its reference line changes kind (straight, curve,
    clothoid; pieces of geometry shorter than `MIN_PIECE_M` joined to the one before)."""
    pieces = []
    for k, (s0, s1) in enumerate(section_ends(road)):
        if s1 - s0 <= 1e-6:
            continue
        cuts = [s0]
        for c in [g.s for g in road.geometries if s0 + MIN_PIECE_M <= g.s <= s1 - MIN_PIECE_M]:
            if c - cuts[-1] >= MIN_PIECE_M:
                cuts.append(c)
        cuts.append(s1)
        spans: list[tuple[float, float, SectionKind]] = []
        for a, b in zip(cuts, cuts[1:]):
            kind = _piece_kind(road, a, b)
            if spans and spans[-1][2] == kind:
                spans[-1] = (spans[-1][0], b, kind)
            else:
                spans.append((a, b, kind))
        pieces += [Piece(k, i, a, b, kind) for i, (a, b, kind) in enumerate(spans)]
    return pieces


def _stations(road: Road, section: LaneSection, piece: Piece) -> np.ndarray:
    """Dense stations over the piece, with every record start inside it (where a border may kink)."""
    n = max(1, int(np.ceil((piece.s_end - piece.s_start) / DENSE_STEP_M)))
    inner = [r.s for r in road.lane_offsets] + [section.s + w.s for lane in section.lanes for w in lane.widths]
    s = np.concatenate([np.linspace(piece.s_start, piece.s_end, n + 1),
                        [v for v in inner if piece.s_start < v < piece.s_end]])
    return np.unique(s)


def _thinned(borders: np.ndarray) -> np.ndarray:
    """Indices of the vertices kept of the dense borders (m, n, 2): no border's vertices more than
    `MAX_VERTEX_SPACING_M` apart along it, and none of its dense points farther than
    `VERTEX_TOLERANCE_M` from the chord between kept vertices."""
    along = np.concatenate([np.zeros((len(borders), 1)),
                            np.cumsum(np.linalg.norm(np.diff(borders, axis=1), axis=2), axis=1)], axis=1)
    keep, i, n = [0], 0, borders.shape[1]
    while i < n - 1:
        j = i + 1
        while j + 1 < n and np.max(along[:, j + 1] - along[:, i]) <= MAX_VERTEX_SPACING_M + 1e-9 and \
                _chord_error(borders[:, i:j + 2]) <= VERTEX_TOLERANCE_M:
            j += 1
        keep.append(j)
        i = j
    return np.array(keep)


def _chord_error(points: np.ndarray) -> float:
    """The largest distance of the inner points of each polyline (m, k, 2) from its end-to-end chord."""
    a, b = points[:, :1], points[:, -1:]
    chord = b - a
    length = np.maximum(np.linalg.norm(chord, axis=2, keepdims=True), 1e-12)
    rel = points[:, 1:-1] - a
    cross = np.abs(chord[..., 0] * rel[..., 1] - chord[..., 1] * rel[..., 0]) / length[..., 0]
    return float(cross.max()) if cross.size else 0.0


def lane_edges(road: Road, section: LaneSection, s: np.ndarray) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Each lane's borders at stations ``s`` as lateral offsets (low t, high t), by lane id: built
    outwards from the lane offset by the lanes' widths."""
    offset = piecewise(road.lane_offsets, s)
    edges: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    for side in (-1, 1):
        edge = offset
        for lane in sorted((l for l in section.lanes if l.id * side > 0), key=lambda l: abs(l.id)):
            outer = edge + side * piecewise(lane.widths, s - section.s)
            edges[lane.id] = (outer, edge) if side < 0 else (edge, outer)
            edge = outer
    return edges


def _in_plane(poses: Poses, roll: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Points (n, 2) at lateral offsets ``t`` from the reference line's ``poses``, the cross section
    rolled by ``roll`` (the superelevation)."""
    horizontal = t * np.cos(roll)
    return np.column_stack([poses.x - horizontal * np.sin(poses.hdg), poses.y + horizontal * np.cos(poses.hdg)])


def lane_centre(road: Road, section: int, lane_id: int, s: float) -> np.ndarray:
    """The centre of lane ``lane_id`` of lane section ``section`` at station ``s``: (x, y)."""
    at = np.array([s])
    low, high = lane_edges(road, road.sections[section], at)[lane_id]
    return _in_plane(reference_poses(road.geometries, at), piecewise(road.superelevation, at), 0.5 * (low + high))[0]


def lane_strips(road: Road, piece: Piece, wanted: Callable[[Lane], bool]) -> dict[int, LaneStrip]:
    """The ``wanted`` lanes of the piece's section over the piece, by lane id (their borders alone
    choose the vertices)."""
    section = road.sections[piece.section]
    s = _stations(road, section, piece)
    ids = {lane.id for lane in section.lanes if wanted(lane)}
    edges = {lid: pair for lid, pair in lane_edges(road, section, s).items() if lid in ids}
    if not edges:
        return {}
    poses, roll = reference_poses(road.geometries, s), piecewise(road.superelevation, s)
    plane = {lid: (_in_plane(poses, roll, low), _in_plane(poses, roll, high)) for lid, (low, high) in edges.items()}
    keep = _thinned(np.stack([border for pair in plane.values() for border in pair]))
    elevation = piecewise(road.elevation, s)
    by_id = {lane.id: lane for lane in section.lanes}
    return {lid: LaneStrip(by_id[lid], plane[lid][0][keep], plane[lid][1][keep],
                           (elevation + edges[lid][0] * np.sin(roll))[keep],
                           (elevation + edges[lid][1] * np.sin(roll))[keep]) for lid in edges}
