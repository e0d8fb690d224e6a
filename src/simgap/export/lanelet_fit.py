"""A road of lanelets between two joints as OpenDRIVE geometry: its reference line fitted with
clothoids, and the lane offset and lane widths as few cubic polynomials as fit.

The reference line follows the road's middle (`road_topology.reference_bounds`: its centre lane's
border, or its middle lane's centre line, or the bound between its two middle lanes) from the start
joint to the end joint. It starts
and ends on the joints' lines with the joints' headings (so that roads meeting at a joint continue
one another in heading), and passes through a subset of the bound's vertices between them: a G1
clothoid spline (pyclothoids' Hermite clothoids; each piece an OpenDRIVE spiral, arc or line),
chosen greedily so that every piece stays within `FIT_TOLERANCE_M` of the middle line.

Across it, each bound's offset is read along the reference line's normals every `SAMPLE_M` (where
the normal crosses the bound), and pinned at both ends to the joints' offsets. The lane offset
(reference line to the left bound) and each lane's width (its left to its right bound) become
piecewise cubic polynomials: C1 Hermite cubics between knots chosen greedily, a new record only
where the previous one leaves the samples by more than `RECORD_TOLERANCE_M`. Widths stay at least
`MIN_WIDTH_M`. The deviation is the largest distance of a fitted border from its bound or of a
fitted lane centre from its lanelet's centre line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from pyclothoids import Clothoid
from shapely.geometry import LineString

from simgap.export.road_topology import MIN_WIDTH_M, Border, Joint, RoadPiece, centred, middle_line, reference_bounds

FIT_TOLERANCE_M = 0.1       # the reference line's largest distance from the road's middle line (the lane
                            # offset carries the rest; a smooth line keeps the lanes' normals apart)
RECORD_TOLERANCE_M = 0.005  # a lane offset or width record's largest distance from the measured one
SAMPLE_M = 0.1              # spacing of the samples across the road
CENTRE_REACH_M = 5.0        # a lanelet's centre line continued this far past its ends when a lane centre is
                            # compared with it (across the lane, not along it)
_JOINT_CLEARANCE_M = 0.5    # middle-line vertices this close to a joint's line are left to the joint
_VERTEX_SPACING_M = 0.5     # middle-line vertices closer than this to the last one kept are left out
_STRAIGHT = 1e-9            # curvature [1/m] below which a piece is a line, rate below which an arc


@dataclass(frozen=True)
class Piece:
    """One OpenDRIVE geometry: start pose, length and the curvature at both ends."""

    x: float
    y: float
    hdg: float
    length: float
    k_start: float
    k_end: float

    @property
    def kind(self) -> str:
        if abs(self.k_end - self.k_start) > _STRAIGHT * max(1.0, self.length):
            return "spiral"
        return "arc" if abs(self.k_start) > _STRAIGHT else "line"


@dataclass(frozen=True)
class Cubic:
    """a + b ds + c ds^2 + d ds^3 from ``s`` on (OpenDRIVE's width and lane offset records)."""

    s: float
    a: float
    b: float
    c: float
    d: float

    def at(self, s: np.ndarray | float) -> np.ndarray | float:
        u = s - self.s
        return self.a + u * (self.b + u * (self.c + u * self.d))


@dataclass(frozen=True)
class RoadFit:
    pieces: tuple[Piece, ...]
    offset: tuple[Cubic, ...]                   # reference line to the centre lane [m]
    widths: tuple[tuple[Cubic, ...], ...]       # per lane, left to right [m]
    deviation_m: float                          # largest distance of a fitted lane centre from its lanelet's
                                                # centre line
    border_deviation_m: float = 0.0             # largest distance of a fitted border from its bound
    left: int = 0                               # the first ``left`` lanes are left lanes (offset: their
                                                # right border, the centre lane)

    @property
    def length(self) -> float:
        return sum(p.length for p in self.pieces)


# ------------------------------------------------------------------------------ reference line
def _headings(xy: np.ndarray, span: float = 1.5) -> np.ndarray:
    """The polyline's direction at each vertex: the chord from ``span`` metres before it to
    ``span`` metres after it (along the polyline)."""
    d = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])
    at = lambda v: np.column_stack([np.interp(v, d, xy[:, 0]), np.interp(v, d, xy[:, 1])])  # noqa: E731
    chord = at(np.minimum(d + span, d[-1])) - at(np.maximum(d - span, 0.0))
    return np.arctan2(chord[:, 1], chord[:, 0])


def _samples(clothoid: Clothoid, step: float = SAMPLE_M) -> np.ndarray:
    n = max(2, math.ceil(clothoid.length / step) + 1)
    s = np.linspace(0.0, clothoid.length, n)
    return np.column_stack([[clothoid.X(v) for v in s], [clothoid.Y(v) for v in s]])


def _hermite(xy: np.ndarray, heading: np.ndarray, i: int, j: int) -> Clothoid | None:
    c = Clothoid.G1Hermite(xy[i, 0], xy[i, 1], heading[i], xy[j, 0], xy[j, 1], heading[j])
    return c if math.isfinite(c.length) and c.length > 0 else None


def _fits(xy: np.ndarray, heading: np.ndarray, i: int, j: int) -> Clothoid | None:
    c = _hermite(xy, heading, i, j)
    if c is None or c.length > 1.5 * float(np.sum(np.linalg.norm(np.diff(xy[i:j + 1], axis=0), axis=1))) + 1e-6:
        return None
    gap = shapely.hausdorff_distance(LineString(_samples(c)), LineString(xy[i:j + 1]))
    return c if gap <= FIT_TOLERANCE_M else None


def _step(xy: np.ndarray, heading: np.ndarray, i: int) -> Clothoid:
    """The piece from vertex i to i + 1 where no piece within the tolerance reaches further: the
    circular arc tangent to the heading at i (G1 kept; the heading at i + 1 becomes the arc's, so
    that no clothoid loops between close vertices with discordant headings)."""
    d = xy[i + 1] - xy[i]
    chord, length = math.atan2(d[1], d[0]), float(np.hypot(*d))
    turn = math.remainder(chord - heading[i], 2 * math.pi)
    if abs(turn) >= math.pi / 2 - 1e-6:             # the polyline doubles back: no arc, a straight
        return Clothoid.StandardParams(xy[i, 0], xy[i, 1], chord, 0.0, 0.0, length)
    if i + 1 < len(xy) - 1:                         # the last vertex keeps its heading: the joint's
        c = _hermite(xy, heading, i, i + 1)         # the polyline's own heading there, where a clothoid
        if c is not None and c.length <= 1.2 * length:   # reaches it without a loop (else each arc
            return c                                # mirrors the last turn and the line zigzags on)
        heading[i + 1] = heading[i] + 2 * turn
    c = _hermite(xy, heading, i, i + 1)
    return c if c is not None else Clothoid.StandardParams(xy[i, 0], xy[i, 1], chord, 0.0, 0.0, length)


def fit_reference(xy: np.ndarray, heading: np.ndarray) -> list[Clothoid]:
    """Clothoids through vertices of ``xy`` (first and last included) with the given headings at
    them: from each vertex, the longest Hermite clothoid within the tolerance of the polyline."""
    out, i, n = [], 0, len(xy)
    while i < n - 1:
        lo, hi, best = i + 2, n - 1, None
        while lo <= hi:                            # the farthest end that still fits
            mid = (lo + hi) // 2
            c = _fits(xy, heading, i, mid)
            if c is not None:
                best, lo = (mid, c), mid + 1
            else:
                hi = mid - 1
        best = best or (i + 1, _step(xy, heading, i))
        out.append(best[1])
        i = best[0]
    return out


def reference_offset(joint: Joint, borders: tuple[Border, ...], reference: tuple[int, int]) -> float:
    """Where a road's reference line crosses a joint (its offset along it): midway between the
    borders ``reference`` (indices)."""
    i, j = reference
    return 0.5 * (joint.t[borders[i]] + joint.t[borders[j]])


def _reference(piece: RoadPiece) -> tuple[int, int]:
    return piece.reference or reference_bounds(len(piece.bounds) - 1, piece.left)


def _reference_polyline(piece: RoadPiece) -> tuple[np.ndarray, np.ndarray]:
    """The road's middle line between the two joints: its vertices within the road's span and
    clear of both joints, with the joints' points and headings at the ends."""
    start, end = piece.start, piece.end
    p0 = start.origin + reference_offset(start, piece.start_borders, _reference(piece)) * start.normal
    p1 = end.origin + reference_offset(end, piece.end_borders, _reference(piece)) * end.normal
    i, j = _reference(piece)
    middle = piece.middle if piece.middle is not None else \
        middle_line(np.asarray(piece.bounds[i], float), np.asarray(piece.bounds[j], float))
    along = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(middle, axis=0), axis=1))])
    inside = (along > piece.span[0] + _JOINT_CLEARANCE_M) & (along < piece.span[1] - _JOINT_CLEARANCE_M)
    kept = [p0]
    for v in middle[inside]:
        if np.linalg.norm(v - kept[-1]) >= _VERTEX_SPACING_M and np.linalg.norm(v - p1) >= _VERTEX_SPACING_M:
            kept.append(v)
    xy = np.vstack(kept + [p1])
    heading = np.unwrap(_headings(xy))
    heading[0], heading[-1] = start.heading, end.heading
    return xy, heading


# ------------------------------------------------------------------------------ across the road
def _offsets(points: np.ndarray, normals: np.ndarray, polyline: np.ndarray, reach: float) -> np.ndarray:
    """Signed offset along each normal from each point to where it crosses ``polyline`` (the
    crossing nearest the point; where none is within ``reach``, the nearest sample's)."""
    lines = shapely.linestrings(np.stack([points - reach * normals, points + reach * normals], axis=1))
    coords, index = shapely.get_coordinates(shapely.intersection(lines, LineString(polyline)), return_index=True)
    t = np.full(len(points), np.nan)
    if len(coords):
        along = np.einsum("ij,ij->i", coords - points[index], normals[index])
        order = np.lexsort((np.abs(along), index))
        first = np.unique(index[order], return_index=True)[1]
        t[index[order][first]] = along[order][first]
    known = np.flatnonzero(~np.isnan(t))
    if not len(known):
        nearest = shapely.shortest_line(shapely.points(points), LineString(polyline))
        q = shapely.get_coordinates(nearest).reshape(-1, 2, 2)[:, 1]
        return np.einsum("ij,ij->i", q - points, normals)
    return np.interp(np.arange(len(t)), known, t[known])


def extended(polyline: np.ndarray, by: float) -> np.ndarray:
    """The polyline continued straight by ``by`` metres at both ends: lanes end square to the
    reference line, lanelets may end askew, and a border is compared across, not along."""
    head, tail = polyline[0] - polyline[1], polyline[-1] - polyline[-2]
    return np.vstack([polyline[0] + by * head / max(np.linalg.norm(head), 1e-12), polyline,
                      polyline[-1] + by * tail / max(np.linalg.norm(tail), 1e-12)])


def _slopes(s: np.ndarray, v: np.ndarray, window: float = 0.5) -> np.ndarray:
    """dv/ds at every sample, by the secant over ``window`` metres around it."""
    lo = np.searchsorted(s, s - window)
    hi = np.minimum(np.searchsorted(s, s + window, side="right") - 1, len(s) - 1)
    return (v[hi] - v[lo]) / np.maximum(s[hi] - s[lo], 1e-12)


def _hermite_cubic(s0: float, v0: float, m0: float, s1: float, v1: float, m1: float) -> Cubic:
    h = s1 - s0
    slope = (v1 - v0) / h
    return Cubic(s0, v0, m0, (3 * slope - 2 * m0 - m1) / h, (m0 + m1 - 2 * slope) / h ** 2)


def _least(cubic: Cubic, s1: float) -> float:
    """The cubic's least value on [cubic.s, s1]."""
    h = s1 - cubic.s
    candidates = [0.0, h] + [float(r.real) for r in np.roots([3 * cubic.d, 2 * cubic.c, cubic.b])
                             if abs(r.imag) < 1e-12 and 0.0 < r.real < h] if (cubic.c or cubic.d) else [0.0, h]
    return min(float(cubic.at(cubic.s + u)) for u in candidates)


def records(s: np.ndarray, v: np.ndarray, floor: float | None = None) -> tuple[Cubic, ...]:
    """Cubic records through the samples (s, v), ends exact: from each knot, the farthest knot whose
    Hermite cubic stays within `RECORD_TOLERANCE_M` of every sample between (and, with ``floor``,
    not below it)."""
    m = _slopes(s, v)
    out, i, n = [], 0, len(s)

    def piece(i: int, j: int) -> Cubic | None:
        c = _hermite_cubic(s[i], v[i], m[i], s[j], v[j], m[j])
        if np.max(np.abs(c.at(s[i:j + 1]) - v[i:j + 1])) > RECORD_TOLERANCE_M:
            return None
        return c if floor is None or _least(c, s[j]) >= floor - 1e-9 else None

    while i < n - 1:
        lo, hi, best = i + 2, n - 1, None
        while lo <= hi:
            mid = (lo + hi) // 2
            c = piece(i, mid)
            if c is not None:
                best, lo = (mid, c), mid + 1
            else:
                hi = mid - 1
        if best is None:       # the next sample only: the cubic, or the straight between them
            c = piece(i, i + 1)
            slope = (v[i + 1] - v[i]) / (s[i + 1] - s[i])
            best = (i + 1, c or Cubic(float(s[i]), float(v[i]), float(slope), 0.0, 0.0))
        out.append(best[1])
        i = best[0]
    return tuple(Cubic(float(c.s), float(c.a), float(c.b), float(c.c), float(c.d)) for c in _merged(out, s, v))


def _merged(cubics: list[Cubic], s: np.ndarray, v: np.ndarray) -> list[Cubic]:
    """A record that only continues the one before it (the same polynomial) is left out."""
    out = [cubics[0]]
    for c in cubics[1:]:
        prev = out[-1]
        u = c.s - prev.s
        same = (abs(prev.at(c.s) - c.a) < 1e-9 and abs(prev.b + u * (2 * prev.c + 3 * u * prev.d) - c.b) < 1e-9
                and abs(prev.c + 3 * u * prev.d - c.c) < 1e-9 and abs(prev.d - c.d) < 1e-9)
        if not same:
            out.append(c)
    return out


def value(cubics: tuple[Cubic, ...], s: np.ndarray) -> np.ndarray:
    """Piecewise records evaluated at ``s`` (each record from its s on)."""
    starts = np.array([c.s for c in cubics])
    k = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, len(cubics) - 1)
    out = np.empty(len(s))
    for j, c in enumerate(cubics):
        sel = k == j
        out[sel] = c.at(s[sel])
    return out


def fit_road(piece: RoadPiece) -> RoadFit:
    """The geometry of one road between its joints (see the module's description)."""
    xy, heading = _reference_polyline(piece)
    clothoids = fit_reference(xy, heading)
    pieces = tuple(Piece(c.XStart, c.YStart, c.ThetaStart, c.length, c.KappaStart, c.KappaEnd) for c in clothoids)
    s_at: list[float] = []
    points: list[tuple[float, float]] = []
    headings: list[float] = []
    s0 = 0.0
    for c in clothoids:
        n = max(2, math.ceil(c.length / SAMPLE_M) + 1)
        for u in np.linspace(0.0, c.length, n)[(1 if s_at else 0):]:
            s_at.append(s0 + u)
            points.append((c.X(u), c.Y(u)))
            headings.append(c.Theta(u))
        s0 += c.length
    s, pts, hdg = np.asarray(s_at), np.asarray(points), np.asarray(headings)
    keep = np.concatenate([s[:-1] < s[-1] - 1e-6, [True]]) & np.concatenate([[True], np.diff(s) > 1e-6])
    s, pts, hdg = s[keep], pts[keep], hdg[keep]
    normals = np.column_stack([-np.sin(hdg), np.cos(hdg)])
    width = max(float(np.max(np.linalg.norm(piece.bounds[0] - piece.bounds[-1][[0, -1]][:, None], axis=2))),
                1.0) if len(piece.bounds) > 1 else 1.0
    reach = 2.0 * width + 5.0
    bounds = [extended(np.asarray(b, float), reach) for b in piece.bounds]
    centres = [extended(np.asarray(c, float), CENTRE_REACH_M)
               for c in (piece.centres if piece.lanelet_centres is None else piece.lanelet_centres)]
    t0 = reference_offset(piece.start, piece.start_borders, _reference(piece))
    t1 = reference_offset(piece.end, piece.end_borders, _reference(piece))
    across = centred(np.array([_offsets(pts, normals, b, reach) for b in bounds]),
                     np.array([_offsets(pts, normals, extended(np.asarray(c, float), reach), reach)
                               for c in piece.centres]))
    for k in range(len(across)):
        across[k, 0] = piece.start.t[piece.start_borders[k]] - t0
        across[k, -1] = piece.end.t[piece.end_borders[k]] - t1
    offset = records(s, across[piece.left])
    widths = tuple(records(s, np.maximum(across[k - 1] - across[k], MIN_WIDTH_M), floor=MIN_WIDTH_M)
                   for k in range(1, len(across)))
    # the deviation, on a grid twice as fine as the file is checked on
    s, pts, hdg = _poses(clothoids, np.unique(np.concatenate([np.arange(0.0, s[-1], 0.5 * SAMPLE_M), [s[-1]]])))
    normals = np.column_stack([-np.sin(hdg), np.cos(hdg)])
    border = [value(offset, s)]                                  # the centre lane's border, then outwards
    for k in range(piece.left, len(widths)):
        border.append(border[-1] - value(widths[k], s))
    for k in range(piece.left - 1, -1, -1):
        border.insert(0, border[0] + value(widths[k], s))

    def at(t: np.ndarray) -> np.ndarray:
        return pts + t[:, None] * normals

    centre_deviation = max(_distance(at(0.5 * (border[k] + border[k + 1])), centres[k]) for k in range(len(centres)))
    border_deviation = max(_distance(at(t), b) for t, b in zip(border, bounds))
    return RoadFit(pieces, offset, widths, centre_deviation, border_deviation, piece.left)


def _poses(clothoids: list[Clothoid], s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stations, points and headings of the clothoids laid end to end, at stations ``s``."""
    starts = np.cumsum([0.0] + [c.length for c in clothoids[:-1]])
    k = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, len(clothoids) - 1)
    u = np.minimum(s - starts[k], [clothoids[j].length for j in k])
    pts = np.array([(clothoids[j].X(v), clothoids[j].Y(v)) for j, v in zip(k, u)])
    return s, pts, np.array([clothoids[j].Theta(v) for j, v in zip(k, u)])


def _distance(points: np.ndarray, polyline: np.ndarray) -> float:
    """The largest distance of ``points`` from ``polyline``."""
    return float(shapely.distance(LineString(polyline), shapely.points(points)).max())
