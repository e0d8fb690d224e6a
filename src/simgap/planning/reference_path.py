"""The reference path: the route's centre line from the start to the goal, smoothed, resampled,
and extended straight beyond both ends, so that a planning horizon never runs off it.

The Frenet frame of the planner is the frame of this path; it is computed once per agent.
Evaluation uses the same path (``xy`` and ``s``) to express lateral displacement d(s).
"""

from __future__ import annotations

import copy
import logging
from dataclasses import dataclass

import numpy as np
from commonroad.planning.planning_problem import PlanningProblem
from commonroad.scenario.lanelet import LaneletNetwork

from simgap.errors import InputError

_FINE_STEP_M = 0.1
# tighter than a 4 m radius is no lane's curve but a kink between lanelets: smoothed with 3 m
KINK_CURVATURE = 0.25
KINK_SMOOTHING_M = 3.0


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
    """The centre line of the shortest route (fewest lane changes) from the initial state to the
    goal, as commonroad-route-planner computes it, and the route's lanelet ids (see
    `lanelet_routes`). Where the route planner's lane-change geometry fails (some real maps), the
    route's centre lines are joined."""
    # imported here: the route planner pulls in networkx and its own logging at import time
    from commonroad_route_planner.reference_path_planner import ReferencePathPlanner

    routes, planning_problem = lanelet_routes(lanelet_network, planning_problem)
    try:
        route = ReferencePathPlanner(lanelet_network, planning_problem, routes,
                                     logging_level=logging.ERROR).plan_shortest_reference_path()
        centre, ids = np.asarray(route.reference_path, dtype=float), tuple(int(i) for i in route.lanelet_ids)
    except Exception:  # noqa: BLE001 - its lane-change geometry fails on some real maps
        centre, ids = np.empty((0, 2)), ()
    if len(centre) < 2:
        centre, ids = _joined_centre_lines(lanelet_network, shortest_route(routes))
    return centre, ids


def lanelet_routes(lanelet_network: LaneletNetwork, planning_problem: PlanningProblem) -> tuple[list, PlanningProblem]:
    """commonroad-route-planner's routes from the initial state to the goal, and the planning
    problem they start from.

    The route planner changes lanes where the goal lanelet needs it and, for a goal without
    lanelets (no position, or one off the lanelets), follows the road from the start. An initial
    state off every lanelet (between lanelets, on the shoulder, on an intersection's boundary)
    starts the route from the nearest lanelet with a matching direction; only where no route
    exists on the map is the planning problem refused, with the reason."""
    from commonroad_route_planner.route_planner import RoutePlanner

    pid = planning_problem.planning_problem_id
    first = ""
    for candidate in (planning_problem, None):
        candidate = candidate or _snapped_to_lanelet(lanelet_network, planning_problem)
        if candidate is None:
            break
        try:
            routes = RoutePlanner(lanelet_network, candidate, logging_level=logging.ERROR).plan_routes()
        except Exception as exc:  # noqa: BLE001 - the route planner raises many kinds
            first = first or str(exc) or type(exc).__name__
            continue
        if routes and any(len(r.lanelet_ids) for r in routes):
            return [r for r in routes if len(r.lanelet_ids)], candidate
        first = first or "no route found"
    raise InputError(f"no route from the initial state to the goal on the lanelet network ({first})",
                     field=f"planning problem {pid}",
                     allowed="a goal reachable along lanelets (successors and same-direction neighbours)") from None


def shortest_route(routes) -> tuple[int, ...]:
    """The lanelet ids of the route through the fewest lanelets."""
    return tuple(int(i) for i in min(routes, key=lambda r: len(r.lanelet_ids)).lanelet_ids)


def _joined_centre_lines(lanelet_network: LaneletNetwork, lanelet_ids) -> tuple[np.ndarray, tuple[int, ...]]:
    """The route's centre lines joined end to end (a lane change becomes a short lateral shift,
    which the smoothing rounds off) - used where the route planner's own geometry fails."""
    parts = []
    for lanelet_id in lanelet_ids:
        centre = np.asarray(lanelet_network.find_lanelet_by_id(lanelet_id).center_vertices, dtype=float)
        if parts:
            # after a lane change, continue the neighbour from the point beside where we are
            k = int(np.hypot(*(centre - parts[-1][-1]).T).argmin())
            centre = centre[min(k + 1, len(centre) - 1):] if k else centre[1:]
        parts.append(centre)
    return np.vstack(parts), tuple(int(i) for i in lanelet_ids)


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
    fine = _gaussian_smooth(fine, smoothing / _FINE_STEP_M)
    s_fine = _arc_length(fine)
    dx = np.gradient(fine[:, 0], s_fine)
    dy = np.gradient(fine[:, 1], s_fine)
    theta_fine = np.unwrap(np.arctan2(dy, dx))
    kappa_fine = np.gradient(theta_fine, s_fine)
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


def plan_reference_path(lanelet_network: LaneletNetwork, planning_problem: PlanningProblem,
                        spacing: float = 1.0, smoothing: float = 1.0, extension_back: float = 20.0,
                        extension_forward: float = 100.0) -> ReferencePath:
    """The reference path of ``planning_problem``: route → centre line → `smooth_reference_path`.

    Real maps have kinks where lanelets meet off-line (a lane shifting by a metre within a few
    metres): where the smoothed route still turns tighter than `KINK_CURVATURE`, it is smoothed
    again with `KINK_SMOOTHING_M`, as a driver would round the kink off."""
    centre, ids = route_centre_line(lanelet_network, planning_problem)
    path = smooth_reference_path(centre, spacing, smoothing, extension_back, extension_forward, ids)
    lo, hi = path.route_s
    on_route = (path.s >= lo) & (path.s <= hi)
    if smoothing < KINK_SMOOTHING_M and np.abs(path.kappa[on_route]).max(initial=0.0) > KINK_CURVATURE:
        path = smooth_reference_path(centre, spacing, KINK_SMOOTHING_M, extension_back, extension_forward, ids)
    return path
