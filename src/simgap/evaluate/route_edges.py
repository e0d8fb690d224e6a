"""Where the road ends, in an agent's route frame (`simgap.evaluate.route_centre`): the edges of
the lanes it drives and of the road beside them as lateral offsets d over arc length s, and
where each event of its run happened in that frame — what the d-over-s plot draws, and what
`simgap compare` prints.

The lane edges are the boundaries of the route's lanelets; the road edges the outermost
boundaries of the lanelets beside them (their left and right neighbours, in either direction),
as far as those reach. Near a junction, where lanelets leave the route, they stay those of the
route's own side-by-side lanelets (the drivable area there is larger)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from commonroad.planning.planning_problem import PlanningProblem
from commonroad.scenario.lanelet import Lanelet, LaneletNetwork

from simgap.cosim.history import Event
from simgap.evaluate.route_centre import route_lanelets
from simgap.scenario.road_frame import PathFrame

EDGE_STEP_M = 0.5       # the s grid of the edges


@dataclass(frozen=True)
class RouteEdges:
    """Lane and road edges along a route: lateral offsets [m] (positive to the left) on the grid
    ``s`` [m]; NaN where no lanelet reaches."""

    s: np.ndarray
    lane_left: np.ndarray
    lane_right: np.ndarray
    road_left: np.ndarray
    road_right: np.ndarray


@dataclass(frozen=True)
class EventPlace:
    """An event of a run where it happened: its time and its place in the world (x, y) and in the
    agent's route frame (s, d; None without a place or a frame)."""

    event: Event
    s: float | None
    d: float | None

    def describe(self) -> str:
        e = self.event
        where = "" if e.x is None or e.y is None else f" at ({e.x:.1f}, {e.y:.1f})"
        along = "" if self.s is None or self.d is None else f", s = {self.s:.1f} m, d = {self.d:+.2f} m"
        return f"t = {e.t:.2f} s agent {e.agent_id} {e.kind.value}{where}{along}" + (f": {e.detail}" if e.detail else "")


def route_edges(network: LaneletNetwork, problem: PlanningProblem, frame: PathFrame) -> RouteEdges | None:
    """The lane and road edges of ``problem``'s route in ``frame`` (its centre line); None when it
    has no route."""
    ids = route_lanelets(network, problem)
    if not ids:
        return None
    grid = np.arange(0.0, float(frame.s[-1]) + EDGE_STEP_M, EDGE_STEP_M)
    nan = np.full(len(grid), np.nan)
    lane_left, lane_right, road_left, road_right = nan.copy(), nan.copy(), nan.copy(), nan.copy()
    for lanelet_id in ids:
        lanelet = network.find_lanelet_by_id(lanelet_id)
        lane_left = np.fmax(lane_left, _offsets(frame, lanelet.left_vertices, grid))
        lane_right = np.fmin(lane_right, _offsets(frame, lanelet.right_vertices, grid))
        for beside in _side_by_side(network, lanelet):
            for boundary in (beside.left_vertices, beside.right_vertices):
                d = _offsets(frame, boundary, grid)
                road_left, road_right = np.fmax(road_left, d), np.fmin(road_right, d)
    return RouteEdges(grid, lane_left, lane_right, road_left, road_right)


def _side_by_side(network: LaneletNetwork, lanelet: Lanelet) -> list[Lanelet]:
    """``lanelet`` and every lanelet beside it, left and right, in either direction."""
    found = {lanelet.lanelet_id: lanelet}
    todo = [lanelet]
    while todo:
        current = todo.pop()
        for other_id in (current.adj_left, current.adj_right):
            if other_id is not None and other_id not in found:
                other = network.find_lanelet_by_id(other_id)
                if other is not None:
                    found[other_id] = other
                    todo.append(other)
    return list(found.values())


def _offsets(frame: PathFrame, boundary: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """A boundary's lateral offset on the grid, NaN beyond the stretch it spans."""
    s, d = frame.project(boundary)
    order = np.argsort(s)
    s, d = s[order], d[order]
    out = np.interp(grid, s, d)
    out[(grid < s[0]) | (grid > s[-1])] = np.nan
    return out


def event_places(events: Sequence[Event], frames: dict[int, PathFrame | None]) -> list[EventPlace]:
    """Every event in time order with its place in its agent's route frame (``frames``: per agent,
    None for one without a route)."""
    places = []
    for e in sorted(events, key=lambda e: (e.t, e.agent_id)):
        frame = frames.get(e.agent_id)
        if frame is None or e.x is None or e.y is None:
            places.append(EventPlace(e, None, None))
            continue
        s, d = frame.project(np.array([[e.x, e.y]]))
        places.append(EventPlace(e, float(s[0]), float(d[0])))
    return places
