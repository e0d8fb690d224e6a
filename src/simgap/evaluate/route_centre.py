"""The evaluation frame of an agent: the centre line of the lanelets on its route to the goal.

It is independent of any planner's (smoothed) reference path, so lateral displacement d means
the same for every planner and every fidelity: offset from the centre of the lane it drives on.
"""

from __future__ import annotations

import numpy as np
from commonroad.planning.planning_problem import PlanningProblem
from commonroad.scenario.lanelet import LaneletNetwork

from simgap.errors import InputError
from simgap.planning.route import lanelet_routes, preferred_route
from simgap.scenario.road_frame import PathFrame
from simgap.scenario.sections import UNKNOWN, RoadSections


def route_lanelets(network: LaneletNetwork, problem: PlanningProblem) -> list[int]:
    """The lanelets of the planners' route (`preferred_route`; a start off every lanelet included);
    empty when there is none."""
    try:
        found = lanelet_routes(network, problem)
    except InputError:
        return []
    return list(preferred_route(found.network, found.routes, found.problem.initial_state))


def route_centre(network: LaneletNetwork, problem: PlanningProblem) -> PathFrame | None:
    ids = route_lanelets(network, problem)
    if not ids:
        return None
    parts = [network.find_lanelet_by_id(i).center_vertices for i in ids]
    xy = np.vstack([parts[0]] + [p[1:] for p in parts[1:]])
    return PathFrame(xy)


def section_of_s(network: LaneletNetwork, problem: PlanningProblem, sections: RoadSections,
                 s: np.ndarray) -> np.ndarray:
    """The road section kind (straight, curve, clothoid, junction) at each arc length ``s``."""
    ids = route_lanelets(network, problem)
    bounds, kinds, acc = [], [], 0.0
    for i in ids:
        lanelet = network.find_lanelet_by_id(i)
        acc += float(lanelet.distance[-1])
        bounds.append(acc)
        kinds.append(sections.kind_of(i))
    if not bounds:
        return np.full(len(s), UNKNOWN)
    idx = np.clip(np.searchsorted(np.array(bounds), s), 0, len(kinds) - 1)
    return np.array(kinds)[idx]
