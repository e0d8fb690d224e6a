"""Road networks as OpenDRIVE 1.7, built with scenariogeneration's ``xodr``.

Two ways, chosen per scenario:

* **exact** — a road network simgap generated (its sidecar holds the blueprint,
  `simgap.scenario.blueprint`, and rebuilding the blueprint gives the scenario's lanelets). A road
  is one OpenDRIVE road whose reference line is the generated centre line, its straights, arcs
  and clothoids written as line, arc and spiral geometry; its lanes keep their count, width and
  direction (right of the reference line along it, left against it) and the lanelets' markings. A
  junction is a road per arm (lane -1 leaving the junction, lane +1 arriving), a connecting road
  per turning lanelet (its cubic Hermite curve as a normalised paramPoly3, a straight as a line)
  and the junction that joins them.
* **fitted** — any other lanelet network (recorded maps): lanelets cut where a neighbour begins,
  ends, joins or leaves their bound (`simgap.export.lanelet_split`; the lanes still stand for the
  source's lanelets), then same-direction neighbours that share
  their bound become one road of several lanes, opposite-direction neighbours its left lanes (where
  their lanes end square to it), lane changes allowed across a mark that is not solid, roads meet at shared cross-sections (G1: the
  reference lines continue in heading), continue road to road where the lanelets continue one to
  one, and through a junction with a connecting road per successor relation elsewhere
  (`simgap.export.road_topology`); each road's reference line, lane offset and widths are fitted
  to its lanelets (`simgap.export.lanelet_fit`: each lane's centre on its lanelet's centre line)
  and its largest deviation from them is reported.

Every driving lane carries the road friction as its material friction. A generated road's relief
(`simgap.scenario.relief`), with the run's tilt laid on it (`RoadTilt`, the reality knobs
``road_bank`` and ``road_grade``: the relief the MuJoCo world drove, `ReliefProfile.tilted`), is its
``elevationProfile`` (a record per grade and per vertical curve: lines and parabolas) and its
``lateralProfile/superelevation`` (a record per stretch between two bank knots: linear), exact. On
a road without a relief the tilt's bank is every road's superelevation (positive: the road falls
to the right of its reference line) and its grade the elevation of a network of one road (a network
whose roads meet has no single elevation profile for it: the caller notes it instead).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum
from typing import TypeAlias

import numpy as np
from commonroad.scenario.lanelet import Lanelet, LaneletNetwork, LineMarking
from scenariogeneration import xodr

from simgap.export.lanelet_fit import Cubic, Piece, RoadFit, fit_road
from simgap.export.lanelet_split import split
from simgap.export.road_topology import topology
from simgap.scenario.blueprint import JunctionBlueprint, RoadBlueprint
from simgap.scenario.geometry import curvature_pieces
from simgap.scenario.markings import MARKING_STYLE
from simgap.scenario.relief import LEVEL, ReliefProfile, RoadTilt

OPENDRIVE_VERSION = (1, 7)          # the version written (its schema ships with scenariogeneration)
FINDING_ROADS = "grouping lanelets into roads"     # the phases of a fitted export, as its progress names them
FITTING_ROADS = "fitting roads"

_MARK_TYPE = {
    LineMarking.SOLID: xodr.RoadMarkType.solid, LineMarking.DASHED: xodr.RoadMarkType.broken,
    LineMarking.BROAD_SOLID: xodr.RoadMarkType.solid, LineMarking.BROAD_DASHED: xodr.RoadMarkType.broken,
    LineMarking.SOLID_SOLID: xodr.RoadMarkType.solid_solid, LineMarking.DASHED_DASHED: xodr.RoadMarkType.broken_broken,
    LineMarking.SOLID_DASHED: xodr.RoadMarkType.solid_broken, LineMarking.DASHED_SOLID: xodr.RoadMarkType.broken_solid,
    LineMarking.CURB: xodr.RoadMarkType.curb, LineMarking.LOWERED_CURB: xodr.RoadMarkType.curb,
}


_NO_CROSSING = {LineMarking.SOLID, LineMarking.BROAD_SOLID, LineMarking.SOLID_SOLID, LineMarking.CURB,
                LineMarking.LOWERED_CURB}

Geometry: TypeAlias = xodr.Line | xodr.Arc | xodr.Spiral | xodr.ParamPoly3


class Method(StrEnum):
    EXACT = "exact"
    FITTED = "fitted"


@dataclass(frozen=True)
class UniformRoad:
    """What the whole road is made of and how it is tilted, the same everywhere: friction (1 = dry) and
    the tilt laid on its relief (its relief, where it has one, is `simgap.scenario.relief`'s)."""

    friction: float = 1.0
    tilt: RoadTilt = LEVEL


@dataclass(frozen=True)
class LaneOfLanelets:
    """An OpenDRIVE lane and the lanelets it stands for, in driving order."""

    road: int
    lane: int
    lanelets: tuple[int, ...]


@dataclass
class RoadNetwork:
    """An OpenDRIVE road network and how it relates to the lanelets it came from."""

    opendrive: xodr.OpenDrive
    method: Method
    lanes: list[LaneOfLanelets]
    fit_deviation_m: dict[int, float] = field(default_factory=dict)   # fitted: road id -> largest deviation
    notes: list[str] = field(default_factory=list)


def road_network(network: LaneletNetwork, name: str, blueprint: RoadBlueprint | JunctionBlueprint | None,
                 surface: UniformRoad = UniformRoad(), on_progress: Callable[[str, int, int], None] = lambda *_: None
                 ) -> RoadNetwork:
    """``network`` as OpenDRIVE: exact when ``blueprint`` rebuilds it, fitted otherwise (saying
    ``on_progress(phase, done, total)`` after each road it fits)."""
    notes = []
    if blueprint is not None:
        if _rebuilds(blueprint, network):
            build = _exact_road if isinstance(blueprint, RoadBlueprint) else _exact_junction
            result = build(blueprint, name, surface)
            result.notes += _surface_notes(result, surface)
            return result
        notes.append("the scenario's lanelets differ from its recorded blueprint: the road network is fitted")
    result = _fitted(network, name, surface, on_progress)
    result.notes = notes + _surface_notes(result, surface)
    return result


def _surface_notes(result: RoadNetwork, surface: UniformRoad) -> list[str]:
    notes = []
    bank, grade = surface.tilt.road_bank, surface.tilt.road_grade
    if bank:
        notes.append(f"road_bank {bank:g} deg is added to every road's superelevation (falling to the right of its "
                     "reference line)")
    if grade and len(result.opendrive.roads) > 1:
        notes.append(f"road_grade {grade:g} deg is not written as elevation (the network has "
                     f"{len(result.opendrive.roads)} roads; a uniform grade has no single elevation profile there)")
    return notes


def _rebuilds(blueprint: RoadBlueprint | JunctionBlueprint, network: LaneletNetwork) -> bool:
    rebuilt = blueprint.rebuild().lanelets
    if len(rebuilt) != len(network.lanelets):
        return False
    for lanelet in rebuilt:
        own = network.find_lanelet_by_id(lanelet.lanelet_id)
        if own is None or own.center_vertices.shape != lanelet.center_vertices.shape or \
                not np.allclose(own.center_vertices, lanelet.center_vertices, atol=1e-6):
            return False
    return True


# ------------------------------------------------------------------------------ lanes
def _mark(marking: LineMarking) -> xodr.RoadMark:
    if marking not in _MARK_TYPE:
        return xodr.RoadMark(xodr.RoadMarkType.none)
    width = MARKING_STYLE[marking][0] if marking in MARKING_STYLE else 0.3
    return xodr.RoadMark(_MARK_TYPE[marking], width)


def _lane(width: float | tuple[Cubic, ...], marking: LineMarking, surface: UniformRoad) -> xodr.Lane:
    """A driving lane of constant ``width`` or of width polynomials, its outer mark and friction."""
    if isinstance(width, tuple):
        lane = xodr.Lane(xodr.LaneType.driving, width[0].a, width[0].b, width[0].c, width[0].d, width[0].s)
        for w in width[1:]:
            lane.add_lane_width(w.a, w.b, w.c, w.d, w.s)
    else:
        lane = xodr.Lane(xodr.LaneType.driving, a=width)
    lane.add_roadmark(_mark(marking))
    lane.add_lane_material(surface.friction)
    return lane


def _centre_lane(marking: LineMarking) -> xodr.Lane:
    lane = xodr.Lane(xodr.LaneType.none)
    lane.add_roadmark(_mark(marking))
    return lane


def _road(road_id: int, pieces: list[tuple[Geometry, float, float, float]], lanes: xodr.Lanes,
          surface: UniformRoad, junction: int = -1, grade: bool = False, relief: ReliefProfile | None = None) -> xodr.Road:
    """A road from geometries placed at (x, y, heading), laid end to end, on its ``relief`` (None: flat)."""
    planview = xodr.PlanView()
    s = 0.0
    for geometry, x, y, hdg in pieces:
        planview.add_fixed_geometry(geometry, float(x), float(y), float(hdg), s)
        s += geometry.length
    planview.adjust_geometries()
    road = xodr.Road(road_id, planview, lanes, road_type=junction)
    tilt = surface.tilt
    if relief is not None:
        _add_relief(road, relief.tilted(tilt))
        return road
    if tilt.road_bank:
        road.add_superelevation(0.0, math.radians(tilt.road_bank), 0.0, 0.0, 0.0)
    if grade and tilt.road_grade:
        road.add_elevation(0.0, 0.0, math.tan(math.radians(tilt.road_grade)), 0.0, 0.0)
    return road


def _add_relief(road: xodr.Road, relief: ReliefProfile) -> None:
    """The relief's records."""
    pieces = relief.elevation.pieces()
    for piece, after in zip(pieces, pieces[1:] + (None,)):
        if after is None or after.s_start > piece.s_start:      # a piece of no length (a curve from s = 0) is left out
            road.add_elevation(piece.s_start, piece.a, piece.b, piece.c, 0.0)
    stations = np.array([0.0] + [k.s for k in relief.superelevation if k.s > 0.0])
    banks = relief.bank(stations)[0]
    previous = None
    for s, bank, rate in zip(stations, banks, np.append(np.diff(banks) / np.diff(stations), 0.0)):
        if previous is not None and abs(previous[1] + previous[2] * (s - previous[0]) - bank) < 1e-12 \
                and abs(previous[2] - rate) < 1e-12:
            continue                     # the record before goes on as this one would (a redundant record)
        road.add_superelevation(float(s), float(bank), float(rate), 0.0, 0.0)
        previous = (s, bank, rate)


def _opendrive(name: str) -> xodr.OpenDrive:
    major, minor = OPENDRIVE_VERSION
    return xodr.OpenDrive(name, revMajor=str(major), revMinor=str(minor))


# ------------------------------------------------------------------------------ exact
def _exact_road(blueprint: RoadBlueprint, name: str, surface: UniformRoad) -> RoadNetwork:
    centre, built = blueprint.centre(), blueprint.rebuild()
    pieces, s = [], 0.0
    for kind, length, k0, k1 in curvature_pieces(blueprint.segments):
        i = int(np.argmin(np.abs(centre.s - s)))
        geometry = (xodr.Line(length) if kind == "straight" else xodr.Arc(k0, length=length) if kind == "curve"
                    else xodr.Spiral(k0, k1, length=length))
        pieces.append((geometry, centre.xy[i, 0], centre.xy[i, 1], centre.heading[i]))
        s += length
    w = blueprint.lane_width
    section = xodr.LaneSection(0, _centre_lane(built.forward[0][0].line_marking_left_vertices))
    lanes = []
    for k, lane in enumerate(built.forward):
        section.add_right_lane(_lane(w, lane[0].line_marking_right_vertices, surface))
        lanes.append(LaneOfLanelets(1, -(k + 1), tuple(l.lanelet_id for l in lane)))
    for k, lane in enumerate(built.backward):
        section.add_left_lane(_lane(w, lane[0].line_marking_right_vertices, surface))
        lanes.append(LaneOfLanelets(1, k + 1, tuple(l.lanelet_id for l in lane)))
    odr_lanes = xodr.Lanes()
    odr_lanes.add_lanesection(section)
    odr = _opendrive(name)
    odr.add_road(_road(1, pieces, odr_lanes, surface, grade=True, relief=blueprint.relief))
    return RoadNetwork(odr, Method.EXACT, lanes)


def _hermite_poly3(centre: np.ndarray, t0: np.ndarray, t1: np.ndarray) -> xodr.ParamPoly3:
    """The junction's cubic Hermite turn (`simgap.scenario.junction`) as a normalised paramPoly3 in
    the frame of its start."""
    p0, p1 = centre[0], centre[-1]
    scale = float(np.linalg.norm(p1 - p0))
    b, c, d = scale * t0, -3 * p0 - 2 * scale * t0 + 3 * p1 - scale * t1, 2 * p0 + scale * t0 - 2 * p1 + scale * t1
    cos, sin = float(t0[0]), float(t0[1])
    u = lambda v: cos * v[0] + sin * v[1]          # noqa: E731 - into the start frame
    v = lambda v: -sin * v[0] + cos * v[1]         # noqa: E731
    length = _poly3_length(b, c, d)
    return xodr.ParamPoly3(0.0, u(b), u(c), u(d), 0.0, v(b), v(c), v(d), "normalized", length)


def _poly3_length(b: np.ndarray, c: np.ndarray, d: np.ndarray, n: int = 2000) -> float:
    p = np.linspace(0.0, 1.0, n + 1)
    speed = np.linalg.norm(b[None, :] + 2 * p[:, None] * c[None, :] + 3 * p[:, None] ** 2 * d[None, :], axis=1)
    return float(np.sum(0.5 * (speed[1:] + speed[:-1])) / n)


def _exact_junction(blueprint: JunctionBlueprint, name: str, surface: UniformRoad) -> RoadNetwork:
    built = blueprint.rebuild()
    by_id = {l.lanelet_id: l for l in built.lanelets}
    w = blueprint.lane_width
    odr, lanes = _opendrive(name), []
    junction_id = 1
    junction = xodr.Junction(name, junction_id)
    for index, arm in enumerate(built.arms):
        out, inc = by_id[arm.outgoing], by_id[arm.incoming]
        a = math.radians(arm.angle_deg)
        left = np.array([-math.sin(a), math.cos(a)])
        start = out.center_vertices[0] + 0.5 * w * left           # the arm's axis at the junction
        length = float(np.linalg.norm(out.center_vertices[-1] - out.center_vertices[0]))
        section = xodr.LaneSection(0, _centre_lane(out.line_marking_left_vertices))
        section.add_right_lane(_lane(w, out.line_marking_right_vertices, surface))
        section.add_left_lane(_lane(w, inc.line_marking_right_vertices, surface))
        odr_lanes = xodr.Lanes()
        odr_lanes.add_lanesection(section)
        road = _road(index + 1, [(xodr.Line(length), start[0], start[1], a)], odr_lanes, surface)
        road.add_predecessor(xodr.ElementType.junction, junction_id)
        odr.add_road(road)
        lanes += [LaneOfLanelets(index + 1, -1, (arm.outgoing,)), LaneOfLanelets(index + 1, 1, (arm.incoming,))]
    for n, ((i, j), lanelet_id) in enumerate(sorted(built.connectors.items())):
        lanelet = by_id[lanelet_id]
        centre = lanelet.center_vertices
        ai, aj = (math.radians(built.arms[k].angle_deg) for k in (i, j))
        t0, t1 = -np.array([math.cos(ai), math.sin(ai)]), np.array([math.cos(aj), math.sin(aj)])
        if abs(float(np.dot(t0, t1)) - 1.0) < 1e-6:
            geometry = xodr.Line(float(np.linalg.norm(centre[-1] - centre[0])))
        else:
            geometry = _hermite_poly3(centre, t0, t1)
        section = xodr.LaneSection(0, _centre_lane(lanelet.line_marking_left_vertices))
        lane = _lane(w, lanelet.line_marking_right_vertices, surface)
        lane.add_link("predecessor", 1)
        lane.add_link("successor", -1)
        section.add_right_lane(lane)
        odr_lanes = xodr.Lanes()
        odr_lanes.add_laneoffset(xodr.LaneOffset(0.0, 0.5 * w, 0.0, 0.0, 0.0))
        odr_lanes.add_lanesection(section)
        road_id = 100 + n
        road = _road(road_id, [(geometry, centre[0, 0], centre[0, 1], math.atan2(t0[1], t0[0]))], odr_lanes,
                     surface, junction=junction_id)
        road.add_predecessor(xodr.ElementType.road, i + 1, xodr.ContactPoint.start)
        road.add_successor(xodr.ElementType.road, j + 1, xodr.ContactPoint.start)
        odr.add_road(road)
        connection = xodr.Connection(i + 1, road_id, xodr.ContactPoint.start)
        connection.add_lanelink(1, -1)
        junction.add_connection(connection)
        lanes.append(LaneOfLanelets(road_id, -1, (lanelet_id,)))
    odr.add_junction(junction)
    return RoadNetwork(odr, Method.EXACT, lanes)


# ------------------------------------------------------------------------------ fitted
def _geometry(piece: Piece) -> Geometry:
    if piece.kind == "spiral":
        return xodr.Spiral(piece.k_start, piece.k_end, length=piece.length)
    if piece.kind == "arc":
        return xodr.Arc(piece.k_start, length=piece.length)
    return xodr.Line(piece.length)


def _lane_change(marking: LineMarking) -> xodr.LaneChange:
    """Whether the mark between two lanes of a road lets cars change lanes across it."""
    return xodr.LaneChange.none if marking in _NO_CROSSING else xodr.LaneChange.both


def _fitted_road(road_id: int, fit: RoadFit, lanelets: list[Lanelet], surface: UniformRoad, junction: int = -1,
                 grade: bool = False) -> xodr.Road:
    """A road of ``lanelets`` (left to right; the first ``fit.left`` of them left lanes, against the
    reference line) as ``fit`` places them."""
    centre = lanelets[fit.left].line_marking_left_vertices
    centre_lane = _centre_lane(centre)
    if fit.left:
        centre_lane.roadmark[0].laneChange = _lane_change(centre)
    section = xodr.LaneSection(0, centre_lane)
    for k in range(fit.left - 1, -1, -1):               # outwards from the centre lane
        lanelet = lanelets[k]
        lane = _lane(fit.widths[k], lanelet.line_marking_right_vertices, surface)
        if k > 0:
            lane.roadmark[0].laneChange = _lane_change(lanelet.line_marking_right_vertices)
        section.add_left_lane(lane)
    for k in range(fit.left, len(lanelets)):
        lanelet = lanelets[k]
        lane = _lane(fit.widths[k], lanelet.line_marking_right_vertices, surface)
        if k < len(lanelets) - 1:
            lane.roadmark[0].laneChange = _lane_change(lanelet.line_marking_right_vertices)
        section.add_right_lane(lane)
    lanes = xodr.Lanes()
    if any(abs(c.a) > 0 or c.b or c.c or c.d for c in fit.offset):
        for c in fit.offset:
            lanes.add_laneoffset(xodr.LaneOffset(c.s, c.a, c.b, c.c, c.d))
    lanes.add_lanesection(section)
    return _road(road_id, [(_geometry(p), p.x, p.y, p.hdg) for p in fit.pieces], lanes, surface, junction, grade)


def _way(end: str) -> str:
    return "successor" if end == "end" else "predecessor"


def _fitted(network: LaneletNetwork, name: str, surface: UniformRoad,
            on_progress: Callable[[str, int, int], None]) -> RoadNetwork:
    """Roads of laterally adjacent lanelets between shared cross-sections, direct links and
    junctions (`simgap.export.road_topology`), each road's geometry fitted (`lanelet_fit`)."""
    odr = _opendrive(name)
    result = RoadNetwork(odr, Method.FITTED, [])
    on_progress(FINDING_ROADS, 0, 1)
    parts = split(network.lanelets)          # lanelets cut where their neighbours begin and end
    top = topology(parts)
    on_progress(FINDING_ROADS, 1, 1)
    fitted, to_fit = 0, len(top.pieces) + len(top.connections)
    by_id = {l.lanelet_id: l for l in parts.lanelets}
    source = parts.origin                    # a piece -> the source's lanelet its lane stands for
    lane_of = {i: lane for i, (_, lane) in top.lane_of.items()}
    road_of = {i: r for i, (r, _) in top.lane_of.items()}
    roads: list[xodr.Road] = []
    for r, piece in enumerate(top.pieces):
        fit = fit_road(piece)
        road = _fitted_road(r + 1, fit, [by_id[i] for i in piece.lanelets], surface, grade=len(top.pieces) == 1)
        odr.add_road(road)
        roads.append(road)
        result.lanes += [LaneOfLanelets(road.id, lane_of[i], (source[i],)) for i in piece.lanelets]
        result.fit_deviation_m[road.id] = fit.deviation_m
        fitted += 1
        on_progress(FITTING_ROADS, fitted, to_fit)
    for link in top.links:
        (r1, e1), (r2, e2) = link.ends
        getattr(roads[r1], f"add_{_way(e1)}")(xodr.ElementType.road, roads[r2].id, xodr.ContactPoint[e2])
        getattr(roads[r2], f"add_{_way(e2)}")(xodr.ElementType.road, roads[r1].id, xodr.ContactPoint[e1])
        ways = {r1: _way(e1), r2: _way(e2)}
        for a, b in link.relations:
            ra, rb = road_of[a], road_of[b]
            _lane_of(roads[ra], lane_of[a]).add_link(ways[ra], lane_of[b])
            _lane_of(roads[rb], lane_of[b]).add_link(ways[rb], lane_of[a])
    junction_ids = {j: len(roads) + len(top.connections) + j for j in sorted(set(top.junction_ends.values()))}
    junctions = {j: xodr.Junction(f"junction {j}", junction_ids[j]) for j in junction_ids}
    for (r, end), j in sorted(top.junction_ends.items()):
        getattr(roads[r], f"add_{_way(end)}")(xodr.ElementType.junction, junction_ids[j])
    for n, c in enumerate(top.connections):
        (ri, ei), (ro, eo) = c.incoming, c.outgoing
        incoming, outgoing = roads[ri], roads[ro]
        fit = fit_road(c.piece)
        road = _fitted_road(len(roads) + n + 1, fit, [by_id[c.successor]], surface, junction=junction_ids[c.junction])
        road.add_predecessor(xodr.ElementType.road, incoming.id, xodr.ContactPoint[ei])
        road.add_successor(xodr.ElementType.road, outgoing.id, xodr.ContactPoint[eo])
        _lane_of(road, -1).add_link("predecessor", lane_of[c.predecessor])
        _lane_of(road, -1).add_link("successor", lane_of[c.successor])
        odr.add_road(road)
        connection = xodr.Connection(incoming.id, road.id, xodr.ContactPoint.start)
        connection.add_lanelink(lane_of[c.predecessor], -1)
        junctions[c.junction].add_connection(connection)
        result.lanes.append(LaneOfLanelets(road.id, -1, tuple(source[i] for i in c.lanelets)))
        result.fit_deviation_m[road.id] = fit.deviation_m
        fitted += 1
        on_progress(FITTING_ROADS, fitted, to_fit)
    for j in sorted(junctions):
        odr.add_junction(junctions[j])
    if top.unjoined:
        result.notes.append(f"{len(top.unjoined)} successor relation(s) not joined: the successor begins "
                            f"{min(g for _, _, g in top.unjoined):.1f}-{max(g for _, _, g in top.unjoined):.1f} m "
                            f"from its predecessor's end ({', '.join(f'{source[a]}->{source[b]}' for a, b, _ in top.unjoined[:4])}"
                            f"{', ...' if len(top.unjoined) > 4 else ''})")
    return result


def _lane_of(road: xodr.Road, lane_id: int) -> xodr.Lane:
    section = road.lanes.lanesections[0]
    return section.rightlanes[-lane_id - 1] if lane_id < 0 else section.leftlanes[lane_id - 1]
