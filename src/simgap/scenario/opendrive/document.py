"""An OpenDRIVE file as typed records: roads (reference line geometry, lane offsets, lane sections
and their lanes, elevation and superelevation, links) and junctions (connections and lane links).

Read with lxml, without resolving entities or reaching the network. What shapes the lanes is read;
what does not (objects, signals, surfaces, speeds, materials, road marks' details, user data) is
passed over; an element that would shape the lanes or the road surface and is not handled (a
geometry other than line, arc, spiral, poly3 and paramPoly3, a lane ``border``, a lateral
``shape`` or ``crossfall``, a single-sided lane section) is refused with an `InputError` naming the
file, the element, its line and what is supported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from lxml import etree
from pydantic import BaseModel, ConfigDict

from simgap.errors import InputError
from simgap.scenario.geometry import MAX_ROAD_LENGTH_M

GeometryKind = Literal["line", "arc", "spiral", "poly3", "paramPoly3"]
ContactPoint = Literal["start", "end"]

# the children each element may have: read ones, and ones passed over (they do not shape the lanes)
_EVERYWHERE = {"userData", "include", "dataQuality"}
_CHILDREN: dict[str, tuple[set[str], set[str]]] = {
    "OpenDRIVE": ({"header", "road", "junction"}, {"controller", "junctionGroup", "station"}),
    "road": ({"link", "type", "planView", "elevationProfile", "lateralProfile", "lanes"},
             {"objects", "signals", "surface", "railroad"}),
    "planView": ({"geometry"}, set()),
    "elevationProfile": ({"elevation"}, set()),
    "lateralProfile": ({"superelevation"}, set()),
    "lanes": ({"laneOffset", "laneSection"}, set()),
    "laneSection": ({"left", "center", "right"}, set()),
    "lane": ({"link", "width", "roadMark"}, {"material", "speed", "access", "height", "rule", "visibility"}),
    "junction": ({"connection"}, {"priority", "controller", "surface", "boundary", "elevationGrid", "crossPath"}),
    "connection": ({"laneLink"}, {"predecessor", "successor"}),
}
_SUPPORTED = {
    "road": "link, type, planView, elevationProfile, lateralProfile, lanes (objects, signals, surface, railroad "
            "are passed over)",
    "lateralProfile": "superelevation",
    "lane": "link, width, roadMark (material, speed, access, height, rule are passed over)",
}
GEOMETRY_KINDS: tuple[GeometryKind, ...] = ("line", "arc", "spiral", "poly3", "paramPoly3")


class Poly3(BaseModel):
    """A cubic ``a + b u + c u^2 + d u^3`` in ``u = s - s_start``, valid from ``s_start`` to the
    next record (OpenDRIVE's elevation, superelevation, lane offset and lane width records)."""

    model_config = ConfigDict(frozen=True, allow_inf_nan=False)
    s: float
    a: float
    b: float = 0.0
    c: float = 0.0
    d: float = 0.0


@dataclass(frozen=True)
class Geometry:
    """One piece of a road's reference line, from station ``s`` for ``length`` metres, starting at
    (``x``, ``y``) heading ``hdg``. ``values``: the shape's own numbers — arc: curvature; spiral:
    curvStart, curvEnd; poly3: a, b, c, d; paramPoly3: aU..dU, aV..dV and 1.0 for a normalised
    parameter range (0.0: arc length)."""

    kind: GeometryKind
    s: float
    x: float
    y: float
    hdg: float
    length: float
    values: tuple[float, ...] = ()
    line: int | None = None                   # where the file states it


@dataclass(frozen=True)
class RoadMark:
    s_offset: float
    type: str


@dataclass(frozen=True)
class Lane:
    """A lane of a lane section. ``type``: OpenDRIVE's (driving, sidewalk, border, ...);
    ``reversed``: it runs against its side's usual direction (OpenDRIVE 1.8's ``direction``)."""

    id: int
    type: str
    widths: tuple[Poly3, ...]                 # s: the offset from the section's start
    predecessors: tuple[int, ...]
    successors: tuple[int, ...]
    marks: tuple[RoadMark, ...]
    reversed: bool = False
    both_ways: bool = False
    line: int | None = None


@dataclass(frozen=True)
class LaneSection:
    s: float
    lanes: tuple[Lane, ...]                   # left and right lanes (the centre lane has no width)
    centre_marks: tuple[RoadMark, ...]


@dataclass(frozen=True)
class RoadLink:
    element_type: Literal["road", "junction"]
    element_id: str
    contact_point: ContactPoint | None


@dataclass(frozen=True)
class Road:
    id: str
    length: float
    junction: str | None                       # the junction a connecting road belongs to
    left_hand_traffic: bool
    road_type: str | None                      # the first <type>: motorway, town, rural, ...
    predecessor: RoadLink | None
    successor: RoadLink | None
    geometries: tuple[Geometry, ...]
    lane_offsets: tuple[Poly3, ...]
    sections: tuple[LaneSection, ...]
    elevation: tuple[Poly3, ...]
    superelevation: tuple[Poly3, ...]
    line: int | None = None


@dataclass(frozen=True)
class Connection:
    """A junction's connection: from ``incoming_road`` into ``road`` (its connecting road, or the
    linked road of a direct junction) at ``road``'s ``contact_point``; lane links (from, to)."""

    incoming_road: str
    road: str
    contact_point: ContactPoint
    lane_links: tuple[tuple[int, int], ...]


@dataclass(frozen=True)
class Junction:
    id: str
    connections: tuple[Connection, ...]


@dataclass(frozen=True)
class OpenDriveDocument:
    path: Path
    roads: dict[str, Road]
    junctions: dict[str, Junction]


class _Reader:
    def __init__(self, path: Path):
        self.path = path

    # ----------------------------------------------------------------- refusals and numbers
    def refuse(self, el: etree._Element, reason: str, allowed: str) -> InputError:
        return InputError(f"<{el.tag}> on line {el.sourceline}: {reason}", file=self.path, field=self.where(el),
                          allowed=allowed)

    @staticmethod
    def where(el: etree._Element) -> str:
        """The element's place: its road or junction and the path below it."""
        parts = []
        for node in [el, *el.iterancestors()]:
            if node.tag in ("road", "junction"):
                parts.append(f"{node.tag} {node.get('id')}")
                break
            parts.append(node.tag)
        return "/".join(reversed(parts))

    def number(self, el: etree._Element, name: str, default: float | None = None) -> float:
        text = el.get(name)
        if text is None:
            if default is None:
                raise self.refuse(el, f"no attribute '{name}'", f"a number in '{name}'")
            return default
        try:
            value = float(text)
        except ValueError:
            raise self.refuse(el, f"'{name}' is '{text}'", "a number") from None
        if not math.isfinite(value):
            raise self.refuse(el, f"'{name}' is {text}", "a finite number")
        return value

    def poly3(self, el: etree._Element, s_name: str = "s") -> Poly3:
        return Poly3(s=self.number(el, s_name, 0.0), a=self.number(el, "a", 0.0), b=self.number(el, "b", 0.0),
                     c=self.number(el, "c", 0.0), d=self.number(el, "d", 0.0))

    def children(self, el: etree._Element) -> list[etree._Element]:
        """``el``'s element children that are read (passed-over ones dropped; any other refused)."""
        read, passed = _CHILDREN[el.tag]
        out = []
        for child in el:
            if not isinstance(child.tag, str):          # comments, processing instructions
                continue
            if child.tag in read:
                out.append(child)
            elif child.tag not in passed and child.tag not in _EVERYWHERE:
                raise self.refuse(child, f"not supported in <{el.tag}>",
                                  _SUPPORTED.get(el.tag, ", ".join(sorted(read))))
        return out

    # ----------------------------------------------------------------- roads
    def road(self, el: etree._Element) -> Road:
        parts: dict[str, list[etree._Element]] = {}
        for child in self.children(el):
            parts.setdefault(child.tag, []).append(child)
        lane_children = self.children(parts["lanes"][0]) if "lanes" in parts else []
        if "planView" not in parts or not any(c.tag == "laneSection" for c in lane_children):
            raise self.refuse(el, "a road needs a planView and lanes in a lane section",
                              "a road with <planView> and <lanes> holding a <laneSection>")
        length = self.number(el, "length")
        if not 0.0 < length <= MAX_ROAD_LENGTH_M:
            raise self.refuse(el, f"length {length:g} m", f"roads longer than 0 m and up to {MAX_ROAD_LENGTH_M:g} m")
        link = parts.get("link", [None])[0]
        junction = el.get("junction", "-1")
        types = parts.get("type", [])
        return Road(
            id=str(el.get("id")), length=length,
            junction=None if junction == "-1" else junction,
            left_hand_traffic=el.get("rule", "RHT") == "LHT",
            road_type=types[0].get("type") if types else None,
            predecessor=self.road_link(link, "predecessor"), successor=self.road_link(link, "successor"),
            geometries=self.geometries(parts["planView"][0]),
            lane_offsets=_in_order(self.poly3(o) for o in lane_children if o.tag == "laneOffset"),
            sections=tuple(self.section(sec) for sec in lane_children if sec.tag == "laneSection"),
            elevation=_in_order(self.poly3(e) for p in parts.get("elevationProfile", []) for e in self.children(p)),
            superelevation=_in_order(self.poly3(e) for p in parts.get("lateralProfile", []) for e in self.children(p)),
            line=el.sourceline)

    def road_link(self, link: etree._Element | None, which: str) -> RoadLink | None:
        el = link.find(which) if link is not None else None
        if el is None:
            return None
        kind = el.get("elementType", "road")
        if kind not in ("road", "junction"):
            raise self.refuse(el, f"elementType '{kind}'", "road or junction")
        contact = el.get("contactPoint")
        if kind == "road" and contact not in ("start", "end"):
            raise self.refuse(el, f"contactPoint '{contact}'", "start or end")
        return RoadLink(kind, str(el.get("elementId")), contact if kind == "road" else None)

    def geometries(self, plan_view: etree._Element) -> tuple[Geometry, ...]:
        out = []
        for g in self.children(plan_view):
            shapes = [c for c in g if isinstance(c.tag, str) and c.tag not in _EVERYWHERE]
            if len(shapes) != 1 or shapes[0].tag not in GEOMETRY_KINDS:
                raise self.refuse(shapes[0] if shapes else g, "a reference line geometry that is not read",
                                  ", ".join(GEOMETRY_KINDS))
            shape = shapes[0]
            kind = shape.tag
            if kind == "line":
                values: tuple[float, ...] = ()
            elif kind == "arc":
                values = (self.number(shape, "curvature"),)
            elif kind == "spiral":
                values = (self.number(shape, "curvStart"), self.number(shape, "curvEnd"))
            elif kind == "poly3":
                values = tuple(self.number(shape, k) for k in "abcd")
            else:
                p_range = shape.get("pRange", "normalized")
                if p_range not in ("normalized", "arcLength"):
                    raise self.refuse(shape, f"pRange '{p_range}'", "normalized or arcLength")
                values = tuple(self.number(shape, f"{k}{axis}") for axis in "UV" for k in "abcd") + \
                    (1.0 if p_range == "normalized" else 0.0,)
            length = self.number(g, "length")
            if length < 0:
                raise self.refuse(g, f"length {length:g}", "a length >= 0 m")
            if length > 0:
                out.append(Geometry(kind, self.number(g, "s"), self.number(g, "x"), self.number(g, "y"),
                                    self.number(g, "hdg"), length, values, g.sourceline))
        if not out:
            raise self.refuse(plan_view, "no geometry of positive length", "one or more <geometry>")
        return tuple(sorted(out, key=lambda g: g.s))

    def section(self, el: etree._Element) -> LaneSection:
        if el.get("singleSide", "false") == "true":
            raise self.refuse(el, "a single-sided lane section", "lane sections for both sides (singleSide false)")
        lanes: list[Lane] = []
        centre_marks: tuple[RoadMark, ...] = ()
        for side in self.children(el):
            for lane in side:
                if not isinstance(lane.tag, str) or lane.tag in _EVERYWHERE:
                    continue
                if lane.tag != "lane":
                    raise self.refuse(lane, f"not supported in <{side.tag}>", "lane")
                if side.tag == "center":
                    centre_marks = self.marks(lane)
                    continue
                read = self.lane(lane)
                if any(other.id == read.id for other in lanes):
                    raise self.refuse(lane, f"lane id {read.id} again in this lane section", "one <lane> per id")
                lanes.append(read)
        return LaneSection(self.number(el, "s"), tuple(lanes), centre_marks)

    def marks(self, lane: etree._Element) -> tuple[RoadMark, ...]:
        return tuple(RoadMark(self.number(m, "sOffset", 0.0), m.get("type", "none"))
                     for m in lane if m.tag == "roadMark")

    def lane(self, el: etree._Element) -> Lane:
        if el.find("border") is not None:
            raise self.refuse(el.find("border"), "lane borders are not read", "lanes given by <width>")
        children = self.children(el)
        link = next((c for c in children if c.tag == "link"), None)
        ids = {which: tuple(int(self.number(x, "id")) for x in (link.findall(which) if link is not None else []))
               for which in ("predecessor", "successor")}
        direction = el.get("direction", "standard")
        return Lane(id=int(self.number(el, "id")), type=el.get("type", "none"),
                    widths=_in_order(self.poly3(w, "sOffset") for w in children if w.tag == "width"),
                    predecessors=ids["predecessor"], successors=ids["successor"], marks=self.marks(el),
                    reversed=direction == "reversed", both_ways=direction == "both", line=el.sourceline)

    # ----------------------------------------------------------------- junctions
    def junction(self, el: etree._Element) -> Junction:
        connections = []
        for c in self.children(el):
            road = c.get("connectingRoad") or c.get("linkedRoad")
            contact = c.get("contactPoint")
            if road is None or contact not in ("start", "end"):
                raise self.refuse(c, "a connection without connectingRoad (or linkedRoad) and a contactPoint",
                                  "incomingRoad, connectingRoad or linkedRoad, contactPoint start or end")
            links = tuple((int(self.number(k, "from")), int(self.number(k, "to"))) for k in self.children(c))
            connections.append(Connection(str(c.get("incomingRoad")), str(road), contact, links))
        return Junction(str(el.get("id")), tuple(connections))


def _in_order(records) -> tuple[Poly3, ...]:
    """Records by station (of equal ones, the last in the file counts: see `piecewise`)."""
    return tuple(sorted(records, key=lambda r: r.s))


def read_document(path: str | Path) -> OpenDriveDocument:
    """The roads and junctions of the OpenDRIVE file at ``path`` (a road or junction id stated
    twice is refused: which of the two the links mean cannot be told)."""
    path = Path(path)
    if not path.is_file():
        raise InputError("no such OpenDRIVE file", file=path, allowed="an .xodr file")
    parser = etree.XMLParser(resolve_entities=False, no_network=True, remove_comments=True)
    try:
        root = etree.fromstring(path.read_bytes(), parser, base_url=str(path))
    except OSError as exc:
        raise InputError(f"cannot be read ({exc.strerror or exc})", file=path, allowed="a readable .xodr file") from None
    except etree.XMLSyntaxError as exc:
        allowed = ("text in the encoding its XML declaration names (UTF-8 without one)" if "encoding" in str(exc)
                   else "an OpenDRIVE (.xodr) file")
        raise InputError(f"not readable as XML ({exc.msg})", file=path, allowed=allowed) from None
    if root.tag != "OpenDRIVE":
        raise InputError(f"the root element is <{root.tag}>", file=path, allowed="<OpenDRIVE>")
    reader = _Reader(path)
    roads: dict[str, Road] = {}
    junctions: dict[str, Junction] = {}
    lines: dict[tuple[str, str], int | None] = {}
    for el in reader.children(root):
        if el.tag not in ("road", "junction"):
            continue
        key = (el.tag, str(el.get("id")))
        if key in lines:
            raise reader.refuse(el, f"{el.tag} id '{key[1]}' again (first on line {lines[key]})",
                                f"one <{el.tag}> per id")
        lines[key] = el.sourceline
        if el.tag == "road":
            road = reader.road(el)
            roads[road.id] = road
        else:
            junction = reader.junction(el)
            junctions[junction.id] = junction
    if not roads:
        raise InputError("no road", file=path, allowed="an OpenDRIVE file with one or more <road>")
    return OpenDriveDocument(path, roads, junctions)


def piecewise(records: tuple[Poly3, ...], s: np.ndarray) -> np.ndarray:
    """The records' cubics at stations ``s``: each station in the record that starts last at or
    before it (0 before the first record, and with no record at all)."""
    s = np.asarray(s, dtype=float)
    if not records:
        return np.zeros_like(s)
    starts = np.array([r.s for r in records])
    coeff = np.array([(r.a, r.b, r.c, r.d) for r in records])
    k = np.searchsorted(starts, s + 1e-9, side="right") - 1
    a, b, c, d = coeff[np.clip(k, 0, None)].T
    u = s - starts[np.clip(k, 0, None)]
    return np.where(k >= 0, a + u * (b + u * (c + u * d)), 0.0)
