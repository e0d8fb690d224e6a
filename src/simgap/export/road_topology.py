"""A lanelet network as OpenDRIVE's topology: roads of laterally adjacent lanelets, the cross-sections
where they meet, and junctions where the lanelets fork or merge.

* **Roads.** Lanelets that are each other's same-direction neighbours and share their common bound
  end to end (within `SHARED_BOUND_M`) form one road: its lanes, left to right, in one lane section.
* **Joints.** Where roads meet, one cross-section — a line square to the direction of travel — is
  shared by all of them: each border that ends or begins there is pinned to one offset along it.
  Every road that meets at a joint leaves or enters it with the joint's heading, so linked reference
  lines are continuous in heading (G1) and linked lanes' borders meet without gaps.
* **Links.** Road A's end and road B's start are linked directly when the lanelets continue one to
  one (every lanelet of A with a successor has exactly one, in B, whose one predecessor it is, in
  the same left-to-right order, and the lanelets meet within `SEAMLESS_M`). Any other place where
  lanelets join is a junction: every successor relation there becomes a connecting road, the first
  part of the successor lanelet (up to `CONNECTOR_M`, at most half of it), from the end of the
  predecessor's road to a cut across the successor's road, whose rest is a road of its own. A
  connecting road belongs to one junction and joins two ordinary roads, as OpenDRIVE requires.
  A lanelet that begins at such a place without a predecessor loses the part before the cut.
"""

from __future__ import annotations

import math
from collections import defaultdict
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
MIN_WIDTH_M = 1e-3        # a lane's least width at a joint (OpenDRIVE readers treat zero-width lanes apart)

Border = tuple[int, str]  # (lanelet id, "left" | "right")


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


@dataclass(frozen=True)
class RoadPiece:
    """One OpenDRIVE road to write: its lanes (lanelet ids, left to right) between two joints.

    ``bounds`` are the lanelets' bounds, left to right (the left bound of the first lane, then
    each lane's right bound), ``centres`` their centre lines; ``start_borders`` and ``end_borders``
    name each bound on the joints; ``span`` is the stretch of the lanelets' middle line (midway
    between the outermost bounds) that the road covers, from and to [m].
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


@dataclass(frozen=True)
class Link:
    """The end of one road joined directly to the start of another, lanelet by lanelet."""

    predecessor: int                              # group
    successor: int                                # group
    relations: tuple[tuple[int, int], ...]        # (lanelet, its successor)


@dataclass(frozen=True)
class Connection:
    """A successor relation through a junction: from a lanelet's road to the connecting road cut
    from its successor, which continues into the successor's road."""

    junction: int
    predecessor: int          # lanelet id
    successor: int            # lanelet id
    piece: RoadPiece


@dataclass
class Topology:
    """Roads (lateral groups of lanelets, and their rests after a cut), direct links and junctions."""

    groups: list[tuple[int, ...]]                              # lanelet ids, left to right
    pieces: list[RoadPiece]                                    # one per group, in the order of groups
    links: list[Link]
    connections: list[Connection]
    junction_ends: dict[tuple[int, str], int]                  # (group, "start" | "end") -> junction
    unjoined: list[tuple[int, int, float]]                     # successor relations too far apart to join
    neighbours: list[tuple[int, int]] = field(default_factory=list)    # (lanelet, right neighbour) in one road


def _direction(lanelet: Lanelet, at_end: bool) -> float:
    """The lanelet's direction of travel at its start or end (over `_DIRECTION_M` of its centre)."""
    c = lanelet.center_vertices if at_end else lanelet.center_vertices[::-1]
    line = LineString(c)
    back = line.interpolate(max(0.0, line.length - _DIRECTION_M)) if line.length > 1e-9 else None
    d = c[-1] - np.array(back.coords[0]) if back is not None else np.zeros(2)
    if np.hypot(*d) < 1e-9:
        d = c[-1] - c[0]
    if not at_end:
        d = -d
    return math.atan2(d[1], d[0])


def _mean_heading(headings: list[float]) -> float:
    return math.atan2(sum(math.sin(h) for h in headings), sum(math.cos(h) for h in headings))


def _shares_bound(a: np.ndarray, b: np.ndarray) -> bool:
    return (np.linalg.norm(a[0] - b[0]) <= SHARED_BOUND_M and np.linalg.norm(a[-1] - b[-1]) <= SHARED_BOUND_M
            and shapely.hausdorff_distance(LineString(a), LineString(b)) <= SHARED_BOUND_M)


def lateral_groups(network: LaneletNetwork) -> list[tuple[int, ...]]:
    """Chains of same-direction neighbours that share their common bound, left to right."""
    by_id = {l.lanelet_id: l for l in network.lanelets}

    def right_of(l: Lanelet) -> int | None:
        r = by_id.get(l.adj_right) if l.adj_right is not None and l.adj_right_same_direction else None
        if r is None or r.adj_left != l.lanelet_id or not r.adj_left_same_direction:
            return None
        return r.lanelet_id if _shares_bound(l.right_vertices, r.left_vertices) else None

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


def _bounds(lanelets: list[Lanelet]) -> tuple[np.ndarray, ...]:
    return (lanelets[0].left_vertices,) + tuple(l.right_vertices for l in lanelets)


def _borders(group: tuple[int, ...]) -> tuple[Border, ...]:
    return ((group[0], "left"),) + tuple((i, "right") for i in group)


def _vertex(lanelet: Lanelet, side: str, at_end: bool) -> np.ndarray:
    v = lanelet.left_vertices if side == "left" else lanelet.right_vertices
    return v[-1] if at_end else v[0]


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


def _group_slots(slots: _Slots, lanelets: list[Lanelet], at_end: bool) -> None:
    for k, lanelet in enumerate(lanelets):
        for side in ("left", "right"):
            slots.add((lanelet.lanelet_id, side), _vertex(lanelet, side, at_end))
        if k:
            slots.union((lanelets[k - 1].lanelet_id, "right"), (lanelet.lanelet_id, "left"))


def _end_joint(ends: list[tuple[list[Lanelet], bool]], pairs: list[tuple[int, int]] = ()) -> Joint:
    """The joint of groups' ends (lanelets, at_end), with the borders of linked lanelets
    (predecessor, successor) made one."""
    slots = _Slots()
    for lanelets, at_end in ends:
        _group_slots(slots, lanelets, at_end)
    for a, b in pairs:
        slots.union((a, "left"), (b, "left"))
        slots.union((a, "right"), (b, "right"))
    return slots.joint(_mean_heading([_direction(l, at_end) for lanelets, at_end in ends for l in lanelets]))


def _cut(lanelets: list[Lanelet], length: float) -> Joint:
    """A joint across a group ``length`` metres along its middle line from its start."""
    middle = LineString(middle_line(lanelets[0].left_vertices, lanelets[-1].right_vertices))
    p = np.array(middle.interpolate(length).coords[0])
    a = np.array(middle.interpolate(max(0.0, length - 1.0)).coords[0])
    b = np.array(middle.interpolate(min(middle.length, length + 1.0)).coords[0])
    joint = Joint(p, math.atan2(*(b - a)[::-1]))
    reach = 4.0 * sum(float(np.max(np.linalg.norm(l.left_vertices - l.right_vertices, axis=1))) for l in lanelets) + 5
    across = LineString([p + reach * joint.normal, p - reach * joint.normal])
    slots = _Slots()
    for lanelet in lanelets:
        for side in ("left", "right"):
            bound = LineString(lanelet.left_vertices if side == "left" else lanelet.right_vertices)
            hit = shapely.get_coordinates(across.intersection(bound))
            q = hit[np.argmin(np.linalg.norm(hit - p, axis=1))] if len(hit) else \
                np.array(bound.interpolate(bound.project(shapely.Point(p))).coords[0])
            slots.add((lanelet.lanelet_id, side), q - ((q - p) @ joint.direction) * joint.direction)
    for k in range(1, len(lanelets)):
        slots.union((lanelets[k - 1].lanelet_id, "right"), (lanelets[k].lanelet_id, "left"))
    return slots.joint(joint.heading)          # its origin: the borders' mean, on the same line


def _gap(a: Lanelet, b: Lanelet) -> float:
    """How far lanelet ``b`` begins from where ``a`` ends (the larger of the two bounds' gaps)."""
    return float(max(np.linalg.norm(a.left_vertices[-1] - b.left_vertices[0]),
                     np.linalg.norm(a.right_vertices[-1] - b.right_vertices[0])))


def _is_direct(relations: list[tuple[int, int]], lanes: dict[int, int], gaps: dict[tuple[int, int], float]) -> bool:
    """Relations between one road's end and another's start that continue lane by lane, in order."""
    successors, predecessors = defaultdict(set), defaultdict(set)
    for a, b in relations:
        successors[a].add(b)
        predecessors[b].add(a)
    if any(len(v) > 1 for v in (*successors.values(), *predecessors.values())):
        return False
    if any(gaps[r] > SEAMLESS_M for r in relations):
        return False
    order = sorted(relations, key=lambda r: lanes[r[0]])
    return all(lanes[p[1]] < lanes[q[1]] for p, q in zip(order, order[1:]))


def topology(network: LaneletNetwork) -> Topology:
    """The roads, joints, links and junctions of ``network`` (see the module's description)."""
    by_id = {l.lanelet_id: l for l in network.lanelets}
    groups = lateral_groups(network)
    group_of = {i: g for g, lanelets in enumerate(groups) for i in lanelets}
    lane_index = {i: k for lanelets in groups for k, i in enumerate(lanelets)}
    members = [[by_id[i] for i in lanelets] for lanelets in groups]
    relations, unjoined, gaps = [], [], {}
    for a in sorted(by_id):
        for b in by_id[a].successor or []:
            if b not in by_id:
                continue
            gaps[(a, b)] = _gap(by_id[a], by_id[b])
            (relations if gaps[(a, b)] <= JOINABLE_M else unjoined).append((a, b))
    # where roads meet: ends and starts joined by relations, each connected set one place
    place: dict[tuple[int, str], tuple[int, str]] = {}

    def root(n: tuple[int, str]) -> tuple[int, str]:
        place.setdefault(n, n)
        while place[n] != n:
            place[n] = place[place[n]]
            n = place[n]
        return n

    for a, b in relations:
        ra, rb = root((group_of[a], "end")), root((group_of[b], "start"))
        if ra != rb:
            place[rb] = ra
    at_place: dict[tuple[int, str], list[tuple[int, int]]] = defaultdict(list)
    for a, b in relations:
        at_place[root((group_of[a], "end"))].append((a, b))
    joints: dict[tuple[int, str], Joint] = {}
    links, connections, junction_ends, cut_at = [], [], {}, {}
    junction_relations = []
    for key, rels in sorted(at_place.items()):
        ends = sorted({group_of[a] for a, _ in rels})
        starts = sorted({group_of[b] for _, b in rels})
        if len(ends) == 1 and len(starts) == 1 and _is_direct(rels, lane_index, gaps):
            a, b = ends[0], starts[0]
            joint = _end_joint([(members[a], True), (members[b], False)], rels)
            joints[(a, "end")] = joints[(b, "start")] = joint
            links.append(Link(a, b, tuple(rels)))
            continue
        junction = len({j for j in junction_ends.values()}) + 1
        for g in ends:
            joints[(g, "end")] = _end_joint([(members[g], True)])
            junction_ends[(g, "end")] = junction
        for g in starts:
            length = LineString(middle_line(members[g][0].left_vertices, members[g][-1].right_vertices)).length
            cut_at[g] = min(CONNECTOR_M, 0.5 * length)
            joints[(g, "start")] = _cut(members[g], cut_at[g])
            junction_ends[(g, "start")] = junction
        junction_relations += [(junction, a, b) for a, b in rels]
    pieces = []
    for g, lanelets in enumerate(members):
        for end, at_end in (("start", False), ("end", True)):
            if (g, end) not in joints:
                joints[(g, end)] = _end_joint([(lanelets, at_end)])
        borders = _borders(groups[g])
        length = LineString(middle_line(lanelets[0].left_vertices, lanelets[-1].right_vertices)).length
        pieces.append(RoadPiece(groups[g], _bounds(lanelets), tuple(l.center_vertices for l in lanelets),
                                joints[(g, "start")], joints[(g, "end")], borders, borders,
                                (cut_at.get(g, 0.0), length)))
    for junction, a, b in junction_relations:
        lanelet, cut = by_id[b], joints[(group_of[b], "start")]
        # the cut on the lanelet's own middle line (the group's may run elsewhere)
        middle = LineString(middle_line(lanelet.left_vertices, lanelet.right_vertices))
        at_cut = shapely.Point(0.5 * (cut.point((b, "left")) + cut.point((b, "right"))))
        piece = RoadPiece((b,), (lanelet.left_vertices, lanelet.right_vertices), (lanelet.center_vertices,),
                          joints[(group_of[a], "end")], cut, ((a, "left"), (a, "right")), ((b, "left"), (b, "right")),
                          (0.0, middle.project(at_cut)), junction)
        connections.append(Connection(junction, a, b, piece))
    neighbours = [(l, r) for lanelets in groups for l, r in zip(lanelets, lanelets[1:])]
    return Topology(groups, pieces, links, connections, junction_ends,
                    [(a, b, gaps[(a, b)]) for a, b in unjoined], neighbours)
