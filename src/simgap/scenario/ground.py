"""The ground a scenario's 3D worlds stand on, from what its sidecar keeps (CommonRoad XML is 2D):
a generated road's relief (its blueprint's elevation and superelevation along the centre line), or
an imported OpenDRIVE network's heights (every lanelet bound vertex at the height the file gives
it). None: the scenario is flat, and a 3D world builds a plane.

A world's tilt (`simgap.scenario.relief.RoadTilt`: the reality knobs ``road_bank`` and
``road_grade``) is laid on a generated road's relief, a flat one's too: the ground is then the
tilted road. A scenario without a road's reference line (a recorded map, an imported network, a
generated junction) has no way for a uniform bank or grade to lie: a tilt there is refused, as is
one that takes the road's relief past its bounds.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from commonroad.scenario.lanelet import LaneletNetwork
from pydantic import ValidationError

from simgap.errors import InputError
from simgap.scenario.blueprint import JunctionBlueprint, RoadBlueprint
from simgap.scenario.opendrive.origin import OpenDriveOrigin
from simgap.scenario.relief import (
    LEVEL,
    MAX_BANK_DEG,
    MAX_GRADE_PERCENT,
    BankKnot,
    RoadRelief,
    RoadTilt,
    SampledSurface,
    Surface,
)
from simgap.scenario.sidecar import ScenarioSidecar, read_sidecar

FLAT_M = 1e-6     # heights within this of zero everywhere: a flat network


def ground_of(sidecar: ScenarioSidecar, network: LaneletNetwork | None = None, tilt: RoadTilt = LEVEL,
              file: str | Path | None = None) -> Surface | None:
    """The surface of the scenario whose sidecar is ``sidecar`` and whose lanelets are ``network``
    (an imported network's heights need its lanelets' positions), with ``tilt`` laid on a generated
    road; None where it is flat. A tilt it cannot lay is an `InputError` naming ``file`` (the
    scenario's) and the knob (see the module doc)."""
    if isinstance(sidecar.blueprint, RoadBlueprint):
        return _tilted_road(sidecar.blueprint, tilt, file)
    if not tilt.is_level:
        raise _no_reference_line(sidecar, tilt, file)
    if sidecar.opendrive is not None and network is not None:
        return network_surface(sidecar.opendrive, network)
    return None


def ground_of_file(xml: str | Path, network: LaneletNetwork | None = None, tilt: RoadTilt = LEVEL) -> Surface | None:
    """`ground_of` the scenario file ``xml``: its sidecar read beside it (a refusal names the file)."""
    return ground_of(read_sidecar(xml), network, tilt, xml)


def _knob(tilt: RoadTilt, bank: bool) -> tuple[str, str, float]:
    """The knob of ``tilt`` a refusal names, its bank's or its grade's: its field, what it is, its value."""
    return ("road_bank", "bank", tilt.road_bank) if bank else ("road_grade", "grade", tilt.road_grade)


def _no_reference_line(sidecar: ScenarioSidecar, tilt: RoadTilt, file: str | Path | None) -> InputError:
    field, what, value = _knob(tilt, bank=tilt.road_bank != 0.0)      # the bank where both are set
    scenario = ("a generated junction" if isinstance(sidecar.blueprint, JunctionBlueprint) else
                "an imported OpenDRIVE network" if sidecar.opendrive is not None else "a recorded map")
    return InputError(f"a uniform {what} of {value:g} deg is laid along a road's reference line, and {scenario} "
                      "has none", file=file, field=field,
                      allowed="a generated road, whose centre line is one; 0 here, where the scenario's own relief "
                              "is the ground")


def _tilted_road(blueprint: RoadBlueprint, tilt: RoadTilt, file: str | Path | None) -> RoadRelief | None:
    """The generated road's surface with ``tilt`` laid on it; a tilt that takes its relief past the
    relief's bounds is refused naming the knob that does."""
    try:
        return blueprint.road_relief(tilt)
    except ValidationError as err:
        banked = err.title == BankKnot.__name__
        field, what, value = _knob(tilt, bank=banked)
        bound = f"±{MAX_BANK_DEG:g} deg" if banked else \
            f"±{MAX_GRADE_PERCENT:g} % ({math.degrees(math.atan(MAX_GRADE_PERCENT / 100.0)):.1f} deg)"
        raise InputError(f"a {what} of {value:g} deg laid on the road's relief takes it past {bound} somewhere",
                         file=file, field=field, allowed=f"a road {what} within {bound}, the relief's and the tilt's "
                                                         "together") from None


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
