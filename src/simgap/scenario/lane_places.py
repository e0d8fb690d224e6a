"""Places on a lanelet network: the lanelet under a point and the distance along its centre line
(`LanePlace`), and the lanelets a car can reach from one (`reachable`). The OpenDRIVE import
(``--start X,Y``) and agents placed on any map (`simgap.scenario.placement`) find their places so."""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
import shapely
from commonroad.scenario.lanelet import Lanelet, LaneletNetwork

from simgap.errors import InputError
from simgap.scenario.problem import pose_on_lanelet
from simgap.scenario.road_frame import PathFrame


@dataclass(frozen=True)
class LanePlace:
    """A place on a lanelet: the lanelet and the distance along its centre line [m]."""

    lanelet: Lanelet
    s: float


def on_lanelet(lanelet: Lanelet, point: np.ndarray) -> LanePlace:
    """The place on ``lanelet``'s centre line nearest ``point``."""
    s, _ = PathFrame(lanelet.center_vertices).project(point)
    return LanePlace(lanelet, float(np.clip(s[0], 0.0, lanelet.distance[-1])))


def place_under(network: LaneletNetwork, point: np.ndarray, option: str, allowed: str,
                prefer: set[int] | None = None, heading: float | None = None) -> LanePlace:
    """The place of the lanelet under ``point``: of several (a junction's), one in ``prefer`` (those
    reachable from the start), then the one whose direction is nearest ``heading`` [rad] when it is
    given, then the one whose centre line is nearest. ``option`` and ``allowed`` word the refusal
    of a point on no lanelet."""
    under = [l for l in network.lanelets if l.polygon.shapely_object.buffer(1e-6).contains(shapely.Point(point))]
    if not under:
        if not network.lanelets:
            raise InputError("the map has no lanelets", field=option, allowed="a map with lanelets")
        nearest = min(network.lanelets, key=lambda l: l.polygon.shapely_object.distance(shapely.Point(point)))
        gap = nearest.polygon.shapely_object.distance(shapely.Point(point))
        raise InputError(f"the point ({point[0]:g}, {point[1]:g}) is on no driving lane (the nearest lanelet, "
                         f"{nearest.lanelet_id}, is {gap:.1f} m away)", field=option, allowed=allowed)

    def rank(lanelet: Lanelet) -> tuple[bool, float, float]:
        s, d = PathFrame(lanelet.center_vertices).project(point)
        turn = 0.0
        if heading is not None:
            _, direction = pose_on_lanelet(lanelet, float(np.clip(s[0], 0.0, lanelet.distance[-1])))
            turn = abs(math.remainder(direction - heading, 2 * math.pi))
        return (prefer is not None and lanelet.lanelet_id not in prefer, turn, abs(float(d[0])))

    return on_lanelet(min(under, key=rank), point)


def reachable(network: LaneletNetwork, start: int) -> set[int]:
    """The lanelets a car on ``start`` can reach: along successors, and changing lanes the same way."""
    seen, queue = {start}, deque([start])
    while queue:
        lanelet = network.find_lanelet_by_id(queue.popleft())
        ahead = list(lanelet.successor)
        ahead += [n for n, same in ((lanelet.adj_left, lanelet.adj_left_same_direction),
                                    (lanelet.adj_right, lanelet.adj_right_same_direction)) if n is not None and same]
        for n in ahead:
            if n not in seen:
                seen.add(n)
                queue.append(n)
    return seen
