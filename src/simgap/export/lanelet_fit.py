"""A lanelet as an OpenDRIVE lane: its centre line fitted with OpenDRIVE geometry, its extent
across the centre line with cubic polynomials, and how far the fitted lane lies from the lanelet.

The centre line becomes a G1 clothoid spline (pyclothoids' Hermite clothoids; each piece is an
OpenDRIVE spiral, an arc or a line) through a subset of the centre vertices, chosen greedily so
that every piece stays within `FIT_TOLERANCE_M` of the centre polyline. Across it, the distances to
the left and the right bound at every centre vertex become the lane offset (to the left bound) and
the lane width (left to right bound) as C1 cubic Hermite polynomials between the vertices. The
deviation is the largest distance, in either direction, between the fitted lane's centre, left and
right border and the lanelet's centre, left and right bound.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from pyclothoids import Clothoid
from shapely.geometry import LineString, Point

FIT_TOLERANCE_M = 0.02      # the fitted centre line's largest distance from the centre polyline
_KNOT_M = 2.0               # the widest spacing of the width and offset polynomials' pieces
_SAMPLE_M = 0.1             # spacing of the samples that measure deviations
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

    def clothoid(self) -> Clothoid:
        return Clothoid.StandardParams(self.x, self.y, self.hdg, self.k_start,
                                       (self.k_end - self.k_start) / self.length, self.length)


@dataclass(frozen=True)
class Cubic:
    """a + b ds + c ds^2 + d ds^3 from ``s`` on (OpenDRIVE's width and lane offset records)."""

    s: float
    a: float
    b: float
    c: float
    d: float

    def at(self, s: float) -> float:
        u = s - self.s
        return self.a + u * (self.b + u * (self.c + u * self.d))


@dataclass(frozen=True)
class LaneletFit:
    pieces: tuple[Piece, ...]
    offset: tuple[Cubic, ...]     # reference line to the left bound [m]
    width: tuple[Cubic, ...]      # left bound to right bound [m]
    deviation_m: float            # largest distance of the fitted lane from the lanelet

    @property
    def length(self) -> float:
        return sum(p.length for p in self.pieces)


def _clean(xy: np.ndarray) -> np.ndarray:
    keep = np.concatenate([[True], np.linalg.norm(np.diff(xy, axis=0), axis=1) > 1e-6])
    return xy[keep]


def _headings(xy: np.ndarray) -> np.ndarray:
    d = np.gradient(xy, axis=0) if len(xy) > 2 else np.repeat(np.diff(xy, axis=0), 2, axis=0)
    return np.unwrap(np.arctan2(d[:, 1], d[:, 0]))


def _samples(clothoid: Clothoid, step: float = _SAMPLE_M) -> np.ndarray:
    n = max(2, math.ceil(clothoid.length / step) + 1)
    s = np.linspace(0.0, clothoid.length, n)
    return np.column_stack([[clothoid.X(v) for v in s], [clothoid.Y(v) for v in s]])


def _gap(a: np.ndarray, b: np.ndarray) -> float:
    """The largest distance of a vertex of either polyline from the other polyline (``a`` is
    densely sampled, so this bounds the distance of every point of ``a`` from ``b`` too)."""
    return float(shapely.hausdorff_distance(LineString(a), LineString(b)))


def _distance(points: np.ndarray, polyline: np.ndarray) -> float:
    """The largest distance of ``points`` from ``polyline``."""
    return float(shapely.distance(LineString(polyline), shapely.points(points)).max())


def _extended(polyline: np.ndarray, by: float) -> np.ndarray:
    """The polyline continued straight by ``by`` metres at both ends: OpenDRIVE lanes end square
    to the reference line, lanelets may end askew, and a border is compared across, not along."""
    head = polyline[0] - polyline[1]
    tail = polyline[-1] - polyline[-2]
    return np.vstack([polyline[0] + by * head / max(np.linalg.norm(head), 1e-12), polyline,
                      polyline[-1] + by * tail / max(np.linalg.norm(tail), 1e-12)])


def _hermite(xy: np.ndarray, heading: np.ndarray, i: int, j: int) -> Clothoid | None:
    c = Clothoid.G1Hermite(xy[i, 0], xy[i, 1], heading[i], xy[j, 0], xy[j, 1], heading[j])
    return c if math.isfinite(c.length) and c.length > 0 else None


def _fits(xy: np.ndarray, heading: np.ndarray, i: int, j: int) -> Clothoid | None:
    c = _hermite(xy, heading, i, j)
    if c is None or c.length > 1.5 * float(np.sum(np.linalg.norm(np.diff(xy[i:j + 1], axis=0), axis=1))) + 1e-6:
        return None
    return c if _gap(_samples(c), xy[i:j + 1]) <= FIT_TOLERANCE_M else None


def _line(xy: np.ndarray, i: int) -> Clothoid:
    """The straight from vertex i to i + 1 (where the polyline has a kink no clothoid follows)."""
    d = xy[i + 1] - xy[i]
    return Clothoid.StandardParams(xy[i, 0], xy[i, 1], math.atan2(d[1], d[0]), 0.0, 0.0, float(np.hypot(*d)))


def fit_centre(xy: np.ndarray) -> list[Clothoid]:
    """Pieces through vertices of ``xy`` (first and last included), each within the tolerance of
    the polyline between its ends: from each start, the longest Hermite clothoid that fits, or
    the straight to the next vertex where none does (a kink of the polyline)."""
    xy = _clean(np.asarray(xy, dtype=float))
    heading = _headings(xy)
    out, i, n = [], 0, len(xy)
    while i < n - 1:
        lo, hi, best = i + 1, n - 1, (i + 1, _line(xy, i))
        while lo <= hi:                            # the farthest end that still fits
            mid = (lo + hi) // 2
            c = _fits(xy, heading, i, mid)
            if c is not None:
                best, lo = (mid, c), mid + 1
            else:
                hi = mid - 1
        out.append(best[1])
        i = best[0]
    return out


def _cubic_hermite(s: np.ndarray, v: np.ndarray) -> list[Cubic]:
    """C1 cubic pieces through (s, v), slopes by finite differences."""
    h = np.diff(s)
    slope = np.diff(v) / h
    m = np.empty_like(v)
    m[0], m[-1] = slope[0], slope[-1]
    m[1:-1] = 0.5 * (slope[:-1] + slope[1:])
    out = []
    for k in range(len(h)):
        c = (3 * slope[k] - 2 * m[k] - m[k + 1]) / h[k]
        d = (m[k] + m[k + 1] - 2 * slope[k]) / h[k] ** 2
        out.append(Cubic(float(s[k]), float(v[k]), float(m[k]), float(c), float(d)))
    return out


def _value(cubics: tuple[Cubic, ...] | list[Cubic], s: float) -> float:
    k = max(0, int(np.searchsorted([c.s for c in cubics], s, side="right")) - 1)
    return cubics[k].at(s)


def fit_lanelet(centre: np.ndarray, left: np.ndarray, right: np.ndarray) -> LaneletFit:
    """The fit of one lanelet (its centre, left and right vertices)."""
    clothoids = fit_centre(centre)
    pieces = tuple(Piece(c.XStart, c.YStart, c.ThetaStart, c.length, c.KappaStart, c.KappaEnd) for c in clothoids)
    # the reference line, sampled, with arc length, heading and the left normal: every _SAMPLE_M,
    # every whole metre of the road (where a reader samples it) and both sides of each joint
    s0, pts, hdg, ss = 0.0, [], [], []
    for c in clothoids:
        n = max(2, math.ceil(c.length / _SAMPLE_M) + 1)
        metres = np.arange(math.ceil(s0), s0 + c.length, 1.0) - s0
        for v in np.unique(np.concatenate([np.linspace(0.0, c.length, n), metres])):
            pts.append((c.X(v), c.Y(v)))
            hdg.append(c.Theta(v))
            ss.append(s0 + v)
        s0 += c.length
    pts, hdg, ss = np.asarray(pts), np.asarray(hdg), np.asarray(ss)
    normal = np.column_stack([-np.sin(hdg), np.cos(hdg)])
    reach = 2.0 * float(np.max(np.linalg.norm(left - right, axis=1)))
    left, right = _extended(np.asarray(left, float), reach), _extended(np.asarray(right, float), reach)
    ref, left_line, right_line = LineString(pts), LineString(left), LineString(right)
    # knots: every _KNOT_M and the vertices of the centre and both bounds projected onto the reference line
    knots = np.array(sorted({0.0, float(ref.length)} | set(np.arange(0.0, ref.length, _KNOT_M).tolist())
                            | {float(ref.project(Point(p))) for p in np.vstack([centre, left, right])}))
    knots = knots[np.concatenate([[True], np.diff(knots) > 0.05])]
    knots[-1] = ss[-1]
    scale = ss[-1] / ref.length
    at = [ref.interpolate(k / scale) for k in knots]
    to_left = np.array([p.distance(left_line) for p in at])
    to_right = np.array([p.distance(right_line) for p in at])
    offset = _cubic_hermite(knots, to_left) if len(knots) > 1 else [Cubic(0, to_left[0], 0, 0, 0)]
    width = _cubic_hermite(knots, to_left + to_right) if len(knots) > 1 else [Cubic(0, to_left[0] + to_right[0], 0, 0, 0)]
    off = np.array([_value(offset, v) for v in ss])
    wid = np.array([_value(width, v) for v in ss])
    fitted_left = pts + off[:, None] * normal
    fitted_right = pts + (off - wid)[:, None] * normal
    fitted_centre = pts + (off - 0.5 * wid)[:, None] * normal
    deviation = max(_distance(fitted_left, left), _distance(fitted_right, right), _gap(fitted_centre, centre))
    return LaneletFit(pieces, tuple(offset), tuple(width), float(deviation))
