"""Checks of written files, not hopes: each validates against the ASAM schema of the version it
declares (the XSDs scenariogeneration ships, through xmlschema); an OpenSCENARIO file parses back
with scenariogeneration's reader with every trajectory vertex where the run had it; an OpenDRIVE
file, read back and sampled every metre, puts each lane's centre where its lanelets' centre is.
"""

from __future__ import annotations

import contextlib
import functools
import importlib.metadata
import io
import math
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import shapely
import xmlschema
from commonroad.scenario.lanelet import LaneletNetwork
from scenariogeneration import xosc
from shapely.geometry import LineString

from simgap.export.opendrive import RoadNetwork
from simgap.export.opendrive_sampling import sample_roads
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
    return root.tag, int(header.get("revMajor")), int(header.get("revMinor"))


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


def lane_centre_deviation(path: str | Path, network: RoadNetwork, lanelets: LaneletNetwork,
                          step: float = 1.0) -> dict[int, float]:
    """Per road of the written OpenDRIVE file: the largest distance [m] of a lane centre, sampled
    every ``step`` metres, from the centre line of the lanelets that lane stands for."""
    samples = {r.road: r for r in sample_roads(path, step)}
    worst: dict[int, float] = {}
    for lane in network.lanes:
        road = samples[lane.road]
        centre = np.vstack([lanelets.find_lanelet_by_id(i).center_vertices for i in lane.lanelets])
        d = float(shapely.distance(LineString(centre), shapely.points(road.lane_centres[lane.lane])).max())
        worst[lane.road] = max(worst.get(lane.road, 0.0), d)
    return worst
