"""An OpenDRIVE file read back on its own terms: each road's reference line and lane centres,
sampled along the road — to check a written file against the lanelets it stands for, without the
writer's objects (geometry evaluated with pyclothoids; a paramPoly3 by its polynomials).

Only what simgap writes is read: line, arc, spiral and paramPoly3 geometry, lane offsets, one or
more lane sections with width polynomials.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pyclothoids import Clothoid


@dataclass(frozen=True)
class RoadSamples:
    """One road sampled every ``step`` metres: arc length, reference points, and the centre
    points and outer border points of each lane (by lane id)."""

    road: int
    s: np.ndarray
    reference: np.ndarray
    lane_centres: dict[int, np.ndarray]
    lane_borders: dict[int, np.ndarray]


def _poly(records: list[dict[str, float]], s: float, key: str = "s") -> float:
    rec = None
    for r in records:
        if r[key] <= s + 1e-9:
            rec = r
    if rec is None:
        return 0.0
    u = s - rec[key]
    return rec["a"] + u * (rec["b"] + u * (rec["c"] + u * rec["d"]))


def _floats(el: ET.Element, *names: str) -> dict[str, float]:
    return {n: float(el.get(n, 0.0)) for n in names}


def _pose(geometry: ET.Element, ds: float) -> tuple[float, float, float]:
    g = _floats(geometry, "x", "y", "hdg", "length")
    shape = geometry[0]
    if shape.tag == "paramPoly3":
        c = _floats(shape, "aU", "bU", "cU", "dU", "aV", "bV", "cV", "dV")
        p = ds / g["length"] if shape.get("pRange", "normalized") == "normalized" else ds
        u = c["aU"] + p * (c["bU"] + p * (c["cU"] + p * c["dU"]))
        v = c["aV"] + p * (c["bV"] + p * (c["cV"] + p * c["dV"]))
        du = c["bU"] + p * (2 * c["cU"] + 3 * p * c["dU"])
        dv = c["bV"] + p * (2 * c["cV"] + 3 * p * c["dV"])
        cos, sin = math.cos(g["hdg"]), math.sin(g["hdg"])
        return g["x"] + cos * u - sin * v, g["y"] + sin * u + cos * v, g["hdg"] + math.atan2(dv, du)
    if shape.tag == "line":
        k0 = k1 = 0.0
    elif shape.tag == "arc":
        k0 = k1 = float(shape.get("curvature"))
    elif shape.tag == "spiral":
        k0, k1 = float(shape.get("curvStart")), float(shape.get("curvEnd"))
    else:
        raise ValueError(f"geometry <{shape.tag}> is not read here")
    c = Clothoid.StandardParams(g["x"], g["y"], g["hdg"], k0, (k1 - k0) / g["length"], g["length"])
    return c.X(ds), c.Y(ds), c.Theta(ds)


def reference_ends(path: str | Path) -> dict[int, tuple[tuple[float, float, float], tuple[float, float, float]]]:
    """Each road's reference line at its start and its end: (x, y, heading)."""
    out = {}
    for road in ET.parse(path).getroot().iter("road"):
        geometries = list(road.find("planView").iter("geometry"))
        out[int(road.get("id"))] = (_pose(geometries[0], 0.0), _pose(geometries[-1], float(geometries[-1].get("length"))))
    return out


def sample_roads(path: str | Path, step: float = 0.1) -> list[RoadSamples]:
    """Every road of the OpenDRIVE file at ``path``, sampled every ``step`` metres (and at its end)."""
    root = ET.parse(path).getroot()
    out = []
    for road in root.iter("road"):
        length = float(road.get("length"))
        geometries = [(float(g.get("s")), g) for g in road.find("planView").iter("geometry")]
        lanes_el = road.find("lanes")
        offsets = [_floats(o, "s", "a", "b", "c", "d") for o in lanes_el.iter("laneOffset")]
        sections = [(float(sec.get("s")), sec) for sec in lanes_el.iter("laneSection")]
        s_values = np.unique(np.concatenate([np.arange(0.0, length, step), [length]]))
        ref, centres, borders = [], {}, {}
        for s in s_values:
            g_s, g = [item for item in geometries if item[0] <= s + 1e-9][-1]
            x, y, hdg = _pose(g, min(s - g_s, float(g.get("length"))))
            ref.append((x, y))
            normal = np.array([-math.sin(hdg), math.cos(hdg)])
            sec_s, sec = [item for item in sections if item[0] <= s + 1e-9][-1]
            t0 = _poly(offsets, s)
            for side, sign in (("left", 1.0), ("right", -1.0)):
                el = sec.find(side)
                if el is None:
                    continue
                edge = t0
                for lane in sorted(el.iter("lane"), key=lambda e: abs(int(e.get("id")))):
                    widths = [_floats(w, "sOffset", "a", "b", "c", "d") for w in lane.iter("width")]
                    width = _poly(widths, s - sec_s, key="sOffset")
                    centre = edge + sign * 0.5 * width
                    edge += sign * width
                    centres.setdefault(int(lane.get("id")), []).append(np.array([x, y]) + centre * normal)
                    borders.setdefault(int(lane.get("id")), []).append(np.array([x, y]) + edge * normal)
        out.append(RoadSamples(int(road.get("id")), s_values, np.asarray(ref),
                               {k: np.asarray(v) for k, v in centres.items()},
                               {k: np.asarray(v) for k, v in borders.items()}))
    return out
