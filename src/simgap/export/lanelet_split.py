"""Lanelets cut where their neighbours begin and end, so that neighbours of different lengths can be
lanes of one road.

`simgap.export.road_topology` makes one road of neighbours whose common bound they share end to
end. Where a neighbour begins or ends inside a lanelet (adjacent lanes split at different places,
as round a roundabout), the two would be separate roads and the file would lose their neighbour
relation. Here every lanelet is cut where a neighbour's shared bound begins or ends on its own
(within `road_topology.SHARED_BOUND_M` of it and at least `MIN_PIECE_M` from its ends), across the
lanelet's own cross-section there (its bounds' vertices are paired, as in the source), until no
more cuts arise. The pieces follow one another (successors), the first takes the lanelet's
predecessors and the last its successors, and two pieces are neighbours where their lanelets are
each other's neighbours and the pieces share the bound end to end. ``origin`` maps a piece back
to its lanelet: the file's lanes stand for the source's lanelets.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from commonroad.scenario.lanelet import Lanelet
from shapely.geometry import LineString

from simgap.export.road_topology import SHARED_BOUND_M, _shares_bound

MIN_PIECE_M = 1.0        # no piece shorter than this along the shared bound (ends this close are left as they are)
_SAMPLE_M = 0.25         # a neighbour's bound is followed at this spacing
_TOUCH_M = 0.05          # ... and is on ours where within this of it
_ROUNDS = 6              # cuts made round after round until none arises (a cut may cause one next door)


@dataclass
class Split:
    """The network's lanelets with their pieces (``lanelets``) and each piece's lanelet."""

    lanelets: list[Lanelet]
    origin: dict[int, int]            # piece id -> the source lanelet's id

    def find_lanelet_by_id(self, i: int) -> Lanelet | None:
        return self._by_id.get(i)

    def __post_init__(self) -> None:
        self._by_id = {l.lanelet_id: l for l in self.lanelets}


@dataclass
class _Piece:
    source: int
    left: np.ndarray
    right: np.ndarray
    centre: np.ndarray


def _cut(piece: _Piece, side: str, at: float) -> tuple[_Piece, _Piece]:
    """The piece cut across its cross-section where ``at`` metres along its ``side`` bound falls."""
    bound = piece.left if side == "left" else piece.right
    d = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(bound, axis=0), axis=1))])
    i = int(np.clip(np.searchsorted(d, at, side="right") - 1, 0, len(d) - 2))
    f = (at - d[i]) / max(d[i + 1] - d[i], 1e-12)

    def parts(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p = v[i] + f * (v[i + 1] - v[i])
        return np.vstack([v[:i + 1], p]), np.vstack([p, v[i + 1:]])

    (l0, l1), (r0, r1), (c0, c1) = parts(piece.left), parts(piece.right), parts(piece.centre)
    return _Piece(piece.source, l0, r0, c0), _Piece(piece.source, l1, r1, c1)


def _cuts(piece: _Piece, side: str, other: np.ndarray) -> list[float]:
    """Where ``other`` (a neighbour's bound) begins or ends on the piece's ``side`` bound, or leaves
    it or joins it (lanes that diverge or merge), inside it: metres along the bound."""
    bound = LineString(piece.left if side == "left" else piece.right)
    line = LineString(other)
    if line.length < 1e-9:
        return []
    stations = np.linspace(0.0, line.length, max(2, int(line.length / _SAMPLE_M) + 1))
    points = shapely.line_interpolate_point(line, stations)
    near = shapely.distance(bound, points) <= _TOUCH_M
    at = []
    if near[0] and shapely.distance(bound, points[0]) <= SHARED_BOUND_M:
        at.append(points[0])
    if near[-1]:
        at.append(points[-1])
    for k in np.flatnonzero(near[1:] != near[:-1]):     # it leaves our bound or joins it
        at.append(points[k] if near[k] else points[k + 1])
    out = []
    for p in at:
        s = bound.project(p)
        if MIN_PIECE_M <= s <= bound.length - MIN_PIECE_M:
            out.append(float(s))
    return out


def _facing(lanelet: Lanelet, side: str) -> tuple[int | None, bool | None]:
    if side == "left":
        return lanelet.adj_left, lanelet.adj_left_same_direction
    return lanelet.adj_right, lanelet.adj_right_same_direction


def _their_bound(piece: _Piece, same: bool, side: str) -> np.ndarray:
    """The bound of a neighbour's piece that meets ours on our ``side``, in our direction."""
    if same:
        return piece.right if side == "left" else piece.left
    return (piece.left if side == "left" else piece.right)[::-1]


def split(lanelets: list[Lanelet]) -> Split:
    """The lanelets cut where their neighbours begin and end (see the module's description)."""
    by_id = {l.lanelet_id: l for l in lanelets}

    def mutual(l: Lanelet, side: str) -> tuple[int, bool] | None:
        other, same = _facing(l, side)
        if other is None or other not in by_id:
            return None
        o = by_id[other]
        back = "right" if (side == "left") == bool(same) else "left"
        return (other, bool(same)) if _facing(o, back)[0] == l.lanelet_id else None

    pieces = {l.lanelet_id: [_Piece(l.lanelet_id, l.left_vertices, l.right_vertices, l.center_vertices)]
              for l in lanelets}
    neighbours = {(i, side): mutual(l, side) for i, l in by_id.items() for side in ("left", "right")}
    for _ in range(_ROUNDS):
        changed = False
        for (i, side), rel in neighbours.items():
            if rel is None:
                continue
            other, same = rel
            out = []
            for piece in pieces[i]:
                ats = sorted({round(a, 3) for q in pieces[other]
                              for a in _cuts(piece, side, _their_bound(q, same, side))})
                done = 0.0
                for at in ats:
                    if at - done < MIN_PIECE_M:
                        continue
                    first, piece = _cut(piece, side, at - done)
                    out.append(first)
                    done = at
                    changed = True
                out.append(piece)
            pieces[i] = out
        if not changed:
            break
    # a set of neighbours is cut only where that makes more of them share a bound end to end (cuts
    # spread across a road; where they gain nothing they only shorten its roads)
    cluster = {i: i for i in by_id}

    def root(i: int) -> int:
        while cluster[i] != i:
            cluster[i] = cluster[cluster[i]]
            i = cluster[i]
        return i

    for (i, _), rel in neighbours.items():
        if rel is not None:
            cluster[root(rel[0])] = root(i)

    def shared(i: int, side: str, rel: tuple[int, bool], cut: bool) -> bool:
        other, same = rel
        mine = pieces[i] if cut else [_Piece(i, by_id[i].left_vertices, by_id[i].right_vertices, by_id[i].center_vertices)]
        theirs = pieces[other] if cut else [_Piece(other, by_id[other].left_vertices, by_id[other].right_vertices,
                                                   by_id[other].center_vertices)]
        return any(_shares_bound(p.left if side == "left" else p.right, _their_bound(q, same, side))
                   for p in mine for q in theirs)

    gain: dict[int, int] = {}
    for (i, side), rel in neighbours.items():
        if rel is not None:
            gain[root(i)] = gain.get(root(i), 0) + shared(i, side, rel, True) - shared(i, side, rel, False)
    for i in by_id:
        if gain.get(root(i), 0) <= 0 and len(pieces[i]) > 1:
            l = by_id[i]
            pieces[i] = [_Piece(i, l.left_vertices, l.right_vertices, l.center_vertices)]
    if all(len(p) == 1 for p in pieces.values()):
        return Split(list(lanelets), {l.lanelet_id: l.lanelet_id for l in lanelets})
    # ids: a lanelet of one piece keeps its own; pieces of a cut one get new ids
    next_id = max(by_id) + 1
    ids: dict[int, list[int]] = {}
    for i in sorted(pieces):
        if len(pieces[i]) == 1:
            ids[i] = [i]
        else:
            ids[i] = list(range(next_id, next_id + len(pieces[i])))
            next_id += len(pieces[i])
    origin = {p: i for i, ps in ids.items() for p in ps}
    out = []
    for i in sorted(pieces):
        l = by_id[i]
        near = [*l.predecessor, *l.successor, l.adj_left, l.adj_right]
        if len(ids[i]) == 1 and all(j is None or j not in ids or len(ids[j]) == 1 for j in near):
            out.append(l)                       # neither it nor any lanelet next to it was cut
            continue
        for k, (pid, piece) in enumerate(zip(ids[i], pieces[i])):
            is_first, is_last = k == 0, k == len(pieces[i]) - 1
            predecessor = [ids[p][-1] for p in l.predecessor if p in ids] if is_first else [ids[i][k - 1]]
            successor = [ids[s][0] for s in l.successor if s in ids] if is_last else [ids[i][k + 1]]
            adj: dict[str, tuple[int | None, bool | None]] = {}
            for side in ("left", "right"):
                rel = neighbours[(i, side)]
                adj[side] = (None, None)
                facing, facing_same = _facing(l, side)
                if facing is not None and facing in ids and len(ids[facing]) == 1 and len(ids[i]) == 1:
                    adj[side] = (facing, facing_same)   # neither cut: as the source has it
                    continue
                if rel is None:                         # one-sided: not carried over to pieces
                    continue
                other, same = rel
                ours = piece.left if side == "left" else piece.right
                for qid, q in zip(ids[other], pieces[other]):
                    if _shares_bound(ours, _their_bound(q, same, side)):
                        adj[side] = (qid, same)
                        break
            out.append(Lanelet(piece.left, piece.centre, piece.right, pid, predecessor, successor,
                               adj["left"][0], adj["left"][1], adj["right"][0], adj["right"][1],
                               l.line_marking_left_vertices, l.line_marking_right_vertices,
                               lanelet_type=set(l.lanelet_type or ())))
    return Split(out, origin)
