"""The reference path: the route's centre line from the start to the goal, smoothed, resampled,
and extended straight beyond both ends, so that a planning horizon never runs off it.

The Frenet frame of the planner is the frame of this path; it is computed once per agent.
Evaluation uses the same path (``xy`` and ``s``) to express lateral displacement d(s).

`plan_reference_path` is the entry point: the route and its centre line (`planning.route`, with
the lane changes of `planning.lane_change`), moved onto a goal beside it and smoothed
(`planning.path_smoothing`), into a `ReferencePath`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from commonroad.planning.planning_problem import PlanningProblem
from commonroad.scenario.lanelet import LaneletNetwork

from simgap.planning.path_smoothing import smooth_centre_line, towards_goal
from simgap.planning.route import route_centre_line
from simgap.polyline import Polyline

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

    @cached_property
    def polyline(self) -> Polyline:
        """The path as a `simgap.polyline.Polyline` (its points ``xy`` and arc length ``s``)."""
        return Polyline(self.xy, self.s)

    @property
    def length(self) -> float:
        return self.polyline.length

    def interpolate(self, s: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(x, y, theta, kappa) at arc lengths ``s`` (linear between points, clamped at the ends)."""
        s = np.asarray(s, dtype=float)
        line = self.polyline
        x, y = line.point_at(s)
        return x, y, line.interpolate(self.theta, s), line.interpolate(self.kappa, s)

    def dead_end(self, network: LaneletNetwork) -> float | None:
        """The arc length where the route reaches the end of the mapped road (its last lanelet has
        no successor); None where the road goes on."""
        if not self.lanelet_ids:
            return None
        last = network.find_lanelet_by_id(self.lanelet_ids[-1])
        return None if last is None or last.successor else float(self.route_s[1])


def smooth_reference_path(centre: np.ndarray, spacing: float = 1.0, smoothing: float = 1.0,
                          extension_back: float = 20.0, extension_forward: float = 100.0,
                          lanelet_ids: tuple[int, ...] = ()) -> ReferencePath:
    """Extend, smooth and resample a centre line into a `ReferencePath` (`smooth_centre_line`).

    ``smoothing`` is the Gaussian's standard deviation in metres: it turns a curvature jump (a
    straight meeting an arc) into a ramp over about 4 sigma, which a vehicle can steer.
    """
    xy, s, theta, kappa, route_s = smooth_centre_line(centre, spacing, smoothing, extension_back, extension_forward)
    return ReferencePath(xy, s, theta, kappa, tuple(lanelet_ids), route_s)


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
