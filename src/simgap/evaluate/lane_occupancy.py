"""Which lanelet a driven trajectory occupies at each step, and what follows from it: the progress
along that lane's direction, the speed limit there, and whether the footprint straddles lanes.

A point in several lanelets (where lanelets overlap, e.g. in a junction) is given the lanelet it
was in before, else the one whose direction is closest to the vehicle's heading — the way nuPlan
follows the lanes and lane connectors of the ego's route (``get_route`` of its route extractor).
"""

from __future__ import annotations

import math
import re
from functools import cached_property

import numpy as np
from commonroad.scenario.lanelet import LaneletNetwork

from simgap.scenario.road_frame import PathFrame
from simgap.trajectory import Trajectory, wrap_angle

NO_LANELET = -1


class LaneOccupancy:
    """The lanelets of a road network, looked up by position."""

    def __init__(self, network: LaneletNetwork):
        self.network = network
        self._paths: dict[int, PathFrame] = {}

    def centre_line(self, lanelet_id: int) -> PathFrame:
        if lanelet_id not in self._paths:
            self._paths[lanelet_id] = PathFrame(self.network.find_lanelet_by_id(lanelet_id).center_vertices)
        return self._paths[lanelet_id]

    def lanelets_at(self, points: np.ndarray) -> list[list[int]]:
        """The ids of the lanelets each point lies in (empty: none)."""
        return self.network.find_lanelet_by_position([np.asarray(p, dtype=float) for p in points])

    def lane_of_each_step(self, driven: Trajectory) -> np.ndarray:
        """The lanelet the centre of ``driven`` is in at each step (`NO_LANELET`: none)."""
        candidates = self.lanelets_at(np.column_stack([driven.x, driven.y]))
        out = np.full(len(driven), NO_LANELET)
        previous = NO_LANELET
        for k, ids in enumerate(candidates):
            if not ids:
                previous = NO_LANELET
                continue
            if previous in ids:
                out[k] = previous
            elif len(ids) == 1:
                out[k] = ids[0]
            else:
                point = np.array([driven.x[k], driven.y[k]])
                out[k] = min(ids, key=lambda i: abs(wrap_angle(self._heading(i, point) - driven.yaw[k])))
            previous = out[k]
        return out

    def _heading(self, lanelet_id: int, point: np.ndarray) -> float:
        path = self.centre_line(lanelet_id)
        s, _ = path.project(point)
        ahead = np.clip([s[0] - 0.5, s[0] + 0.5], 0.0, path.length)
        x, y = path.point_at(ahead)
        return math.atan2(y[1] - y[0], x[1] - x[0])

    def progress_along_lanes(self, driven: Trajectory, lanes: np.ndarray) -> np.ndarray:
        """Per step, how far the vehicle moved along its lane's direction since the step before
        (0 at the first step, off the lanelets and where it entered another lanelet)."""
        progress = np.zeros(len(driven))
        s = np.full(len(driven), np.nan)
        for lanelet_id in set(lanes.tolist()) - {NO_LANELET}:
            mine = lanes == lanelet_id
            s[mine], _ = self.centre_line(int(lanelet_id)).project(np.column_stack([driven.x[mine], driven.y[mine]]))
        same = (lanes[1:] == lanes[:-1]) & (lanes[1:] != NO_LANELET)
        progress[1:][same] = np.diff(s)[same]
        return progress

    def speed_limits(self, lanes: np.ndarray) -> np.ndarray:
        """The speed limit [m/s] of each step's lanelet (NaN: none): the lowest ``MAX_SPEED`` sign
        the lanelet references, as commonroad-io's `TrafficSignInterpreter` reads it, with a unit
        when the value carries one (``50kmh``, as some converted maps write it)."""
        out = np.full(len(lanes), np.nan)
        for lanelet_id in set(lanes.tolist()) - {NO_LANELET}:
            read = [_speed(value) for sign_id in self.network.find_lanelet_by_id(int(lanelet_id)).traffic_signs
                    for element in self.network.find_traffic_sign_by_id(sign_id).traffic_sign_elements
                    if element.traffic_sign_element_id.name == "MAX_SPEED" and element.additional_values
                    for value in element.additional_values[:1]]
            limits = [v for v in read if v is not None]
            if limits:
                out[lanes == lanelet_id] = min(limits)
        return out

    @cached_property
    def junction_lanelets(self) -> frozenset[int]:
        """The lanelets inside the network's intersections (the incomings' successors)."""
        return frozenset(i for inter in self.network.intersections for inc in inter.incomings
                         for i in (inc.successors_left | inc.successors_right | inc.successors_straight))

    def straddles_lanes(self, corners: np.ndarray) -> bool:
        """Whether a footprint (its corners) lies in more than one lane or partly off the lanelets:
        its corners are not all in one lanelet or in lanelets that follow each other."""
        sets = [set(ids) for ids in self.lanelets_at(corners)]
        if not all(sets):
            return True
        if set.intersection(*sets):
            return False
        return not all(self._connected(a, b) for a, b in zip(sets, sets[1:] + sets[:1]))

    def _connected(self, a: set[int], b: set[int]) -> bool:
        for i in a:
            lanelet = self.network.find_lanelet_by_id(i)
            if b & ({i} | set(lanelet.successor or []) | set(lanelet.predecessor or [])):
                return True
        return False


_UNITS = {"": 1.0, "m/s": 1.0, "mps": 1.0, "kmh": 1 / 3.6, "km/h": 1 / 3.6, "kph": 1 / 3.6, "mph": 0.44704}


def _speed(value: str) -> float | None:
    """A sign's speed value in m/s (CommonRoad's unit unless the value names another)."""
    match = re.fullmatch(r"\s*([0-9]+(?:\.[0-9]*)?)\s*([a-z/]*)\s*", str(value).lower())
    if match is None or match.group(2) not in _UNITS:
        return None
    return float(match.group(1)) * _UNITS[match.group(2)]
