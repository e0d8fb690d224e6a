"""Road centre lines from segments: straights, arcs and clothoid transitions.

A road is a sequence of segments laid end to end. Curvature is piecewise constant on straights
and arcs and linear on clothoids, so heading and position follow by integration; the centre
line is sampled at no more than ``max_step`` metres, and every sample carries its arc length,
heading, curvature and the kind of section it belongs to.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

SectionKind = Literal["straight", "curve", "clothoid", "junction"]
MAX_ROAD_LENGTH_M = 20_000.0    # the longest road, and junction approach, simgap builds [m]


class Straight(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)
    kind: Literal["straight"] = "straight"
    length: float = Field(gt=0, description="length [m]")


class Arc(BaseModel):
    """A circular arc; ``angle`` > 0 turns left. ``transition`` > 0 adds clothoids of that
    length before and after, so the curvature ramps linearly from 0 to 1/radius and back
    (the arc itself is shortened so the total turning angle stays ``angle``)."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    kind: Literal["arc"] = "arc"
    radius: float = Field(gt=0, description="radius [m]")
    angle: float = Field(description="turning angle [deg], positive = left")
    transition: float = Field(0.0, ge=0, description="clothoid length on each side [m]")


Segment = Straight | Arc


@dataclass(frozen=True)
class Section:
    """A stretch of road of one kind, by arc length along the centre line."""

    kind: SectionKind
    s_start: float
    s_end: float


@dataclass(frozen=True)
class CentreLine:
    xy: np.ndarray         # (n, 2)
    s: np.ndarray          # (n,)
    heading: np.ndarray    # (n,)
    curvature: np.ndarray  # (n,)
    sections: tuple[Section, ...]

    @property
    def length(self) -> float:
        return float(self.s[-1])

    def offset(self, d: float) -> np.ndarray:
        """Points at lateral offset ``d`` (positive = left)."""
        normal = np.column_stack([-np.sin(self.heading), np.cos(self.heading)])
        return self.xy + d * normal



def curvature_pieces(segments: Sequence[Segment]) -> list[tuple[SectionKind, float, float, float]]:
    """(kind, length, curvature at start, curvature at end) of each piece of constant or linear
    curvature: a straight, an arc or a clothoid."""
    pieces: list[tuple[SectionKind, float, float, float]] = []
    for seg in segments:
        if isinstance(seg, Straight):
            pieces.append(("straight", seg.length, 0.0, 0.0))
            continue
        if seg.angle == 0:
            continue
        sign = 1.0 if seg.angle > 0 else -1.0
        k = sign / seg.radius
        total = math.radians(abs(seg.angle))
        lt = seg.transition
        # each clothoid turns by lt * |k| / 2; the arc turns the rest
        arc_angle = total - lt / seg.radius
        if arc_angle < 0:
            lt = total * seg.radius  # transitions alone take the whole angle
            arc_angle = 0.0
        if lt > 0:
            pieces.append(("clothoid", lt, 0.0, k))
        if arc_angle > 0:
            pieces.append(("curve", arc_angle * seg.radius, k, k))
        if lt > 0:
            pieces.append(("clothoid", lt, k, 0.0))
    return pieces


def centre_line(segments: Sequence[Segment], start=(0.0, 0.0), heading: float = 0.0,
                max_step: float = 1.0) -> CentreLine:
    """Integrate the segments from ``start`` at ``heading`` into a sampled centre line."""
    pieces = curvature_pieces(segments)
    xs, ys, hs, ss = [start[0]], [start[1]], [heading], [0.0]
    ks = [pieces[0][2] if pieces else 0.0]
    sections: list[Section] = []
    x, y, h, s = float(start[0]), float(start[1]), float(heading), 0.0
    for kind, length, k0, k1 in pieces:
        n = max(1, math.ceil(length / max_step))
        ds = length / n
        for i in range(n):
            # exact integration: heading is quadratic in s; position by Simpson's rule per step
            ka = k0 + (k1 - k0) * i / n
            kb = k0 + (k1 - k0) * (i + 1) / n
            dk = (kb - ka) / ds

            def head(u: float, h: float = h, ka: float = ka, dk: float = dk) -> float:
                return h + ka * u + 0.5 * dk * u * u

            sub = 8
            us = np.linspace(0.0, ds, 2 * sub + 1)
            hv = np.array([head(u) for u in us])
            w = np.ones(2 * sub + 1)
            w[1:-1:2], w[2:-1:2] = 4, 2
            x += ds / (6 * sub) * float(np.dot(w, np.cos(hv)))
            y += ds / (6 * sub) * float(np.dot(w, np.sin(hv)))
            h = head(ds)
            s += ds
            xs.append(x)
            ys.append(y)
            hs.append(h)
            ks.append(kb)
            ss.append(s)
        if sections and sections[-1].kind == kind:
            sections[-1] = Section(kind, sections[-1].s_start, s)
        else:
            sections.append(Section(kind, s - length, s))
    return CentreLine(np.column_stack([xs, ys]), np.array(ss), np.array(hs), np.array(ks),
                      tuple(sections))


def self_intersects(polyline: np.ndarray) -> bool:
    """True when a polyline crosses itself (segments that are not neighbours intersect)."""
    from shapely.geometry import LineString

    return not LineString(polyline).is_simple
