"""A lanelet network as OpenDRIVE's topology: roads of laterally adjacent lanelets, the cross-sections
where they meet, and junctions where the lanelets fork or merge.

* **Roads.** Lanelets that are each other's same-direction neighbours and share their common bound
  end to end (within `SHARED_BOUND_M`) form a group, left to right. Two groups whose leftmost
  lanelets are each other's opposite-direction left neighbours and share that bound end to end are
  one road: the group along the road's direction its right lanes, the other its left lanes (their
  lanelets' bounds and centres reversed, so that every road is described left to right along it),
  where their lanes end nearly square to it (`SKEW_M`, `SKEW_SHARE`) or the skew is taken
  (`_skew_taken`: the lanes point the road's way at each end). A malformed lanelet (bounds that
  touch, cross or double back) and its same-direction neighbour are one group also where their
  common bound meets at one end only and lies within `MALFORMED_SHARE_M` elsewhere: their border is
  the well-formed lanelet's bound and the malformed lane lies midway between its borders.
* **Road ends.** A lanelet leaves its road at the road's end when it is a right lane and at its
  start when it is a left lane (and enters it at the other end).
* **Joints.** Where roads meet, one cross-section — a line square to the direction of travel — is
  shared by all of them: each border that ends or begins there is pinned to one offset along it.
  Every road that meets at a joint leaves or enters it with the joint's heading, so linked reference
  lines are continuous in heading (G1) and linked lanes' borders meet without gaps.
* **Links.** Two road ends are linked directly when the lanelets continue one to one (every lanelet
  there with a successor has exactly one, at the other road end, whose one predecessor it is, and
  the lanelets meet within `SEAMLESS_M`). Any other place where lanelets join is a junction: every
  successor relation there becomes a connecting road from the predecessor's road to a cut across
  the successor's road (up to `CONNECTOR_M` into it, at most half of it), whose rest is the road.
  A road end where some lanelet enters the road is cut there, and so is one where the lanelets
  end askew (their bounds more than `ASKEW_M` apart along the road; a road of at least
  `ASKEW_ROAD_M` without a bound that doubles back), by that skew and `ASKEW_MARGIN_M`; a lanelet
  that leaves a cut road end continues on each of its connecting roads from the cut (they stand
  for its last part and the successor's first part). Cuts are placed along the road's axis
  (`Strip.axis`); its reference line follows `Strip.middle` (`reference_bounds`). A connecting road belongs to one junction and joins two ordinary roads,
  as OpenDRIVE requires.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import shapely
from commonroad.scenario.lanelet import Lanelet, LaneletNetwork
from shapely.geometry import LineString

SHARED_BOUND_M = 0.1      # neighbours whose common bound differs by more are separate roads
SEAMLESS_M = 0.1          # lanelets that meet within this are linked directly (else through a junction)
JOINABLE_M = 1.0          # a successor that begins farther than this from its predecessor's end is not joined
CONNECTOR_M = 10.0        # the longest connecting road cut from a successor lanelet
_DIRECTION_M = 2.0        # the stretch of a lanelet's centre that gives its direction at an end
SKEW_M = 2.0              # opposite groups are one road only where their lanes end within this along it,
SKEW_SHARE = 0.25         # ... and within this share of its length (else two roads: one each way), or where
                          # their lanes point the road's way at each end (`_skew_taken`)
SPREAD_DEG = 30.0         # ... and its lanes' directions there lie within this of the road's
PAIRED_REFERENCE_M = 4.0  # a road without left lanes shorter than this has its reference midway between its outermost bounds
ASKEW_M = 0.5             # a junction road end whose bounds end farther apart than this along it is cut back
ASKEW_MARGIN_M = 2.0      # ... by that much and this (the connecting roads take the lanelets' last parts),
ASKEW_ROAD_M = 2.5        # ... where the road is this long (shorter: wedges and stubs, left whole: a 1.6 m
                          # wedge in DEU_Thiergarten-1 and a 1.8 m stub in USA_Intersection-1 got worse cut)
CENTRE_WEIGHT = 10.0      # a lane centre's weight against a border's where borders are placed across a road
MALFORMED_SHARE_M = 4.0   # a malformed lanelet's neighbour within this of it (meeting at one end) is in its group
MIN_WIDTH_M = 1e-3        # a lane's least width at a joint (OpenDRIVE readers treat zero-width lanes apart)

Border = tuple[int, str]  # (lanelet id, "left" | "right")


RoadEnd = tuple[int, str]  # (road index, "start" | "end")


@dataclass
class Joint:
    """A cross-section: the line through ``origin`` square to ``heading``; ``t`` is each border's
    offset along it (to the left of the direction of travel positive)."""

    origin: np.ndarray
    heading: float
    t: dict[Border, float] = field(default_factory=dict)

    @property
    def normal(self) -> np.ndarray:
        return np.array([-math.sin(self.heading), math.cos(self.heading)])

    @property
    def direction(self) -> np.ndarray:
        return np.array([math.cos(self.heading), math.sin(self.heading)])

    def point(self, border: Border) -> np.ndarray:
        return self.origin + self.t[border] * self.normal

    def turned(self) -> Joint:
        """The same cross-section seen from the other way (heading + pi, offsets negated)."""
        return Joint(self.origin, math.remainder(self.heading + math.pi, 2 * math.pi),
                     {b: -t for b, t in self.t.items()})


@dataclass(frozen=True)
class Strip:
    """The lanelets of one road, left to right along it: the first ``left`` run against the road's
    direction (OpenDRIVE's left lanes). ``bounds`` (one more than lanes) and ``centres`` run along
    the road; ``names`` are each bound's borders (lanelet, side in the lanelet's own direction)."""

    lanelets: tuple[int, ...]
    left: int
    bounds: tuple[np.ndarray, ...]
    names: tuple[tuple[Border, ...], ...]
    centres: tuple[np.ndarray, ...]
    lanelet_centres: tuple[np.ndarray, ...] | None = None   # the lanelets' own where ``centres`` differ (`_strip`)

    @property
    def middle(self) -> np.ndarray:
        """The line the road's reference line follows (`reference_bounds`): its centre lane's border
        where it has left lanes, else its middle lane's centre line (an odd number of lanes) or the
        bound between its two middle lanes (an even number)."""
        i, j = self.reference
        if i == j:
            return self.bounds[i]
        return self.centres[i] if j == i + 1 else middle_line(self.bounds[i], self.bounds[j])

    @property
    def reference(self) -> tuple[int, int]:
        """The bounds midway between which the reference line runs: `reference_bounds`, on a road
        shorter than `PAIRED_REFERENCE_M` without left lanes its outermost bounds (the axis: a stub's
        inner bounds may not span it, where its lanelets end askew)."""
        n = len(self.centres)
        if not self.left and LineString(self.axis).length < PAIRED_REFERENCE_M:
            return 0, n
        return reference_bounds(n, self.left)

    @property
    def axis(self) -> np.ndarray:
        """The line along which the road is measured and cut: its centre lane's border where it has
        left lanes, else midway between its outermost bounds."""
        return self.bounds[self.left] if self.left else middle_line(self.bounds[0], self.bounds[-1])


def reference_bounds(lanes: int, left: int) -> tuple[int, int]:
    """The two bounds (indices, left to right) midway between which a road's reference line runs:
    the centre lane's (twice) where it has left lanes, else the middle lane's bounds or, for an even
    number of lanes, the bound between the middle two. Not the outermost bounds: their vertices are
    not paired (they belong to different lanelets), and where one of them flares out the line midway
    at equal fractions of their lengths runs askew and jogs (DEU_AachenUniTemplergraben-1: 0.6 m);
    a lanelet's own centre line pairs its bounds' vertices as the source does."""
    if left:
        return left, left
    return (lanes // 2, lanes // 2) if lanes % 2 == 0 else (lanes // 2, lanes // 2 + 1)


@dataclass(frozen=True)
class RoadPiece:
    """One OpenDRIVE road to write: its lanes (lanelet ids, left to right; the first ``left`` of
    them left lanes) between two joints.

    ``bounds`` are the lanelets' bounds, left to right along the road, ``centres`` their centre
    lines; ``start_borders`` and ``end_borders`` name each bound on the joints; ``span`` is the
    stretch of ``middle`` (default: midway between the outermost bounds) that the road covers,
    from and to [m].
    """

    lanelets: tuple[int, ...]
    bounds: tuple[np.ndarray, ...]
    centres: tuple[np.ndarray, ...]
    start: Joint
    end: Joint
    start_borders: tuple[Border, ...]
    end_borders: tuple[Border, ...]
    span: tuple[float, float]
    junction: int | None = None           # the junction a connecting road belongs to
    left: int = 0
    middle: np.ndarray | None = None
    reference: tuple[int, int] | None = None     # the bounds the reference line runs midway between
                                                 # (default: `reference_bounds`)
    lanelet_centres: tuple[np.ndarray, ...] | None = None   # the deviation is measured from these where set


@dataclass(frozen=True)
class Link:
    """Two road ends joined directly, lanelet by lanelet."""

    ends: tuple[RoadEnd, RoadEnd]
    relations: tuple[tuple[int, int], ...]        # (lanelet, its successor)


@dataclass(frozen=True)
class Connection:
    """A successor relation through a junction: from a lanelet's road end to the connecting road
    (the predecessor's last part where its road end is cut, and the successor's first part), which
    continues into the successor's road."""

    junction: int
    predecessor: int          # lanelet id
    successor: int            # lanelet id
    piece: RoadPiece
    lanelets: tuple[int, ...]  # the lanelets the connecting lane stands for, in driving order
    incoming: RoadEnd
    outgoing: RoadEnd


@dataclass
class Topology:
    """Roads (strips of lanelets, less their cuts), direct links and junctions."""

    strips: list[Strip]
    pieces: list[RoadPiece]                                    # one per strip
    links: list[Link]
    connections: list[Connection]
    junction_ends: dict[RoadEnd, int]                          # road end -> junction
    unjoined: list[tuple[int, int, float]]                     # successor relations too far apart to join
    lane_of: dict[int, tuple[int, int]] = field(default_factory=dict)  # lanelet -> (road index, lane id)


def _direction(xy: np.ndarray, at_end: bool) -> float:
    """The direction along the polyline at its end or its start (over `_DIRECTION_M` of it)."""
    c = xy if at_end else xy[::-1]
    line = LineString(c)
    back = line.interpolate(max(0.0, line.length - _DIRECTION_M)) if line.length > 1e-9 else None
    d = c[-1] - np.array(back.coords[0]) if back is not None else np.zeros(2)
    if np.hypot(*d) < 1e-9:
        d = c[-1] - c[0]
    if not at_end:
        d = -d
    return math.atan2(d[1], d[0])


def _direction_along(line: LineString, at: float) -> float:
    """The direction of ``line`` at ``at`` metres along it (the chord over `_DIRECTION_M` around it)."""
    a = np.array(line.interpolate(max(0.0, at - 0.5 * _DIRECTION_M)).coords[0])
    b = np.array(line.interpolate(min(line.length, at + 0.5 * _DIRECTION_M)).coords[0])
    return math.atan2(*(b - a)[::-1])


def _mean_heading(headings: list[float]) -> float:
    return math.atan2(sum(math.sin(h) for h in headings), sum(math.cos(h) for h in headings))


def _shares_bound(a: np.ndarray, b: np.ndarray) -> bool:
    return (np.linalg.norm(a[0] - b[0]) <= SHARED_BOUND_M and np.linalg.norm(a[-1] - b[-1]) <= SHARED_BOUND_M
            and shapely.hausdorff_distance(LineString(a), LineString(b)) <= SHARED_BOUND_M)


def _malformed(lanelet: Lanelet) -> bool:
    """Whether the lanelet's bounds touch or cross, or one doubles back: it has no faithful lane."""
    return LineString(lanelet.left_vertices).intersects(LineString(lanelet.right_vertices)) or _doubles_back(lanelet)


def _near_malformed(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether a malformed lanelet's bound ``a`` and its neighbour's ``b`` can be one border (the
    neighbour's): they meet at one end and lie within `MALFORMED_SHARE_M` of each other."""
    meet = min(np.linalg.norm(a[0] - b[0]), np.linalg.norm(a[-1] - b[-1])) <= SHARED_BOUND_M
    return bool(meet and shapely.hausdorff_distance(LineString(a), LineString(b)) <= MALFORMED_SHARE_M)


def _border(a: Lanelet, a_bound: np.ndarray, b: Lanelet, b_bound: np.ndarray) -> np.ndarray:
    """The border between neighbours ``a`` and ``b`` (their bounds along the road): ``a``'s, or
    ``b``'s where they do not share it and only ``a`` is malformed (the well-formed lanelet keeps its lane)."""
    if _shares_bound(a_bound, b_bound):
        return a_bound
    return b_bound if _malformed(a) and not _malformed(b) else a_bound


def lateral_groups(network: LaneletNetwork) -> list[tuple[int, ...]]:
    """Chains of same-direction neighbours that share their common bound, left to right (or, where
    one of two is malformed, whose bounds meet at one end and lie near: `_near_malformed`)."""
    by_id = {l.lanelet_id: l for l in network.lanelets}

    def right_of(l: Lanelet) -> int | None:
        r = by_id.get(l.adj_right) if l.adj_right is not None and l.adj_right_same_direction else None
        if r is None or r.adj_left != l.lanelet_id or not r.adj_left_same_direction:
            return None
        if _shares_bound(l.right_vertices, r.left_vertices):
            return r.lanelet_id
        if (_malformed(l) or _malformed(r)) and _near_malformed(l.right_vertices, r.left_vertices):
            return r.lanelet_id
        return None

    right = {i: right_of(l) for i, l in by_id.items()}
    has_left = {r for r in right.values() if r is not None}
    groups, seen = [], set()
    for i in sorted(by_id):
        if i in has_left or i in seen:
            continue
        chain = [i]
        while right[chain[-1]] is not None and right[chain[-1]] not in seen and right[chain[-1]] not in chain:
            chain.append(right[chain[-1]])
        seen.update(chain)
        groups.append(tuple(chain))
    for i in sorted(set(by_id) - seen):           # a ring of neighbours (none in real maps): one road each
        groups.append((i,))
    return groups


def middle_line(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """The line midway between two bounds: both at the same fractions of their length (each
    one's vertices), averaged."""
    def fractions(v: np.ndarray) -> np.ndarray:
        d = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(v, axis=0), axis=1))])
        return d / max(d[-1], 1e-12)

    fl, fr = fractions(left), fractions(right)
    f = np.unique(np.concatenate([fl, fr]))
    at = lambda v, fv: np.column_stack([np.interp(f, fv, v[:, 0]), np.interp(f, fv, v[:, 1])])  # noqa: E731
    return 0.5 * (at(left, fl) + at(right, fr))


class _Slots:
    """Borders that are one line on a joint (union-find), with the points they are seen at."""

    def __init__(self) -> None:
        self.parent: dict[Border, Border] = {}
        self.points: dict[Border, list[np.ndarray]] = defaultdict(list)

    def find(self, b: Border) -> Border:
        self.parent.setdefault(b, b)
        while self.parent[b] != b:
            self.parent[b] = self.parent[self.parent[b]]
            b = self.parent[b]
        return b

    def add(self, b: Border, point: np.ndarray) -> None:
        self.points[self.find(b)].append(point)

    def union(self, a: Border, b: Border) -> None:
        ra, rb = self.find(a), self.find(b)
        if ra != rb:
            self.parent[rb] = ra
            self.points[ra] += self.points.pop(rb, [])

    def joint(self, heading: float) -> Joint:
        roots = {self.find(b) for b in self.parent}
        origin = np.mean([p for r in roots for p in self.points[r]], axis=0)
        joint = Joint(origin, heading)
        t_root = {r: float(np.mean([(p - origin) @ joint.normal for p in self.points[r]])) for r in roots}
        # each lane at least MIN_WIDTH_M wide: sweep the borders from left to right
        ordered = sorted(roots, key=lambda r: -t_root[r])
        for left, right in zip(ordered, ordered[1:]):
            t_root[right] = min(t_root[right], t_root[left] - MIN_WIDTH_M)
        joint.t = {b: t_root[self.find(b)] for b in self.parent}
        return joint


def _opposite(a: Lanelet, by_id: dict[int, Lanelet]) -> Lanelet | None:
    """The opposite-direction left neighbour of ``a`` that has ``a`` as its own and shares the bound."""
    if a.adj_left is None or a.adj_left_same_direction is not False or a.adj_left not in by_id:
        return None
    b = by_id[a.adj_left]
    if b.adj_left != a.lanelet_id or b.adj_left_same_direction is not False:
        return None
    return b if _shares_bound(a.left_vertices, b.left_vertices[::-1]) else None


def _strip(right: list[Lanelet], left: list[Lanelet]) -> Strip:
    """A road of ``right`` lanelets (left to right) and ``left`` lanelets (left to right along the
    road, each against it)."""
    bounds, names, centres = [], [], []
    for k, l in enumerate(left):                  # the farthest left lane first, reversed
        bounds.append(_border(l, l.right_vertices[::-1], left[k - 1], left[k - 1].left_vertices[::-1]) if k
                      else l.right_vertices[::-1])
        names.append(((l.lanelet_id, "right"),) + (((left[k - 1].lanelet_id, "left"),) if k else ()))
        centres.append(l.center_vertices[::-1])
    bounds.append(right[0].left_vertices)
    names.append(((right[0].lanelet_id, "left"),) + (((left[-1].lanelet_id, "left"),) if left else ()))
    for k, l in enumerate(right):
        bounds.append(_border(l, l.right_vertices, right[k + 1], right[k + 1].left_vertices) if k + 1 < len(right)
                      else l.right_vertices)
        names.append(((l.lanelet_id, "right"),) + (((right[k + 1].lanelet_id, "left"),) if k + 1 < len(right) else ()))
        centres.append(l.center_vertices)
    own = tuple(centres)
    for k, l in enumerate(left + right):   # a malformed lane given its neighbour's bound is placed midway between its borders
        if _malformed(l) and not (_same(bounds[k], l, k < len(left), "left") and _same(bounds[k + 1], l, k < len(left), "right")):
            centres[k] = middle_line(bounds[k], bounds[k + 1])
    return Strip(tuple(l.lanelet_id for l in left + right), len(left), tuple(bounds), tuple(names), tuple(centres),
                 own if any(c is not o for c, o in zip(centres, own)) else None)


def _same(bound: np.ndarray, lanelet: Lanelet, against: bool, side: str) -> bool:
    """Whether ``bound`` (along the road) is the lanelet's own bound on its ``side`` along the road
    (within `SHARED_BOUND_M`)."""
    if against:
        own = (lanelet.right_vertices if side == "left" else lanelet.left_vertices)[::-1]
    else:
        own = lanelet.left_vertices if side == "left" else lanelet.right_vertices
    return _shares_bound(bound, own)


def strips(network: LaneletNetwork) -> list[Strip]:
    """The roads' lanelets: lateral groups, two of them one road where they are opposite neighbours."""
    by_id = {l.lanelet_id: l for l in network.lanelets}
    groups = lateral_groups(network)
    first = {g[0]: g for g in groups}
    paired: set[tuple[int, ...]] = set()
    out = []
    for group in groups:
        if group in paired:
            continue
        b = _opposite(by_id[group[0]], by_id)
        other = first.get(b.lanelet_id) if b is not None else None
        if other is None or other in paired or other == group:
            other = ()
        paired.update({group, other})
        right, left = [by_id[i] for i in group], [by_id[i] for i in reversed(other)]
        strip = _strip(right, left)
        if left and not _square(strip) and not _skew_taken(strip):          # two roads (one each way) rather than one askew
            paired.discard(other)
            out.append(_strip(right, []))
            continue
        out.append(strip)
    return out


def _square(strip: Strip) -> bool:
    """Whether the road's lanes end on lines nearly square to it: its bounds' ends lie within
    `SKEW_SHARE` of its length (and `SKEW_M`) of one another along its direction at each end."""
    length = LineString(strip.axis).length
    return all(_skew(strip, end) <= min(SKEW_M, SKEW_SHARE * length) for end in ("start", "end"))


def _skew_taken(strip: Strip) -> bool:
    """Whether a road of opposite groups whose lanes end askew can still be one road: at each end its
    lanes point the road's way (within `SPREAD_DEG`: a 0.3 m strip of DEU_Thiergarten-1 whose lanes
    turn 54 degrees has no one cross-section there). Where lanelets continue, a direct link's joint
    or a junction's cut back road end (`ASKEW_M`) takes the skew: the 7-lane 3.9 m crossing strip in
    DEU_AachenAseag-1 whose 4.5 m skew gave QC gap errors before junction ends were cut back is QC
    clean as one road now. An open end (no lanelet continues) has no link whose lanes could part:
    its skew only moves the lanes' ends off the lanelets' (CHN_Roundabout-1's 16.5 m road 111|109,
    12 m askew: 0.52 m there, kept as one road)."""
    for end in ("start", "end"):
        heading = _heading_at(strip, end)
        if any(abs(math.remainder(_direction(c, end == "end") - heading, 2 * math.pi)) > math.radians(SPREAD_DEG)
               for c in strip.centres):
            return False
    return True


def _doubles_back(lanelet: Lanelet) -> bool:
    """Whether a bound of the lanelet turns by more than 90 degrees between two segments (it has no
    direction to cut it along)."""
    for bound in (lanelet.left_vertices, lanelet.right_vertices):
        d = np.diff(bound, axis=0)
        d = d[np.linalg.norm(d, axis=1) > 1e-6]
        h = np.arctan2(d[:, 1], d[:, 0])
        if len(h) > 1 and np.max(np.abs(np.angle(np.exp(1j * np.diff(h))))) > math.pi / 2:
            return True
    return False


def _skew(strip: Strip, end: str) -> float:
    """How far apart the road's bounds end along its direction there [m] (0: square)."""
    heading = _heading_at(strip, end)
    d = np.array([math.cos(heading), math.sin(heading)])
    along = [float((b[-1] if end == "end" else b[0]) @ d) for b in strip.bounds]
    return max(along) - min(along)


def _road_end_slots(slots: _Slots, strip: Strip, end: str) -> None:
    for bound, names in zip(strip.bounds, strip.names):
        for name in names:
            slots.add(name, bound[-1] if end == "end" else bound[0])
            slots.union(names[0], name)


def _heading_at(strip: Strip, end: str) -> float:
    """The road's direction at its start or end: the mean of its lanes' centres' directions."""
    return _mean_heading([_direction(c, end == "end") for c in strip.centres])


def _place_joint(ends: list[tuple[Strip, str]], pairs: Sequence[tuple[int, int]] = ()) -> Joint:
    """The joint of road ends (strip, "start" | "end"), with the borders of linked lanelets
    (predecessor, successor) made one; its heading that of the first road end's road there."""
    slots = _Slots()
    for strip, end in ends:
        _road_end_slots(slots, strip, end)
    for a, b in pairs:
        slots.union((a, "left"), (b, "left"))
        slots.union((a, "right"), (b, "right"))
    first = ends[0][1]
    headings = [_heading_at(strip, end) + (math.pi if k and end == first else 0.0)
                for k, (strip, end) in enumerate(ends)]
    return slots.joint(_mean_heading(headings))


def _cut(strip: Strip, end: str, length: float) -> Joint:
    """A joint across a road ``length`` metres along its axis from its start or end."""
    middle = LineString(strip.axis)
    at = length if end == "start" else middle.length - length
    p = np.array(middle.interpolate(at).coords[0])
    a = np.array(middle.interpolate(max(0.0, at - 1.0)).coords[0])
    b = np.array(middle.interpolate(min(middle.length, at + 1.0)).coords[0])
    joint = Joint(p, math.atan2(*(b - a)[::-1]))
    reach = 4.0 * float(np.max(np.linalg.norm(strip.bounds[0][[0, -1]] - strip.bounds[-1][[0, -1]], axis=1))) + \
        4.0 * sum(float(np.max(np.linalg.norm(l - r, axis=1))) if len(l) == len(r) else 0.0
                  for l, r in zip(strip.bounds, strip.bounds[1:])) + 5
    across = LineString([p + reach * joint.normal, p - reach * joint.normal])

    def offset(vertices: np.ndarray) -> float:
        line = LineString(vertices)
        hit = shapely.get_coordinates(across.intersection(line))
        q = hit[np.argmin(np.linalg.norm(hit - p, axis=1))] if len(hit) else \
            np.array(line.interpolate(line.project(shapely.Point(p))).coords[0])
        return float((q - p) @ joint.normal)

    t = centred(np.array([[offset(b)] for b in strip.bounds]), np.array([[offset(c)] for c in strip.centres]))[:, 0]
    slots = _Slots()
    for value, names in zip(t, strip.names):
        for name in names:
            slots.add(name, p + value * joint.normal)
            slots.union(names[0], name)
    return slots.joint(joint.heading)          # its origin: the borders' mean, on the same line


def centred(bounds: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """Border offsets (n + 1, m) that put each lane's centre on its lanelet's centre line: the least
    squares fit of every lane's middle to its centre (weighted `CENTRE_WEIGHT`) and of every border
    to its bound. ``bounds`` (n + 1, m) and ``centres`` (n, m): offsets along the same normals."""
    n = len(centres)
    rows = np.zeros((2 * n + 1, n + 1))
    for k in range(n):
        rows[k, k] = rows[k, k + 1] = 0.5 * CENTRE_WEIGHT
    rows[n:, :] = np.eye(n + 1)
    return np.linalg.pinv(rows) @ np.vstack([CENTRE_WEIGHT * centres, bounds])


def _gap(a: Lanelet, b: Lanelet) -> float:
    """How far lanelet ``b`` begins from where ``a`` ends (the larger of the two bounds' gaps)."""
    return float(max(np.linalg.norm(a.left_vertices[-1] - b.left_vertices[0]),
                     np.linalg.norm(a.right_vertices[-1] - b.right_vertices[0])))


def _is_direct(relations: list[tuple[int, int]], gaps: dict[tuple[int, int], float]) -> bool:
    """Relations between two road ends that continue lane by lane."""
    successors, predecessors = defaultdict(set), defaultdict(set)
    for a, b in relations:
        successors[a].add(b)
        predecessors[b].add(a)
    if any(len(v) > 1 for v in (*successors.values(), *predecessors.values())):
        return False
    return all(gaps[r] <= SEAMLESS_M for r in relations)


def _towards(joint: Joint, heading: float) -> Joint:
    """``joint`` seen in the direction ``heading`` (turned when it faces the other way)."""
    return joint if math.cos(joint.heading - heading) >= 0 else joint.turned()


def topology(network: LaneletNetwork) -> Topology:
    """The roads, joints, links and junctions of ``network`` (see the module's description)."""
    by_id = {l.lanelet_id: l for l in network.lanelets}
    roads = strips(network)
    road_of = {i: r for r, strip in enumerate(roads) for i in strip.lanelets}
    lane_of = {}
    for r, strip in enumerate(roads):
        for k, i in enumerate(strip.lanelets):
            lane_of[i] = (r, strip.left - k if k < strip.left else -(k - strip.left + 1))

    def leaves(i: int) -> RoadEnd:          # where lanelet i leaves its road
        return road_of[i], "end" if lane_of[i][1] < 0 else "start"

    def enters(i: int) -> RoadEnd:
        return road_of[i], "start" if lane_of[i][1] < 0 else "end"

    relations: list[tuple[int, int]] = []
    unjoined: list[tuple[int, int]] = []
    gaps: dict[tuple[int, int], float] = {}
    for a in sorted(by_id):
        for b in by_id[a].successor or []:
            if b not in by_id:
                continue
            gaps[(a, b)] = _gap(by_id[a], by_id[b])
            (relations if gaps[(a, b)] <= JOINABLE_M else unjoined).append((a, b))
    # where roads meet: road ends joined by relations, each connected set one place
    place: dict[RoadEnd, RoadEnd] = {}

    def root(n: RoadEnd) -> RoadEnd:
        place.setdefault(n, n)
        while place[n] != n:
            place[n] = place[place[n]]
            n = place[n]
        return n

    for a, b in relations:
        ra, rb = root(leaves(a)), root(enters(b))
        if ra != rb:
            place[rb] = ra
    at_place: dict[RoadEnd, list[tuple[int, int]]] = defaultdict(list)
    for a, b in relations:
        at_place[root(leaves(a))].append((a, b))
    joints: dict[RoadEnd, Joint] = {}
    links, connections = [], []
    junction_ends: dict[RoadEnd, int] = {}
    cut_at: dict[RoadEnd, float] = {}
    junction_relations = []
    for _, rels in sorted(at_place.items()):
        ends = sorted({leaves(a) for a, _ in rels} | {enters(b) for _, b in rels})
        if len(ends) == 2 and ends[0][0] != ends[1][0] and _is_direct(rels, gaps):
            joint = _place_joint([(roads[r], e) for r, e in ends], rels)
            for r, e in ends:
                joints[(r, e)] = _towards(joint, _heading_at(roads[r], e))
            links.append(Link((ends[0], ends[1]), tuple(rels)))
            continue
        junction = len(set(junction_ends.values())) + 1
        entering = {enters(b) for _, b in rels}
        for r, e in ends:
            if (r, e) in entering:
                cut_at[(r, e)] = CONNECTOR_M
            elif _skew(roads[r], e) > ASKEW_M and LineString(roads[r].axis).length >= ASKEW_ROAD_M and \
                    not any(_doubles_back(by_id[i]) for i in roads[r].lanelets):
                # its lanelets end askew: the connecting roads take their last part (a square joint
                # there would cut some short and run others on, off their successors' centre lines)
                cut_at[(r, e)] = _skew(roads[r], e) + ASKEW_MARGIN_M
            else:
                joints[(r, e)] = _place_joint([(roads[r], e)])
            junction_ends[(r, e)] = junction
        junction_relations += [(junction, a, b) for a, b in rels]
    for r, e in sorted(cut_at):                # cut at most half a road, a third where both ends are cut
        length = LineString(roads[r].axis).length
        share = 1 / 3 if (r, "start") in cut_at and (r, "end") in cut_at else 0.5
        cut_at[(r, e)] = min(cut_at[(r, e)], share * length)
        joints[(r, e)] = _cut(roads[r], e, cut_at[(r, e)])
    pieces = []
    for r, strip in enumerate(roads):
        for e in ("start", "end"):
            if (r, e) not in joints:
                joints[(r, e)] = _place_joint([(strip, e)])
        borders = tuple(names[0] for names in strip.names)
        middle = LineString(strip.middle)
        span = [0.0, middle.length]          # the stretch of the middle line between the joints
        for k, e in enumerate(("start", "end")):
            if (r, e) in cut_at:
                i, j = strip.reference
                joint = joints[(r, e)]
                span[k] = middle.project(shapely.Point(joint.origin + 0.5 * (joint.t[borders[i]] + joint.t[borders[j]])
                                                       * joint.normal))
        pieces.append(RoadPiece(strip.lanelets, strip.bounds, strip.centres, joints[(r, "start")],
                                joints[(r, "end")], borders, borders, (span[0], span[1]),
                                left=strip.left, middle=strip.middle, reference=strip.reference,
                                lanelet_centres=strip.lanelet_centres))
    for junction, a, b in junction_relations:
        pa, pb = by_id[a], by_id[b]
        start, end = joints[leaves(a)], joints[enters(b)]
        middle_a = middle_line(pa.left_vertices, pa.right_vertices)
        middle_b = middle_line(pb.left_vertices, pb.right_vertices)
        line_a, line_b = LineString(middle_a), LineString(middle_b)
        from_a = line_a.project(shapely.Point(0.5 * (start.point((a, "left")) + start.point((a, "right")))))
        tail = leaves(a) in cut_at
        if not tail:
            from_a = line_a.length
        to_b = line_b.project(shapely.Point(0.5 * (end.point((b, "left")) + end.point((b, "right")))))
        # each joint faces the way of travel where the connecting road meets it: at a cut that is the
        # lanelet's direction there, not at its end (a lanelet that turns before the cut: a joint
        # turned the wrong way put the lane's left border on its right)
        start = _towards(start, _direction_along(line_a, from_a) if tail else _direction(pa.center_vertices, True))
        end = _towards(end, _direction_along(line_b, to_b) if to_b > _DIRECTION_M else
                       _direction(pb.center_vertices, False))
        piece = RoadPiece((b,), (np.vstack([pa.left_vertices, pb.left_vertices]),
                                 np.vstack([pa.right_vertices, pb.right_vertices])),
                          (np.vstack([pa.center_vertices, pb.center_vertices]),),
                          start, end, ((a, "left"), (a, "right")), ((b, "left"), (b, "right")),
                          (from_a, line_a.length + to_b), junction, middle=np.vstack([middle_a, middle_b]))
        # the connecting lane stands for the predecessor's end too where its road end is not cut: a road
        # ends on a joint square to it, and where its lanelets end askew, a lanelet's last part lies past
        # the joint (DEU_AachenAseag-1: 0.8 m of lanelet 216, whose successor 245 turns 29 degrees)
        connections.append(Connection(junction, a, b, piece, (a, b), leaves(a), enters(b)))
    return Topology(roads, pieces, links, connections, junction_ends,
                    [(a, b, gaps[(a, b)]) for a, b in unjoined], lane_of)
