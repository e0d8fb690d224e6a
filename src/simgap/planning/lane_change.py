"""A route's lane change: how long it is (`lane_change_length`), which consecutive lanelets of a
route are one (`adjacent`, `lane_changes`, `changes_from`), where a change from a short lanelet
starts on the lanes beside the route (`lanes_beside`), and the path blended from one lane's
centre line into its neighbour's (`lane_change_path`). The route (`planning.route`) joins these
into its centre line."""

from __future__ import annotations

import numpy as np
from commonroad.scenario.lanelet import LaneletNetwork

from simgap.polyline import Polyline, nearest

# a route's lane change takes this long at the vehicle's initial speed, and at least so far [s], [m]
LANE_CHANGE_S = 4.0
LANE_CHANGE_MIN_M = 30.0


def lane_change_length(speed: float) -> float:
    """How long [m] a route's lane change is: `LANE_CHANGE_S` at ``speed``, at least `LANE_CHANGE_MIN_M`."""
    return max(LANE_CHANGE_MIN_M, LANE_CHANGE_S * speed)


def adjacent(network: LaneletNetwork, a: int, b: int) -> bool:
    lanelet = network.find_lanelet_by_id(a)
    return b in (lanelet.adj_left, lanelet.adj_right)


def lane_changes(network: LaneletNetwork, route: tuple[int, ...]) -> int:
    return sum(adjacent(network, a, b) for a, b in zip(route, route[1:]))


def changes_from(network: LaneletNetwork, lanelet_ids: tuple[int, ...], k: int) -> int:
    """How many lane changes follow one another from ``lanelet_ids[k - 1]`` on (each next lanelet a neighbour)."""
    n = 0
    while k + n < len(lanelet_ids) and adjacent(network, lanelet_ids[k + n - 1], lanelet_ids[k + n]):
        n += 1
    return n


def lanes_beside(network: LaneletNetwork, behind: list[int], source: int, target: int,
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


def lane_change_path(from_lane: np.ndarray, to_lane: np.ndarray, start: np.ndarray, change_m: float,
                     after: float | None) -> tuple[np.ndarray, float]:
    """A path along two side-by-side lines, blended from ``from_lane`` into ``to_lane`` by a
    smoothstep over ``change_m`` metres, from beside ``start`` (or where the lanes begin), or from
    the fraction ``after`` of their length (a change that follows another); and where it ends."""
    from_line, to_line = Polyline(from_lane), Polyline(to_lane)
    n = max(len(from_lane), len(to_lane), int(np.ceil(max(from_line.length, to_line.length) / 0.5)) + 1)
    u = np.linspace(0.0, 1.0, n)
    # both lines at the same fractions of their length
    a = np.stack(from_line.point_at(u * from_line.length), 1)
    b = np.stack(to_line.point_at(u * to_line.length), 1)
    u0 = after if after is not None else float(u[nearest(a, start)])
    u1 = min(1.0, u0 + change_m / max(from_line.length, 1e-6))
    x = np.clip((u - u0) / max(u1 - u0, 1e-6), 0.0, 1.0)
    w = (x ** 3 * (10.0 - 15.0 * x + 6.0 * x * x))[:, None]
    return (1.0 - w) * a + w * b, u1
