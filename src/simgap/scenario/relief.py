"""A road's relief: its 3D shape along its reference line, which CommonRoad's 2D lanelets leave out.

* **Elevation** (`ElevationProfile`): the grade from the road's start [%; positive: uphill along
  the reference line], changed at stations by **vertical curves** (`VerticalCurve`): parabolas of a
  given radius at their vertex, the road designer's vertical curve — a crest where the grade falls,
  a sag where it rises — of length ``radius * |change of grade|``, centred on the station where the
  two grades meet. Heights are relative to the road's start (z = 0 at s = 0).
* **Superelevation** (`BankKnot`): the roll of the cross section about the reference line [deg;
  positive: the road falls to the right of its reference line, OpenDRIVE's sign], linear between
  knots (the transitions, run-in and run-out), held before the first knot and after the last.
* **Tilt** (`RoadTilt`, the reality knobs ``road_bank`` and ``road_grade``): a bank and a grade laid
  uniformly on a profile (`ReliefProfile.tilted`): the bank added to every superelevation knot, the
  grade to every grade. A tilt needs a reference line to lie along, as the profile does: a
  generated road's centre line (a map's relief is its own, `simgap.scenario.ground`).

The cross section is straight: at lateral offset d (positive to the left) the surface lies
``d * tan(bank)`` above the reference line, and **the verge continues the road's cross slope** —
no kink at the road's edge, so a car that leaves the road meets the ground it would meet on a
road built wider. Both profiles are piecewise polynomials in s (`ElevationPiece`, the knots),
exactly what OpenDRIVE's ``elevation`` and ``superelevation`` records hold.

A `Surface` is what the 3D worlds stand on: the height and unit normal at any (x, y), and the
area it covers. Two kinds exist. `RoadRelief` lays a profile on its reference line (a
`CentreLine`: a generated road's centre line) and gives the surface through the line's Frenet frame:
each point takes the station of its nearest point on the line (found in a k-d tree of the finely
sampled line, then projected on that sample's tangent). Where two stretches of one road come close
(the legs of a hairpin on a grade) the ground between them therefore steps halfway between them.
`SampledSurface` passes through given 3D points — an imported road network's lanelet bounds at
the heights its OpenDRIVE file gives them — as planes over their Delaunay triangles (exact where
the road's cross section is straight between two bound vertices, as OpenDRIVE's lanes are), and
continues level at the nearest point's height outside them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator
from scipy.spatial import Delaunay, cKDTree

from simgap.scenario.geometry import CentreLine

MAX_GRADE_PERCENT = 40.0        # steeper than any public road (the steepest streets reach ~35 %)
MAX_BANK_DEG = 30.0
MIN_TANGENT_SCALE = 0.1         # 1 - curvature * d, bounded away from 0 near a curve's centre
MAX_TILT_DEG = 15.0             # a uniform bank or grade laid on a road (the reality knobs' range)


class VerticalCurve(BaseModel):
    """A change of grade at station ``s`` (where the two grades meet) to ``grade``, rounded by a
    parabola of ``radius`` at its vertex, ``radius * |change|`` long and centred on ``s``."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
    s: float = Field(description="station where the grades meet [m]")
    grade: float = Field(ge=-MAX_GRADE_PERCENT, le=MAX_GRADE_PERCENT, description="grade after it [%]")
    radius: float = Field(gt=0.0, description="radius of the vertical curve at its vertex [m]")


@dataclass(frozen=True)
class ElevationPiece:
    """Height ``a + b u + c u^2`` at ``u = s - s_start`` from ``s_start`` to the next piece [m]."""

    s_start: float
    a: float
    b: float
    c: float


class ElevationProfile(BaseModel):
    """The grade from the road's start and its changes (see the module doc)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
    grade: float = Field(0.0, ge=-MAX_GRADE_PERCENT, le=MAX_GRADE_PERCENT, description="grade at the start [%]")
    changes: tuple[VerticalCurve, ...] = ()

    @model_validator(mode="after")
    def _curves_in_order(self) -> ElevationProfile:
        end, previous = 0.0, self.grade
        for k, curve in enumerate(self.changes):
            half = 0.5 * curve.radius * abs(curve.grade - previous) / 100.0
            if curve.s - half < end - 1e-9:
                raise ValueError(f"the vertical curve at s = {curve.s:g} m begins at {curve.s - half:g} m, before "
                                 f"{'the road starts' if k == 0 else 'the one before it ends'} ({end:g} m)")
            end, previous = curve.s + half, curve.grade
        return self

    @property
    def flat(self) -> bool:
        return self.grade == 0.0 and all(c.grade == 0.0 for c in self.changes)

    def pieces(self) -> tuple[ElevationPiece, ...]:
        """The profile as pieces from s = 0 on: a line per grade, a parabola per vertical curve
        (before s = 0 the first line continues, after the last piece the last)."""
        g = self.grade / 100.0
        pieces = [ElevationPiece(0.0, 0.0, g, 0.0)]
        for curve in self.changes:
            g1 = curve.grade / 100.0
            length = curve.radius * abs(g1 - g)
            if length == 0.0:
                continue
            start = curve.s - 0.5 * length
            z = _piece_height(pieces[-1], start)
            pieces.append(ElevationPiece(start, z, g, (g1 - g) / (2.0 * length)))
            pieces.append(ElevationPiece(start + length, z + 0.5 * (g + g1) * length, g1, 0.0))
            g = g1
        return tuple(pieces)


def _piece_height(piece: ElevationPiece, s: float) -> float:
    u = s - piece.s_start
    return piece.a + piece.b * u + piece.c * u * u


class BankKnot(BaseModel):
    """The superelevation at station ``s`` (linear between knots)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
    s: float = Field(description="station [m]")
    bank: float = Field(ge=-MAX_BANK_DEG, le=MAX_BANK_DEG,
                        description="roll of the cross section [deg]; positive: falls to the right of the reference line")


class RoadTilt(BaseModel):
    """A bank and a grade laid uniformly on a road's relief along its reference line (`ReliefProfile.tilted`):
    the reality knobs ``road_bank`` and ``road_grade``, a world's settings where it includes this
    model (`simgap.sim.settings.RoadTiltSettings`)."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    road_bank: float = Field(0.0, ge=-MAX_TILT_DEG, le=MAX_TILT_DEG,
                             description="bank laid on the road's relief, about its reference line [deg]; positive: "
                                         "the road falls to the right of the line")
    road_grade: float = Field(0.0, ge=-MAX_TILT_DEG, le=MAX_TILT_DEG,
                              description="grade laid on the road's relief, along its reference line [deg]; "
                                          "positive: uphill along it")

    @property
    def is_level(self) -> bool:
        """No bank and no grade: the road's relief as it is."""
        return self.road_bank == 0.0 and self.road_grade == 0.0

    @property
    def grade_percent(self) -> float:
        """The grade as a road designer's grade [%] (rise over run)."""
        return 100.0 * math.tan(math.radians(self.road_grade))


LEVEL = RoadTilt()      # no tilt: a road's relief as it is


def road_tilt(settings: BaseModel | None) -> RoadTilt:
    """The tilt a world's ``settings`` lay on its road: theirs where their model includes `RoadTilt`,
    none in a world that does not tilt its road (the ideal world's, the dynamic world's)."""
    if not isinstance(settings, RoadTilt):
        return LEVEL
    return RoadTilt(road_bank=settings.road_bank, road_grade=settings.road_grade)


class ReliefProfile(BaseModel):
    """A road's relief along its reference line: elevation and superelevation (see the module doc)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
    elevation: ElevationProfile = ElevationProfile()
    superelevation: tuple[BankKnot, ...] = ()

    @model_validator(mode="after")
    def _knots_in_order(self) -> ReliefProfile:
        s = [k.s for k in self.superelevation]
        if any(b <= a for a, b in zip(s, s[1:])):
            raise ValueError("superelevation knots must follow each other along the road (s increasing)")
        return self

    @property
    def flat(self) -> bool:
        """No grade and no bank anywhere: the plane the 2D world assumes."""
        return self.elevation.flat and all(k.bank == 0.0 for k in self.superelevation)

    def tilted(self, tilt: RoadTilt) -> ReliefProfile:
        """This relief with ``tilt`` laid on it: its bank added to every superelevation knot (to a
        knot at s = 0 where there is none), its grade to the starting grade and to every vertical
        curve's, so that each curve keeps its change of grade, hence its length and its place. A
        sum beyond the relief's bounds is a `pydantic.ValidationError` of the `BankKnot` or the
        grade's model it breaks."""
        if tilt.is_level:
            return self
        rise = tilt.grade_percent
        elevation = ElevationProfile(grade=self.elevation.grade + rise,
                                     changes=tuple(VerticalCurve(s=c.s, grade=c.grade + rise, radius=c.radius)
                                                   for c in self.elevation.changes))
        knots = self.superelevation or (BankKnot(s=0.0, bank=0.0),)
        return ReliefProfile(elevation=elevation,
                             superelevation=tuple(BankKnot(s=k.s, bank=k.bank + tilt.road_bank) for k in knots))

    def height(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Height of the reference line [m] and its slope dz/ds at stations ``s``."""
        pieces = self.elevation.pieces()
        starts = np.array([p.s_start for p in pieces])
        coeff = np.array([(p.a, p.b, p.c) for p in pieces])
        s = np.asarray(s, dtype=float)
        k = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, len(pieces) - 1)
        u = s - starts[k]
        a, b, c = coeff[k].T
        return a + (b + c * u) * u, b + 2.0 * c * u

    def bank(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Superelevation [rad] and its rate d(bank)/ds [rad/m] at stations ``s``."""
        s = np.asarray(s, dtype=float)
        if not self.superelevation:
            return np.zeros_like(s), np.zeros_like(s)
        ks = np.array([k.s for k in self.superelevation])
        kb = np.radians([k.bank for k in self.superelevation])
        rate = np.zeros_like(s)
        if len(ks) > 1:
            j = np.clip(np.searchsorted(ks, s, side="right") - 1, 0, len(ks) - 2)
            inside = (s >= ks[0]) & (s < ks[-1])
            rate = np.where(inside, (kb[j + 1] - kb[j]) / (ks[j + 1] - ks[j]), 0.0)
        return np.interp(s, ks, kb), rate


@dataclass(frozen=True)
class SurfacePoints:
    """The road's surface at points: height [m] and unit normal (n, 3) pointing up."""

    z: np.ndarray
    normal: np.ndarray


class Surface(Protocol):
    """The ground a 3D world builds (see the module doc)."""

    def surface(self, x: np.ndarray, y: np.ndarray) -> SurfacePoints:
        """Height and unit normal at the points (x, y) (arrays of one shape, or floats)."""
        ...

    def bounds(self) -> tuple[float, float, float, float]:
        """x0, y0, x1, y1 of what the surface describes (beyond it, it continues as it can)."""
        ...


class RoadRelief:
    """A `ReliefProfile` laid on its reference line: the road's surface in the world (see the
    module doc). ``centre`` is sampled finely (a generated road's centre line with ``max_step``
    well under a metre): a point's station comes from its nearest sample."""

    def __init__(self, profile: ReliefProfile, centre: CentreLine):
        self.profile = profile
        self.centre = centre
        self._tree = cKDTree(centre.xy)
        self._tangent = np.column_stack([np.cos(centre.heading), np.sin(centre.heading)])

    def frenet(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Station s, lateral offset d (positive left) and the index of the nearest sample of each
        point: projected onto the circle that osculates the line at that sample."""
        points = np.column_stack([np.ravel(x), np.ravel(y)]).astype(float)
        _, j = self._tree.query(points)
        rel = points - self.centre.xy[j]
        t = self._tangent[j]
        u = np.einsum("ij,ij->i", rel, t)                      # along the sample's tangent
        w = t[:, 0] * rel[:, 1] - t[:, 1] * rel[:, 0]          # to its left
        k = self.centre.curvature[j]
        turn = np.arctan2(k * u, 1.0 - k * w)                   # angle about the centre of curvature
        along = np.divide(turn, k, out=u.copy(), where=k != 0.0)
        d = (2.0 * w - k * (u * u + w * w)) / (1.0 + np.hypot(k * u, 1.0 - k * w))
        return self.centre.s[j] + along, d, j

    def surface(self, x: np.ndarray, y: np.ndarray) -> SurfacePoints:
        """Height and unit normal of the surface at the points (x, y) (arrays of one shape, or floats)."""
        shape = np.shape(x)
        s, d, j = self.frenet(x, y)
        height, slope = self.profile.height(s)
        bank, bank_rate = self.profile.bank(s)
        tan_bank = np.tan(bank)
        # z = height(s) + d tan(bank(s)); a unit step along the line at offset d covers 1 / (1 - kappa d) of s
        scale = np.maximum(1.0 - self.centre.curvature[j] * d, MIN_TANGENT_SCALE)
        along = (slope + d * bank_rate / np.cos(bank) ** 2) / scale
        t = self._tangent[j]
        gx = along * t[:, 0] - tan_bank * t[:, 1]
        gy = along * t[:, 1] + tan_bank * t[:, 0]
        norm = np.sqrt(1.0 + gx * gx + gy * gy)
        normal = np.column_stack([-gx / norm, -gy / norm, 1.0 / norm])
        return SurfacePoints((height + d * tan_bank).reshape(shape), normal.reshape(shape + (3,)))

    def bounds(self) -> tuple[float, float, float, float]:
        """x0, y0, x1, y1 of the reference line."""
        lo, hi = self.centre.xy.min(axis=0), self.centre.xy.max(axis=0)
        return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])


class SampledSurface:
    """The surface through the 3D points ``xyz`` (n, 3): planes over their Delaunay triangles in
    (x, y); level at the nearest point's height outside them. Points with the same (x, y) to a
    millimetre are one (the first height is kept)."""

    def __init__(self, xyz: np.ndarray):
        xyz = np.asarray(xyz, dtype=float)
        _, first = np.unique(np.round(xyz[:, :2], 3), axis=0, return_index=True)
        self.xyz = xyz[np.sort(first)]
        self._triangles = Delaunay(self.xyz[:, :2])
        self._tree = cKDTree(self.xyz[:, :2])
        # each triangle's plane z = a x + b y + c, solved from its three corners
        corners = self.xyz[self._triangles.simplices]                   # (m, 3, 3)
        design = np.concatenate([corners[:, :, :2], np.ones(corners.shape[:2] + (1,))], axis=2)
        ok = np.abs(np.linalg.det(design)) > 1e-12
        self._planes = np.zeros((len(corners), 3))
        self._planes[ok] = np.linalg.solve(design[ok], corners[ok, :, 2, None])[..., 0]
        self._flat_triangle = ~ok

    def surface(self, x: np.ndarray, y: np.ndarray) -> SurfacePoints:
        shape = np.shape(x)
        points = np.column_stack([np.ravel(x), np.ravel(y)]).astype(float)
        triangle = self._triangles.find_simplex(points)
        inside = triangle >= 0
        plane = self._planes[np.where(inside, triangle, 0)]
        gx = np.where(inside, plane[:, 0], 0.0)
        gy = np.where(inside, plane[:, 1], 0.0)
        z = gx * points[:, 0] + gy * points[:, 1] + plane[:, 2]
        level = ~inside | self._flat_triangle[np.where(inside, triangle, 0)]
        if level.any():
            _, nearest = self._tree.query(points[level])
            z[level] = self.xyz[nearest, 2]
            gx[level] = gy[level] = 0.0
        norm = np.sqrt(1.0 + gx * gx + gy * gy)
        normal = np.column_stack([-gx / norm, -gy / norm, 1.0 / norm])
        return SurfacePoints(z.reshape(shape), normal.reshape(shape + (3,)))

    def bounds(self) -> tuple[float, float, float, float]:
        lo, hi = self.xyz[:, :2].min(axis=0), self.xyz[:, :2].max(axis=0)
        return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])


def tilt_of(normal: np.ndarray, heading: float) -> tuple[float, float]:
    """Pitch [rad, positive nose up] and roll [rad, positive right side down] of a plane with unit
    ``normal`` under a vehicle facing ``heading``."""
    hx, hy = math.cos(heading), math.sin(heading)
    nx, ny, nz = (float(c) for c in normal)
    return math.atan2(-(nx * hx + ny * hy), nz), math.atan2(nx * hy - ny * hx, nz)
