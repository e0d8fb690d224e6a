"""What an OpenDRIVE file must state to be a road, and what of it the reader drops.

The rule: what would move or lose a road is **refused**; a link that leads nowhere is **dropped**,
with a warning.

* **Refused** (an `InputError` naming the file, the road, the element's line and what is allowed):
  a road that cannot be one, since leaving it out would move or cut off the roads around it —

  - a reference line with a gap: its geometries follow each other from s = 0 to the road's length,
    each starting where the one before ends, in s and in the plane (within `JOIN_TOLERANCE_M`); a
    geometry of length 0 is passed over, as it adds nothing, unless the others then leave a gap;
  - a reference line curved tighter than `MAX_CURVATURE` anywhere (a radius under 1 m: the lanes
    beside it fold over), or whose polynomials give no finite position (coefficients that overflow);
  - a paramPoly3 whose curve is not as long as its geometry (within `LENGTH_TOLERANCE`): all-zero
    coefficients would collapse the road to a point;
  - a lane whose width falls below ``-NEGATIVE_WIDTH_TOLERANCE_M`` in its lane section (the lanes
    beyond it would swap sides), a lane border farther than `MAX_LATERAL_M` from the reference line,
    a height beyond `MAX_HEIGHT_M`, or a superelevation of 90 degrees or more (a wall, or upside
    down) — each evaluated every metre along the road;
  - a road or junction id stated twice, or a lane id twice in a lane section
    (`simgap.scenario.opendrive.document`: which one a link means cannot be told).

* **Dropped with a warning** (`Dropped`: one line per kind, with a count and the first few): a
  link to a road, junction or lane that is not in the file, a junction's connection from a road
  that does not lead into it, and a junction linked into itself (a connection whose incoming road
  is the junction's own connecting road, or a connecting road linked to its own junction). The
  roads are whole without it; only that connection between lanes is lost, and a route that needed
  it is refused where its goal is placed (not ahead of the start).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from simgap.errors import InputError
from simgap.scenario.opendrive.document import (
    Connection,
    Geometry,
    Junction,
    Lane,
    LaneSection,
    OpenDriveDocument,
    Road,
    RoadLink,
    piecewise,
)
from simgap.scenario.opendrive.lanes import section_ends
from simgap.scenario.opendrive.reference_line import geometry_poses, polynomial_length

JOIN_TOLERANCE_M = 0.05          # geometries meet within this (the files seen: 0.3 mm at worst)
MAX_CURVATURE = 1.0              # 1/m: a reference line turning on a radius under 1 m is no road
LENGTH_TOLERANCE = 0.01          # a paramPoly3's curve within 1 % of its geometry's length
NEGATIVE_WIDTH_TOLERANCE_M = 0.01    # a lane tapering to 0 may dip this far below (a cubic's overshoot)
MAX_LATERAL_M = 1000.0           # no lane border farther from its reference line
MAX_HEIGHT_M = 10_000.0          # no road higher or lower (the highest pass is under 6 km)
CHECK_STEP_M = 1.0               # the profiles are evaluated at least this often along a road
EXAMPLES = 3                     # dropped links named in a warning


@dataclass(frozen=True)
class Dropped:
    """Links of one kind that were dropped: how many, and the first few."""

    kind: str
    count: int
    examples: tuple[str, ...]

    def describe(self) -> str:
        more = " ..." if self.count > len(self.examples) else ""
        return f"{self.kind}: {self.count} dropped ({', '.join(self.examples)}{more})"


# ------------------------------------------------------------------------- refusals
def _refuse(document: OpenDriveDocument, road: Road, where: str, line: int | None, reason: str,
            allowed: str) -> InputError:
    on_line = f"line {line}: " if line is not None else ""
    return InputError(f"{on_line}{reason}", file=document.path, field=f"road {road.id}/{where}",
                      allowed=allowed)


def _check_geometry(document: OpenDriveDocument, road: Road, k: int, g: Geometry) -> None:
    where = f"planView/geometry {k}"
    if g.kind in ("arc", "spiral") and max(abs(v) for v in g.values) > MAX_CURVATURE:
        raise _refuse(document, road, where, g.line, f"<{g.kind}> of curvature {max(g.values, key=abs):g} 1/m",
                      f"curvatures within +-{MAX_CURVATURE:g} 1/m (radii of 1 m and more)")
    if g.kind not in ("poly3", "paramPoly3"):
        return
    with np.errstate(all="ignore"):
        length = polynomial_length(g)
        poses = geometry_poses(g, np.linspace(0.0, g.length, max(65, int(g.length / CHECK_STEP_M) + 1)))
    values = np.concatenate([poses.x, poses.y, poses.hdg, poses.curvature])
    if not (math.isfinite(length) and np.all(np.isfinite(values))):
        raise _refuse(document, road, where, g.line, f"the <{g.kind}> gives no finite position (its coefficients "
                      "overflow)", "coefficients of a curve of finite size")
    if g.kind == "paramPoly3" and abs(length - g.length) > LENGTH_TOLERANCE * g.length:
        raise _refuse(document, road, where, g.line, f"the <paramPoly3> is {length:.4g} m long, its geometry "
                      f"{g.length:.4g} m", f"a curve as long as its geometry (within {LENGTH_TOLERANCE:.0%})")
    worst = float(np.max(np.abs(poses.curvature)))
    if worst > MAX_CURVATURE:
        raise _refuse(document, road, where, g.line, f"the <{g.kind}> curves at {worst:.3g} 1/m",
                      f"curvatures within +-{MAX_CURVATURE:g} 1/m (radii of 1 m and more)")


def _check_reference_line(document: OpenDriveDocument, road: Road) -> None:
    """Each geometry a curve of a road, the next starting where it ends, from 0 to the road's length."""
    joined = f"geometries that follow each other within {JOIN_TOLERANCE_M:g} m from s = 0 to the road's length"
    reached, end_xy = 0.0, None
    for k, g in enumerate(road.geometries):
        _check_geometry(document, road, k, g)
        where = f"planView/geometry {k}"
        if abs(g.s - reached) > JOIN_TOLERANCE_M:
            raise _refuse(document, road, where, g.line, f"the first geometry starts at s = {g.s:g} m" if k == 0 else
                          f"starts at s = {g.s:g} m, but the one before ends at s = {reached:g} m", joined)
        if end_xy is not None and math.hypot(g.x - end_xy[0], g.y - end_xy[1]) > JOIN_TOLERANCE_M:
            raise _refuse(document, road, where, g.line, f"starts at ({g.x:g}, {g.y:g}), "
                          f"{math.hypot(g.x - end_xy[0], g.y - end_xy[1]):.3g} m from where the one before ends",
                          joined)
        end = geometry_poses(g, np.array([g.length]))
        reached, end_xy = g.s + g.length, (float(end.x[0]), float(end.y[0]))
    if abs(reached - road.length) > JOIN_TOLERANCE_M:
        raise _refuse(document, road, "planView", road.line, f"the geometries end at s = {reached:g} m, the "
                      f"road's length is {road.length:g} m", joined)


def _stations(s0: float, s1: float, starts: list[float]) -> np.ndarray:
    n = max(2, int(math.ceil((s1 - s0) / CHECK_STEP_M)) + 1)
    return np.unique(np.concatenate([np.linspace(s0, s1, n), [s for s in starts if s0 < s < s1]]))


def _check_profiles(document: OpenDriveDocument, road: Road) -> None:
    """Heights, superelevation, lane offset and lane widths every metre along the road."""
    with np.errstate(all="ignore"):
        s = _stations(0.0, road.length, [r.s for r in (*road.elevation, *road.superelevation, *road.lane_offsets)])
        for name, records, bound, unit in (("elevationProfile", road.elevation, MAX_HEIGHT_M, "m"),
                                           ("lateralProfile", road.superelevation, math.pi / 2, "rad")):
            values = piecewise(records, s)
            bad = ~(np.abs(values) < bound)
            if bad.any():
                k = int(np.argmax(bad))
                raise _refuse(document, road, name, road.line, f"{values[k]:.4g} {unit} at s = {s[k]:.4g} m",
                              f"heights within +-{MAX_HEIGHT_M:g} m" if unit == "m"
                              else "superelevations under 90 degrees (pi/2 rad) either way")
        for index, (section, (s0, s1)) in enumerate(zip(road.sections, section_ends(road))):
            if s1 <= s0:
                continue
            at = _stations(s0, s1, [r.s for r in road.lane_offsets] +
                           [section.s + w.s for lane in section.lanes for w in lane.widths])
            _check_lanes(document, road, index, section, at)


def _check_lanes(document: OpenDriveDocument, road: Road, index: int, section: LaneSection, s: np.ndarray) -> None:
    offset = piecewise(road.lane_offsets, s)
    for side in (-1, 1):
        edge = offset
        for lane in sorted((l for l in section.lanes if l.id * side > 0), key=lambda l: abs(l.id)):
            where = f"laneSection {index}/lane {lane.id}"
            width = piecewise(lane.widths, s - section.s)
            narrow = ~(width >= -NEGATIVE_WIDTH_TOLERANCE_M)
            if narrow.any():
                k = int(np.argmax(narrow))
                raise _refuse(document, road, where, lane.line, f"width {width[k]:.4g} m at s = {s[k]:.4g} m",
                              f"widths of 0 m and more (down to -{NEGATIVE_WIDTH_TOLERANCE_M:g} m where a lane "
                              "tapers out)")
            edge = edge + side * width
            far = ~(np.abs(edge) <= MAX_LATERAL_M)
            if far.any():
                k = int(np.argmax(far))
                raise _refuse(document, road, where, lane.line, f"its outer border lies {edge[k]:.4g} m from the "
                              f"reference line at s = {s[k]:.4g} m", f"lane borders within {MAX_LATERAL_M:g} m of it")


def check_roads(document: OpenDriveDocument) -> None:
    """Refuse a road that cannot be one (see the module doc)."""
    for road in document.roads.values():
        _check_reference_line(document, road)
        _check_profiles(document, road)


# ------------------------------------------------------------------------- dropped links
class _Tally:
    def __init__(self) -> None:
        self.found: dict[str, list[str]] = {}

    def drop(self, kind: str, example: str) -> None:
        self.found.setdefault(kind, []).append(example)

    def dropped(self) -> tuple[Dropped, ...]:
        return tuple(Dropped(kind, len(examples), tuple(examples[:EXAMPLES])) for kind, examples in self.found.items())


NO_ROAD = "road links to roads that are not in the file"
NO_JUNCTION = "road links to junctions that are not in the file"
NO_LANE = "lane links to lanes that the linked lane section does not have"
NO_CONNECTION = "junction connections from or to roads that are not in the file, or that do not lead into it"
CIRCULAR = "links of a junction into itself"


def _end_section(road: Road, contact: str) -> LaneSection:
    return road.sections[0] if contact == "start" else road.sections[-1]


def _lane_ids(section: LaneSection) -> set[int]:
    return {lane.id for lane in section.lanes}


def _kept_lane_links(road: Road, lane: Lane, which: str, targets: set[int] | None, tally: _Tally) -> tuple[int, ...]:
    """``lane``'s predecessor or successor ids that name a lane of ``targets`` (None: the links lead
    to no road's lanes and are not read)."""
    ids = lane.predecessors if which == "predecessor" else lane.successors
    if targets is None:
        return ids
    for m in ids:
        if m not in targets:
            tally.drop(NO_LANE, f"road {road.id} lane {lane.id} {which} {m}")
    return tuple(m for m in ids if m in targets)


def _road_link(document: OpenDriveDocument, road: Road, link: RoadLink | None, which: str,
               tally: _Tally) -> RoadLink | None:
    if link is None:
        return None
    if link.element_type == "road" and link.element_id not in document.roads:
        tally.drop(NO_ROAD, f"road {road.id} {which} {link.element_id}")
        return None
    if link.element_type == "junction":
        if link.element_id not in document.junctions:
            tally.drop(NO_JUNCTION, f"road {road.id} {which} {link.element_id}")
            return None
        if link.element_id == road.junction:
            tally.drop(CIRCULAR, f"road {road.id} of junction {road.junction} {which} to it")
            return None
    return link


def _linked_lanes(document: OpenDriveDocument, link: RoadLink | None) -> set[int] | None:
    """The lane ids at the end of the road ``link`` leads to (None: not a road)."""
    if link is None or link.element_type != "road":
        return None
    return _lane_ids(_end_section(document.roads[link.element_id], link.contact_point or "start"))


def _road_without_broken_links(document: OpenDriveDocument, road: Road, tally: _Tally) -> Road:
    predecessor = _road_link(document, road, road.predecessor, "predecessor", tally)
    successor = _road_link(document, road, road.successor, "successor", tally)
    before, after = _linked_lanes(document, predecessor), _linked_lanes(document, successor)
    sections = []
    last = len(road.sections) - 1
    for k, section in enumerate(road.sections):
        lanes = []
        for lane in section.lanes:
            previous = before if k == 0 else _lane_ids(road.sections[k - 1])
            following = after if k == last else _lane_ids(road.sections[k + 1])
            lanes.append(replace(lane, predecessors=_kept_lane_links(road, lane, "predecessor", previous, tally),
                                 successors=_kept_lane_links(road, lane, "successor", following, tally)))
        sections.append(replace(section, lanes=tuple(lanes)))
    return replace(road, predecessor=predecessor, successor=successor, sections=tuple(sections))


def _connection_kept(document: OpenDriveDocument, junction: Junction, c: Connection, tally: _Tally) -> Connection | None:
    roads = document.roads
    name = f"junction {junction.id} from road {c.incoming_road} into {c.road}"
    incoming, other = roads.get(c.incoming_road), roads.get(c.road)
    if incoming is None or other is None:
        tally.drop(NO_CONNECTION, name)
        return None
    if c.incoming_road == c.road or incoming.junction == junction.id:
        tally.drop(CIRCULAR, name)
        return None
    ends = [which for which, link in (("start", incoming.predecessor), ("end", incoming.successor))
            if link is not None and link.element_type == "junction" and link.element_id == junction.id]
    if not ends:
        tally.drop(NO_CONNECTION, name)
        return None
    sources = set().union(*(_lane_ids(_end_section(incoming, which)) for which in ends))
    targets = _lane_ids(_end_section(other, c.contact_point))
    kept = []
    for a, b in c.lane_links:
        if a in sources and b in targets:
            kept.append((a, b))
        else:
            tally.drop(NO_LANE, f"{name} lane {a} to {b}")
    return replace(c, lane_links=tuple(kept))


def without_broken_links(document: OpenDriveDocument) -> tuple[OpenDriveDocument, tuple[Dropped, ...]]:
    """``document`` without the links that lead nowhere, and what was dropped (see the module doc)."""
    tally = _Tally()
    roads = {rid: _road_without_broken_links(document, road, tally) for rid, road in document.roads.items()}
    junctions = {}
    for jid, junction in document.junctions.items():
        kept = (_connection_kept(document, junction, c, tally) for c in junction.connections)
        junctions[jid] = replace(junction, connections=tuple(c for c in kept if c is not None))
    return replace(document, roads=roads, junctions=junctions), tally.dropped()
