"""Checks of written files, not hopes: each validates against the ASAM schema of the version it
declares (the XSDs scenariogeneration ships, through xmlschema); an OpenSCENARIO file parses back
with scenariogeneration's reader with every trajectory vertex where the run had it; an OpenDRIVE
file, read back and sampled every 0.1 m, puts each lane's centre where its lanelets' centre is,
and keeps the lanelets' successor and neighbour relations as links, junction connections and
lanes side by side (counted from the file).
"""

from __future__ import annotations

import contextlib
import functools
import importlib.metadata
import io
import math
import warnings
import xml.etree.ElementTree as ET
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import shapely
import xmlschema
from commonroad.scenario.lanelet import LaneletNetwork
from scenariogeneration import xosc
from shapely.geometry import LineString

from simgap.export.lanelet_fit import CENTRE_REACH_M, extended
from simgap.export.opendrive import RoadNetwork
from simgap.export.opendrive_sampling import RoadSamples
from simgap.trajectory import Trajectory

SCHEMA_FILES = {("OpenSCENARIO", 1, 0): "OpenSCENARIO_1_0.xsd", ("OpenSCENARIO", 1, 1): "OpenSCENARIO_1_1.xsd",
                 ("OpenSCENARIO", 1, 2): "OpenSCENARIO_1_2.xsd", ("OpenSCENARIO", 1, 3): "OpenSCENARIO_1_3_1.xsd",
                 ("OpenDRIVE", 1, 7): "opendrive_17_core.xsd"}


class CheckFailed(RuntimeError):
    """A written file failed its check: simgap wrote something wrong (a bug, not bad input)."""


def declared_version(path: str | Path) -> tuple[str, int, int]:
    """(format, major, minor) a file declares in its header."""
    root = ET.parse(path).getroot()
    header = root.find("FileHeader" if root.tag == "OpenSCENARIO" else "header")
    if header is None:
        raise CheckFailed(f"{path}: no header")
    return root.tag, int(header.attrib["revMajor"]), int(header.attrib["revMinor"])


@functools.cache
def schema(name: str) -> xmlschema.XMLSchema:
    """The XSD ``name`` as scenariogeneration installs it, loaded once per process."""
    files = importlib.metadata.files("scenariogeneration") or []
    found = next((f for f in files if f.name == name), None)
    if found is None:
        raise CheckFailed(f"the schema {name} is not installed with scenariogeneration")
    return xmlschema.XMLSchema(str(found.locate()))


def schema_errors(path: str | Path) -> tuple[str, list[str]]:
    """The schema a file is checked against (by the version it declares) and its errors."""
    version = declared_version(path)
    if version not in SCHEMA_FILES:
        raise CheckFailed(f"{path}: no schema for {version[0]} {version[1]}.{version[2]}")
    name = SCHEMA_FILES[version]
    return name, [str(e.reason or e) for e in schema(name).iter_errors(str(path))]


def _trajectories(path: str | Path) -> dict[str, list[tuple[float, float, float]]]:
    """Each entity's FollowTrajectoryAction vertices (t, x, y), as scenariogeneration reads them."""
    with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scenario = xosc.ParseOpenScenario(str(path))
    out: dict[str, list[tuple[float, float, float]]] = {}
    for story in scenario.storyboard.stories:
        for act in story.acts:
            for group in act.maneuvergroup:
                actors = [a.entity for a in group.actors.actors]
                for maneuver in group.maneuvers:
                    for event in maneuver.events:
                        for action in event.action:
                            follow = action.action
                            if not isinstance(follow, xosc.FollowTrajectoryAction):
                                continue
                            shape = follow.trajectory.shapes
                            points = [(float(t), float(p.x), float(p.y)) for t, p in zip(shape.time, shape.positions)]
                            for actor in actors:
                                out[actor] = points
    return out


def trajectory_error(path: str | Path, expected: dict[str, Trajectory]) -> float:
    """The largest distance [m] between a parsed-back trajectory vertex and the run's state at the
    same index (infinite when an entity's trajectory is missing or has another length or timing)."""
    parsed = _trajectories(path)
    worst = 0.0
    for name, trajectory in expected.items():
        got = parsed.get(name)
        if got is None or len(got) != len(trajectory):
            return math.inf
        for (t, x, y), tt, xx, yy in zip(got, trajectory.t, trajectory.x, trajectory.y):
            if abs(t - tt) > 1e-6:
                return math.inf
            worst = max(worst, math.hypot(x - xx, y - yy))
    return worst


CHECKING_LANES = "checking lane centres"     # the phase, as an export's progress names it


def lane_centre_deviation(samples: list[RoadSamples], network: RoadNetwork, lanelets: LaneletNetwork,
                          on_progress: Callable[[str, int, int], None] = lambda *_: None) -> dict[int, np.ndarray]:
    """Per road of a written OpenDRIVE file (``samples``: its roads read back): the distance [m]
    of each lane centre sample from the centre line of the lanelets that lane stands for (continued
    straight past its ends: a lane ends square to its road, a lanelet may end askew, and the
    distance is measured across the lane, not along it). ``on_progress(phase, done, total)`` after
    each lane."""
    by_road = {r.road: r for r in samples}
    out: dict[int, list[np.ndarray]] = defaultdict(list)
    for done, lane in enumerate(network.lanes, 1):
        road = by_road[lane.road]
        centre = extended(np.vstack([lanelets.find_lanelet_by_id(i).center_vertices for i in lane.lanelets]),
                          CENTRE_REACH_M)
        out[lane.road].append(shapely.distance(LineString(centre), shapely.points(road.lane_centres[lane.lane])))
        on_progress(CHECKING_LANES, done, len(network.lanes))
    return {road: np.concatenate(d) for road, d in out.items()}


@dataclass(frozen=True)
class LinksKept:
    """The lanelets' relations and how many of them the written file keeps."""

    successors: int
    successors_kept: int
    neighbours: int                     # each lanelet's left and right neighbour, counted from both sides
    neighbours_kept: int
    junctions: int                      # <junction> elements written
    junction_connections: int           # successor relations kept through a junction
    lost_successors: tuple[tuple[int, int], ...] = ()   # (lanelet, successor) the file does not keep
    lost_neighbours: tuple[tuple[int, int], ...] = ()   # (lanelet, its neighbour) the file does not keep


def _lanes_of(network: RoadNetwork) -> dict[int, list[tuple[int, int, int]]]:
    """lanelet -> its lanes (road, lane, position in the lane's lanelets)."""
    out: dict[int, list[tuple[int, int, int]]] = defaultdict(list)
    for lane in network.lanes:
        for k, i in enumerate(lane.lanelets):
            out[i].append((lane.road, lane.lane, k))
    return out


def links_kept(path: str | Path, network: RoadNetwork, lanelets: LaneletNetwork) -> LinksKept:
    """Counts, from the written file, which successor and neighbour relations of ``lanelets`` it
    keeps: a successor as the next lanelet of the same lane, a lane link between linked roads, or a
    junction connection whose connecting lane stands for the successor; a neighbour as the next
    lane of the same road (across the centre lane for opposite directions)."""
    root = ET.parse(path).getroot()
    road_links, lane_links = {}, set()
    for road in root.iter("road"):
        rid = int(road.attrib["id"])
        for way in ("predecessor", "successor"):
            el = road.find(f"link/{way}")
            if el is not None:
                road_links[(rid, way)] = (el.get("elementType"), int(el.attrib["elementId"]))
        for lane in road.iter("lane"):
            for way in ("predecessor", "successor"):
                for el in lane.findall(f"link/{way}"):
                    lane_links.add((rid, int(lane.attrib["id"]), way, int(el.attrib["id"])))
    junctions = root.findall("junction")
    through = set()
    for junction in junctions:
        for connection in junction.iter("connection"):
            incoming, connecting = int(connection.attrib["incomingRoad"]), int(connection.attrib["connectingRoad"])
            for link in connection.iter("laneLink"):
                through.add((incoming, int(link.attrib["from"]), connecting, int(link.attrib["to"])))
    lanes = _lanes_of(network)
    successors = kept = via_junction = 0
    lost_successors, lost_neighbours = [], []
    for lanelet in lanelets.lanelets:
        for b in lanelet.successor or []:
            if lanelets.find_lanelet_by_id(b) is None:
                continue
            successors += 1
            how = _successor_kept(lanes[lanelet.lanelet_id], lanes[b], road_links, lane_links, through)
            kept += how is not None
            via_junction += how == "junction"
            if how is None:
                lost_successors.append((lanelet.lanelet_id, b))
    neighbours = neighbours_kept = 0
    for lanelet in lanelets.lanelets:
        for other in (lanelet.adj_left, lanelet.adj_right):
            if other is None or lanelets.find_lanelet_by_id(other) is None:
                continue
            neighbours += 1
            side_by_side = any(r == q and (abs(l - m) == 1 or {l, m} == {-1, 1})
                               for r, l, _ in lanes[lanelet.lanelet_id] for q, m, _ in lanes[other])
            neighbours_kept += side_by_side
            if not side_by_side:
                lost_neighbours.append((lanelet.lanelet_id, other))
    return LinksKept(successors, kept, neighbours, neighbours_kept, len(junctions), via_junction,
                     tuple(lost_successors), tuple(lost_neighbours))


def _successor_kept(ahead: list[tuple[int, int, int]], behind: list[tuple[int, int, int]], road_links: dict,
                    lane_links: set, through: set) -> str | None:
    for road, lane, k in ahead:
        for other, other_lane, m in behind:
            if road == other and lane == other_lane and m == k + 1:
                return "lane"
            forward = "successor" if lane < 0 else "predecessor"
            if road_links.get((road, forward)) == ("road", other) and (road, lane, forward, other_lane) in lane_links:
                return "road link"
            if (road, lane, other, other_lane) in through:
                return "junction"
    return None
