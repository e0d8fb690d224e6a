"""The route: commonroad-route-planner's lanelet routes from the initial state to the goal
(`lanelet_routes`, with the map's repairs: a start off every lanelet snapped onto the nearest one,
lanes side by side that the map leaves unlinked linked), the one the planners drive
(`preferred_route`), its centre line (`route_centre_line`: the route planner's reference path, or
the lanelets' centre lines joined, with the lane changes of `planning.lane_change`); where the
route reaches the end of the mapped road is the reference path's (`ReferencePath.dead_end`)."""

from __future__ import annotations

import copy
import logging
import math
import re
from dataclasses import dataclass

import numpy as np
import shapely
from commonroad.planning.planning_problem import PlanningProblem
from commonroad.scenario.lanelet import LaneletNetwork
from commonroad.scenario.state import InitialState

from simgap.errors import InputError
from simgap.planning.lane_change import (
    adjacent,
    changes_from,
    lane_change_length,
    lane_change_path,
    lane_changes,
    lanes_beside,
)
from simgap.polyline import arc_length, nearest, resample, without_duplicates

# two lanelets whose boundaries lie within this of each other end to end are side by side [m]
SHARED_BOUNDARY_M = 0.2


def route_centre_line(lanelet_network: LaneletNetwork,
                      planning_problem: PlanningProblem) -> tuple[np.ndarray, tuple[int, ...]]:
    """The centre line of the route from the initial state to the goal (commonroad-route-planner's
    routes, `preferred_route`; see `lanelet_routes`) and its lanelet ids.

    Without a lane change it is the route planner's reference path. With one, the route's centre
    lines are joined and the lane change blends from one lane's centre line into its neighbour's
    over `lane_change_length` (a smoothstep, from where the vehicle is or where the two lanes
    begin): on recorded maps the route planner squeezes some lane changes into the last metres
    before the goal (a sharp S the speed profile must crawl through), and its lane-change geometry
    fails outright on others."""
    found = lanelet_routes(lanelet_network, planning_problem)
    network, planning_problem = found.network, found.problem
    ids = preferred_route(network, found.routes, planning_problem.initial_state)
    if not lane_changes(network, ids):
        path = _planners_path(network, planning_problem, found.routes, ids)
        if path is not None:
            return path, ids
    initial = planning_problem.initial_state
    speed = float(getattr(initial, "velocity", 0.0) or 0.0)
    return _joined_centre_lines(network, ids, np.asarray(initial.position, dtype=float),
                                lane_change_length(speed)), ids


def _planners_path(network: LaneletNetwork, planning_problem: PlanningProblem, routes: list,
                   ids: tuple[int, ...]) -> np.ndarray | None:
    """The route planner's reference path of the route ``ids`` (no lane change) among ``routes``;
    None where it chose another route or its geometry fails (as on some real maps)."""
    # imported here: the route planner pulls in networkx and its own logging at import time
    from commonroad_route_planner.reference_path_planner import ReferencePathPlanner

    try:
        if len(routes) == 1:        # the route planner's choice of one route is that route
            path = _route_planner_path(network, ids)
        else:
            # it logs an error where no route is 'well oriented' and returns the first: checked below
            route = ReferencePathPlanner(network, planning_problem, routes,
                                         logging_level=logging.CRITICAL).plan_shortest_reference_path()
            if tuple(int(i) for i in route.lanelet_ids) != ids:
                return None
            path = route.reference_path
    except Exception:  # noqa: BLE001 - its geometry fails on some real maps: the centre lines are joined
        return None
    return np.asarray(path, dtype=float) if len(path) >= 2 else None


def _route_planner_path(network: LaneletNetwork, lanelet_ids: tuple[int, ...]) -> np.ndarray:
    """commonroad-route-planner's reference path of a route without lane changes, made with its own
    polyline operations as its default generation strategy makes it (each centre line sampled at
    1 m, joined, sampled at 2 m, without duplicate points, Chaikin's corner cutting) — without the
    strategy's lane-change bookkeeping, which hashes every lanelet of the route by printing its
    vertices as text (0.1-0.25 s of a run on the curve road, where the whole path takes 5 ms)."""
    import commonroad_route_planner.utility.polyline_operations.polyline_operations as polylines
    from commonroad_route_planner.utility.route_util import chaikins_corner_cutting

    centres = [polylines.sample_polyline(network.find_lanelet_by_id(i).center_vertices, 1.0) for i in lanelet_ids]
    joined = polylines.sample_polyline(np.concatenate(centres, axis=0), step=2)
    return chaikins_corner_cutting(polylines.remove_duplicate_points(joined))


def _route_length(network: LaneletNetwork, route: tuple[int, ...]) -> float:
    return sum(float(network.find_lanelet_by_id(i).distance[-1]) for i in route)


@dataclass(frozen=True)
class LaneletRoutes:
    """commonroad-route-planner's routes, the planning problem they start from, and the lanelet
    network they run on (the file's, or a copy with unlinked neighbours linked: `_linked_neighbours`)."""

    routes: list
    problem: PlanningProblem
    network: LaneletNetwork


def lanelet_routes(lanelet_network: LaneletNetwork, planning_problem: PlanningProblem) -> LaneletRoutes:
    """commonroad-route-planner's routes from the initial state to the goal.

    The route planner changes lanes where the goal lanelet needs it and, for a goal without
    lanelets (no position, or one off the lanelets), follows the road from the start. An initial
    state off every lanelet (between lanelets, on the shoulder, on an intersection's boundary)
    starts the route from the nearest lanelet with a matching direction; a map that leaves two
    lanes side by side unlinked (one's boundary is the other's, the same way) is routed with them
    linked; only where no route exists on the map is the planning problem refused, with the reason."""
    from commonroad_route_planner.route_planner import RoutePlanner

    pid = planning_problem.planning_problem_id
    first = ""
    for network in (lanelet_network, None):
        network = network or _linked_neighbours(lanelet_network)
        if network is None:
            break
        for candidate in (planning_problem, None):
            candidate = candidate or _snapped_to_lanelet(network, planning_problem)
            if candidate is None:
                break
            try:    # its errors are logged as it raises them: the raised one is reported, in our words
                routes = RoutePlanner(network, candidate, logging_level=logging.CRITICAL).plan_routes()
            except Exception as exc:  # noqa: BLE001 - the route planner raises many kinds
                first = first or _readable(exc)
                continue
            if routes and any(len(r.lanelet_ids) for r in routes):
                return LaneletRoutes([r for r in routes if len(r.lanelet_ids)], candidate, network)
            first = first or "no route found"
    raise InputError(f"no route from the initial state to the goal on the lanelet network ({first})",
                     field=f"planning problem {pid}",
                     allowed="a goal reachable along lanelets (successors and same-direction neighbours)") from None


def _linked_neighbours(network: LaneletNetwork) -> LaneletNetwork | None:
    """A copy of ``network`` in which lanelets side by side that the map does not link are
    neighbours (the same way): one's right boundary is the other's left, end to end (within
    `SHARED_BOUNDARY_M`); None when there are none."""
    lanelets = [l for l in network.lanelets if len(l.left_vertices) >= 2 and len(l.right_vertices) >= 2]
    if len(lanelets) < 2:
        return None
    lefts = np.array([[l.left_vertices[0], l.left_vertices[-1]] for l in lanelets], dtype=float)
    pairs = []
    for i, lanelet in enumerate(lanelets):
        if lanelet.adj_right is not None:
            continue
        right = np.array([lanelet.right_vertices[0], lanelet.right_vertices[-1]], dtype=float)
        ends = np.hypot(*(lefts - right).transpose(2, 0, 1)).max(axis=1)
        for j in np.flatnonzero(ends <= SHARED_BOUNDARY_M):
            other = lanelets[j]
            if j != i and other.adj_left is None and _shared(lanelet.right_vertices, other.left_vertices):
                pairs.append((lanelet.lanelet_id, other.lanelet_id))
    if not pairs:
        return None
    linked = copy.deepcopy(network)
    for left_id, right_id in pairs:
        left, right = linked.find_lanelet_by_id(left_id), linked.find_lanelet_by_id(right_id)
        left.adj_right, left.adj_right_same_direction = right_id, True
        right.adj_left, right.adj_left_same_direction = left_id, True
    return linked


def _shared(a: np.ndarray, b: np.ndarray) -> bool:
    """Do the polylines ``a`` and ``b`` (the same way) lie on each other, within `SHARED_BOUNDARY_M`?"""
    fine_a, fine_b = resample(np.asarray(a, dtype=float), 1.0), resample(np.asarray(b, dtype=float), 1.0)
    if abs(arc_length(fine_a)[-1] - arc_length(fine_b)[-1]) > SHARED_BOUNDARY_M:
        return False
    return bool(shapely.LineString(fine_b).distance(shapely.points(fine_a)).max() <= SHARED_BOUNDARY_M)


def _readable(exc: Exception) -> str:
    """The route planner's message for a user: an object's repr (``<...Planner object at 0x...>``)
    becomes its class's name."""
    return re.sub(r"<(?:[\w]+\.)*(\w+) object at 0x[0-9a-fA-F]+>", r"\1", str(exc)) or type(exc).__name__


def preferred_route(network: LaneletNetwork, routes, initial: InitialState | None = None) -> tuple[int, ...]:
    """The lanelet ids of the route with the fewest lane changes, then the one whose first lanelet
    the car is on (``initial``: the planning problem's initial state; where two lanelets merge, as
    at a roundabout's entry, both hold the car: the one heading its way), then the shortest."""
    start = None if initial is None else np.asarray(initial.position, dtype=float)
    heading = 0.0 if initial is None else float(getattr(initial, "orientation", 0.0) or 0.0)   # read with start

    def misfit(route: tuple[int, ...]) -> float:
        if start is None:
            return 0.0
        lanelet = network.find_lanelet_by_id(route[0])
        if not lanelet.polygon.contains_point(start):
            return math.inf
        centre = np.asarray(lanelet.center_vertices, dtype=float)
        k = min(nearest(centre, start), len(centre) - 2)
        along = math.atan2(*(centre[k + 1] - centre[k])[::-1])
        return round(abs(math.remainder(heading - along, 2.0 * math.pi)), 1)   # 0.1 rad: the same way

    return min((tuple(int(i) for i in r.lanelet_ids) for r in routes),
               key=lambda route: (lane_changes(network, route), misfit(route), _route_length(network, route)))


def _joined_centre_lines(network: LaneletNetwork, lanelet_ids: tuple[int, ...], start: np.ndarray,
                         change_m: float) -> np.ndarray:
    """The route's centre lines joined end to end; a lane change (the next lanelet is a neighbour,
    not a successor) blends into the neighbour's centre line over ``change_m`` metres from where
    ``start`` lies beside the two lanes (or where they begin; a second change in the same stretch
    follows the first, the series sharing the stretch when it is shorter than a change each). A
    lane change from a lanelet shorter than ``change_m`` starts on the
    lanelets before it whose neighbours lead into the target lane (`lanes_beside`): the route
    planner puts a change on the last lanelet before the goal, a few metres long on some maps."""
    done: list[np.ndarray] = []         # the path before the lanelet we are on
    done_ids: list[int] = []            # ... the lanelet each of those pieces follows
    current: np.ndarray | None = None   # the path along the lanelet we are on (whole: a lane change
    changed_at = None                   # blends from it); where along it the last lane change ended
    each_m = change_m                   # how long each change of the present series is
    for k, lanelet_id in enumerate(lanelet_ids):
        centre = _centre_line(network, lanelet_id)
        if current is None:
            current = centre
        elif adjacent(network, lanelet_ids[k - 1], lanelet_id):
            if changed_at is None:          # the first of a series of changes: they share the stretch
                series = changes_from(network, lanelet_ids, k)
                back = lanes_beside(network, done_ids, lanelet_ids[k - 1], lanelet_id,
                                    series * change_m - float(arc_length(current)[-1]))
                if back:
                    current = _joined([*done[-len(back):], current])
                    centre = _joined([*(_centre_line(network, i) for i in back), centre])
                    del done[-len(back):], done_ids[-len(back):]
                along = arc_length(current)
                each_m = min(change_m, (along[-1] - along[nearest(current, start)]) / series) if series > 1 \
                    else change_m
            current, changed_at = lane_change_path(current, centre, start, each_m, changed_at)
        else:
            done.append(current)
            done_ids.append(lanelet_ids[k - 1] if changed_at is None else -1)
            current, changed_at = centre, None
    return _joined([*done, current])


def _centre_line(network: LaneletNetwork, lanelet_id: int) -> np.ndarray:
    return without_duplicates(np.asarray(network.find_lanelet_by_id(lanelet_id).center_vertices, dtype=float))


def _joined(pieces: list[np.ndarray]) -> np.ndarray:
    """Polylines end to end; where one starts at the previous one's end, the shared point once."""
    return np.vstack([pieces[0], *(piece[1:] if np.allclose(piece[0], before[-1], atol=0.05) else piece
                                   for before, piece in zip(pieces, pieces[1:]))])


def _snapped_to_lanelet(lanelet_network: LaneletNetwork, planning_problem: PlanningProblem) -> PlanningProblem | None:
    """A copy of the planning problem whose initial position is moved onto the nearest centre-line
    point of a lanelet heading within 90 degrees of the initial orientation (None: no lanelet)."""
    init = planning_problem.initial_state
    pos = np.asarray(init.position, dtype=float)
    yaw = float(getattr(init, "orientation", 0.0) or 0.0)
    best, best_distance = None, np.inf
    for lanelet in lanelet_network.lanelets:
        centre = np.asarray(lanelet.center_vertices, dtype=float)
        if len(centre) < 2:
            continue
        distance = np.hypot(*(centre - pos).T)
        k = int(min(distance.argmin(), len(centre) - 2))
        heading = np.arctan2(*(centre[k + 1] - centre[k])[::-1])
        if np.cos(heading - yaw) > 0 and distance[k] < best_distance:
            best, best_distance = centre[k] + 0.05 * (centre[k + 1] - centre[k]), distance[k]
    if best is None:
        return None
    snapped = copy.deepcopy(planning_problem)
    snapped.initial_state.position = best
    return snapped
