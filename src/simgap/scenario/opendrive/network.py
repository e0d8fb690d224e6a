"""An OpenDRIVE road network as a CommonRoad lanelet network.

Each lane a car may drive in (driving lanes and ramps: `DRIVABLE`) becomes one lanelet per piece
of its lane section (`lanes.road_pieces`); sidewalks, shoulders, borders, parking, bidirectional
lanes and the like are left out. A lanelet runs in its lane's driving direction: with the reference
line right of it under right-hand traffic (``rule="LHT"``: left of it; OpenDRIVE 1.8's lane
``direction="reversed"`` turns it round).

Links are OpenDRIVE's, joined at lane ends: lane links between lane sections, road links with
their lanes' links, and junctions' connections with their lane links (connecting roads and direct
junctions alike). A link becomes a successor relation where one lane's exit meets the other's
entry; a link between two lanes driven towards (or away from) each other is no relation and is
counted as not kept (`LinkTally`). Lanes side by side in a lane section are neighbours, the same
way or the opposite.

A file that cannot be a road is refused, and a link that leads nowhere is dropped and reported
(`OpenDriveNetwork.dropped`), by `simgap.scenario.opendrive.checks`.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from commonroad.scenario.lanelet import Lanelet, LaneletNetwork, LaneletType, LineMarking

from simgap.scenario.opendrive.checks import Dropped, check_roads, without_broken_links
from simgap.scenario.opendrive.document import Lane, OpenDriveDocument, Road, RoadMark, read_document
from simgap.scenario.opendrive.lanes import LaneStrip, Piece, lane_strips, road_pieces
from simgap.scenario.opendrive.origin import LaneletPlace, OpenDriveOrigin, RoadProfile
from simgap.scenario.physical_bounds import MIN_LANELET_WIDTH
from simgap.scenario.sections import RoadSections

FIRST_LANELET_ID = 100          # as simgap's templates: planning problems take ids 1, 2, 3, ...
DRIVABLE = ("driving", "entry", "exit", "onRamp", "offRamp", "connectingRamp", "mwyEntry", "mwyExit")
_RAMPS = {"entry": LaneletType.ACCESS_RAMP, "onramp": LaneletType.ACCESS_RAMP, "mwyentry": LaneletType.ACCESS_RAMP,
          "connectingramp": LaneletType.ACCESS_RAMP, "exit": LaneletType.EXIT_RAMP,
          "offramp": LaneletType.EXIT_RAMP, "mwyexit": LaneletType.EXIT_RAMP}
_ROAD_TYPES = {"motorway": LaneletType.HIGHWAY, "rural": LaneletType.COUNTRY, "town": LaneletType.URBAN,
               "lowspeed": LaneletType.URBAN, "townexpressway": LaneletType.URBAN,
               "townarterial": LaneletType.URBAN, "towncollector": LaneletType.URBAN,
               "townlocal": LaneletType.URBAN, "townprivate": LaneletType.URBAN}
_MARKS = {"solid": LineMarking.SOLID, "broken": LineMarking.DASHED, "solid solid": LineMarking.SOLID_SOLID,
          "broken broken": LineMarking.DASHED_DASHED, "solid broken": LineMarking.SOLID_DASHED,
          "broken solid": LineMarking.DASHED_SOLID, "curb": LineMarking.CURB, "none": LineMarking.NO_MARKING}

LaneEnd = tuple[str, int, int, str | None]  # road, lane section, lane id, "start" or "end" (along the road;
                                            # None: a road link without a contact point)
DraftKey = tuple[str, int, int, int]        # a lanelet to be: road, lane section, lane id, piece of the section


@dataclass(frozen=True)
class LinkTally:
    """The file's lane links between lanes that became lanelets, and how many became a successor
    relation (the others join lanes driven in opposite directions)."""

    source: int
    kept: int


@dataclass
class OpenDriveNetwork:
    """The lanelets of an OpenDRIVE file, each one's kind of road section, where each came from,
    the links kept, and the links dropped as leading nowhere (`checks`)."""

    document: OpenDriveDocument
    lanelets: LaneletNetwork
    sections: RoadSections
    origin: OpenDriveOrigin
    links: LinkTally
    dropped: tuple[Dropped, ...] = ()


def _drivable(lane: Lane) -> bool:
    return lane.type.lower() in {t.lower() for t in DRIVABLE} and not lane.both_ways


def _forward(road: Road, lane: Lane) -> bool:
    """The lane is driven along its road's reference line."""
    return (lane.id < 0) ^ road.left_hand_traffic ^ lane.reversed


def _mark(marks: tuple[RoadMark, ...], s_offset: float) -> LineMarking:
    current = [m for m in marks if m.s_offset <= s_offset + 1e-9]
    return _MARKS.get(current[-1].type, LineMarking.UNKNOWN) if current else LineMarking.NO_MARKING


def _lanelet_type(road: Road, lane: Lane) -> set[LaneletType]:
    if road.junction is not None:
        return {LaneletType.INTERSECTION}
    kind = lane.type.lower()
    if kind in _RAMPS:
        return {_RAMPS[kind]}
    return {_ROAD_TYPES.get((road.road_type or "").lower(), LaneletType.UNKNOWN)}


@dataclass
class _Draft:
    """A lanelet before its relations are complete."""

    road: Road
    strip: LaneStrip
    piece: Piece
    forward: bool
    marks: tuple[LineMarking, LineMarking]       # low-t and high-t border
    predecessors: list[int]
    successors: list[int]
    left: tuple[int, bool] | None = None         # neighbour id, same direction
    right: tuple[int, bool] | None = None

    def exit_end(self) -> str:
        return "end" if self.forward else "start"

    def lanelet(self, lanelet_id: int) -> Lanelet:
        low, high = self.strip.low, self.strip.high
        left, right = (high, low) if self.forward else (low[::-1], high[::-1])
        mark_left, mark_right = self.marks[::-1] if self.forward else self.marks
        return Lanelet(left, 0.5 * (left + right), right, lanelet_id,
                       predecessor=sorted(set(self.predecessors)) or None,
                       successor=sorted(set(self.successors)) or None,
                       adjacent_left=self.left[0] if self.left else None,
                       adjacent_left_same_direction=self.left[1] if self.left else None,
                       adjacent_right=self.right[0] if self.right else None,
                       adjacent_right_same_direction=self.right[1] if self.right else None,
                       line_marking_left_vertices=mark_left, line_marking_right_vertices=mark_right,
                       lanelet_type=_lanelet_type(self.road, self.strip.lane))

    def place(self, relief: bool) -> LaneletPlace:
        low, high = np.round(self.strip.low_z, 4), np.round(self.strip.high_z, 4)
        left, right = (high, low) if self.forward else (low[::-1], high[::-1])
        return LaneletPlace(road=self.road.id, section=self.piece.section, lane=self.strip.lane.id,
                            s_start=round(self.piece.s_start, 6), s_end=round(self.piece.s_end, 6),
                            left_z=tuple(left.tolist()) if relief else None,
                            right_z=tuple(right.tolist()) if relief else None)


def _border_marks(road: Road, section: int, lane: Lane, s_offset: float) -> tuple[LineMarking, LineMarking]:
    """The markings of a lane's low-t and high-t borders: each border is the outer border of the
    lane beyond it from the centre (or of the centre lane)."""
    sec = road.sections[section]
    marks = {l.id: l.marks for l in sec.lanes} | {0: sec.centre_marks}
    inner = lane.id + 1 if lane.id < 0 else lane.id - 1
    own, towards_centre = _mark(marks[lane.id], s_offset), _mark(marks.get(inner, ()), s_offset)
    return (own, towards_centre) if lane.id < 0 else (towards_centre, own)


def _has_relief(road: Road) -> bool:
    return any((r.a, r.b, r.c, r.d) != (0.0, 0.0, 0.0, 0.0) for r in (*road.elevation, *road.superelevation))


def _lane_links(document: OpenDriveDocument) -> set[frozenset[LaneEnd]]:
    """Every pair of lane ends the file joins (between lane sections, roads, and through junctions)."""
    roads = document.roads
    pairs: set[frozenset[LaneEnd]] = set()

    def last(road: Road) -> int:
        return len(road.sections) - 1

    for road in roads.values():
        for k, (sec, nxt) in enumerate(zip(road.sections, road.sections[1:])):
            pairs |= {frozenset({(road.id, k, lane.id, "end"), (road.id, k + 1, m, "start")})
                      for lane in sec.lanes for m in lane.successors}
            pairs |= {frozenset({(road.id, k + 1, lane.id, "start"), (road.id, k, m, "end")})
                      for lane in nxt.lanes for m in lane.predecessors}
        for which, link in (("start", road.predecessor), ("end", road.successor)):
            if link is None or link.element_type != "road":
                continue
            other = roads[link.element_id]
            own = 0 if which == "start" else last(road)
            theirs = 0 if link.contact_point == "start" else last(other)
            for lane in road.sections[own].lanes:
                for m in lane.predecessors if which == "start" else lane.successors:
                    pairs.add(frozenset({(road.id, own, lane.id, which), (other.id, theirs, m, link.contact_point)}))
    for junction in document.junctions.values():
        for c in junction.connections:
            incoming, other = roads[c.incoming_road], roads[c.road]
            theirs = 0 if c.contact_point == "start" else last(other)
            for which, link in (("start", incoming.predecessor), ("end", incoming.successor)):
                if link is None or link.element_type != "junction" or link.element_id != junction.id:
                    continue
                own = 0 if which == "start" else last(incoming)
                pairs |= {frozenset({(incoming.id, own, a, which), (other.id, theirs, b, c.contact_point)})
                          for a, b in c.lane_links}
    return pairs


def opendrive_network(path: str | Path) -> OpenDriveNetwork:
    """The lanelet network of the OpenDRIVE file at ``path`` (see the module doc)."""
    document = read_document(path)
    check_roads(document)
    document, dropped = without_broken_links(document)
    drafts: dict[DraftKey, _Draft] = {}
    pieces_in: dict[tuple[str, int], int] = {}                # (road, section) -> number of pieces
    for road in document.roads.values():
        for piece in road_pieces(road):
            pieces_in[(road.id, piece.section)] = piece.index + 1
            section_start = road.sections[piece.section].s
            for lane_id, strip in sorted(lane_strips(road, piece, _drivable).items()):
                if strip.widest < MIN_LANELET_WIDTH:
                    continue
                drafts[(road.id, piece.section, lane_id, piece.index)] = _Draft(
                    road, strip, piece, _forward(road, strip.lane),
                    _border_marks(road, piece.section, strip.lane, piece.s_start - section_start), [], [])
    ids = {key: FIRST_LANELET_ID + k for k, key in enumerate(drafts)}

    def join(a: DraftKey, a_end: str | None, b: DraftKey, b_end: str | None) -> bool:
        """A successor relation where ``a``'s exit meets ``b``'s entry (or the other way round)."""
        for x, x_end, y, y_end in ((a, a_end, b, b_end), (b, b_end, a, a_end)):
            if drafts[x].exit_end() == x_end and drafts[y].exit_end() != y_end:
                drafts[x].successors.append(ids[y])
                drafts[y].predecessors.append(ids[x])
                return True
        return False

    for (road_id, section, lane, index) in drafts:          # the pieces of one lane section, end to end
        if (road_id, section, lane, index + 1) in drafts:
            join((road_id, section, lane, index), "end", (road_id, section, lane, index + 1), "start")

    def lanelet_at(end: LaneEnd) -> DraftKey | None:
        road_id, section, lane, which = end
        index = 0 if which == "start" else pieces_in.get((road_id, section), 0) - 1
        key = (road_id, section, lane, index)
        return key if key in drafts else None

    source = kept = 0
    for pair in _lane_links(document):
        ends = sorted(pair)
        if len(ends) != 2:
            continue
        a, b = (lanelet_at(e) for e in ends)
        if a is None or b is None:
            continue
        source += 1
        kept += join(a, ends[0][3], b, ends[1][3])

    for (road_id, section, lane, index), draft in drafts.items():   # neighbours: lanes side by side
        order = sorted(l.id for l in draft.road.sections[section].lanes)
        k = order.index(lane)
        if k + 1 < len(order) and (higher := drafts.get((road_id, section, order[k + 1], index))) is not None:
            same = draft.forward == higher.forward
            if draft.forward:
                draft.left = (ids[(road_id, section, order[k + 1], index)], same)
            else:
                draft.right = (ids[(road_id, section, order[k + 1], index)], same)
            if higher.forward:
                higher.right = (ids[(road_id, section, lane, index)], same)
            else:
                higher.left = (ids[(road_id, section, lane, index)], same)

    relief = {road.id for road in document.roads.values() if _has_relief(road)}
    lanelets = [draft.lanelet(ids[key]) for key, draft in drafts.items()]
    origin = OpenDriveOrigin(
        source=document.path.name, sha256=hashlib.sha256(document.path.read_bytes()).hexdigest(),
        lanelets={ids[key]: draft.place(draft.road.id in relief) for key, draft in drafts.items()},
        profiles={road.id: RoadProfile(elevation=road.elevation, superelevation=road.superelevation)
                  for road in document.roads.values() if road.id in relief})
    return OpenDriveNetwork(document, LaneletNetwork.create_from_lanelet_list(lanelets),
                            RoadSections({ids[key]: draft.piece.kind for key, draft in drafts.items()}), origin,
                            LinkTally(source, kept), dropped)
