"""The reference path: the route's centre line from the start to the goal, smoothed, resampled,
and extended straight beyond both ends, so that a planning horizon never runs off it.

The Frenet frame of the planner is the frame of this path; it is computed once per agent.
Evaluation uses the same path (``xy`` and ``s``) to express lateral displacement d(s).
"""

from __future__ import annotations

import copy
import logging
import math
import re
from dataclasses import dataclass

import numpy as np
import shapely
from scipy.ndimage import maximum_filter1d, minimum_filter1d
from commonroad.planning.planning_problem import PlanningProblem
from commonroad.scenario.lanelet import LaneletNetwork
from commonroad.scenario.state import InitialState

from simgap.errors import InputError
from simgap.scenario.goal import area_of

_FINE_STEP_M = 0.1
# a route's lane change takes this long at the vehicle's initial speed, and at least so far [s], [m]
LANE_CHANGE_S = 4.0
LANE_CHANGE_MIN_M = 30.0
# the path is smoothed more widely (these multiples of the smoothing) where that keeps it within
# DEVIATION_TOLERANCE_M of the route's centre line (`_widened_smoothing`)
WIDER_SMOOTHING = (1.0, 2.0, 4.0, 8.0, 16.0)
DEVIATION_TOLERANCE_M = 0.1
# ... and within KINK_DEVIATION_TOLERANCE_M where the curvature changes faster than KINK_RAMP [1/m^2]
KINK_RAMP = 0.03
KINK_DEVIATION_TOLERANCE_M = 0.4
LEVEL_BLEND_M = 4.0
# tighter than a 4 m radius is no lane's curve but a kink between lanelets: smoothed with 3 m
KINK_CURVATURE = 0.25
KINK_SMOOTHING_M = 3.0
# a goal area the route's centre line passes less deep inside than this is aimed at (`towards_goal`),
# when its centre lies this far beside the line; the move over takes at least this long [m]
GOAL_DEPTH_M = 0.5
GOAL_BESIDE_MIN_M = 0.3
GOAL_BESIDE_MAX_M = 2.5
GOAL_SHIFT_MIN_RAMP_M = 10.0
GOAL_SHIFT_MAX_TURN_RAD = 0.2       # ... along a line that turns at most this much over the move
# ... arriving with the goal's heading when it turns at most this from the line's (a lane change),
# the sideways slope easing out over this distance beyond the goal [rad], [m]
GOAL_HEADING_MAX_RAD = 0.3
GOAL_RUN_OUT_M = 10.0
# two lanelets whose boundaries lie within this of each other end to end are side by side [m]
SHARED_BOUNDARY_M = 0.2


@dataclass(frozen=True, eq=False)
class ReferencePath:
    """A smooth polyline in world coordinates with its arc length, heading and curvature.

    ``xy``: (n, 2) points about ``spacing`` apart; ``s``: (n,) arc length from the first point;
    ``theta``: (n,) heading, unwrapped (continuous); ``kappa``: (n,) signed curvature (positive
    = turning left). ``route_s`` is the arc-length interval covered by the route itself; what lies
    before and after is the straight extension.
    """

    xy: np.ndarray
    s: np.ndarray
    theta: np.ndarray
    kappa: np.ndarray
    lanelet_ids: tuple[int, ...] = ()
    route_s: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        for name in ("xy", "s", "theta", "kappa"):
            getattr(self, name).flags.writeable = False

    @property
    def length(self) -> float:
        return float(self.s[-1])

    def interpolate(self, s: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(x, y, theta, kappa) at arc lengths ``s`` (linear between points, clamped at the ends)."""
        s = np.asarray(s, dtype=float)
        return (np.interp(s, self.s, self.xy[:, 0]), np.interp(s, self.s, self.xy[:, 1]),
                np.interp(s, self.s, self.theta), np.interp(s, self.s, self.kappa))


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
    if not _lane_changes(network, ids):
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


def lane_change_length(speed: float) -> float:
    """How long [m] a route's lane change is: `LANE_CHANGE_S` at ``speed``, at least `LANE_CHANGE_MIN_M`."""
    return max(LANE_CHANGE_MIN_M, LANE_CHANGE_S * speed)


def _adjacent(network: LaneletNetwork, a: int, b: int) -> bool:
    lanelet = network.find_lanelet_by_id(a)
    return b in (lanelet.adj_left, lanelet.adj_right)


def _lane_changes(network: LaneletNetwork, route: tuple[int, ...]) -> int:
    return sum(_adjacent(network, a, b) for a, b in zip(route, route[1:]))


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
    fine_a, fine_b = _resample(np.asarray(a, dtype=float), 1.0), _resample(np.asarray(b, dtype=float), 1.0)
    if abs(_arc_length(fine_a)[-1] - _arc_length(fine_b)[-1]) > SHARED_BOUNDARY_M:
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
    heading = None if initial is None else float(getattr(initial, "orientation", 0.0) or 0.0)

    def misfit(route: tuple[int, ...]) -> float:
        if start is None:
            return 0.0
        lanelet = network.find_lanelet_by_id(route[0])
        if not lanelet.polygon.contains_point(start):
            return math.inf
        centre = np.asarray(lanelet.center_vertices, dtype=float)
        k = min(_nearest(centre, start), len(centre) - 2)
        along = math.atan2(*(centre[k + 1] - centre[k])[::-1])
        return round(abs(math.remainder(heading - along, 2.0 * math.pi)), 1)   # 0.1 rad: the same way

    return min((tuple(int(i) for i in r.lanelet_ids) for r in routes),
               key=lambda route: (_lane_changes(network, route), misfit(route), _route_length(network, route)))


def _nearest(points: np.ndarray, point: np.ndarray) -> int:
    """The index of the row of ``points`` nearest ``point``."""
    return int(np.hypot(*(points - point).T).argmin())


def _joined_centre_lines(network: LaneletNetwork, lanelet_ids: tuple[int, ...], start: np.ndarray,
                         change_m: float) -> np.ndarray:
    """The route's centre lines joined end to end; a lane change (the next lanelet is a neighbour,
    not a successor) blends into the neighbour's centre line over ``change_m`` metres from where
    ``start`` lies beside the two lanes (or where they begin; a second change in the same stretch
    follows the first, the series sharing the stretch when it is shorter than a change each). A
    lane change from a lanelet shorter than ``change_m`` starts on the
    lanelets before it whose neighbours lead into the target lane (`_lanes_beside`): the route
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
        elif _adjacent(network, lanelet_ids[k - 1], lanelet_id):
            if changed_at is None:          # the first of a series of changes: they share the stretch
                series = _changes_from(network, lanelet_ids, k)
                back = _lanes_beside(network, done_ids, lanelet_ids[k - 1], lanelet_id,
                                     series * change_m - float(_arc_length(current)[-1]))
                if back:
                    current = _joined([*done[-len(back):], current])
                    centre = _joined([*(_centre_line(network, i) for i in back), centre])
                    del done[-len(back):], done_ids[-len(back):]
                along = _arc_length(current)
                each_m = min(change_m, (along[-1] - along[_nearest(current, start)]) / series) if series > 1 \
                    else change_m
            current, changed_at = _lane_change(current, centre, start, each_m, changed_at)
        else:
            done.append(current)
            done_ids.append(lanelet_ids[k - 1] if changed_at is None else -1)
            current, changed_at = centre, None
    return _joined([*done, current])


def _changes_from(network: LaneletNetwork, lanelet_ids: tuple[int, ...], k: int) -> int:
    """How many lane changes follow one another from ``lanelet_ids[k - 1]`` on (each next lanelet a neighbour)."""
    n = 0
    while k + n < len(lanelet_ids) and _adjacent(network, lanelet_ids[k + n - 1], lanelet_ids[k + n]):
        n += 1
    return n


def _centre_line(network: LaneletNetwork, lanelet_id: int) -> np.ndarray:
    return _without_duplicates(np.asarray(network.find_lanelet_by_id(lanelet_id).center_vertices, dtype=float))


def _joined(pieces: list[np.ndarray]) -> np.ndarray:
    """Polylines end to end; where one starts at the previous one's end, the shared point once."""
    return np.vstack([pieces[0], *(piece[1:] if np.allclose(piece[0], before[-1], atol=0.05) else piece
                                   for before, piece in zip(pieces, pieces[1:]))])


def _lanes_beside(network: LaneletNetwork, behind: list[int], source: int, target: int,
                  needed_m: float) -> list[int]:
    """For a lane change from ``source`` into its neighbour ``target``: the neighbours, on the same
    side and in the same direction, of the lanelets the route passed just before ``source``
    (``behind``, nearest last), that lead into ``target`` one after the other; as many as make up
    ``needed_m`` metres, nearest last (none where the lane beside does not go back that far)."""
    left = network.find_lanelet_by_id(source).adj_left == target
    beside: list[int] = []
    ahead = target
    for lanelet_id in reversed(behind):
        if needed_m <= 0 or lanelet_id < 0:
            break
        lanelet = network.find_lanelet_by_id(lanelet_id)
        neighbour = lanelet.adj_left if left else lanelet.adj_right
        same_way = lanelet.adj_left_same_direction if left else lanelet.adj_right_same_direction
        if neighbour is None or not same_way or neighbour not in network.find_lanelet_by_id(ahead).predecessor:
            break
        beside.insert(0, neighbour)
        needed_m -= float(network.find_lanelet_by_id(lanelet_id).distance[-1])
        ahead = neighbour
    return beside


def _lane_change(from_lane: np.ndarray, to_lane: np.ndarray, start: np.ndarray, change_m: float,
                 after: float | None) -> tuple[np.ndarray, float]:
    """A path along two side-by-side lines, blended from ``from_lane`` into ``to_lane`` by a
    smoothstep over ``change_m`` metres, from beside ``start`` (or where the lanes begin), or from
    the fraction ``after`` of their length (a change that follows another); and where it ends."""
    s_from, s_to = _arc_length(from_lane), _arc_length(to_lane)
    n = max(len(from_lane), len(to_lane), int(np.ceil(max(s_from[-1], s_to[-1]) / 0.5)) + 1)
    u = np.linspace(0.0, 1.0, n)
    a = np.stack([np.interp(u * s_from[-1], s_from, from_lane[:, j]) for j in range(2)], 1)
    b = np.stack([np.interp(u * s_to[-1], s_to, to_lane[:, j]) for j in range(2)], 1)
    u0 = after if after is not None else float(u[_nearest(a, start)])
    u1 = min(1.0, u0 + change_m / max(s_from[-1], 1e-6))
    x = np.clip((u - u0) / max(u1 - u0, 1e-6), 0.0, 1.0)
    w = (x ** 3 * (10.0 - 15.0 * x + 6.0 * x * x))[:, None]
    return (1.0 - w) * a + w * b, u1


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


def _arc_length(xy: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])


def _without_duplicates(xy: np.ndarray) -> np.ndarray:
    keep = np.concatenate([[True], np.hypot(*np.diff(xy, axis=0).T) > 1e-6])
    return xy[keep]


def _resample(xy: np.ndarray, step: float) -> np.ndarray:
    s = _arc_length(xy)
    n = max(2, int(np.ceil(s[-1] / step)) + 1)
    grid = np.linspace(0.0, s[-1], n)
    return np.stack([np.interp(grid, s, xy[:, 0]), np.interp(grid, s, xy[:, 1])], axis=1)


def _end_direction(xy: np.ndarray, at_end: bool, over_m: float = 2.0) -> np.ndarray:
    """Unit direction of the first (last) ``over_m`` metres of a polyline."""
    s = _arc_length(xy)
    if at_end:
        k = int(np.searchsorted(s, s[-1] - over_m, side="right")) - 1
        vec = xy[-1] - xy[max(0, min(k, len(xy) - 2))]
    else:
        k = int(np.searchsorted(s, over_m))
        vec = xy[min(max(k, 1), len(xy) - 1)] - xy[0]
    return vec / np.linalg.norm(vec)


def _extend(xy: np.ndarray, back_m: float, forward_m: float, step: float) -> np.ndarray:
    parts = []
    if back_m > 0:
        d = _end_direction(xy, at_end=False)
        dist = np.arange(np.ceil(back_m / step), 0, -1) * step
        parts.append(xy[0] - dist[:, None] * d)
    parts.append(xy)
    if forward_m > 0:
        d = _end_direction(xy, at_end=True)
        dist = np.arange(1, np.ceil(forward_m / step) + 1) * step
        parts.append(xy[-1] + dist[:, None] * d)
    return np.vstack(parts)


def _heading_and_curvature(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Arc length, heading (unwrapped) and signed curvature at every point of a polyline."""
    s = _arc_length(xy)
    theta = np.unwrap(np.arctan2(np.gradient(xy[:, 1], s), np.gradient(xy[:, 0], s)))
    return s, theta, np.gradient(theta, s)


def _gaussian_smooth(xy: np.ndarray, sigma_samples: float) -> np.ndarray:
    """Gaussian smoothing along the polyline; the ends are padded by point reflection so that
    straight ends stay straight (a Gaussian keeps linear functions unchanged)."""
    if sigma_samples <= 0:
        return xy
    half = int(np.ceil(4 * sigma_samples))
    half = min(half, len(xy) - 1)
    k = np.arange(-half, half + 1)
    kernel = np.exp(-0.5 * (k / sigma_samples) ** 2)
    kernel /= kernel.sum()
    head = 2 * xy[0] - xy[half:0:-1]
    tail = 2 * xy[-1] - xy[-2:-half - 2:-1]
    padded = np.vstack([head, xy, tail])
    return np.stack([np.convolve(padded[:, j], kernel, mode="valid") for j in range(2)], axis=1)


def _widened_smoothing(xy: np.ndarray, sigma_m: float, tolerance_m: float, kink_tolerance_m: float) -> np.ndarray:
    """``xy`` (a polyline `_FINE_STEP_M` apart) Gaussian-smoothed with ``sigma_m``, and more widely
    (`WIDER_SMOOTHING`) wherever the wider smoothing stays within ``tolerance_m`` of the polyline
    — ``kink_tolerance_m`` where the narrow smoothing's curvature changes faster than `KINK_RAMP`.

    Lanelets of recorded maps meet at small angles (a degree or two where two centre lines join);
    smoothed over a metre such a kink asks for a steering rate that only a slow car has, and the
    speed profile would brake for it on a straight highway. A driver rounds it off over tens of
    metres within a hand's breadth of the lane centre, as this does; a curve's real shape keeps
    the narrow smoothing (a wide one would cut it by more than the tolerance). Where a turn's
    curvature sets in within a metre or two (faster than `KINK_RAMP`: a recorded turn drawn with a
    few chords, a tight arc joined to a straight without a transition), which the steering rate
    follows only below about 4 m/s, the driver eases the bend over a few metres, up to
    ``kink_tolerance_m`` off the centre line."""
    sigmas = [sigma_m * factor for factor in WIDER_SMOOTHING]
    levels = [_gaussian_smooth(xy, s / _FINE_STEP_M) for s in sigmas]
    ramp = np.abs(np.gradient(_heading_and_curvature(levels[0])[2], _FINE_STEP_M))
    reach = 2 * int(np.ceil(2 * sigmas[-1] / _FINE_STEP_M)) + 1
    tolerance = np.where(maximum_filter1d(ramp, size=reach, mode="nearest") > KINK_RAMP, kink_tolerance_m, tolerance_m)
    allowed = np.zeros(len(xy))
    ok = np.ones(len(xy), dtype=bool)
    for j in range(1, len(sigmas)):
        deviation = np.hypot(*(levels[j] - xy).T)
        reach = 2 * int(np.ceil(2 * sigmas[j] / _FINE_STEP_M)) + 1
        ok &= maximum_filter1d(deviation, size=reach, mode="nearest") <= tolerance
        allowed[ok] = j
    if not allowed.any():
        return levels[0]
    # the level changes gradually along the path (over `LEVEL_BLEND_M`), never above what is allowed:
    # narrowed first by the blend's reach, then smoothed
    reach = int(np.ceil(3 * LEVEL_BLEND_M / _FINE_STEP_M))
    narrowed = minimum_filter1d(allowed, size=2 * reach + 1, mode="nearest")
    blend = _gaussian_smooth(np.stack([narrowed, np.zeros_like(narrowed)], 1), LEVEL_BLEND_M / _FINE_STEP_M)[:, 0]
    blend = np.clip(np.minimum(blend, allowed), 0.0, len(sigmas) - 1)
    low = np.floor(blend).astype(int)
    high = np.minimum(low + 1, len(sigmas) - 1)
    share = (blend - low)[:, None]
    stack = np.stack(levels)
    rows = np.arange(len(xy))
    return (1.0 - share) * stack[low, rows] + share * stack[high, rows]


def smooth_reference_path(centre: np.ndarray, spacing: float = 1.0, smoothing: float = 1.0,
                          extension_back: float = 20.0, extension_forward: float = 100.0,
                          lanelet_ids: tuple[int, ...] = ()) -> ReferencePath:
    """Extend, smooth and resample a centre line into a `ReferencePath`.

    ``smoothing`` is the Gaussian's standard deviation in metres: it turns a curvature jump (a
    straight meeting an arc) into a ramp over about 4 sigma, which a vehicle can steer.
    """
    centre = _without_duplicates(np.asarray(centre, dtype=float))
    if len(centre) < 2:
        raise ValueError("a centre line needs at least two distinct points")
    fine = _resample(centre, _FINE_STEP_M)
    route_length = _arc_length(fine)[-1]
    fine = _extend(fine, extension_back, extension_forward, _FINE_STEP_M)
    fine = _widened_smoothing(fine, smoothing, DEVIATION_TOLERANCE_M, KINK_DEVIATION_TOLERANCE_M) \
        if smoothing > 0 else fine
    s_fine, theta_fine, kappa_fine = _heading_and_curvature(fine)
    n = max(3, int(np.ceil(s_fine[-1] / spacing)) + 1)
    s = np.linspace(0.0, s_fine[-1], n)
    xy = np.stack([np.interp(s, s_fine, fine[:, 0]), np.interp(s, s_fine, fine[:, 1])], axis=1)
    # arc length of the coarse polyline (chords are a little shorter than the arc)
    s_poly = _arc_length(xy)
    theta = np.interp(s, s_fine, theta_fine)
    kappa = np.interp(s, s_fine, kappa_fine)
    start = float(np.ceil(extension_back / _FINE_STEP_M) * _FINE_STEP_M) if extension_back > 0 else 0.0
    scale = s_poly[-1] / s_fine[-1]
    return ReferencePath(xy, s_poly, theta, kappa, tuple(lanelet_ids),
                         (start * scale, (start + route_length) * scale))


def towards_goal(centre: np.ndarray, planning_problem: PlanningProblem) -> np.ndarray:
    """``centre`` moved over to the goal where the goal is an area beside it.

    A recorded scenario's goal is often a small rectangle around where the human driver was at the
    end, a metre off the lane's centre: a car on the centre line passes beside it. When the line
    passes less than `GOAL_DEPTH_M` inside the first goal area and the area's centre lies beside
    the line (between `GOAL_BESIDE_MIN_M` and `GOAL_BESIDE_MAX_M`; farther is another lane, the
    route's business), the line moves sideways onto that centre before it, as gently as a lane
    change at the initial speed (`lane_change_length`; less when the start is nearer), arriving
    with the heading the goal's orientation window asks for when that is a lane change's
    (`GOAL_HEADING_MAX_RAD`; a recording's window is often +-5 deg around a driver changing
    lanes), the sideways slope easing out beyond. A goal on the line whose orientation window
    the line's heading misses (by a lane change's turn at most) is passed at that heading. Only
    where the line runs nearly straight before the goal (`GOAL_SHIFT_MAX_TURN_RAD`): in a turn
    the move would change its radius."""
    area = next((area_of(st.position) for st in planning_problem.goal.state_list
                 if getattr(st, "position", None) is not None), None)
    if area is None or area.is_empty:
        return centre
    fine = _resample(_without_duplicates(np.asarray(centre, dtype=float)), _FINE_STEP_M)
    if len(fine) < 3:
        return centre
    target = np.asarray(area.centroid.coords[0], dtype=float)
    k = _nearest(fine, target)
    if k == 0 or k == len(fine) - 1:               # the goal's centre lies beyond an end of the line
        return centre
    s = _arc_length(fine)
    tangent = np.gradient(fine, s, axis=0)
    normal = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1) / np.hypot(*tangent.T)[:, None]
    # the goal's heading relative to the line's there: the recorded driver may have been changing lanes
    turn, misses = _goal_heading_offset(planning_problem, math.atan2(tangent[k, 1], tangent[k, 0]))
    inside = shapely.contains_xy(area, fine[:, 0], fine[:, 1])
    deep = inside.any() and shapely.distance(area.boundary, shapely.points(fine[inside])).max() >= GOAL_DEPTH_M
    if deep and not misses:
        return centre
    offset = float(np.dot(target - fine[k], normal[k]))
    start = float(s[_nearest(fine, np.asarray(planning_problem.initial_state.position, dtype=float))])
    speed = float(getattr(planning_problem.initial_state, "velocity", 0.0) or 0.0)
    ramp = min(lane_change_length(speed), s[k] - start)
    if abs(offset) > GOAL_BESIDE_MAX_M or ramp < GOAL_SHIFT_MIN_RAMP_M:
        return centre
    if abs(offset) < GOAL_BESIDE_MIN_M or deep:
        if not misses:
            return centre
        offset = 0.0                # on the line, but the line misses the goal's heading: only turn to it
    heading = np.unwrap(np.arctan2(tangent[:, 1], tangent[:, 0]))
    if abs(heading[k] - np.interp(s[k] - ramp, s, heading)) > GOAL_SHIFT_MAX_TURN_RAD:
        return centre               # a turn before the goal: moving over there would tighten or widen it
    slope = math.tan(turn)
    u = np.clip((s - (s[k] - ramp)) / ramp, 0.0, 1.0)
    lateral = offset * u * u * (3.0 - 2.0 * u) + slope * ramp * u * u * (u - 1.0)      # cubic Hermite
    beyond = np.clip(s - s[k], 0.0, GOAL_RUN_OUT_M)                # then the slope eases out
    lateral += slope * beyond * (1.0 - beyond / (2.0 * GOAL_RUN_OUT_M))
    return fine + lateral[:, None] * normal


def _goal_heading_offset(planning_problem: PlanningProblem, heading: float) -> tuple[float, bool]:
    """How far the middle of the first goal state's orientation window turns from ``heading``
    (wrapped; 0 without a window, or when it turns more than `GOAL_HEADING_MAX_RAD`: a turn, not
    a lane change), and whether ``heading`` lies outside the window (False in both those cases)."""
    window = next((st.orientation for st in planning_problem.goal.state_list
                   if getattr(st, "orientation", None) is not None), None)
    if window is None or not hasattr(window, "start"):
        return 0.0, False
    middle = 0.5 * (float(window.start) + float(window.end))
    turn = math.remainder(middle - heading, 2.0 * math.pi)
    if abs(turn) > GOAL_HEADING_MAX_RAD:
        return 0.0, False
    return turn, abs(turn) > 0.5 * (float(window.end) - float(window.start))


def dead_end(reference: ReferencePath, network: LaneletNetwork) -> float | None:
    """The arc length where ``reference``'s route reaches the end of the mapped road (its last
    lanelet has no successor); None where the road goes on."""
    if not reference.lanelet_ids:
        return None
    last = network.find_lanelet_by_id(reference.lanelet_ids[-1])
    return None if last is None or last.successor else float(reference.route_s[1])


def plan_reference_path(lanelet_network: LaneletNetwork, planning_problem: PlanningProblem,
                        spacing: float = 1.0, smoothing: float = 1.0, extension_back: float = 20.0,
                        extension_forward: float = 100.0) -> ReferencePath:
    """The reference path of ``planning_problem``: route → centre line → `smooth_reference_path`.

    Real maps have kinks where lanelets meet off-line (a lane shifting by a metre within a few
    metres): where the smoothed route still turns tighter than `KINK_CURVATURE`, it is smoothed
    again with `KINK_SMOOTHING_M`, as a driver would round the kink off."""
    centre, ids = route_centre_line(lanelet_network, planning_problem)
    centre = towards_goal(centre, planning_problem)
    path = smooth_reference_path(centre, spacing, smoothing, extension_back, extension_forward, ids)
    lo, hi = path.route_s
    on_route = (path.s >= lo) & (path.s <= hi)
    if smoothing < KINK_SMOOTHING_M and np.abs(path.kappa[on_route]).max(initial=0.0) > KINK_CURVATURE:
        path = smooth_reference_path(centre, spacing, KINK_SMOOTHING_M, extension_back, extension_forward, ids)
    return path
