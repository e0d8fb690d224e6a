"""The ground a scenario's 3D worlds stand on, from what its sidecar keeps (CommonRoad XML is 2D):
a generated road's relief (its blueprint's elevation and superelevation along the centre line), or
an imported OpenDRIVE network's heights (every lanelet bound vertex at the height the file gives
it). None: the scenario is flat, and a 3D world builds a plane.
"""

from __future__ import annotations

import numpy as np
from commonroad.scenario.lanelet import LaneletNetwork

from simgap.errors import InputError
from simgap.scenario.blueprint import RoadBlueprint
from simgap.scenario.opendrive.origin import OpenDriveOrigin
from simgap.scenario.relief import SampledSurface, Surface
from simgap.scenario.sidecar import ScenarioSidecar

FLAT_M = 1e-6     # heights within this of zero everywhere: a flat network


def ground_of(sidecar: ScenarioSidecar, network: LaneletNetwork | None = None) -> Surface | None:
    """The surface of the scenario whose sidecar is ``sidecar`` and whose lanelets are ``network``
    (an imported network's heights need its lanelets' positions); None where it is flat."""
    if isinstance(sidecar.blueprint, RoadBlueprint):
        return sidecar.blueprint.road_relief()
    if sidecar.opendrive is not None and network is not None:
        return network_surface(sidecar.opendrive, network)
    return None


def network_surface(origin: OpenDriveOrigin, network: LaneletNetwork) -> SampledSurface | None:
    """The surface through every lanelet's bound vertices at their heights in ``origin`` (a lanelet
    without heights lies at 0, as OpenDRIVE's roads without elevation do); None if all are 0."""
    points = []
    for lanelet in network.lanelets:
        place = origin.lanelets.get(lanelet.lanelet_id)
        for bound, z in ((lanelet.left_vertices, place.left_z if place else None),
                         (lanelet.right_vertices, place.right_z if place else None)):
            heights = np.zeros(len(bound)) if z is None else np.asarray(z, dtype=float)
            if len(heights) != len(bound):
                raise InputError(f"lanelet {lanelet.lanelet_id} has {len(bound)} bound vertices but "
                                 f"{len(heights)} heights", field="opendrive.lanelets",
                                 allowed="a height per bound vertex (the sidecar simgap generate wrote)")
            points.append(np.column_stack([bound, heights]))
    xyz = np.vstack(points) if points else np.zeros((0, 3))
    return SampledSurface(xyz) if len(xyz) >= 3 and np.abs(xyz[:, 2]).max() > FLAT_M else None
